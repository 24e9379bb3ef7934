//! Leave out what a scene does not need: with the plugin added but no
//! `Eye` and no mirror, no extra pipeline is built, no clone camera, twin,
//! field or mirror camera exists; with an eye the clone and resolve pipelines compile (wgpu's
//! noop backend), for both shadings and with MSAA on the eye camera.

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_harness::{Adapter, Headless, PipelineReport};
use optica_spectacles::{CloneCameraOf, CloneDefocus, CloneOf, CloneShading, Eye, MirrorState, Spectacles};
use optica_spectacles::twins::{CubeFace, EyeOptics, MirrorEnvironment};

use super::{Target, scene};

fn pipelines(setup: impl FnOnce(&mut App)) -> PipelineReport {
    crate::noop_pipelines(3, setup)
}

fn targets() -> Vec<Target> {
    vec![Target::checker(2.0, 1.0, 4)]
}

/// The same scene without the plugin.
fn without_plugin(app: &mut App) {
    app.add_systems(
        Startup,
        |mut commands: Commands,
         mut meshes: ResMut<Assets<Mesh>>,
         mut materials: ResMut<Assets<StandardMaterial>>| {
            commands.spawn((
                Mesh3d(meshes.add(Plane3d::new(Vec3::Z, Vec2::splat(0.5)).mesh().subdivisions(15))),
                MeshMaterial3d(materials.add(StandardMaterial {
                    unlit: true,
                    ..default()
                })),
                Transform::from_xyz(0.0, 0.0, -2.0),
            ));
            commands.spawn((Camera3d::default(), Msaa::Off));
        },
    );
}

/// What the plugin makes for a mirror.
type MirrorMade = Or<(With<MirrorEnvironment>, With<CubeFace>, With<MirrorState>)>;

/// Counts, every frame, the entities the plugin would make.
fn count_plugin_entities(app: &mut App, seen: Arc<AtomicUsize>) {
    app.add_systems(
        Last,
        move |rigs: Query<(), With<CloneCameraOf>>,
              twins: Query<(), With<CloneOf>>,
              optics: Query<(), With<EyeOptics>>,
              mirrors: Query<(), MirrorMade>| {
            let n = rigs.iter().count() + twins.iter().count() + optics.iter().count() + mirrors.iter().count();
            seen.fetch_max(n, Ordering::Relaxed);
        },
    );
}

#[test]
fn no_eye_no_pipeline_no_clone_and_the_passes_compile_on_noop() {
    let plain = pipelines(without_plugin);
    let seen = Arc::new(AtomicUsize::new(0));
    let plugin_no_eye = pipelines({
        let seen = seen.clone();
        move |app| {
            scene(targets(), None, None, 0.8)(app);
            count_plugin_entities(app, seen);
        }
    });
    assert_eq!(
        plugin_no_eye.ok, plain.ok,
        "{:?}\n{:?}",
        plugin_no_eye.labels, plain.labels
    );
    assert_eq!(seen.load(Ordering::Relaxed), 0, "clone cameras, twins or optics without an eye");

    for shading in [CloneShading::Reprojected, CloneShading::Full] {
        for spectacles in [None, Some(Spectacles::sphere(-2.0))] {
            let seen = Arc::new(AtomicUsize::new(0));
            let with_eye = pipelines({
                let seen = seen.clone();
                let spectacles = spectacles.clone();
                move |app| {
                    let defocus = CloneDefocus {
                        clones: 4,
                        shading,
                        ..default()
                    };
                    scene(targets(), Some((Eye::default(), defocus)), spectacles, 0.8)(app);
                    count_plugin_entities(app, seen);
                }
            });
            eprintln!(
                "{shading:?}, glasses {}: {} pipelines ({} without the eye)",
                spectacles.is_some(),
                with_eye.ok,
                plain.ok
            );
            assert!(
                with_eye.labels.iter().any(|l| l == "optica_spectacles_resolve"),
                "{:?}",
                with_eye.labels
            );
            assert!(with_eye.ok > plain.ok + 1, "{:?}", with_eye.labels);
            // One clone camera, four twins, the eye's optics.
            assert_eq!(seen.load(Ordering::Relaxed), 6);
        }
    }
}

/// The reprojection resolve reads an MSAA eye camera's depth: the view is
/// blurred as without MSAA (SSIM ≥ 0.9 between the two; against the sharp
/// view under 0.8).
#[test]
fn reprojection_works_with_msaa() {
    let render = |eye: bool, msaa: Msaa| {
        Headless::new(64, 64)
            .frames(4)
            .render(move |app: &mut App| {
                scene(
                    vec![Target::checker(2.0, 1.2, 6)],
                    eye.then(|| {
                        (
                            Eye {
                                refractive_error_d: -3.0,
                                pupil: optica_spectacles::Pupil::Diameter { mm: 12.0 },
                                ..default()
                            },
                            CloneDefocus::default(),
                        )
                    }),
                    None,
                    0.8,
                )(app);
                app.add_systems(Update, move |mut cameras: Query<&mut Msaa, Without<CloneCameraOf>>| {
                    for mut m in &mut cameras {
                        *m = msaa;
                    }
                });
            })
            .expect("render")
            .to_rgba8()
    };
    let sharp = render(false, Msaa::Sample4);
    let plain = render(true, Msaa::Off);
    let msaa = render(true, Msaa::Sample4);
    let same = optica_harness::metrics::ssim(&plain, &msaa).unwrap();
    let blurred = optica_harness::metrics::ssim(&sharp, &msaa).unwrap();
    eprintln!("MSAA eye camera: SSIM against no MSAA {same:.3}, against the sharp view {blurred:.3}");
    assert!(same >= 0.9 && blurred < 0.8, "{same} {blurred}");
}

/// A mirror's cameras compile on noop, and go with it: with a per-vertex
/// mirror one environment camera, with a cube map six faces (and, on a
/// device without reflection probes, the cube as the viewer's environment
/// map, given back when the mirror goes); a frame after the mirror is
/// despawned none is left.
#[test]
fn mirror_cameras_come_and_go_with_the_mirror() {
    use optica_spectacles::{CurvedMirror, MirrorMethod, MirrorViewer};
    for (method, made) in [(MirrorMethod::PerVertex, 2), (MirrorMethod::CubeMap, 7)] {
        let during = Arc::new(AtomicUsize::new(0));
        let after = Arc::new(AtomicUsize::new(usize::MAX));
        let lit_after = Arc::new(AtomicUsize::new(usize::MAX));
        let report = Headless::new(32, 32)
            .adapter(Adapter::Noop)
            .frames(6)
            .check_pipelines({
                let (during, after, lit_after) = (during.clone(), after.clone(), lit_after.clone());
                let method = method.clone();
                move |app: &mut App| {
                    scene(targets(), None, None, 0.8)(app);
                    app.add_systems(Startup, move |mut commands: Commands, cameras: Query<Entity, With<Camera3d>>| {
                        for c in &cameras {
                            commands.entity(c).insert(MirrorViewer);
                        }
                        commands.spawn((
                            CurvedMirror {
                                method: method.clone(),
                                resolution: 32,
                                ..default()
                            },
                            Transform::from_xyz(0.0, 0.0, -1.0).looking_at(Vec3::ZERO, Vec3::Y),
                        ));
                    });
                    let mut frame = 0;
                    app.add_systems(
                        Last,
                        move |mut commands: Commands,
                              mirrors: Query<Entity, With<CurvedMirror>>,
                              made: Query<(), MirrorMade>,
                              cameras: Query<(), With<Camera>>,
                              lit: Query<(), (With<MirrorViewer>, With<bevy::light::EnvironmentMapLight>)>| {
                            frame += 1;
                            let n = made.iter().count() + cameras.iter().count() - 1;
                            if frame == 3 {
                                during.store(n, Ordering::Relaxed);
                                for m in &mirrors {
                                    commands.entity(m).despawn();
                                }
                            } else if frame > 4 {
                                after.store(n, Ordering::Relaxed);
                                lit_after.store(lit.iter().count(), Ordering::Relaxed);
                            }
                        },
                    );
                }
            })
            .expect("the mirror's pipelines compile");
        eprintln!("{method:?}: {} pipelines", report.ok);
        // The mirror's state and its cameras (counted as cameras and as
        // what the plugin made).
        assert!(during.load(Ordering::Relaxed) >= made, "{method:?}: {}", during.load(Ordering::Relaxed));
        assert_eq!(after.load(Ordering::Relaxed), 0, "{method:?}: left behind");
        assert_eq!(lit_after.load(Ordering::Relaxed), 0, "{method:?}: the viewer keeps the cube");
    }
}

/// The plugin's own entities are Bevy relationships that users can filter
/// out: with four clones, each scene mesh lists its four twins in
/// `CloneTwins` (clone order), the eye its `CloneCamera`, and
/// `Query<&Mesh3d, NotSpectaclesHelper>` sees the scene's meshes alone.
#[test]
fn helpers_are_relationships_that_users_can_filter_out() {
    use optica_spectacles::{CloneCamera, CloneTwins, NotSpectaclesHelper};
    let counts = Arc::new(std::sync::Mutex::new((0, 0, 0, false)));
    let log = counts.clone();
    Headless::new(64, 64)
        .frames(3)
        .render(move |app: &mut App| {
            let defocus = CloneDefocus {
                clones: 4,
                ..default()
            };
            scene(targets(), Some((Eye::default(), defocus)), None, 0.8)(app);
            app.add_systems(
                Last,
                move |all: Query<&Mesh3d>,
                      ours: Query<&Mesh3d, NotSpectaclesHelper>,
                      twins: Query<&CloneTwins>,
                      tags: Query<&bevy::mesh::MeshTag>,
                      eyes: Query<&CloneCamera>| {
                    let ordered = twins.iter().all(|t| {
                        t.iter()
                            .enumerate()
                            .all(|(k, e)| tags.get(e).is_ok_and(|tag| tag.0 == k as u32))
                    });
                    *log.lock().expect("log") = (
                        all.iter().count(),
                        ours.iter().count(),
                        twins.iter().map(|t| t.len()).sum::<usize>(),
                        ordered && eyes.iter().count() == 1,
                    );
                },
            );
        })
        .expect("render");
    let (all, ours, twins, ordered) = *counts.lock().expect("log");
    assert!(ours > 0 && twins == 4 * ours && all == ours + twins, "{all} {ours} {twins}");
    assert!(ordered, "twins out of clone order, or no clone camera");
}


/// Turning the blur off takes the resolve off the view: after a few
/// frames with clones, a view whose `CloneDefocus` is switched off draws
/// the same image as one that never had it on.
#[test]
fn switching_the_blur_off_leaves_the_sharp_view() {
    let render = |switch_off: bool| {
        Headless::new(64, 64)
            .hdr(true)
            .frames(8)
            .render(move |app: &mut App| {
                let defocus = CloneDefocus {
                    clones: 4,
                    enabled: switch_off,
                    ..default()
                };
                scene(targets(), Some((Eye { refractive_error_d: -3.0, ..default() }, defocus)), None, 0.8)(app);
                app.add_systems(Update, move |mut frame: Local<u32>, mut eyes: Query<&mut CloneDefocus>| {
                    *frame += 1;
                    if *frame == 4 {
                        for mut d in &mut eyes {
                            d.enabled = false;
                        }
                    }
                });
            })
            .expect("render")
    };
    let (switched, sharp) = (render(true), render(false));
    let (a, b) = (switched.hdr().expect("HDR"), sharp.hdr().expect("HDR"));
    let worst = a
        .as_raw()
        .iter()
        .zip(b.as_raw())
        .map(|(x, y)| (x - y).abs())
        .fold(0f32, f32::max);
    assert!(worst < 1e-3, "the switched-off view differs from the sharp one by {worst}");
}

/// The clones are cut at their tiles two ways: by clip distances
/// (`clone_clip.wgsl`, where the device has them) or by a discard in the
/// fragment shader. Lavapipe has clip distances; the same blurred view
/// drawn both ways agrees to rounding, and differs from the sharp view.
#[test]
fn clip_distances_and_the_discard_cut_clones_alike() {
    use optica_spectacles::SpectaclesDevice;
    use std::sync::Mutex;
    let render = |eye: bool, force_discard: bool| {
        let device = Arc::new(Mutex::new(None));
        let seen = device.clone();
        let image = Headless::new(64, 64)
            .hdr(true)
            .frames(6)
            .render(move |app: &mut App| {
                let defocus = CloneDefocus {
                    clones: 4,
                    ..default()
                };
                let eye = eye.then(|| (Eye { refractive_error_d: -3.0, ..default() }, defocus));
                scene(targets(), eye, None, 0.8)(app);
                app.add_systems(Startup, move |mut device: ResMut<SpectaclesDevice>| {
                    *seen.lock().unwrap() = Some(*device);
                    if force_discard {
                        device.clip_distances = false;
                    }
                });
            })
            .expect("render");
        let device = device.lock().unwrap().expect("SpectaclesDevice after the plugins finish");
        (image.hdr().expect("HDR").clone(), device)
    };
    let (clipped, device) = render(true, false);
    assert!(device.clip_distances, "lavapipe should offer clip distances: {device:?}");
    let (discarded, _) = render(true, true);
    let (sharp, _) = render(false, false);
    let diff = |a: &[f32], b: &[f32]| a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0f32, f32::max);
    let both = diff(clipped.as_raw(), discarded.as_raw());
    let blur = diff(clipped.as_raw(), sharp.as_raw());
    eprintln!("clip vs discard {both}, blurred vs sharp {blur}");
    assert!(both < 1e-3, "clip distances and the discard differ by {both}");
    assert!(blur > 0.05, "the blurred view is the sharp one (differs by {blur})");
}

/// Despawning the last eye camera despawns its clones too. The plugin's
/// systems were gated on an eye existing, so the frame after the last one
/// went nothing removed the clones: ten entities a mesh stayed for good
/// (found by the soak).
#[test]
fn the_last_eye_takes_its_clones_with_it() {
    let mut run = Headless::new(32, 32)
        .start(scene(targets(), Some((Eye::default(), CloneDefocus { clones: 4, ..default() })), None, 0.8))
        .expect("app");
    for _ in 0..4 {
        run.step().expect("frame");
    }
    let count = |run: &mut optica_harness::HeadlessRun| {
        let world = run.app().world_mut();
        world.query_filtered::<(), With<CloneOf>>().iter(world).count()
    };
    assert_eq!(count(&mut run), 4, "four clones of the target while the eye looks");
    let world = run.app().world_mut();
    let eye = world.query_filtered::<Entity, With<Eye>>().single(world).expect("the eye");
    world.despawn(eye);
    for _ in 0..3 {
        run.step().expect("frame");
    }
    assert_eq!(count(&mut run), 0, "clones left after the last eye went");
}
