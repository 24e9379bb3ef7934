//! Random accepted settings rendered on lavapipe: per plugin one app at
//! 32² (HDR), whose settings are redrawn at random (`optica_harness::
//! randomise`, over their whole type range) and, once the plugin's own
//! check accepts them, drawn and read back as floats. Asserted for every
//! draw: no panic, no wgpu error (validation errors included: the harness
//! records them), no NaN or infinite value in the HDR target. Settings
//! without a check of their own (the clone count, the tracer's layers,
//! the tracked head) are drawn freely: the plugin must clamp or fall back.
//! `OPTICA_RANDOM_RENDERS` draws per plugin (default 6; the release run in
//! `docs/reliability.md` draws 300).

use bevy::prelude::*;
use optica_harness::randomise::randomise_some;
use optica_harness::{Headless, HeadlessRun};
use rand::SeedableRng;
use rand_xoshiro::SplitMix64;

const SIZE: u32 = 32;

fn draws() -> u64 {
    crate::count_from_env("OPTICA_RANDOM_RENDERS", 6)
}

/// `base` redrawn (a share of its fields, from `seed`) until `accepted`
/// takes it; `None` after 500 tries.
fn accepted<T: Reflect + Clone>(
    base: &T,
    seed: &mut u64,
    accepted: impl Fn(&T) -> bool,
) -> Option<T> {
    for _ in 0..500 {
        *seed = seed.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut value = base.clone();
        let mut rng = SplitMix64::seed_from_u64(*seed);
        randomise_some(
            &mut value,
            &mut rng,
            [0.05, 0.15, 0.3][(*seed % 3) as usize],
        );
        if accepted(&value) {
            return Some(value);
        }
    }
    None
}

/// `value` redrawn freely (a share of its fields) from `seed`.
fn any<T: Reflect + Clone>(base: &T, seed: u64) -> T {
    let mut value = base.clone();
    randomise_some(&mut value, &mut SplitMix64::seed_from_u64(seed), 0.2);
    value
}

/// Draws `count` times: `redraw` changes the scene, then the frame is
/// read back and every value checked.
fn run(what: &str, run: &mut HeadlessRun, count: u64, mut redraw: impl FnMut(&mut World, u64)) {
    // The scene's startup systems first.
    run.step()
        .unwrap_or_else(|e| panic!("{what}, first frame: {e}"));
    for k in 0..count {
        redraw(run.app().world_mut(), k);
        for _ in 0..2 {
            run.step()
                .unwrap_or_else(|e| panic!("{what}, draw {k}: {e}"));
        }
        let frame = run
            .frame()
            .unwrap_or_else(|e| panic!("{what}, draw {k}: {e}"));
        let img = frame.hdr().expect("HDR");
        let bad = img.as_raw().iter().filter(|v| !v.is_finite()).count();
        assert_eq!(bad, 0, "{what}, draw {k}: {bad} values not finite");
    }
    eprintln!("{what}: {count} random settings drawn, every value finite");
}

fn headless() -> Headless {
    Headless::new(SIZE, SIZE).hdr(true)
}

#[test]
fn random_lens_flares_draw_finite() {
    use optica_lens_flare::{LensFlare, LensFlarePlugin};
    let mut app = headless()
        .start(|app: &mut App| {
            app.add_plugins(LensFlarePlugin);
            app.add_systems(
                Startup,
                |mut commands: Commands, assets: Res<AssetServer>| {
                    commands.spawn(crate::lens_flare::sun(
                        Vec3::new(0.1, -0.1, 1.0).normalize(),
                        100_000.0,
                    ));
                    commands.spawn((
                        optica_report::fixtures::black_hdr_camera(),
                        LensFlare {
                            grid: 8,
                            ..LensFlare::new(assets.load("lenses/tessar-us2854889.lens"))
                        },
                    ));
                },
            );
        })
        .expect("app");
    let mut seed = 1;
    run("lens flare", &mut app, draws(), |world, _| {
        let mut q = world.query::<&mut LensFlare>();
        let mut flare = q.single_mut(world).expect("flare");
        let base = LensFlare {
            grid: 8,
            ..LensFlare::new(flare.lens.clone())
        };
        let mut drawn =
            accepted(&base, &mut seed, |f| f.validate().is_ok()).expect("an accepted flare");
        // The lens stays; the sizes stay affordable on a CPU device.
        drawn.lens = flare.lens.clone();
        drawn.grid = drawn.grid.min(24);
        drawn.ghost_budget = drawn.ghost_budget.min(32);
        *flare = drawn;
    });
}

#[test]
fn random_domes_draw_finite() {
    use optica_dome::{DomeCamera, DomeMode};
    let mut app = headless()
        .start(optica_report::fixtures::dome_room(
            [
                Color::srgb(1.0, 0.2, 0.2),
                Color::srgb(0.2, 1.0, 0.2),
                Color::srgb(0.2, 0.2, 1.0),
                Color::WHITE,
                Color::srgb(1.0, 1.0, 0.2),
                Color::srgb(0.5, 0.5, 0.5),
            ],
            2,
            |commands| {
                commands.spawn(crate::dome::dome_camera(
                    DomeCamera::default(),
                    optica_report::fixtures::zenith(),
                ));
            },
        ))
        .expect("app");
    let mut seed = 2;
    run("dome", &mut app, draws(), |world, k| {
        let mut q = world.query::<&mut DomeCamera>();
        let mut dome = q.single_mut(world).expect("dome");
        // Both modes: the draws switch only to unit variants.
        let base = DomeCamera {
            mode: if k % 2 == 0 {
                DomeMode::Vertex
            } else {
                DomeMode::CubeMap { face_px: 64 }
            },
            ..default()
        };
        let mut drawn =
            accepted(&base, &mut seed, |d| d.validate().is_ok()).expect("an accepted dome");
        // The cube faces stay affordable on a CPU device (accepted up to
        // 16,384 px: 13 GB of HDR faces).
        if let DomeMode::CubeMap { face_px } = &mut drawn.mode {
            *face_px = (*face_px).min(128);
        }
        *dome = drawn;
    });
}

#[test]
fn random_compound_eyes_draw_finite() {
    use optica_compound_eye::{CompoundEye, CompoundEyeMaterial, insert_axis_field};
    // With the smooth axis field, for draws that turn `axis_field` on.
    let mut mesh = Sphere::new(1.0).mesh().uv(24, 12);
    insert_axis_field(&mut mesh).expect("a UV sphere takes a field");
    let mut app = headless()
        .start(optica_report::fixtures::compound_eye_scene(
            mesh,
            Transform::IDENTITY,
            Some(CompoundEye::default()),
            Transform::from_xyz(0.0, 0.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
            Projection::default(),
            Some(Color::BLACK),
        ))
        .expect("app");
    let mut seed = 3;
    run("compound eye", &mut app, draws(), |world, _| {
        let drawn = accepted(&CompoundEye::default(), &mut seed, |e| e.validate().is_ok())
            .expect("an accepted eye");
        let mut materials = world.resource_mut::<Assets<CompoundEyeMaterial>>();
        let mut n = 0;
        for (_, m) in materials.iter_mut() {
            m.extension = drawn.clone();
            n += 1;
        }
        assert_eq!(n, 1, "the eye's material");
    });
}

#[test]
fn random_spectacles_draw_finite() {
    use optica_spectacles::{CloneDefocus, Eye, Spectacles};
    let mut app = headless()
        .start(crate::spectacles::scene(
            vec![crate::spectacles::Target::checker(2.0, 1.0, 4)],
            Some((Eye::default(), CloneDefocus::default())),
            Some(Spectacles::sphere(-2.0)),
            0.8,
        ))
        .expect("app");
    let mut seed = 4;
    run("spectacles", &mut app, draws(), |world, k| {
        let mut q = world.query::<(&mut Eye, &mut Spectacles, &mut CloneDefocus)>();
        let (mut eye, mut spectacles, mut defocus) = q.single_mut(world).expect("eye");
        *eye =
            accepted(&Eye::default(), &mut seed, |e| e.optics().is_ok()).expect("an accepted eye");
        *spectacles = accepted(&Spectacles::sphere(-2.0), &mut seed, |s| s.design().is_ok())
            .expect("accepted glasses");
        // No check of its own: the plugin clamps the clone count.
        *defocus = any(&CloneDefocus::default(), k.wrapping_mul(7919));
    });
}

#[test]
fn random_foveated_tracers_draw_finite() {
    use optica_foveated_lod::{
        FoveatedLodPlugin, Foveation, GazeRayTracer, HeadSource, RayTraced, TrackedHead,
    };
    let eye = Vec3::new(0.0, 0.8, 3.0);
    let head = TrackedHead::looking(eye, Quat::IDENTITY, Some(Vec3::NEG_Z), 0.063);
    let start = head.clone();
    let mut app = headless()
        .start(move |app: &mut App| {
            app.add_plugins(FoveatedLodPlugin)
                .insert_resource(HeadSource::External)
                .insert_resource(Foveation::default())
                .insert_resource(start)
                .add_systems(
                    Startup,
                    move |mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>| {
                        commands.spawn((
                            Mesh3d(meshes.add(Sphere::new(0.5).mesh().ico(2).unwrap())),
                            Transform::from_xyz(0.0, 0.5, 0.0),
                            RayTraced::mirror(LinearRgba::rgb(0.9, 0.9, 0.95), 0.7),
                        ));
                        commands.spawn((
                            Mesh3d(meshes.add(Plane3d::default().mesh().size(10.0, 10.0).build())),
                            RayTraced::diffuse(LinearRgba::rgb(0.5, 0.5, 0.5)),
                        ));
                        commands.spawn((
                            GazeRayTracer::default(),
                            Transform::from_translation(eye).looking_at(Vec3::ZERO, Vec3::Y),
                        ));
                    },
                );
        })
        .expect("app");
    let mut seed = 5;
    run("foveated LOD", &mut app, draws(), |world, k| {
        let foveation = accepted(&Foveation::default(), &mut seed, |f| f.check().is_ok())
            .expect("accepted foveation");
        world.insert_resource(foveation);
        // The tracer's settings and the tracked head have no check of their
        // own: the plugin clamps them, and a head that is not finite is a
        // dropout.
        let mut q = world.query::<&mut GazeRayTracer>();
        let mut tracer = q.single_mut(world).expect("tracer");
        *tracer = any(&GazeRayTracer::default(), k.wrapping_mul(104_729));
        world.insert_resource(any(&head, k.wrapping_mul(1_299_709)));
    });
}
