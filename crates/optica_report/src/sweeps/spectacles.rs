//! Spectacles (Kakimoto et al.): error of the voxel field of displacement
//! sets against the direct per-point reference, over the voxel resolution.
//!
//! * Scene: the paper's Fig. 8(d) case — a myopic presbyope (near point
//!   0.5 m, far point 1.3 m, pupil A = 12 mm) corrected for near work by a
//!   +1.5 D lens (n = 1.66, Vogel base curve, 50 mm blank, 12 mm vertex
//!   distance), eye turning about its centre of rotation. Through the lens
//!   the sharp zone moves to 0.29–0.44 m, so test points see both the near
//!   bundle (nearer) and the far bundle (beyond).
//! * Knob: `resolution_scale` k — voxels per axis k × (110, 77, 42) over a
//!   fixed box of 5.5 × 3.85 × 2.1 m (k = 1 is the paper's 110×77×42 with
//!   5 cm cubes) and aims k × (24 rings × 64 segments) so that the bundles
//!   keep up with the voxels (k = 1: 1,537, the paper's ~1,500). Hole filling
//!   on; per-voxel average over all crossings (`VoxelAverage::AllCrossings`,
//!   the crate's default; the paper's `RecordedSets` measured 0–2 % higher
//!   mean error at quick settings, see `spectacles::VoxelAverage`).
//! * Series: rows with `work.clones` = S, the pupil rays per bundle and the
//!   clones each voxel's set (kept as its linear map of the pupil) is
//!   expanded to. The main series is S = 10 (the paper's); error names
//!   without suffix. The full sweep adds S = 4 and S = 20 at every k, with
//!   the error names suffixed `_s4`, `_s20`, so that each S is its own
//!   curve in the plot. An astigmatic series (`_astig`, S = 10): the same
//!   eye with −1.5 D of cylinder at 30° in the toric lens of its
//!   prescription (+1.5 / −1.5 × 30), against its own reference points;
//!   a progressive series (`_pal`, S = 10): the Fig. 8 eye in its
//!   distance correction (−0.78 D) with a +2.00 add; the same lens
//!   decentred (4, −6) mm (`_dec`: its field traced through the lens where
//!   it sits, against reference points through it; `_dec_centred`: the
//!   centred lens's field against the same points, how a decentred lens
//!   was blurred before; both in eye coordinates, the plugin's default
//!   grid); an eye-coordinates
//!   series (`_eyegrid`, S = 10): the plain case with the voxels laid out
//!   in eye coordinates (`FieldGrid::Eye`, the same voxel count). Every
//!   series also gives `near_mean_mrad` over the points nearer than 0.3 m,
//!   and the plain and eye-coordinate series `far_mean_mrad` over points
//!   2.5–10 m away (half as many), beyond the paper's box, looked up as the
//!   plugin does (the box: the set where the sight line leaves it, scaled
//!   by distance).
//!   The rendered series (`spectacles_render`,
//!   `spectacles_refraction`) follow in the same report.
//! * Errors (per point, then mean / max over points): `mean_mm`, `max_mm` —
//!   |RMS radius of the field's set − RMS radius of the reference set|, mm
//!   (the blur's size); `mean_mrad` — the same divided by the distance
//!   (angular, mrad); `edge_mean_mm` — the same for the longest vector (the
//!   disc's edge, which only S samples).
//! * Reference: `reference_at` with 256 pupil rays per bundle at quasi-random
//!   points (Halton) seen through the lens, 0.1–2 m away.
//! * time_ms: the field precompute (median of runs; the paper's setting is
//!   k = 1). baseline_time_ms: the per-vertex
//!   refraction of one lens mesh (1,537 back-surface vertices, the paper's
//!   lens size), which is the per-frame work of §3 when the lens moves.
//! * Stability cases: extremes run through the whole path (lens design,
//!   bundles, field precompute, direct reference); what one function does
//!   alone with bad or extreme input is left to the unit tests.

use optica_optics::glam::{DVec3, Vec3};
use optica_optics::spectacles::{
    DEFAULT_DENSE_SAMPLES, DisplacementField, Eye, EyePlacement, FieldGrid, FieldSettings,
    LensDesignParams, LensMesh, Prescription, SpectacleLens, SpectaclesError, Spread, design_lens,
    precompute_field, reference_at, refract_vertices,
};

use crate::fixtures::halton;
use crate::{Report, Row, SweepContext, time_paired_ms};

/// A test point and its reference RMS and edge radii.
#[derive(Clone)]
struct RefPoint {
    p: DVec3,
    dist: f64,
    rms: f64,
    edge: f64,
}

/// Quasi-random points seen through the lens, 0.1–2 m away, with their
/// references.
fn reference_points(
    eye: &Eye,
    pl: &EyePlacement,
    lens: &SpectacleLens,
    want: usize,
) -> (Vec<RefPoint>, usize) {
    reference_points_in(eye, pl, lens, want, (0.1, 2.0))
}

/// As [`reference_points`], at distances log-uniform in `(near, far)` (m).
fn reference_points_in(
    eye: &Eye,
    pl: &EyePlacement,
    lens: &SpectacleLens,
    want: usize,
    (near, far): (f64, f64),
) -> (Vec<RefPoint>, usize) {
    let mut out = Vec::new();
    let mut skipped = 0;
    let mut i = 0;
    while out.len() < want && i < want * 20 {
        i += 1;
        // A point of the back surface within 85 % of the rim, and a depth.
        let r = 0.85 * lens.rim_radius_m() * halton(i, 2).sqrt();
        let phi = std::f64::consts::TAU * halton(i, 3);
        let z = near * (far / near).powf(halton(i, 5)); // log-uniform
        let Some(on_lens) = lens.back().point(r * phi.cos(), r * phi.sin()) else {
            continue;
        };
        let centre = pl.centre_of_rotation();
        let dir = (on_lens - centre).normalize();
        let p = centre + dir * ((z - centre.z) / dir.z);
        match reference_at(eye, pl, Some(lens), p, DEFAULT_DENSE_SAMPLES) {
            Ok(rf) => out.push(RefPoint {
                p,
                dist: rf.distance_m,
                rms: rf.spread.rms_radius_m,
                edge: rf.spread.max_radius_m,
            }),
            Err(_) => skipped += 1,
        }
    }
    (out, skipped)
}

/// Mean and max of the RMS-radius error (m), mean angular error (rad) and
/// mean edge error (m) of `field` at the points.
fn errors(field: &DisplacementField, pts: &[RefPoint]) -> (f64, f64, f64, f64) {
    let (mut sum, mut max, mut ang, mut edge) = (0.0, 0.0f64, 0.0, 0.0);
    for q in pts {
        let s = field.spread_at(q.p).expect("test points lie in the box");
        let e = (s.rms_radius_m - q.rms).abs();
        sum += e;
        max = max.max(e);
        ang += e / q.dist;
        edge += (s.max_radius_m - q.edge).abs();
    }
    let n = pts.len().max(1) as f64;
    (sum / n, max, ang / n, edge / n)
}

/// Mean angular error (rad) of `field` at points seen from the eye's
/// pupil as the plugin looks them up: inside the field, the voxel's set;
/// beyond the paper's box, the set where the sight line leaves it, scaled
/// by distance (the documented fallback); in eye coordinates, the layers
/// that reach infinity.
fn sight_errors(field: &DisplacementField, pts: &[RefPoint]) -> f64 {
    let mut ang = 0.0;
    for q in pts {
        let s = field
            .displacement_along_sight(q.p, DVec3::ZERO)
            .map(|(map, k)| Spread::of(field.expand(map).iter().map(|v| v.as_dvec3() * k)))
            .map_or(0.0, |s| s.rms_radius_m);
        ang += (s - q.rms).abs() / q.dist;
    }
    ang / pts.len().max(1) as f64
}

/// The lens of the sweep: +1.5 D reading lens at n = 1.66 (the paper's index).
fn sweep_lens() -> SpectacleLens {
    design_lens(
        &Prescription::sphere(1.5).expect("valid"),
        &LensDesignParams::paper(),
    )
    .expect("+1.5 D is a lens")
}

/// The eye and lens of a series.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Case {
    /// The Fig. 8(d) eye in its +1.5 D reading lens.
    Plain,
    /// The same eye, astigmatic, in its toric lens.
    Astigmatic,
    /// The same eye in progressives.
    Progressive,
    /// The plain case with the voxels in eye coordinates.
    EyeGrid,
    /// The progressives decentred (4, −6) mm, their field traced through
    /// the lens where it sits.
    Decentred,
    /// The same decentred progressives' reference points against the field
    /// of the lens centred (how the plugin blurred a decentred lens
    /// before its field followed the lens).
    DecentredAsCentred,
}

impl Case {
    /// The suffix of the series' error names.
    fn suffix(self) -> &'static str {
        match self {
            Case::Plain => "",
            Case::Astigmatic => "_astig",
            Case::Progressive => "_pal",
            Case::EyeGrid => "_eyegrid",
            Case::Decentred => "_dec",
            Case::DecentredAsCentred => "_dec_centred",
        }
    }
}

/// Runs the sweep.
pub fn run(ctx: &SweepContext) -> Report {
    let mut report = Report::cpu("spectacles", "resolution_scale");
    report.baseline =
        "per-vertex refraction of one lens mesh (1,537 back-surface vertices, rayon)".into();
    report.reference = "direct per-point displacement set: chief ray solved through the point, near/far bundles of \
                        256 pupil rays; errors on the set's RMS radius (mm, mrad) and longest vector (edge, mm)"
        .into();

    let eye = Eye::from_near_far(0.5, 1.3, 0.012).expect("Fig. 8 eye");
    let pl = EyePlacement::default();
    let lens = sweep_lens();
    // The same eye with −1.5 D of astigmatism at 30°, in the toric lens of
    // its prescription: elliptical sets, and between the corrected near and
    // far points what astigmatism the lens leaves.
    let astigmat = eye.with_astigmatism(-1.5, 30.0).expect("astigmatic eye");
    let toric = design_lens(
        &Prescription::new(1.5, -1.5, 30.0).expect("valid"),
        &LensDesignParams::paper(),
    )
    .expect("+1.5 / −1.5 × 30 is a lens");
    // The Fig. 8 eye in progressives: its distance correction (−0.78 D,
    // far point to infinity) with a +2.00 add, so that the near zone
    // brings the book in: bundles through the corridor and the blurred
    // zones beside it.
    let progressive = design_lens(
        &Prescription::sphere(-0.78)
            .and_then(|rx| rx.with_addition(2.0))
            .expect("valid"),
        &LensDesignParams::paper(),
    )
    .expect("−0.78 D add +2.00 is a lens");
    let decentred = progressive
        .decentred(optica_optics::glam::DVec2::new(0.004, -0.006))
        .expect("6 mm is on the blank");
    let scales: Vec<f64> = ctx.pick(vec![0.25, 0.5, 1.0], vec![0.25, 0.5, 0.75, 1.0, 1.25, 1.5]);
    // (S, scales, case).
    use Case::{Astigmatic, Decentred, DecentredAsCentred, EyeGrid, Plain, Progressive};
    let series: Vec<(usize, Vec<f64>, Case)> = ctx.pick(
        vec![
            (10, scales.clone(), Plain),
            (4, vec![0.5], Plain),
            (20, vec![0.5], Plain),
            (10, vec![0.5, 1.0], Astigmatic),
            (10, vec![0.5, 1.0], Progressive),
            (10, scales.clone(), EyeGrid),
            (10, vec![0.5, 1.0], Decentred),
            (10, vec![0.5, 1.0], DecentredAsCentred),
        ],
        vec![
            (10, scales.clone(), Plain),
            (4, scales.clone(), Plain),
            (20, scales.clone(), Plain),
            (10, scales.clone(), Astigmatic),
            (10, scales.clone(), Progressive),
            (10, scales.clone(), EyeGrid),
            (10, scales.clone(), Decentred),
            (10, scales.clone(), DecentredAsCentred),
        ],
    );
    let n_points = ctx.pick(60, 300);
    let (runs, budget) = ctx.pick((1, 0.0), (3, 2000.0));
    let total: usize = series.iter().map(|(_, s, _)| s.len()).sum::<usize>() + 1;

    ctx.progress(0, total, "baseline and reference points");
    let mesh = lens
        .mesh(LensMesh::PAPER_RINGS, LensMesh::PAPER_SEGMENTS)
        .expect("mesh");
    let back = mesh.back_positions().to_vec();
    // The baseline, timed against each field's precomputation in
    // alternating blocks.
    let per_vertex = || refract_vertices(&lens, pl.centre_of_rotation(), &back);
    let traces = per_vertex();
    let exits = match &traces {
        Ok(t) => t.iter().filter(|t| t.is_exit()).count(),
        Err(e) => {
            report.case(
                "per-vertex refraction of the lens mesh",
                false,
                e.to_string(),
            );
            0
        }
    };
    let plain = reference_points(&eye, &pl, &lens, n_points);
    // Beyond the paper's box (its far face at 2.13 m): a chart across a room.
    let (far, _) = reference_points_in(&eye, &pl, &lens, n_points / 2, (2.5, 10.0));
    let astig = reference_points(&astigmat, &pl, &toric, n_points);
    let pal = reference_points(&eye, &pl, &progressive, n_points);
    let dec = reference_points(&eye, &pl, &decentred, n_points);

    let mut step = 0;
    for (clones, ks, case) in &series {
        let suffix = match (*clones, case) {
            (10, _) => case.suffix().to_string(),
            (c, _) => format!("{}_s{c}", case.suffix()),
        };
        let (eye, lens, (pts, skipped)) = match case {
            Plain | EyeGrid => (&eye, &lens, &plain),
            Astigmatic => (&astigmat, &toric, &astig),
            Progressive => (&eye, &progressive, &pal),
            Decentred => (&eye, &decentred, &dec),
            DecentredAsCentred => (&eye, &progressive, &dec),
        };
        for &k in ks {
            step += 1;
            ctx.progress(step, total, &format!("S = {clones}, scale {k}"));
            // The decentred series in the plugin's default grid.
            let grid = if matches!(case, EyeGrid | Decentred | DecentredAsCentred) {
                FieldGrid::Eye
            } else {
                FieldGrid::Box
            };
            let st = match FieldSettings::paper()
                .scaled(k)
                .and_then(|st| st.with_clones(*clones))
                .map(|st| st.with_grid(grid))
            {
                Ok(st) => st,
                Err(e) => {
                    report.case(
                        &format!("settings S = {clones}, scale {k}"),
                        false,
                        e.to_string(),
                    );
                    continue;
                }
            };
            let (timed, field) = time_paired_ms(
                ctx.blocks().0,
                runs,
                budget,
                || precompute_field(eye, &pl, Some(lens), &st),
                per_vertex,
            );
            let field = match field {
                Ok(f) => f,
                Err(e) => {
                    report.case(
                        &format!("precompute S = {clones}, scale {k}"),
                        false,
                        e.to_string(),
                    );
                    continue;
                }
            };
            let (mean, max, ang, edge) = errors(&field, pts);
            let near: Vec<RefPoint> = pts.iter().filter(|q| q.dist < 0.3).cloned().collect();
            let (_, _, near_ang, _) = errors(&field, &near);
            // (The far points are the plain lens's.)
            let far_ang = matches!(case, Plain | EyeGrid).then(|| sight_errors(&field, &far));
            let s = field.stats();
            let mut row = Row::paired_cpu(k, &timed);
            if let Some(far_ang) = far_ang {
                row = row.err(&format!("far_mean_mrad{suffix}"), far_ang * 1e3);
            }
            report.rows.push(
                row.err(&format!("mean_mm{suffix}"), mean * 1e3)
                    .err(&format!("max_mm{suffix}"), max * 1e3)
                    .err(&format!("mean_mrad{suffix}"), ang * 1e3)
                    .err(&format!("edge_mean_mm{suffix}"), edge * 1e3)
                    .err(&format!("near_mean_mrad{suffix}"), near_ang * 1e3)
                    .work("clones", *clones as f64)
                    .work("voxels", field.counts().len() as f64)
                    .work("aims", s.aims as f64)
                    .work("aims_failed", s.aims_failed as f64)
                    .work("rays_traced", s.rays_traced as f64)
                    .work("voxel_crossings", s.crossings as f64)
                    .work("coverage", field.coverage())
                    .work("fill_layers", s.fill_passes as f64)
                    .work("points", pts.len() as f64)
                    .work("points_skipped", *skipped as f64)
                    .work("astigmatic", f64::from(u8::from(*case == Astigmatic)))
                    .work("progressive", f64::from(u8::from(*case == Progressive)))
                    .work("eye_grid", f64::from(u8::from(*case == EyeGrid)))
                    .work(
                        "decentred",
                        f64::from(u8::from(matches!(case, Decentred | DecentredAsCentred))),
                    )
                    .work("near_points", near.len() as f64)
                    .work("baseline_exits", exits as f64),
            );
        }
    }
    ctx.progress(total, total, "stability cases");
    stability(&mut report);
    report
}

/// Extreme cases through the whole path: designing the lens, tracing the
/// bundles, precomputing the field and the direct reference together.
fn stability(report: &mut Report) {
    let small = FieldSettings::paper()
        .scaled(0.25)
        .expect("a quarter of the paper's setting is within the caps");
    let finite = |f: &DisplacementField| f.maps().iter().all(|v| v.is_finite());

    // ±20 D.
    let plus20 = design_lens(
        &Prescription::sphere(20.0).expect("valid"),
        &LensDesignParams::default(),
    );
    let minus20 = design_lens(
        &Prescription::sphere(-20.0).expect("valid"),
        &LensDesignParams::default(),
    );
    let eye20 = Eye::new(20.0, 1.0, 0.004).expect("valid");
    let ok_plus = matches!(plus20, Err(SpectaclesError::SurfaceTooSteep { .. }));
    let (ok_minus, detail_minus) = match &minus20 {
        Ok(l) => {
            let fv = l.measured_back_vertex_power_d(0.0).unwrap_or(f64::NAN);
            let f = precompute_field(
                &Eye::new(-20.0, 1.0, 0.004).expect("valid"),
                &EyePlacement::default(),
                Some(l),
                &small,
            );
            let ok = (fv + 20.0).abs() < 0.01 && f.as_ref().is_ok_and(finite);
            (
                ok,
                format!(
                    "−20 D designed (edge {:.1} mm), traced Fv = {fv:.4} D, field finite",
                    l.edge_thickness_m(0.0).unwrap_or(f64::NAN) * 1e3
                ),
            )
        }
        Err(e) => (false, e.to_string()),
    };
    let naked20 = precompute_field(&eye20, &EyePlacement::default(), None, &small);
    report.case(
        "±20 D",
        ok_plus && ok_minus && naked20.as_ref().is_ok_and(finite),
        format!(
            "+20 D CR-39 on 50 mm: {} (R1 = 19.2 mm < 25 mm); {detail_minus}; +20 D hyperopic naked-eye field finite",
            match &plus20 {
                Err(e) => e.to_string(),
                Ok(_) => "designed (unexpected)".into(),
            }
        ),
    );

    // Zero pupil.
    let eye0 = Eye::new(-2.0, 1.0, 0.0).expect("valid");
    let lens = sweep_lens();
    let f0 = precompute_field(&eye0, &EyePlacement::default(), Some(&lens), &small);
    let r0 = reference_at(
        &eye0,
        &EyePlacement::default(),
        Some(&lens),
        DVec3::new(0.0, 0.0, 1.0),
        64,
    );
    let ok = f0
        .as_ref()
        .is_ok_and(|f| f.maps().iter().all(|v| *v == Vec3::ZERO))
        && r0.as_ref().is_ok_and(|r| r.spread.rms_radius_m == 0.0);
    report.case(
        "zero pupil",
        ok,
        "A = 0: every displacement set is exactly zero (a pinhole), reference 0",
    );

    // Near point = far point (Amp = 0).
    let eye_a0 = Eye::new(-2.0, 0.0, 0.004).expect("valid");
    let corr = design_lens(
        &Prescription::sphere(-1.0 / (0.5 - 0.015)).expect("valid"),
        &LensDesignParams::default(),
    )
    .expect("lens");
    let fa = precompute_field(&eye_a0, &EyePlacement::default(), Some(&corr), &small);
    let ra = reference_at(
        &eye_a0,
        &EyePlacement::default(),
        Some(&corr),
        DVec3::new(0.0, 0.0, 2.0),
        256,
    );
    let (ok, detail) = match (&fa, &ra) {
        (Ok(f), Ok(r)) => {
            // Fully corrected, focus at infinity: at 2 m, ΔD ≈ 0.5 D, disc ≈ A·z·ΔD = 4 mm.
            let d = r.spread.disc_diameter_m();
            (
                finite(f) && (d - 0.004).abs() < 0.0008,
                format!(
                    "−2 D, Amp 0, fully corrected: disc at 2 m {:.2} mm (A·z·ΔD = 4 mm), field finite",
                    d * 1e3
                ),
            )
        }
        _ => (false, format!("{:?} {:?}", fa.err(), ra.err())),
    };
    report.case("near point = far point (Amp = 0)", ok, detail);

    // Hyperope: virtual far point behind the eye.
    let hyp = Eye::new(2.0, 0.5, 0.004).expect("valid");
    let plus = design_lens(
        &Prescription::sphere(2.0).expect("valid"),
        &LensDesignParams::default(),
    )
    .expect("lens");
    let naked = reference_at(
        &hyp,
        &EyePlacement::default(),
        None,
        DVec3::new(0.0, 0.0, 1.0),
        256,
    );
    let through = reference_at(
        &hyp,
        &EyePlacement::default(),
        Some(&plus),
        DVec3::new(0.0, 0.0, 1.0),
        256,
    );
    let fh = precompute_field(&hyp, &EyePlacement::default(), Some(&plus), &small);
    let (ok, detail) = match (&naked, &through) {
        (Ok(n), Ok(t)) => {
            // Naked: P_far = −2, P_near = −1.5; V = 1/z from the pupil.
            let z = n.distance_m;
            let want = hyp.blur_disc_diameter_m(z).unwrap_or(f64::NAN);
            let dn = n.spread.disc_diameter_m();
            let dt = t.spread.disc_diameter_m();
            (
                (dn - want).abs() < 1e-9 && dt < 0.5 * dn && fh.as_ref().is_ok_and(finite),
                format!(
                    "+2 D, Amp 0.5, point at 1 m: naked disc {:.2} mm (A·z·ΔD = {:.2} mm), through +2 D {:.2} mm",
                    dn * 1e3,
                    want * 1e3,
                    dt * 1e3
                ),
            )
        }
        _ => (false, format!("{:?} {:?}", naked.err(), through.err())),
    };
    report.case("hyperope", ok, detail);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_sweep_is_finite_and_error_falls_with_resolution() {
        let ctx = SweepContext::new("spectacles", true, true);
        let r = run(&ctx);
        // S = 10 at three scales, S = 4 and 20 at one, the astigmatic and
        // progressive series at two each, eye coordinates at three, the
        // decentred lens's two series at two each.
        assert_eq!(r.rows.len(), 16);
        let problems = r.problems();
        assert!(problems.is_empty(), "{problems:#?}");
        // The S = 10 series: rows 0..3 at scales 0.25, 0.5, 1.
        let err = |i: usize, k: &str| r.rows[i].error[k];
        for k in ["mean_mm", "max_mm", "mean_mrad"] {
            assert!(err(2, k) < err(0, k), "{k} must fall from scale 0.25 to 1");
            assert!(
                err(1, k) <= err(0, k) * 1.05 && err(2, k) <= err(1, k) * 1.05,
                "{k} rises"
            );
        }
        assert!(r.rows[0].work["points"] >= 50.0);
        // The astigmatic and progressive fields follow their references
        // as closely as the plain one at the same resolution (scale 1).
        let at_scale_1 = |key: &str| {
            r.rows
                .iter()
                .find(|row| row.knob == 1.0 && row.error.contains_key(key))
                .map(|row| row.error[key])
                .unwrap_or_else(|| panic!("{key}"))
        };
        // Eye coordinates follow the reference more closely than the box
        // at the same voxel count, near the eye above all.
        for key in ["mean_mrad", "near_mean_mrad"] {
            let (boxed, eyed) = (at_scale_1(key), at_scale_1(&format!("{key}_eyegrid")));
            eprintln!("{key}: box {boxed:.4}, eye coordinates {eyed:.4}");
            assert!(
                eyed < boxed,
                "{key}: eye coordinates {eyed} against the box's {boxed}"
            );
        }
        // A decentred lens's field follows its own references, which the
        // centred lens's field does not.
        let (moved, kept) = (
            at_scale_1("mean_mrad_dec"),
            at_scale_1("mean_mrad_dec_centred"),
        );
        eprintln!("decentred: its own field {moved:.4} mrad, the centred lens's {kept:.4}");
        assert!(
            moved < 0.5 * kept,
            "decentred {moved} against centred {kept}"
        );
        let plain = at_scale_1("mean_mm");
        for key in ["mean_mm_astig", "mean_mm_pal"] {
            let e = at_scale_1(key);
            assert!(
                e.is_finite() && e < 2.0 * plain,
                "{key}: {e} against {plain}"
            );
        }
    }
}
