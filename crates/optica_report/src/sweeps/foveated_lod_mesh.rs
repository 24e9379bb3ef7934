//! The foveated-LOD plugin's mesh path on the adapter: frame time against
//! full quality in the paper's setting, and the image error by eccentricity.
//!
//! * Setting (the paper's §4.2, with ico spheres standing in for its cows):
//!   a 3 m CAVE with front, right and floor walls, one camera per wall
//!   (256² each, quick: 48²) from an eye at (0, 1.5, 0); eight models of
//!   5,780 triangles (the paper: 5,804), N_min = 500, one point light.
//! * Scenes (the paper's four): A mirror-like models spread over all walls,
//!   B diffuse over all walls, C mirror-like in front only, D diffuse in
//!   front only. Gazes: at the front wall, and 60° down at the floor.
//!   "Mirror-like" is a metallic `StandardMaterial` (roughness 0.05):
//!   rasterised, it reflects the environment light, not the other models.
//! * Time: the three walls' frame with `GazeLod` on every model against the
//!   same frame with foveation off (`Foveation::enabled = false`: every
//!   model at its full mesh), medians of the timed frames, same run.
//! * Error: the front wall's image against full quality (8-bit sRGB RMSE
//!   over the colour channels) per eccentricity band from the gaze: 0–5°,
//!   5–30°, beyond 30°; and weighted by each pixel's eq. 8 level. The
//!   central field (≤ 30°) must match full quality exactly.
//! * Models whose level is 0 (outside the visual field) are hidden, as the
//!   paper draws background there.
//! * Work: triangles of the models drawn per frame, foveated and full; the
//!   fraction the levels would save and whether the plugin foveated (it
//!   draws the full meshes where the levels save under a fifth).
//! * Series "central field": scene B with the front gaze, the knob the
//!   central field's radius (degrees).

use bevy::camera::{ClearColorConfig, RenderTarget};
use bevy::prelude::*;
use bevy::render::render_resource::TextureFormat;
use bevy::render::view::Msaa;
use image::RgbaImage;
use optica_foveated_lod::{
    CaveView, Eye, FoveatedLodPlugin, Foveation, FoveationGate, GazeLod, GazeLodState, HeadSource,
    TrackedHead, WallRect,
};
use optica_harness::PairedTimings;
use optica_optics::foveated_lod::GazeFrame;
use optica_optics::glam::DVec3;

use super::SweepError;
use crate::{Report, Row, SweepContext};

pub(super) const EYE: Vec3 = Vec3::new(0.0, 1.5, 0.0);
pub(super) const CAVE_M: f32 = 3.0;
pub(super) const MODELS: usize = 8;
const BANDS_DEG: [(f64, f64, &str); 3] = [
    (0.0, 5.0, "rmse_0_5deg"),
    (5.0, 30.0, "rmse_5_30deg"),
    (30.0, 180.0, "rmse_beyond_30deg"),
];

/// One of the paper's four scenes.
#[derive(Clone, Copy, Debug)]
pub(super) struct Scene {
    pub(super) name: &'static str,
    pub(super) mirror: bool,
    pub(super) all_walls: bool,
}

pub(super) const SCENES: [Scene; 4] = [
    Scene {
        name: "A mirror, all walls",
        mirror: true,
        all_walls: true,
    },
    Scene {
        name: "B diffuse, all walls",
        mirror: false,
        all_walls: true,
    },
    Scene {
        name: "C mirror, front",
        mirror: true,
        all_walls: false,
    },
    Scene {
        name: "D diffuse, front",
        mirror: false,
        all_walls: false,
    },
];

/// The paper's eight cases: each scene with the front and the floor gaze.
pub(super) fn paper_cases() -> Vec<(Scene, bool)> {
    SCENES
        .into_iter()
        .flat_map(|s| [(s, false), (s, true)])
        .collect()
}

/// The name of the front (false) or floor (true) gaze in series names.
pub(super) fn gaze_name(floor: bool) -> &'static str {
    if floor { "floor gaze" } else { "front gaze" }
}

/// The gaze: at the front wall, or 60° down at the floor.
pub(super) fn gaze(floor: bool) -> Vec3 {
    if floor {
        Quat::from_rotation_x(-60f32.to_radians()) * Vec3::NEG_Z
    } else {
        Vec3::NEG_Z
    }
}

/// Where the models stand: spread in front of the front wall, or over the
/// front wall, the right wall and the floor.
pub(super) fn positions(all_walls: bool) -> Vec<Vec3> {
    (0..MODELS)
        .map(|i| {
            let f = i as f32;
            if !all_walls {
                Vec3::new(-1.05 + 0.3 * f, 1.2 + 0.25 * (f % 3.0), -1.0)
            } else {
                match i % 3 {
                    0 => Vec3::new(-0.8 + 0.5 * f / 3.0, 1.4, -1.0),
                    1 => Vec3::new(1.0, 1.0 + 0.2 * f / 3.0, -0.7 + 0.5 * f / 3.0),
                    _ => Vec3::new(-0.7 + 0.4 * f / 3.0, 0.25, -0.6 + 0.2 * f / 3.0),
                }
            }
        })
        .collect()
}

/// The scene's app: walls as cameras (the front one draws into the
/// harness's image, the others into their own), the models, a light.
fn setup(app: &mut App, scene: Scene, floor_gaze: bool, foveation: Foveation, size: u32) {
    let head = TrackedHead::looking(EYE, Quat::IDENTITY, Some(gaze(floor_gaze)), 0.063);
    app.add_plugins(FoveatedLodPlugin)
        .insert_resource(HeadSource::External)
        .insert_resource(head)
        .insert_resource(foveation)
        .add_systems(
            Startup,
            move |mut commands: Commands,
                  mut meshes: ResMut<Assets<Mesh>>,
                  mut images: ResMut<Assets<Image>>,
                  mut materials: ResMut<Assets<StandardMaterial>>| {
                let model = meshes.add(Sphere::new(0.15).mesh().ico(16).expect("ico sphere"));
                let material = materials.add(if scene.mirror {
                    StandardMaterial {
                        base_color: Color::srgb(0.9, 0.9, 0.95),
                        metallic: 1.0,
                        perceptual_roughness: 0.05,
                        ..default()
                    }
                } else {
                    StandardMaterial {
                        base_color: Color::srgb(0.8, 0.5, 0.3),
                        perceptual_roughness: 0.8,
                        ..default()
                    }
                });
                for p in positions(scene.all_walls) {
                    commands.spawn((
                        Mesh3d(model.clone()),
                        MeshMaterial3d(material.clone()),
                        Transform::from_translation(p),
                        // Level 0 draws background, as the paper's rays do.
                        GazeLod {
                            hide_outside_field: true,
                            ..default()
                        },
                    ));
                }
                commands.spawn((
                    PointLight {
                        intensity: 2.0e5,
                        range: 20.0,
                        ..default()
                    },
                    Transform::from_xyz(0.5, 2.8, 0.5),
                ));
                let walls = WallRect::front_right_floor(CAVE_M).expect("a 3 m CAVE");
                for (i, wall) in walls.into_iter().enumerate() {
                    let mut camera = commands.spawn((
                        CaveView::new(wall, Eye::Cyclopean),
                        Camera {
                            order: i as isize,
                            clear_color: ClearColorConfig::Custom(Color::srgb(0.1, 0.1, 0.12)),
                            ..default()
                        },
                        Msaa::Off,
                    ));
                    if i > 0 {
                        let target = Image::new_target_texture(
                            size,
                            size,
                            TextureFormat::Rgba8UnormSrgb,
                            None,
                        );
                        camera.insert(RenderTarget::Image(images.add(target).into()));
                    }
                }
            },
        );
}

/// The foveation of the scenes: the paper's field, or with another central
/// radius; `enabled = false` is full quality.
pub(super) fn foveation(enabled: bool, central_deg: f32) -> Foveation {
    Foveation {
        enabled,
        central_deg,
        ..default()
    }
}

/// The eccentricity (degrees) and the eq. 8 level of each front-wall pixel.
pub(super) fn pixel_field(size: u32, floor_gaze: bool, central_deg: f32) -> Vec<(f64, f64)> {
    let [front, _, _] = WallRect::front_right_floor(CAVE_M).expect("a 3 m CAVE");
    let g = gaze(floor_gaze).as_dvec3();
    let frame = GazeFrame::new(EYE.as_dvec3(), g, DVec3::Y).expect("a valid gaze");
    let field = foveation(true, central_deg)
        .check()
        .expect("valid settings")
        .field(Eye::Cyclopean);
    let (ll, u, v) = (
        front.lower_left.as_dvec3(),
        (front.lower_right - front.lower_left).as_dvec3(),
        (front.upper_left - front.lower_left).as_dvec3(),
    );
    let n = size as f64;
    (0..size * size)
        .map(|i| {
            let (x, y) = ((i % size) as f64 + 0.5, (i / size) as f64 + 0.5);
            let p = ll + u * (x / n) + v * (1.0 - y / n);
            let d = (p - EYE.as_dvec3()).normalize();
            let ecc = d.dot(g.normalize()).clamp(-1.0, 1.0).acos().to_degrees();
            (ecc, field.level(&frame, d))
        })
        .collect()
}

/// RMSE (8-bit sRGB, colour channels, in [0, 1]) per band and weighted by
/// level.
pub(super) fn banded_error(
    a: &RgbaImage,
    b: &RgbaImage,
    field: &[(f64, f64)],
) -> Vec<(&'static str, f64)> {
    let mut sums = [(0.0, 0.0); 4];
    for (i, (pa, pb)) in a.pixels().zip(b.pixels()).enumerate() {
        let e2 = (0..3)
            .map(|c| ((pa[c] as f64 - pb[c] as f64) / 255.0).powi(2))
            .sum::<f64>()
            / 3.0;
        let (ecc, level) = field[i];
        for (k, (lo, hi, _)) in BANDS_DEG.iter().enumerate() {
            if ecc >= *lo && ecc < *hi {
                sums[k].0 += e2;
                sums[k].1 += 1.0;
            }
        }
        sums[3].0 += e2 * level;
        sums[3].1 += level;
    }
    let rmse = |(s, n): (f64, f64)| if n > 0.0 { (s / n).sqrt() } else { 0.0 };
    let mut out: Vec<_> = BANDS_DEG
        .iter()
        .enumerate()
        .map(|(k, (_, _, name))| (*name, rmse(sums[k])))
        .collect();
    out.push(("rmse_level_weighted", rmse(sums[3])));
    out
}

/// The scene's app without rendering (the levels and the CAVE cameras are
/// CPU state), its clock advancing 1/60 s a frame so that dwell and dropout
/// hold play out in frames, not in the machine's speed.
fn cpu_app() -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, AssetPlugin::default()))
        .init_asset::<Mesh>()
        .init_asset::<Image>()
        .init_asset::<StandardMaterial>()
        .insert_resource(bevy::time::TimeUpdateStrategy::ManualDuration(
            std::time::Duration::from_secs_f64(1.0 / 60.0),
        ));
    app
}

/// Triangles the models draw as the plugin chooses them, from the same
/// setup run without rendering (the choice depends on the gaze and the
/// models' places only).
fn triangles_drawn(scene: Scene, floor_gaze: bool, foveation: Foveation) -> (f64, FoveationGate) {
    let mut app = cpu_app();
    setup(&mut app, scene, floor_gaze, foveation, 8);
    for _ in 0..4 {
        app.update();
    }
    let mut q = app.world_mut().query::<&GazeLodState>();
    let drawn = q
        .iter(app.world())
        .filter(|s| !s.hidden)
        .map(|s| s.triangles as f64)
        .sum();
    (drawn, app.world().resource::<FoveationGate>().clone())
}

/// One measured case: foveated against full quality, same run.
struct Case {
    /// The foveated frame against full quality's.
    paired: PairedTimings,
    errors: Vec<(&'static str, f64)>,
    triangles: (f64, f64),
    gate: FoveationGate,
}

fn measure(
    ctx: &SweepContext,
    scene: Scene,
    floor_gaze: bool,
    central_deg: f32,
    report: &mut Report,
) -> Result<Case, SweepError> {
    let size = ctx.pick(48, 256);
    let warmup = ctx.pick(3, 5);
    let headless = ctx.headless(size, size).frames(4);
    let mut images = Vec::new();
    let mut triangles = Vec::new();
    let mut gates = Vec::new();
    for enabled in [true, false] {
        let fov = foveation(enabled, central_deg);
        let frame = headless.render(|app| setup(app, scene, floor_gaze, fov.clone(), size))?;
        report.adapter.get_or_insert(frame.adapter.clone());
        images.push(frame.to_rgba8());
        let (drawn, gate) = triangles_drawn(scene, floor_gaze, fov);
        triangles.push(drawn);
        gates.push(gate);
    }
    // Foveated against full quality in alternating blocks.
    let (blocks, per_block) = ctx.blocks();
    let (foveated, full) = (foveation(true, central_deg), foveation(false, central_deg));
    let paired = headless.time_paired(
        warmup,
        blocks,
        per_block,
        |app| setup(app, scene, floor_gaze, foveated, size),
        |app| setup(app, scene, floor_gaze, full, size),
    )?;
    let field = pixel_field(size, floor_gaze, central_deg);
    Ok(Case {
        paired,
        errors: banded_error(&images[0], &images[1], &field),
        triangles: (triangles[0], triangles[1]),
        gate: gates[0].clone(),
    })
}

/// Adds the mesh path's rows and stability cases to the `foveated_lod` report.
pub fn mesh_rows(ctx: &SweepContext, report: &mut Report) -> Result<(), SweepError> {
    // Quick: two of the eight cases, one knob value.
    let cases = ctx.pick(vec![(SCENES[1], true), (SCENES[3], false)], paper_cases());
    let centrals: Vec<f32> = ctx.pick(vec![10.0], vec![5.0, 10.0, 20.0]);
    let total = cases.len() + centrals.len();
    let mut step = 0;
    for (scene, floor_gaze) in cases {
        let gaze_name = gaze_name(floor_gaze);
        ctx.progress(
            step,
            total,
            &format!("mesh path, {}, {gaze_name}", scene.name),
        );
        step += 1;
        let case = measure(ctx, scene, floor_gaze, 30.0, report)?;
        report.rows.push(row(
            &case,
            30.0,
            &format!("mesh: {}, {gaze_name}", scene.name),
        ));
    }
    for central in centrals {
        ctx.progress(step, total, &format!("mesh path, central field {central}°"));
        step += 1;
        let case = measure(ctx, SCENES[1], false, central, report)?;
        report.rows.push(row(
            &case,
            central as f64,
            "mesh: central field (B, front gaze)",
        ));
    }
    report.ratio_goal("mesh path never slower than full quality", 1.0, |r| {
        r.series.starts_with("mesh:")
    });
    plugin_stability(report);
    Ok(())
}

/// The plugin's systems on hostile heads (no rendering: the levels and the
/// CAVE cameras are CPU state): every level finite and in [0, 1], every
/// camera transform and projection finite, nothing panics.
fn plugin_stability(report: &mut Report) {
    let [front, right, _] = WallRect::front_right_floor(CAVE_M).expect("a 3 m CAVE");
    let seam = (front.lower_right + front.upper_left.with_x(right.lower_left.x)) / 2.0;
    let cases: [(&str, TrackedHead); 5] = [
        (
            "gaze behind the head",
            TrackedHead::looking(EYE, Quat::IDENTITY, Some(Vec3::Z), 0.063),
        ),
        (
            "NaN gaze",
            TrackedHead::looking(EYE, Quat::IDENTITY, Some(Vec3::NAN), 0.063),
        ),
        (
            "zero gaze",
            TrackedHead::looking(EYE, Quat::IDENTITY, Some(Vec3::ZERO), 0.063),
        ),
        (
            "gaze on the front/right wall seam",
            TrackedHead::looking(EYE, Quat::IDENTITY, Some(seam - EYE), 0.063),
        ),
        (
            "head outside the CAVE, behind the front wall",
            TrackedHead::looking(Vec3::new(0.4, 1.5, -4.0), Quat::IDENTITY, None, 0.063),
        ),
    ];
    for (name, head) in cases {
        let mut app = cpu_app();
        setup(&mut app, SCENES[0], false, Foveation::default(), 8);
        for _ in 0..3 {
            app.update();
        }
        app.insert_resource(head);
        for _ in 0..30 {
            app.update();
        }
        let mut levels = app.world_mut().query::<&GazeLodState>();
        let levels: Vec<f32> = levels.iter(app.world()).map(|s| s.level).collect();
        let levels_ok = levels.iter().all(|l| (0.0..=1.0).contains(l));
        let mut cams = app
            .world_mut()
            .query::<(&Transform, &Projection, &CaveView)>();
        let mut cams_ok = true;
        let mut nearest = f64::INFINITY;
        for (t, p, view) in cams.iter(app.world()) {
            let finite = t.translation.is_finite()
                && t.rotation.is_finite()
                && matches!(p, Projection::Custom(_))
                && p.get_clip_from_view().is_finite();
            cams_ok &= finite;
            if let Ok(wall) = view.wall.wall() {
                nearest = nearest.min(wall.signed_distance(t.translation.as_dvec3()));
            }
        }
        let full = app
            .world()
            .resource::<optica_foveated_lod::GazeState>()
            .full_quality();
        // A NaN or zero gaze is a dropout: full quality once the hold is over.
        let full_ok = full == matches!(name, "NaN gaze" | "zero gaze");
        report.case(
            &format!("plugin: {name}"),
            levels_ok && cams_ok && nearest > 0.0 && full_ok,
            format!(
                "levels {:?}; full quality: {full}; wall cameras finite: {cams_ok}, the nearest {nearest:.3} m in front of its wall",
                levels.iter().map(|l| (l * 100.0).round() / 100.0).collect::<Vec<_>>()
            ),
        );
    }
}

fn row(case: &Case, knob: f64, series: &str) -> Row {
    let mut r = Row::paired(knob, &case.paired)
        .series(series)
        .work("triangles_foveated", case.triangles.0)
        .work("triangles_full", case.triangles.1)
        .work("triangle_saving", case.gate.saving as f64)
        .work("foveating", case.gate.active as u8 as f64);
    for (name, value) in &case.errors {
        r = r.err(name, *value);
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_mesh_rows_match_full_quality_in_the_central_field() {
        let ctx = SweepContext::new("foveated_lod", true, true);
        let mut report = Report::cpu("foveated_lod", "level_steps_S");
        mesh_rows(&ctx, &mut report).expect("the mesh rows run on lavapipe");
        assert_eq!(report.rows.len(), 3);
        for c in &report.stability {
            eprintln!("{}: {} — {}", c.case, c.ok, c.detail);
        }
        // The plugin's five hostile heads and the goal on the ratios.
        assert_eq!(report.stability.len(), 6);
        assert!(
            report
                .stability
                .iter()
                .any(|c| c.case.contains("never slower") && c.detail.contains("rows within it")),
            "{:?}",
            report.stability
        );
        for r in &report.rows {
            eprintln!(
                "{} {}: {:.2}/{:.2} ms {:?} {:?}",
                r.series, r.knob, r.time_ms, r.baseline_time_ms, r.error, r.work
            );
            assert!(r.time_ms > 0.0 && r.baseline_time_ms > 0.0);
            // Foveating draws fewer triangles; where the levels would save
            // too little, the full meshes are drawn.
            if r.work["foveating"] == 1.0 {
                assert!(
                    r.work["triangles_foveated"] < r.work["triangles_full"],
                    "{:?}",
                    r.work
                );
            } else {
                assert!(r.work["triangle_saving"] < 0.2, "{:?}", r.work);
                assert_eq!(r.work["triangles_foveated"], r.work["triangles_full"]);
            }
            assert_eq!(r.work["triangles_full"], (MODELS * 5780) as f64);
        }
        // The paper's central field (30°) draws exactly what full quality draws.
        for r in report.rows.iter().filter(|r| r.knob == 30.0) {
            assert_eq!(r.error["rmse_0_5deg"], 0.0, "{}", r.series);
            assert_eq!(r.error["rmse_5_30deg"], 0.0, "{}", r.series);
        }
        assert!(report.problems().is_empty(), "{:?}", report.problems());
    }
}
