//! The GPU ray tracer on lavapipe, held to the CPU reference tracer: the
//! same scene (read back from the app), the same per-pixel levels, the same
//! image; the coarse periphery leaves the central field untouched; a gaze
//! that covers the view is not foveated; rays outside the field are
//! background.

use std::sync::{Arc, Mutex};

use bevy::prelude::*;
use optica_foveated_lod::twins::{TracedScene, reference_of};
use optica_foveated_lod::{
    Eye, FoveatedLodPlugin, Foveation, FoveationWork, GazeRayTracer, GazeRayTracerState, GazeState,
    HeadSource, RayTraced, TrackedHead,
};
use optica_harness::{Adapter, Headless};
use optica_optics::foveated_lod::{
    GazeEstimate, LevelQuantization, TraceSettings, TracerCamera, pixel_levels, render_layered,
};
use optica_optics::glam::DVec3;

const W: u32 = 80;
const H: u32 = 60;
const EYE: Vec3 = Vec3::new(0.0, 1.4, 3.0);
const TARGET: Vec3 = Vec3::new(0.0, 0.6, 0.0);

/// What the app saw, read after the last frame.
#[derive(Default, Clone)]
struct Seen {
    traced: Option<TracedScene>,
    gaze: Option<GazeState>,
    state: Option<GazeRayTracerState>,
    work: Option<FoveationWork>,
}

/// [`trace_head`] with the gaze `gaze` (world direction from the eye)
/// tracked from the camera's eye.
fn trace(gaze: Vec3, tracer: GazeRayTracer, min_saving: f32) -> (Vec<Vec3>, Seen) {
    let head = TrackedHead::looking(EYE, Quat::IDENTITY, Some(gaze.normalize()), 0.0);
    trace_head(head, tracer, min_saving, |_| {})
}

/// A mirror sphere, a glass sphere, a diffuse torus on a ground plane under
/// one light, seen by a tracer camera, the head `head` tracked, foveating
/// where it saves `min_saving` of the rays; `extra` adds to the app.
/// Returns the linear image and what the app saw.
fn trace_head(
    head: TrackedHead,
    tracer: GazeRayTracer,
    min_saving: f32,
    extra: impl FnOnce(&mut App),
) -> (Vec<Vec3>, Seen) {
    let seen = Arc::new(Mutex::new(Seen::default()));
    let out = seen.clone();
    let frame = Headless::new(W, H)
        .hdr(true)
        .frames(3)
        .render(move |app: &mut App| {
            app.add_plugins(FoveatedLodPlugin)
                .insert_resource(HeadSource::External)
                .insert_resource(Foveation {
                    min_saving,
                    ..default()
                })
                .insert_resource(head)
                .add_systems(
                    Startup,
                    move |mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>| {
                        let ball = meshes.add(Sphere::new(0.5).mesh().ico(3).unwrap());
                        let torus = meshes.add(Torus::new(0.15, 0.4).mesh().build());
                        let ground = meshes.add(Plane3d::default().mesh().size(20.0, 20.0).build());
                        let red = LinearRgba::rgb(0.9, 0.3, 0.2);
                        commands.spawn((
                            Mesh3d(ball.clone()),
                            Transform::from_xyz(-0.7, 0.5, 0.0),
                            RayTraced::mirror(LinearRgba::rgb(0.9, 0.9, 0.95), 0.7),
                        ));
                        commands.spawn((
                            Mesh3d(ball),
                            Transform::from_xyz(0.7, 0.5, 0.4),
                            RayTraced::glass(LinearRgba::WHITE, 0.8, 1.5),
                        ));
                        commands.spawn((
                            Mesh3d(torus),
                            Transform::from_xyz(0.0, 0.5, -1.2)
                                .with_rotation(Quat::from_rotation_x(1.2)),
                            RayTraced::diffuse(red),
                        ));
                        commands.spawn((
                            Mesh3d(ground),
                            RayTraced::diffuse(LinearRgba::rgb(0.55, 0.55, 0.5)),
                        ));
                        commands.spawn((
                            PointLight {
                                intensity: 4.0e5,
                                ..default()
                            },
                            Transform::from_xyz(1.0, 4.0, 1.0),
                        ));
                        commands.spawn((
                            tracer.clone(),
                            Transform::from_translation(EYE).looking_at(TARGET, Vec3::Y),
                        ));
                    },
                )
                .add_systems(
                    Last,
                    move |traced: Res<TracedScene>,
                          gaze: Res<GazeState>,
                          work: Res<FoveationWork>,
                          states: Query<&GazeRayTracerState>| {
                        let mut s = out.lock().unwrap();
                        s.work = Some(work.clone());
                        s.traced = Some(traced.clone());
                        s.gaze = Some(gaze.clone());
                        s.state = states.iter().next().cloned();
                    },
                );
            extra(app);
        })
        .expect("render");
    let img = frame.hdr().expect("an HDR frame");
    let pixels = img.pixels().map(|p| Vec3::new(p[0], p[1], p[2])).collect();
    let seen = seen.lock().unwrap().clone();
    (pixels, seen)
}

/// The CPU reference of the same view: the scene the app built, the levels
/// of the app's gaze (eight steps, as the plugin quantises), rays scheduled
/// as the tracer does (`render_layered`); also each pixel's level.
fn reference(seen: &Seen, tracer: &GazeRayTracer, foveated: bool) -> (Vec<Vec3>, Vec<f64>) {
    let scene = reference_of(seen.traced.as_ref().unwrap(), tracer).expect("a traced scene");
    let camera = TracerCamera::pinhole(
        EYE.as_dvec3(),
        (TARGET - EYE).as_dvec3(),
        DVec3::Y,
        std::f64::consts::FRAC_PI_4,
    )
    .unwrap();
    let settings = TraceSettings::new(W as usize, H as usize, tracer.reflect_max).unwrap();
    let gaze = seen.gaze.as_ref().unwrap();
    let estimate = if foveated {
        *gaze.estimate(Eye::Cyclopean)
    } else {
        GazeEstimate::FullQuality { last: None }
    };
    let field = gaze.field(Eye::Cyclopean);
    let quant = LevelQuantization::Steps(8);
    let levels = pixel_levels(&camera, &settings, field, &estimate, quant);
    let img = render_layered(
        &scene,
        &camera,
        &settings,
        field,
        &estimate,
        quant,
        tracer.layers(),
    );
    (img.pixels.iter().map(|p| p.as_vec3()).collect(), levels)
}

/// Pixels of `a` and `b` that differ by more than 1 % of the value plus
/// 0.004 (f16 readback, f32 against f64 arithmetic) in any channel.
fn mismatches(a: &[Vec3], b: &[Vec3]) -> Vec<usize> {
    (0..a.len())
        .filter(|&i| {
            let d = (a[i] - b[i]).abs();
            let tol = b[i].abs() * 0.01 + Vec3::splat(0.004);
            d.cmpgt(tol).any() || !a[i].is_finite()
        })
        .collect()
}

/// A gaze 25° to the left of the view's centre: the central field covers
/// the left of the image, levels fall off to the right. Traced per pixel
/// (no coarse periphery), the GPU image is the CPU tracer's with the same
/// levels, pixel for pixel, on 99 % of the pixels (the rest are silhouette
/// and step edges, where f32 and f64 can pick different triangles or a
/// different level step); then the same gaze with the default layers
/// (levels from ½ to 1 at half resolution, below ½ at quarter resolution)
/// is again the CPU twin's image of that schedule, keeps every
/// central-field pixel as it was, and the rest close.
#[test]
fn gpu_tracer_matches_the_cpu_reference() {
    let forward = (TARGET - EYE).normalize();
    let gaze = Quat::from_rotation_y(25f32.to_radians()) * forward;
    let per_pixel = GazeRayTracer {
        periphery_scale: 1,
        ..default()
    };
    // Per pixel, only eq. 9 and 10 save work: foveate regardless.
    let (gpu, seen) = trace(gaze, per_pixel.clone(), 0.0);
    let state = seen.state.clone().unwrap();
    eprintln!("state {state:?}");
    assert!(
        state.foveating,
        "a 25° gaze leaves part of the view peripheral"
    );
    let (cpu, levels) = reference(&seen, &per_pixel, true);
    let bad = mismatches(&gpu, &cpu);
    let peripheral = levels.iter().filter(|&&l| l < 1.0 && l > 0.0).count();
    eprintln!(
        "{} of {} pixels differ; {} peripheral; stats of the scene: {} triangles",
        bad.len(),
        gpu.len(),
        peripheral,
        seen.traced.as_ref().unwrap().flat.triangles.len()
    );
    for &i in bad.iter().take(5) {
        eprintln!(
            "  pixel {i}: gpu {} cpu {} level {}",
            gpu[i], cpu[i], levels[i]
        );
    }
    assert!(peripheral > gpu.len() / 10, "the gaze leaves a periphery");
    assert!(bad.len() * 100 <= gpu.len(), "{} pixels differ", bad.len());
    // The coarse periphery: central pixels identical, the rest close.
    let (coarse, seen) = trace(gaze, GazeRayTracer::default(), 0.2);
    let (coarse_cpu, _) = reference(&seen, &GazeRayTracer::default(), true);
    let bad = mismatches(&coarse, &coarse_cpu);
    eprintln!(
        "coarse periphery: {} of {} pixels differ",
        bad.len(),
        coarse.len()
    );
    assert!(
        bad.len() * 100 <= coarse.len(),
        "{} pixels differ",
        bad.len()
    );
    let mut rms = 0.0;
    for i in 0..gpu.len() {
        if levels[i] >= 1.0 {
            assert_eq!(coarse[i], gpu[i], "central pixel {i}");
        } else {
            let clamp = |c: Vec3| c.clamp(Vec3::ZERO, Vec3::ONE);
            rms += (clamp(coarse[i]) - clamp(gpu[i])).length_squared() / 3.0;
        }
        assert!(coarse[i].is_finite());
    }
    let rms = (rms / peripheral.max(1) as f32).sqrt();
    eprintln!("periphery in layers: RMS {rms:.4} (linear, clamped to 1) against per pixel");
    assert!(rms < 0.1, "RMS {rms}");
}

/// A gaze at the view's centre: the 45° view lies inside the 30° central
/// field, foveation would save nothing, so the tracer does not foveate and
/// draws what `foveate: false` draws. A gaze straight behind the head puts
/// every pixel outside the field: the background, no ray traced.
#[test]
fn gpu_tracer_foveates_only_where_it_pays() {
    let forward = (TARGET - EYE).normalize();
    let (centre, seen) = trace(forward, GazeRayTracer::default(), 0.2);
    let state = seen.state.unwrap();
    assert!(!state.foveating, "{state:?}");
    assert!(state.saving < 0.1, "{state:?}");
    let (full, seen) = trace(
        forward,
        GazeRayTracer {
            foveate: false,
            ..default()
        },
        0.2,
    );
    assert_eq!(centre, full);
    let (cpu, _) = reference(&seen, &GazeRayTracer::default(), false);
    let bad = mismatches(&full, &cpu);
    assert!(bad.len() * 100 <= full.len(), "{} pixels differ", bad.len());
    let (behind, seen) = trace(-forward, GazeRayTracer::default(), 0.2);
    assert!(seen.state.unwrap().foveating);
    let bg = GazeRayTracer::default().background.to_vec3();
    for p in &behind {
        assert!(
            (*p - bg).abs().max_element() < 2e-3,
            "{p} vs background {bg}"
        );
    }
}

/// Leave out what a scene does not need: with the plugin and a plain camera
/// no tracer pipeline is built; with a `GazeRayTracer` camera its four
/// pipelines compile (wgpu's noop backend validates the shader).
#[test]
fn tracer_pipelines_only_for_tracer_cameras() {
    let labels = |tracer: bool| {
        Headless::new(32, 32)
            .adapter(Adapter::Noop)
            .frames(2)
            .check_pipelines(move |app: &mut App| {
                app.add_plugins(FoveatedLodPlugin).add_systems(
                    Startup,
                    move |mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>| {
                        commands.spawn((
                            Mesh3d(meshes.add(Sphere::new(0.5).mesh().ico(3).unwrap())),
                            RayTraced::diffuse(LinearRgba::WHITE),
                        ));
                        let mut camera = commands.spawn(
                            Transform::from_xyz(0.0, 0.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
                        );
                        if tracer {
                            camera.insert(GazeRayTracer::default());
                        } else {
                            camera.insert(Camera3d::default());
                        }
                    },
                );
            })
            .expect("pipelines compile")
            .labels
    };
    let plain = labels(false);
    assert!(
        !plain.iter().any(|l| l.starts_with("optica_foveated_lod")),
        "{plain:?}"
    );
    let traced = labels(true);
    for want in [
        "optica_foveated_lod_trace_mid",
        "optica_foveated_lod_trace_outer",
        "optica_foveated_lod_trace_full",
        "optica_foveated_lod_blit",
    ] {
        assert!(
            traced.iter().any(|l| l == want),
            "{want} missing: {traced:?}"
        );
    }
}

/// The tracer records its time span and, within it, the trace (compute)
/// and the blit (render) separately.
#[test]
fn the_tracer_records_its_trace_and_blit_spans() {
    let timed = Headless::new(32, 32)
        .time_frames(1, 2, |app: &mut App| {
            app.add_plugins(FoveatedLodPlugin).add_systems(
                Startup,
                |mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>| {
                    commands.spawn((
                        Mesh3d(meshes.add(Sphere::new(0.5).mesh().ico(2).unwrap())),
                        RayTraced::diffuse(LinearRgba::WHITE),
                    ));
                    commands.spawn((
                        GazeRayTracer::default(),
                        Transform::from_xyz(0.0, 0.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
                    ));
                },
            );
        })
        .expect("render");
    for name in [
        "optica/foveated_lod",
        "optica/foveated_lod/trace",
        "optica/foveated_lod/blit",
    ] {
        assert!(timed.span(name).is_some(), "no span {name}");
    }
}

/// Hostile heads on the tracer: a NaN gaze and a zero gaze (full quality,
/// as no valid gaze was ever seen), a head far outside the CAVE gazing
/// along the seam of two walls, and a model with a NaN vertex (left out of
/// the traced scene with a warning): every pixel finite. A still head does
/// not make the tracer's view work again every frame.
#[test]
fn hostile_heads_and_meshes_give_no_nan_pixel() {
    let seam = Vec3::new(1.0, 0.0, -1.0).normalize();
    let bad_mesh = |app: &mut App| {
        let mut mesh = Sphere::new(0.3).mesh().ico(3).unwrap();
        if let Some(bevy::mesh::VertexAttributeValues::Float32x3(p)) =
            mesh.attribute_mut(Mesh::ATTRIBUTE_POSITION)
        {
            p[5] = [f32::NAN, 0.0, 0.0];
        }
        let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(mesh);
        app.world_mut().spawn((
            Mesh3d(mesh),
            Transform::from_xyz(0.0, 1.0, 1.0),
            RayTraced::diffuse(LinearRgba::WHITE),
        ));
    };
    let cases = [
        (
            "NaN gaze",
            TrackedHead::looking(EYE, Quat::IDENTITY, Some(Vec3::NAN), 0.0),
        ),
        (
            "zero gaze",
            TrackedHead::looking(EYE, Quat::IDENTITY, Some(Vec3::ZERO), 0.0),
        ),
        (
            "outside the CAVE, gaze on a seam",
            TrackedHead::looking(
                Vec3::new(40.0, -3.0, 25.0),
                Quat::IDENTITY,
                Some(seam),
                0.063,
            ),
        ),
    ];
    for (i, (what, head)) in cases.into_iter().enumerate() {
        let (img, seen) = if i == 0 {
            trace_head(head, GazeRayTracer::default(), 0.2, bad_mesh)
        } else {
            trace_head(head, GazeRayTracer::default(), 0.2, |_| {})
        };
        let bad = img.iter().filter(|p| !p.is_finite()).count();
        assert_eq!(bad, 0, "{what}: {bad} non-finite pixels");
        assert!(img.iter().any(|p| *p != img[0]), "{what}: a blank image");
        let work = seen.work.unwrap();
        eprintln!(
            "{what}: tracer views prepared {} times in 3 frames",
            work.tracer_views
        );
        assert!(work.tracer_views >= 1 && work.tracer_views < 3, "{what}");
        if i == 0 {
            // The NaN model is left out: the four good ones remain.
            assert_eq!(seen.traced.unwrap().flat.objects.len(), 4);
        }
    }
}

/// Golden of the paper's method on lavapipe: a mirror and a glass ball over
/// a floor, traced with the gaze on the mirror (the foveated LOD's first
/// golden; the mesh path's is the showcase's picture).
#[test]
fn traced_balls_golden() {
    let frame = Headless::new(96, 96)
        .frames(3)
        .render(|app: &mut App| {
            app.add_plugins(FoveatedLodPlugin)
                .insert_resource(HeadSource::External)
                .insert_resource(TrackedHead::looking(
                    Vec3::new(0.0, 1.2, 3.0),
                    Quat::IDENTITY,
                    Some(Vec3::new(-0.6, -0.7, -3.0)),
                    0.0,
                ))
                .add_systems(
                    Startup,
                    |mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>| {
                        let ball = meshes.add(Sphere::new(0.5).mesh().ico(4).unwrap());
                        commands.spawn((
                            Mesh3d(ball.clone()),
                            Transform::from_xyz(-0.6, 0.5, 0.0),
                            RayTraced::mirror(LinearRgba::gray(0.9), 0.7),
                        ));
                        commands.spawn((
                            Mesh3d(ball),
                            Transform::from_xyz(0.6, 0.5, 0.0),
                            RayTraced::glass(LinearRgba::WHITE, 0.8, 1.5),
                        ));
                        commands.spawn((
                            Mesh3d(meshes.add(Plane3d::new(Vec3::Y, Vec2::splat(3.0)))),
                            RayTraced::diffuse(LinearRgba::rgb(0.5, 0.45, 0.4)),
                        ));
                        commands.spawn((PointLight::default(), Transform::from_xyz(1.0, 3.0, 2.0)));
                        commands.spawn((
                            GazeRayTracer::default(),
                            Transform::from_xyz(0.0, 1.2, 3.0)
                                .looking_at(Vec3::new(0.0, 0.4, 0.0), Vec3::Y),
                        ));
                    },
                );
        })
        .expect("render");
    optica_harness::assert_golden!(&frame);
}

/// A background or ambient that is not a colour (±∞, NaN, negative; from
/// code, or a panel dragged to its end) draws finite pixels: each channel
/// is clamped to 0..=65,504 and NaN counts as 0. Before, an infinite
/// ambient drew NaN pixels (found by the soak).
#[test]
fn colours_that_are_not_colours_draw_finite_pixels() {
    let forward = (TARGET - EYE).normalize();
    let tracer = GazeRayTracer {
        background: LinearRgba::new(f32::NAN, -1.0, 1e30, 1.0),
        ambient: LinearRgba::new(f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 1.0),
        ..default()
    };
    let (image, _) = trace(forward, tracer, 0.0);
    let bad = image.iter().filter(|p| !p.is_finite()).count();
    assert_eq!(bad, 0, "{bad} of {} pixels not finite", image.len());
}
