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

use optica_optics::foveated_lod::level::{BoundaryShape, EyeModel, FieldAngles};
use optica_optics::foveated_lod::{
    Camera, DemoDetail, FoveatedError, GazeEstimate, GazeFrame, GazeTracker, HysteresisParams, LevelQuantization,
    PixelLodGrid, TraceSettings, TrackerSample, VisualField, demo_scene, front_right_floor, pixel_levels, render,
    render_full_quality, rmse, weighted_rmse,
};
use optica_optics::glam::DVec3;

use crate::{Report, Row, SweepContext, time_ms};

/// The gaze of the sweep: 35° right and 15° down of −z (the front wall's view axis).
fn sweep_gaze(eye: DVec3) -> GazeFrame {
    let (yaw, pitch) = (35f64.to_radians(), -15f64.to_radians());
    let dir = DVec3::new(yaw.sin() * pitch.cos(), pitch.sin(), -yaw.cos() * pitch.cos());
    GazeFrame::new(eye, dir, DVec3::Y).expect("a finite gaze off the vertical")
}

/// Runs the sweep.
pub fn run(ctx: &SweepContext) -> Report {
    let mut report = Report::cpu("foveated_lod", "level_steps_S");
    report.baseline = "full-quality Whitted trace (level 1 for every ray: Reflect_max = 3, finest meshes)".into();
    report.reference = "the same full-quality trace; errors are linear-RGB RMSE and gaze-weighted RMSE \
                        (weights = continuous eq. 8 level per pixel)"
        .into();

    let n = ctx.pick(32, 128);
    let detail = ctx.pick(DemoDetail::small(), DemoDetail::paper());
    let steps: Vec<u32> = ctx.pick(vec![1, 2, 4, 8], vec![1, 2, 4, 8, 16, 32, 64]);
    let (runs, budget) = ctx.pick((3, 30.0), (3, 1500.0));

    let scene = demo_scene(&detail).expect("demo scene");
    let walls = front_right_floor(3.0).expect("CAVE walls");
    let eye = DVec3::new(0.0, 1.5, 0.0);
    let cam = Camera::cave(walls[0], eye).expect("eye inside the CAVE");
    let settings = TraceSettings {
        width: n,
        height: n,
        reflect_max: 3,
    };
    let field = VisualField::paper();
    let gaze = GazeEstimate::Tracked(sweep_gaze(eye));
    let weights = pixel_levels(&cam, &settings, &field, &gaze, LevelQuantization::Continuous).expect("levels");

    let total = steps.len() + 1;
    ctx.progress(0, total, "full-quality baseline");
    let (t_full, full) = time_ms(runs, budget, || {
        render_full_quality(&scene, &cam, &settings).expect("render")
    });

    for (i, &s) in steps.iter().enumerate() {
        ctx.progress(i + 1, total, &format!("S = {s}"));
        let (t, img) = time_ms(runs, budget, || {
            let lv = pixel_levels(&cam, &settings, &field, &gaze, LevelQuantization::Steps(s)).expect("levels");
            render(&scene, &cam, &settings, &lv).expect("render")
        });
        let e = rmse(&img.pixels, &full.pixels).unwrap_or(f64::NAN);
        let g = weighted_rmse(&img.pixels, &full.pixels, &weights).unwrap_or(f64::NAN);
        report.rows.push(
            Row::new(s as f64, t, t_full)
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

/// Half-width of the step across each axis of the (m_α, m_β) plane, in rad.
const AXIS_EPS: f64 = 1e-6;
/// Largest |Δlevel| / Δφ allowed across an axis, per rad of φ. Eq. 8 gives
/// |∂level/∂φ| ≤ |L′(φ)| / (L − π/6), at most 0.92 per rad for the paper's
/// angles (both shapes, both sides); a jump of the boundary (say b switching
/// 60°/70° in a term that does not vanish at m_β = 0) gives ~0.1 / 2e-6.
const AXIS_SLOPE_BOUND: f64 = 2.0;
/// Eccentricities probed, in degrees: central edge to beyond the ear side.
const AXIS_PROBE_L_DEG: [f64; 8] = [31.0, 40.0, 50.0, 59.0, 65.0, 75.0, 89.0, 99.0];

/// The worst step found by [`axis_probe`].
#[derive(Debug, Clone, Copy)]
struct AxisProbe {
    slope: f64,
    phi_deg: f64,
    l_deg: f64,
    finite: bool,
}

impl Default for AxisProbe {
    fn default() -> Self {
        Self { slope: 0.0, phi_deg: f64::NAN, l_deg: f64::NAN, finite: true }
    }
}

impl AxisProbe {
    fn max(self, o: Self) -> Self {
        let mut w = if o.slope > self.slope { o } else { self };
        w.finite = self.finite && o.finite;
        w
    }

    fn ok(&self) -> bool {
        self.finite && self.slope <= AXIS_SLOPE_BOUND
    }
}

/// Steps `level` across each axis of the (m_α, m_β) plane — φ = 0°, 90°,
/// 180°, 270° ± [`AXIS_EPS`] at each eccentricity of [`AXIS_PROBE_L_DEG`] —
/// and returns the largest |Δlevel| / Δφ. The angles are the ones `eye`'s
/// eq. 4 produces: m_α is unsigned for [`EyeModel::Paper`] (a direction to
/// the left of the gaze has the same angles as its mirror image), signed
/// for the per-eye models; |m_β| stays within eq. 5's π/2.
fn axis_probe(eye: EyeModel, level: impl Fn(FieldAngles) -> f64) -> AxisProbe {
    let mut worst = AxisProbe::default();
    for axis_deg in [0.0f64, 90.0, 180.0, 270.0] {
        for l_deg in AXIS_PROBE_L_DEG {
            let l = l_deg.to_radians();
            let at = |phi: f64| {
                let m_alpha = l * phi.cos();
                let m_alpha = if eye == EyeModel::Paper { m_alpha.abs() } else { m_alpha };
                let m_beta = l * phi.sin();
                (m_beta.abs() <= std::f64::consts::FRAC_PI_2).then(|| level(FieldAngles { m_alpha, m_beta }))
            };
            let phi = axis_deg.to_radians();
            let (Some(a), Some(b)) = (at(phi - AXIS_EPS), at(phi + AXIS_EPS)) else {
                continue;
            };
            let slope = (a - b).abs() / (2.0 * AXIS_EPS);
            worst = worst.max(AxisProbe {
                slope: if slope.is_finite() { slope } else { 0.0 },
                phi_deg: axis_deg,
                l_deg,
                finite: a.is_finite() && b.is_finite() && (0.0..=1.0).contains(&a) && (0.0..=1.0).contains(&b),
            });
        }
    }
    worst
}

fn all_finite(p: &[DVec3]) -> bool {
    p.iter().all(|c| c.is_finite())
}

fn stability(
    report: &mut Report,
    scene: &optica_optics::foveated_lod::Scene,
    cam: &Camera,
    settings: &TraceSettings,
    field: &VisualField,
    full: &[DVec3],
) {
    let eye = cam.eye();

    // 1. Gaze behind the head: the wall is entirely behind the gaze.
    {
        let behind = GazeEstimate::Tracked(GazeFrame::new(eye, DVec3::Z, DVec3::Y).expect("gaze"));
        let lv = pixel_levels(cam, settings, field, &behind, LevelQuantization::Continuous).expect("levels");
        match render(scene, cam, settings, &lv) {
            Ok(img) => {
                let bg = img.pixels.iter().all(|&p| p == scene.background);
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

    // 2. NaN tracker: hold the last pose within the timeout, then full quality.
    {
        let mut tr = GazeTracker::new(0.1).expect("timeout");
        let g = sweep_gaze(eye);
        let good = TrackerSample::Gaze {
            eye,
            gaze: g.forward,
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
        )
        .expect("levels");
        let held_lv = pixel_levels(cam, settings, field, &held, LevelQuantization::Continuous).expect("levels");
        let lost_lv = pixel_levels(cam, settings, field, &lost, LevelQuantization::Continuous).expect("levels");
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

    // 3a. Continuity across the axes of the (m_α, m_β) plane (REFERENCE.md:
    //     "the boundary must be continuous across the axes"): b switches
    //     60°/70° at m_β = 0 (φ = 0°, 180°) and, for the per-eye models, a
    //     switches ear/nose at m_α = 0 (φ = ±90°).
    {
        let mut worst = AxisProbe::default();
        for eye_model in [EyeModel::Paper, EyeModel::LeftEye, EyeModel::RightEye] {
            for shape in [BoundaryShape::PaperEq7, BoundaryShape::TrueEllipse] {
                let f = VisualField::with_options(eye_model, shape);
                worst = worst.max(axis_probe(eye_model, |a| f.level_of_angles(a)));
            }
        }
        report.case(
            "level continuous across the (m_α, m_β) axes",
            worst.ok(),
            format!(
                "level at φ = 0°, ±90°, 180° ± {AXIS_EPS:.0e} rad (b switches 60°/70° at m_β = 0, a switches \
                 ear/nose at m_α = 0 for the per-eye models), l = {:?}°, 3 eye models × 2 shapes (unsigned m_α \
                 for the paper's model): max |Δlevel| / Δφ = {:.3} per rad (bound {AXIS_SLOPE_BOUND}; the largest \
                 slope of eq. 7–8 in φ is 0.92), worst at φ = {:.0}°, l = {:.0}°; all finite: {}",
                AXIS_PROBE_L_DEG, worst.slope, worst.phi_deg, worst.l_deg, worst.finite
            ),
        );
    }

    // 3b. Gaze on the eq. 7 boundary: pixels beyond it are background.
    {
        // A gaze 70° to the right puts the boundary across the wall's left half.
        let yaw = 70f64.to_radians();
        let g =
            GazeEstimate::Tracked(GazeFrame::new(eye, DVec3::new(yaw.sin(), 0.0, -yaw.cos()), DVec3::Y).expect("gaze"));
        let lv = pixel_levels(cam, settings, field, &g, LevelQuantization::Continuous).expect("levels");
        let img = render(scene, cam, settings, &lv);
        let outside = lv.iter().filter(|&&l| l == 0.0).count();
        let bg_ok = img.as_ref().is_ok_and(|im| {
            all_finite(&im.pixels)
                && lv
                    .iter()
                    .zip(&im.pixels)
                    .all(|(&l, &p)| l > 0.0 || p == scene.background)
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

    // 4. Eye on a CAVE wall plane: a typed error, never a NaN frustum.
    {
        let walls = front_right_floor(3.0).expect("walls");
        let on_front = DVec3::new(0.2, 1.5, -1.5);
        let on_floor = DVec3::new(0.2, 0.0, 0.3);
        let a = Camera::cave(walls[0], on_front);
        let b = walls[2].off_axis(on_floor, 0.05, 100.0, Default::default());
        let c = walls[0].off_axis(DVec3::new(0.0, 1.5, -1.6), 0.05, 100.0, Default::default());
        let typed = |r: &Result<_, FoveatedError>| matches!(r, Err(FoveatedError::EyeNotInFront { .. }));
        report.case(
            "eye on a CAVE wall plane",
            typed(&a.map(|_| ())) && typed(&b.map(|_| ())) && typed(&c.map(|_| ())),
            "eye on the front wall, eye on the floor, eye 10 cm behind the front wall: \
             each gives FoveatedError::EyeNotInFront",
        );
    }

    // 5. The paper's angles are singular straight to the ear side (±E_r).
    {
        use optica_optics::foveated_lod::level::VisualField as F;
        let exact = F::paper().level_local(DVec3::Y);
        let g = sweep_gaze(eye);
        let (l_r, l_l) = (field.level(&g, g.right), field.level(&g, -g.right));
        let in_range = |l: f64| l.is_finite() && (0.0..=1.0 / 7.0 + 1e-12).contains(&l);
        let ok = (exact - 1.0 / 7.0).abs() < 1e-12 && in_range(l_r) && in_range(l_l);
        report.case(
            "ray straight to the ear side (±E_r)",
            ok,
            format!(
                "eq. 5's m_β is undefined at d_f = d_u = 0; exactly there atan2(0, 0) = 0 gives \
                 (100 − 90)/(100 − 30) = 1/7 (got {exact:.6}); the world ray E_r of a rotated gaze frame has \
                 rounding-size d_f, d_u, so m_β is arbitrary: levels {l_r:.6}, {l_l:.6}, finite and in [0, 1/7] \
                 (a discontinuity of the paper's angles, documented in level.rs)"
            ),
        );
    }

    // 6. Gaze jitter: ±0.5° tracker noise at 90 Hz for 2 s.
    {
        let params = HysteresisParams {
            steps: 8,
            dead_band: 0.05,
            min_dwell_s: 0.25,
        };
        let mut grid = PixelLodGrid::new(settings.width * settings.height, params).expect("params");
        let mut naive_prev: Option<Vec<f64>> = None;
        let mut naive = 0u64;
        let mut seed = 0x2545F4914F6CDD1Du64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let base = sweep_gaze(eye).forward;
        let frames = 180;
        let npx = settings.width * settings.height;
        let (mut lo, mut hi) = (vec![f64::INFINITY; npx], vec![f64::NEG_INFINITY; npx]);
        for i in 0..frames {
            let jitter = DVec3::new(rnd(), rnd(), rnd()) * (1f64.to_radians());
            let g = GazeEstimate::Tracked(GazeFrame::new(eye, base + jitter, DVec3::Y).expect("gaze"));
            let lv = pixel_levels(cam, settings, field, &g, LevelQuantization::Continuous).expect("levels");
            for (k, &l) in lv.iter().enumerate() {
                lo[k] = lo[k].min(l);
                hi[k] = hi[k].max(l);
            }
            let q: Vec<f64> = lv.iter().map(|&l| LevelQuantization::Steps(8).apply(l)).collect();
            if let Some(p) = &naive_prev {
                naive += p.iter().zip(&q).filter(|(a, b)| a != b).count() as u64;
            }
            naive_prev = Some(q);
            let _ = grid.update(&lv, i as f64 / 90.0);
        }
        let held = grid.switches();
        let swing: Vec<f64> = hi.iter().zip(&lo).map(|(h, l)| h - l).collect();
        let max_swing = swing.iter().cloned().fold(0.0, f64::max);
        let wide = swing.iter().filter(|&&s| s > params.dead_band).count();
        // Gain of eq. 5's m_β on gaze motion, 1/√(d_f² + d_u²), at those pixels.
        let g0 = sweep_gaze(eye);
        let max_gain = swing
            .iter()
            .enumerate()
            .filter(|&(_, &s)| s > params.dead_band)
            .map(|(k, _)| {
                let Some(r) = cam.primary_ray(k % settings.width, k / settings.width, settings.width, settings.height) else { return 0.0 };
                let d = g0.to_local(r.dir());
                1.0 / d.x.hypot(d.z)
            })
            .fold(0.0, f64::max);
        // Bound of hysteresis.rs: D + (D + 1)·S switches per slot, D = ⌈T/dwell⌉,
        // and only slots whose level swings by more than the dead band can switch at all.
        let t = frames as f64 / 90.0;
        let d = (t / params.min_dwell_s).ceil() as u64;
        let bound = wide as u64 * (d + (d + 1) * params.steps as u64);
        report.case(
            "gaze jitter (hysteresis)",
            held <= bound && held * 100 <= naive && naive > 0,
            format!(
                "±0.5° jitter, {frames} frames at 90 Hz, S = 8, dead band 0.05, dwell 0.25 s: {held} pixel LOD \
                 switches with hysteresis, {naive} without; {wide} of {npx} pixels swing by more than the dead band \
                 (max swing {max_swing:.3}; they lie towards the ear side, where eq. 5 amplifies gaze motion by \
                 1/√(d_f² + d_u²), up to {max_gain:.1} here)"
            ),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_probe_passes_the_paper_level_and_catches_a_jump() {
        for eye in [EyeModel::Paper, EyeModel::LeftEye, EyeModel::RightEye] {
            for shape in [BoundaryShape::PaperEq7, BoundaryShape::TrueEllipse] {
                let f = VisualField::with_options(eye, shape);
                let p = axis_probe(eye, |a| f.level_of_angles(a));
                assert!(p.ok() && p.slope > 0.0, "{eye:?} {shape:?}: {p:?}");
            }
        }
        // The bound can fail: eq. 7 with b in the cos² term jumps by
        // 60° ↔ 70° at m_β = 0 (φ = 0), i.e. the level by ~0.1 over 2e-6 rad.
        let f = VisualField::paper();
        let broken = |a: FieldAngles| {
            let b = if a.m_beta >= 0.0 { f.upper } else { f.lower };
            let l2 = a.m_alpha * a.m_alpha + a.m_beta * a.m_beta;
            let big_l = ((b * b * a.m_alpha * a.m_alpha + f.ear * f.ear * a.m_beta * a.m_beta) / l2).sqrt();
            ((big_l - l2.sqrt()) / (big_l - f.central)).clamp(0.0, 1.0)
        };
        let p = axis_probe(EyeModel::Paper, broken);
        assert!(!p.ok() && (p.phi_deg == 0.0 || p.phi_deg == 180.0) && p.slope > 1e3, "{p:?}");
        // A NaN level fails too.
        assert!(!axis_probe(EyeModel::Paper, |_| f64::NAN).ok());
        // The paper model never sees a negative m_α.
        let seen_negative = std::cell::Cell::new(false);
        axis_probe(EyeModel::Paper, |a| {
            seen_negative.set(seen_negative.get() || a.m_alpha < 0.0);
            0.5
        });
        assert!(!seen_negative.get());
    }

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
                assert!(err(i, k) <= err(i - 1, k) * 1.02 + 1e-12, "{k} rises at row {i}");
            }
        }
        // Foveation does less work than the baseline.
        let w = &r.rows[0].work;
        assert!(w["triangle_tests"] < w["baseline_triangle_tests"]);
    }
}
