//! Foveated LOD (Mochizuki & Makino): error of the foveated ray-traced image
//! against the full-quality one, over the level quantisation.
//!
//! * Scene: `demo_scene` (8 objects, 4 reflective, one point light, a ground
//!   plane; LOD chains of 4 tessellations, near the paper's 500–5,804
//!   triangles in the full sweep), traced on the front wall of a 3 m CAVE
//!   from an eye at its centre, Reflect_max = 3 (the paper's §4.2 values).
//! * Gaze: 35° to the right and 15° down of the wall's normal, so that the
//!   image holds central, peripheral and (at the left edge) outside regions.
//! * Knob: the number of level steps S; each ray's eq. 8 level is quantised
//!   to ⌊S·level⌋/S before eq. 9/10. S = 1 keeps only the central field
//!   (everything else is background); S → ∞ is the paper's continuous level.
//!   The steps are nested (S doubles), so a level never drops as S grows.
//! * Errors: `rmse` over all pixels and channels (linear RGB), and
//!   `gaze_weighted_rmse`, each pixel weighted by its continuous eq. 8 level
//!   (what the viewer can see counts, the periphery it is meant to degrade
//!   counts less, outside the field not at all).
//! * Work: rays (primary + reflection + shadow) and ray–triangle tests of the
//!   foveated trace, and the same for the full-quality trace.
//! * time_ms: per-pixel levels plus the foveated trace; baseline_time_ms: the
//!   full-quality trace (level 1 for every ray) of the same scene.

use optica_optics::foveated_lod::{
    DemoDetail, GazeEstimate, GazeFrame, GazeTracker, HysteresisParams, LevelQuantization,
    PixelLodGrid, TraceSettings, TracerCamera, TracerScene, TrackerSample, VisualField, demo_scene,
    front_right_floor, pixel_levels, render, render_full_quality, rmse, weighted_rmse,
};
use optica_optics::glam::DVec3;

use crate::{Report, Row, SweepContext, time_paired_ms};

/// The gaze of the sweep: 35° right and 15° down of −z (the front wall's view axis).
fn sweep_gaze(eye: DVec3) -> GazeFrame {
    let (yaw, pitch) = (35f64.to_radians(), -15f64.to_radians());
    let dir = DVec3::new(
        yaw.sin() * pitch.cos(),
        pitch.sin(),
        -yaw.cos() * pitch.cos(),
    );
    GazeFrame::new(eye, dir, DVec3::Y).expect("a finite gaze off the vertical")
}

/// Runs the sweep.
pub fn run(ctx: &SweepContext) -> Report {
    let mut report = Report::cpu("foveated_lod", "level_steps_S");
    report.baseline =
        "full-quality Whitted trace (level 1 for every ray: Reflect_max = 3, finest meshes)".into();
    report.reference =
        "the same full-quality trace; errors are linear-RGB RMSE and gaze-weighted RMSE \
                        (weights = continuous eq. 8 level per pixel)"
            .into();

    let n = ctx.pick(32, 128);
    let detail = ctx.pick(DemoDetail::small(), DemoDetail::paper());
    let steps: Vec<u32> = ctx.pick(vec![1, 2, 4, 8], vec![1, 2, 4, 8, 16, 32, 64]);
    let (runs, budget) = ctx.pick((3, 30.0), (3, 1500.0));

    let scene = demo_scene(&detail).expect("demo scene");
    let walls = front_right_floor(3.0).expect("CAVE walls");
    let eye = DVec3::new(0.0, 1.5, 0.0);
    let cam = TracerCamera::cave(walls[0], eye).expect("eye inside the CAVE");
    let settings = TraceSettings::new(n, n, 3).expect("a small image");
    let field = VisualField::paper();
    let gaze = GazeEstimate::Tracked(sweep_gaze(eye));
    let weights = pixel_levels(
        &cam,
        &settings,
        &field,
        &gaze,
        LevelQuantization::Continuous,
    );

    let total = steps.len() + 1;
    ctx.progress(0, total, "full-quality baseline");
    let full = render_full_quality(&scene, &cam, &settings);

    for (i, &s) in steps.iter().enumerate() {
        ctx.progress(i + 1, total, &format!("S = {s}"));
        // Against full quality in alternating blocks.
        let (timed, img) = time_paired_ms(
            ctx.blocks().0,
            runs,
            budget,
            || {
                let lv = pixel_levels(&cam, &settings, &field, &gaze, LevelQuantization::Steps(s));
                render(&scene, &cam, &settings, &lv).expect("one level per pixel")
            },
            || render_full_quality(&scene, &cam, &settings),
        );
        let e = rmse(&img.pixels, &full.pixels).unwrap_or(f64::NAN);
        let g = weighted_rmse(&img.pixels, &full.pixels, &weights).unwrap_or(f64::NAN);
        report.rows.push(
            Row::paired_cpu(s as f64, &timed)
                .err("rmse", e)
                .err("gaze_weighted_rmse", g)
                .work("rays", img.stats.rays() as f64)
                .work("triangle_tests", img.stats.triangle_tests as f64)
                .work("background_pixels", img.stats.background_pixels as f64)
                .work("baseline_rays", full.stats.rays() as f64)
                .work("baseline_triangle_tests", full.stats.triangle_tests as f64),
        );
    }

    stability(&mut report, &scene, &cam, &settings, &field, &full.pixels);
    report
}

fn all_finite(p: &[DVec3]) -> bool {
    p.iter().all(|c| c.is_finite())
}

/// Stability cases that run the whole path (tracker or gaze → per-pixel
/// levels → render, or → the hysteresis grid). Properties of one function
/// (the level's continuity and its ear-side singularity, the CAVE's
/// eye-behind-the-wall error) are unit tests in `optica_optics`.
fn stability(
    report: &mut Report,
    scene: &TracerScene,
    cam: &TracerCamera,
    settings: &TraceSettings,
    field: &VisualField,
    full: &[DVec3],
) {
    gaze_behind_the_head(report, scene, cam, settings, field);
    nan_tracker(report, scene, cam, settings, field, full);
    gaze_on_the_boundary(report, scene, cam, settings, field);
    gaze_jitter(report, cam, settings, field);
}

/// Gaze behind the head: the wall is entirely behind the gaze.
fn gaze_behind_the_head(
    report: &mut Report,
    scene: &TracerScene,
    cam: &TracerCamera,
    settings: &TraceSettings,
    field: &VisualField,
) {
    let eye = cam.eye();
    let behind = GazeEstimate::Tracked(GazeFrame::new(eye, DVec3::Z, DVec3::Y).expect("gaze"));
    let lv = pixel_levels(cam, settings, field, &behind, LevelQuantization::Continuous);
    match render(scene, cam, settings, &lv) {
        Ok(img) => {
            let bg = img.pixels.iter().all(|&p| p == scene.background());
            report.case(
                "gaze behind the head",
                all_finite(&img.pixels) && bg && img.stats.rays() == 0,
                format!(
                    "all {} pixels level 0 → background without a ray (rays traced: {}); max level {}",
                    lv.len(),
                    img.stats.rays(),
                    lv.iter().cloned().fold(0.0, f64::max)
                ),
            );
        }
        Err(e) => report.case("gaze behind the head", false, format!("render failed: {e}")),
    }
}

/// NaN tracker: hold the last pose within the timeout, then full quality.
fn nan_tracker(
    report: &mut Report,
    scene: &TracerScene,
    cam: &TracerCamera,
    settings: &TraceSettings,
    field: &VisualField,
    full: &[DVec3],
) {
    let eye = cam.eye();
    let mut tr = GazeTracker::new(0.1).expect("timeout");
    let g = sweep_gaze(eye);
    let good = TrackerSample::Gaze {
        eye,
        gaze: g.forward(),
        up: DVec3::Y,
    };
    let nan = TrackerSample::Gaze {
        eye,
        gaze: DVec3::new(f64::NAN, 0.0, -1.0),
        up: DVec3::Y,
    };
    tr.update(good, 0.0);
    let held = tr.update(nan, 0.05);
    let lost = tr.update(nan, 0.2);
    let tracked_lv = pixel_levels(
        cam,
        settings,
        field,
        &GazeEstimate::Tracked(g),
        LevelQuantization::Continuous,
    );
    let held_lv = pixel_levels(cam, settings, field, &held, LevelQuantization::Continuous);
    let lost_lv = pixel_levels(cam, settings, field, &lost, LevelQuantization::Continuous);
    let lost_img = render(scene, cam, settings, &lost_lv);
    let held_ok = matches!(held, GazeEstimate::Held { .. }) && held_lv == tracked_lv;
    let lost_ok = matches!(lost, GazeEstimate::FullQuality { .. })
        && lost_img
            .as_ref()
            .is_ok_and(|im| im.pixels == full && all_finite(&im.pixels));
    report.case(
        "NaN tracker",
        held_ok && lost_ok,
        format!(
            "NaN at 50 ms: held the last pose (levels identical: {held_ok}); NaN at 200 ms (> 100 ms timeout): \
             full quality, image identical to the full-quality trace: {lost_ok}"
        ),
    );
}

/// Gaze on the eq. 7 boundary: pixels beyond it are background.
fn gaze_on_the_boundary(
    report: &mut Report,
    scene: &TracerScene,
    cam: &TracerCamera,
    settings: &TraceSettings,
    field: &VisualField,
) {
    let eye = cam.eye();
    // A gaze 70° to the right puts the boundary across the wall's left half.
    let yaw = 70f64.to_radians();
    let g = GazeEstimate::Tracked(
        GazeFrame::new(eye, DVec3::new(yaw.sin(), 0.0, -yaw.cos()), DVec3::Y).expect("gaze"),
    );
    let lv = pixel_levels(cam, settings, field, &g, LevelQuantization::Continuous);
    let img = render(scene, cam, settings, &lv);
    let outside = lv.iter().filter(|&&l| l == 0.0).count();
    let bg_ok = img.as_ref().is_ok_and(|im| {
        all_finite(&im.pixels)
            && lv
                .iter()
                .zip(&im.pixels)
                .all(|(&l, &p)| l > 0.0 || p == scene.background())
    });
    report.case(
        "gaze on the eq. 7 boundary",
        bg_ok && outside > 0 && outside < lv.len(),
        format!(
            "gaze 70° right: {outside} of {} pixels beyond the boundary, all background, image finite: {bg_ok}",
            lv.len()
        ),
    );
}

/// Gaze jitter: ±0.5° tracker noise at 90 Hz for 2 s.
fn gaze_jitter(
    report: &mut Report,
    cam: &TracerCamera,
    settings: &TraceSettings,
    field: &VisualField,
) {
    let eye = cam.eye();
    // The defaults: S = 8, dead band 0.05, dwell 0.25 s.
    let params = HysteresisParams::default();
    let mut grid = PixelLodGrid::new(settings.pixel_count(), params);
    let mut naive_prev: Option<Vec<f64>> = None;
    let mut naive = 0u64;
    // Marsaglia's xorshift64 (J. Stat. Softw. 8(14), 2003), fixed seed:
    // the same jitter in every run. (This crate has no `rand`; the
    // reference generators live behind optica_optics' `reference` feature.)
    let mut seed = 0x2545F4914F6CDD1Du64;
    let mut rnd = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let base = sweep_gaze(eye).forward();
    let frames = 180;
    let npx = settings.pixel_count();
    let (mut lo, mut hi) = (vec![f64::INFINITY; npx], vec![f64::NEG_INFINITY; npx]);
    for i in 0..frames {
        let jitter = DVec3::new(rnd(), rnd(), rnd()) * (1f64.to_radians());
        let g = GazeEstimate::Tracked(GazeFrame::new(eye, base + jitter, DVec3::Y).expect("gaze"));
        let lv = pixel_levels(cam, settings, field, &g, LevelQuantization::Continuous);
        for (k, &l) in lv.iter().enumerate() {
            lo[k] = lo[k].min(l);
            hi[k] = hi[k].max(l);
        }
        let q: Vec<f64> = lv
            .iter()
            .map(|&l| LevelQuantization::Steps(params.steps()).apply(l))
            .collect();
        if let Some(p) = &naive_prev {
            naive += p.iter().zip(&q).filter(|(a, b)| a != b).count() as u64;
        }
        naive_prev = Some(q);
        grid.update(&lv, i as f64 / 90.0)
            .expect("one level per pixel");
    }
    let held = grid.switches();
    let swing: Vec<f64> = hi.iter().zip(&lo).map(|(h, l)| h - l).collect();
    let max_swing = swing.iter().cloned().fold(0.0, f64::max);
    let wide = swing.iter().filter(|&&s| s > params.dead_band()).count();
    // Gain of eq. 5's m_β on gaze motion, 1/√(d_f² + d_u²), at those pixels.
    let g0 = sweep_gaze(eye);
    let max_gain = swing
        .iter()
        .enumerate()
        .filter(|&(_, &s)| s > params.dead_band())
        .map(|(k, _)| {
            let r = cam.primary_ray(k % settings.width(), k / settings.width(), settings);
            let d = g0.to_local(r.dir());
            1.0 / d.x.hypot(d.z)
        })
        .fold(0.0, f64::max);
    // Bound of `LodHysteresis`: D + (D + 1)·S switches per slot, D = ⌈T/dwell⌉,
    // and only slots whose level swings by more than the dead band can switch at all.
    let t = frames as f64 / 90.0;
    let d = (t / params.min_dwell_s()).ceil() as u64;
    let bound = wide as u64 * (d + (d + 1) * params.steps() as u64);
    report.case(
        "gaze jitter (hysteresis)",
        held <= bound && held * 100 <= naive && naive > 0,
        format!(
            "±0.5° jitter, {frames} frames at 90 Hz, S = {}, dead band {}, dwell {} s: {held} pixel LOD \
             switches with hysteresis, {naive} without; {wide} of {npx} pixels swing by more than the dead band \
             (max swing {max_swing:.3}; they lie towards the ear side, where eq. 5 amplifies gaze motion by \
             1/√(d_f² + d_u²), up to {max_gain:.1} here)",
            params.steps(),
            params.dead_band(),
            params.min_dwell_s()
        ),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_sweep_is_finite_and_error_falls_with_steps() {
        let ctx = SweepContext::new("foveated_lod", true, true);
        let r = run(&ctx);
        assert_eq!(r.rows.len(), 4);
        let problems = r.problems();
        assert!(problems.is_empty(), "{problems:#?}");
        let err = |i: usize, k: &str| r.rows[i].error[k];
        for k in ["rmse", "gaze_weighted_rmse"] {
            assert!(err(3, k) < err(0, k), "{k} must fall from S = 1 to S = 8");
            for i in 1..4 {
                assert!(
                    err(i, k) <= err(i - 1, k) * 1.02 + 1e-12,
                    "{k} rises at row {i}"
                );
            }
        }
        // Foveation does less work than the baseline.
        let w = &r.rows[0].work;
        assert!(w["triangle_tests"] < w["baseline_triangle_tests"]);
    }
}
