//! The optics core's sweep: one ghost of the Brendel Tessar (US 2,854,889)
//! traced with a square grid of rays over the entrance pupil.
//!
//! Knob: rays per side N of the grid (N² rays). For each N the ghost's
//! energy on the sensor is estimated as Σ throughput · cell area over the
//! rays that pass every clear aperture (`r_rel <= 1`, the per-pixel clip of
//! Hullin, Eisemann, Seidel and Lee, "Physically-Based Real-Time Lens Flare
//! Rendering", ACM Transactions on Graphics 30(4), SIGGRAPH 2011), together
//! with its throughput-weighted centroid and RMS radius on the sensor. The
//! reference is the same estimate on a dense grid (512² in full, 128² in
//! quick). Errors:
//! - `energy_rel`: |E − E_ref| / E_ref;
//! - `rms_radius_rel`: |ρ − ρ_ref| / ρ_ref (ρ = RMS distance from the centroid);
//! - `centroid_over_rms`: |c − c_ref| / ρ_ref (the centroid shift in units of
//!   the ghost's size; the centroid itself is ~0 on axis).
//!
//! `time_ms` is the ghost trace of the N² grid, `baseline_time_ms` the
//! primary-path trace of the same grid, both through
//! [`PreparedLens::trace_many`] (rayon).

use optica_optics::fresnel::Coating;
use optica_optics::glam::{DVec2, DVec3};
use optica_optics::glass::{Glass, LAMBDA_D_NM};
use optica_optics::lens::{
    LensPrescription, LensSurface, Pass, PreparedLens, TraceError, TracePath, TraceResult, builtin,
    ghosts, trace,
};
use optica_optics::ray::Ray;

use crate::{Report, Row, SweepContext, time_paired_ms};

/// Field angle of the point source (degrees): slightly off axis, so that the
/// ghost is not rotationally symmetric and its centroid moves.
const FIELD_DEG: f64 = 3.0;
/// Grid half-width as a multiple of the paraxial entrance-pupil radius: the
/// real pupil of an off-axis beam is a little larger and shifted.
const PUPIL_MARGIN: f64 = 1.15;
/// z of the plane where grid rays start, in front of the first vertex (mm).
const START_Z: f64 = -20.0;

/// What a grid of rays puts on the sensor along one path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GhostStats {
    /// Σ throughput · cell area over rays with `r_rel <= 1` (mm² of pupil).
    pub energy: f64,
    /// Throughput-weighted centroid on the sensor (mm).
    pub centroid: DVec2,
    /// Throughput-weighted RMS distance from the centroid (mm).
    pub rms_radius: f64,
    /// Rays that reached the sensor inside every aperture.
    pub passed: usize,
    /// Rays that died (missed a surface, TIR, missed the sensor).
    pub died: usize,
}

/// The grid: `n × n` parallel rays at `field_deg`, cell-centred on a square of
/// half-width `half` around the axis in the entrance-pupil plane `pupil_z`.
/// Returns the rays and the area of one cell.
pub fn pupil_grid(n: usize, half: f64, pupil_z: f64, field_deg: f64) -> (Vec<Ray>, f64) {
    let dir = DVec3::new(
        field_deg.to_radians().sin(),
        0.0,
        field_deg.to_radians().cos(),
    );
    let cell = 2.0 * half / n as f64;
    let mut rays = Vec::with_capacity(n * n);
    for iy in 0..n {
        for ix in 0..n {
            let x = -half + (ix as f64 + 0.5) * cell;
            let y = -half + (iy as f64 + 0.5) * cell;
            // Back along the ray from the pupil point to the start plane.
            let at_pupil = DVec3::new(x, y, pupil_z);
            let origin = at_pupil + dir * ((START_Z - pupil_z) / dir.z);
            rays.push(Ray::new(origin, dir).expect("the sweep's rays are finite"));
        }
    }
    (rays, cell * cell)
}

/// Energy, centroid and RMS radius of traced rays (each worth `cell_area`).
pub fn ghost_stats(results: &[Result<TraceResult, TraceError>], cell_area: f64) -> GhostStats {
    let (mut e, mut sx, mut sy, mut sxx, mut passed, mut died) = (0.0, 0.0, 0.0, 0.0, 0, 0);
    for r in results {
        match r {
            Ok(r) if r.r_rel <= 1.0 => {
                let w = r.throughput * cell_area;
                let (x, y) = (r.position.x, r.position.y);
                e += w;
                sx += w * x;
                sy += w * y;
                sxx += w * (x * x + y * y);
                passed += 1;
            }
            Ok(_) => {}
            Err(_) => died += 1,
        }
    }
    if e <= 0.0 {
        return GhostStats {
            energy: 0.0,
            centroid: DVec2::ZERO,
            rms_radius: 0.0,
            passed,
            died,
        };
    }
    let c = DVec2::new(sx / e, sy / e);
    let rms = (sxx / e - c.length_squared()).max(0.0).sqrt();
    GhostStats {
        energy: e,
        centroid: c,
        rms_radius: rms,
        passed,
        died,
    }
}

/// Runs the sweep.
pub fn run(ctx: &SweepContext) -> Report {
    let mut report = Report::cpu("optics", "rays_per_side");
    let lens = builtin::tessar();
    let (prepared, para) = match (
        PreparedLens::new(&lens, LAMBDA_D_NM),
        lens.paraxial(LAMBDA_D_NM),
    ) {
        (Ok(p), Ok(q)) => (p, q),
        (a, b) => {
            report.case(
                "prepare the Tessar",
                false,
                format!("{:?} / {:?}", a.err(), b.err()),
            );
            return report;
        }
    };
    let half = PUPIL_MARGIN * para.entrance_pupil_radius_mm;
    let pupil_z = para.entrance_pupil_z_mm;

    // Pick a bright ghost whose reflections both lie behind the stop: then the
    // first stop crossing is before them and the grid over the entrance pupil
    // covers every ray that can contribute.
    let stop = prepared.stop_index();
    let (probe, probe_area) = pupil_grid(32, half, pupil_z, FIELD_DEG);
    let (ghost, _) = ghosts(&lens)
        .into_iter()
        .filter(|&(_, j)| j > stop)
        .map(|(i, j)| {
            (
                (i, j),
                ghost_stats(
                    &prepared.trace_many(&probe, TracePath::ghost(i, j)),
                    probe_area,
                )
                .energy,
            )
        })
        .fold(
            ((0, 0), -1.0),
            |best, g| if g.1 > best.1 { g } else { best },
        );
    let path = TracePath::ghost(ghost.0, ghost.1);

    let reference_n = ctx.pick(128, 512);
    let knobs: Vec<usize> = ctx.pick(vec![4, 8, 16, 32], vec![4, 8, 16, 32, 64, 128]);
    let total = knobs.len() + 1;
    ctx.progress(
        0,
        total,
        &format!("reference {reference_n}² rays, ghost {ghost:?}"),
    );
    let (ref_rays, ref_area) = pupil_grid(reference_n, half, pupil_z, FIELD_DEG);
    let reference = ghost_stats(&prepared.trace_many(&ref_rays, path), ref_area);
    report.reference = format!(
        "Tessar US 2,854,889 ghost {ghost:?} (reflect at surface {} then {}), source {FIELD_DEG}° off axis, d line, \
         {reference_n}x{reference_n} rays over the entrance pupil: energy {:.4e} mm², centroid ({:.3}, {:.3}) mm, \
         RMS radius {:.3} mm",
        ghost.0,
        ghost.1,
        reference.energy,
        reference.centroid.x,
        reference.centroid.y,
        reference.rms_radius
    );
    report.baseline = "primary-path trace of the same grid (rayon)".into();

    let (budget, min_runs) = ctx.pick((15.0, 1), (300.0, 5));
    for (step, &n) in knobs.iter().enumerate() {
        let (rays, area) = pupil_grid(n, half, pupil_z, FIELD_DEG);
        // The ghost path against the primary one in alternating blocks.
        let (timed, results) = time_paired_ms(
            ctx.blocks().0,
            min_runs,
            budget,
            || prepared.trace_many(&rays, path),
            || prepared.trace_many(&rays, TracePath::Primary),
        );
        let s = ghost_stats(&results, area);
        let rel = |a: f64, b: f64| {
            if b != 0.0 {
                (a - b).abs() / b.abs()
            } else {
                (a - b).abs()
            }
        };
        let rho = reference.rms_radius.max(1e-12);
        report.rows.push(
            Row::paired_cpu(n as f64, &timed)
                .err("energy_rel", rel(s.energy, reference.energy))
                .err("rms_radius_rel", rel(s.rms_radius, reference.rms_radius))
                .err(
                    "centroid_over_rms",
                    (s.centroid - reference.centroid).length() / rho,
                )
                .work("rays", (n * n) as f64)
                .work("rays_passed", s.passed as f64)
                .work("rays_died", s.died as f64),
        );
        ctx.progress(step + 1, total, &format!("{n}x{n}"));
    }
    stability(&mut report, &lens);
    report
}

/// The stiff and extreme cases of the lens tracer.
fn stability(report: &mut Report, tessar: &LensPrescription) {
    let wl = LAMBDA_D_NM;

    // Cases the lens tracer's unit tests already pin down (a ray that
    // misses, one outside the semi-aperture, TIR, a flat slab's ghost by
    // hand) are not repeated here.

    // Grazing incidence: a full hemisphere (|R| = semi-aperture) met at its
    // rim, into glass that runs on to the sensor (so no exit surface can turn
    // the steep refracted ray back by total internal reflection).
    let graze = lens(&[
        LensSurface::new(20.0, 25.0, Glass::Constant(1.5), 20.0),
        LensSurface::stop(50.0, Glass::Constant(1.5), 20.0),
    ]);
    let mut detail = String::new();
    let mut ok = graze.is_ok();
    if let Ok(p) = &graze {
        for y in [20.0 * (1.0 - 1e-12), 20.0, 20.0 * (1.0 - 1e-6)] {
            let r = trace(
                p,
                Ray::new(DVec3::new(0.0, y, -5.0), DVec3::Z).expect("the sweep's rays are finite"),
                wl,
                TracePath::Primary,
            );
            // Finite with a throughput falling to 0 at the rim (R -> 1 as cos i -> 0).
            ok &=
                matches!(&r, Ok(t) if t.position.is_finite() && (0.0..0.5).contains(&t.throughput));
            detail.push_str(&format!("y = {y}: {:?}; ", r.map(|t| t.throughput)));
        }
    }
    report.case("grazing incidence", ok, detail);

    // Zero-thickness elements: surfaces touching at the vertex (zero air gap)
    // and a biconvex lens of zero centre thickness (its edge is negative): a
    // ray at 5 mm enters the front sphere (R = 50) at z = +0.25 mm, where the
    // rear sphere (R = −50) already lies behind it, at z = −0.25 mm, so the
    // ray must die at surface 2 on the forward pass.
    let touching = lens(&[
        LensSurface::new(50.0, 3.0, Glass::Constant(1.5), 10.0),
        LensSurface::new(40.0, 0.0, Glass::Air, 10.0),
        LensSurface::new(40.0, 3.0, Glass::Constant(1.6), 10.0),
        LensSurface::new(-60.0, 2.0, Glass::Air, 10.0),
        LensSurface::stop(50.0, Glass::Air, 8.0),
    ]);
    let thin = lens(&[
        LensSurface::stop(0.0, Glass::Air, 8.0),
        LensSurface::new(50.0, 0.0, Glass::Constant(1.5), 10.0),
        LensSurface::new(-50.0, 50.0, Glass::Air, 10.0),
    ]);
    let a = touching.as_ref().map(|p| {
        trace(
            p,
            Ray::new(DVec3::new(0.0, 0.0, -5.0), DVec3::Z).expect("the sweep's rays are finite"),
            wl,
            TracePath::Primary,
        )
    });
    let b = thin.as_ref().map(|p| {
        trace(
            p,
            Ray::new(DVec3::new(0.0, 5.0, -5.0), DVec3::Z).expect("the sweep's rays are finite"),
            wl,
            TracePath::Primary,
        )
    });
    let on_axis_ok = matches!(a, Ok(Ok(ref t)) if t.position.is_finite());
    let off_axis_typed = b
        == Ok(Err(TraceError::Missed {
            surface: 2,
            pass: Pass::Forward,
        }));
    report.case(
        "zero-thickness element",
        on_axis_ok && off_axis_typed,
        format!(
            "touching surfaces, on-axis ray: {:?}; zero-centre biconvex, ray at 5 mm: {:?}",
            a.map(|x| x.map(|t| t.position)),
            b.map(|x| x.map(|t| t.position))
        ),
    );

    // Every ghost of the Tessar on a coated lens: finite or typed, never NaN.
    let coated = match tessar
        .with_coating_everywhere(Coating::quarter_wave(1.38, 550.0).expect("a valid coating"))
    {
        Ok(p) => p,
        Err(e) => {
            report.case(
                "all 21 ghosts, coated, 10° off axis",
                false,
                format!("coating: {e}"),
            );
            return;
        }
    };
    let all = ghosts(&coated);
    let (rays, _) = pupil_grid(8, 20.0, 0.0, 10.0);
    let mut bad = 0;
    if let Ok(p) = PreparedLens::new(&coated, 450.0) {
        for &(i, j) in &all {
            for r in p.trace_many(&rays, TracePath::ghost(i, j)) {
                if let Ok(t) = r
                    && !(t.position.is_finite() && t.throughput.is_finite() && t.r_rel.is_finite())
                {
                    bad += 1;
                }
            }
        }
    } else {
        bad = usize::MAX;
    }
    report.case(
        "all 21 ghosts, coated, 10° off axis",
        all.len() == 21 && bad == 0,
        format!(
            "{} ghosts x 64 rays at 450 nm: {bad} non-finite results",
            all.len()
        ),
    );
}

fn lens(surfaces: &[LensSurface]) -> Result<LensPrescription, String> {
    LensPrescription::new("case", "stability case", surfaces.to_vec()).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_sweep_is_finite_and_converges() {
        let ctx = SweepContext::new("optics", true, true);
        let r = run(&ctx);
        assert_eq!(r.rows.len(), 4);
        let problems = r.problems();
        assert!(problems.is_empty(), "{problems:#?}");
        let first = &r.rows[0].error;
        let last = &r.rows[r.rows.len() - 1].error;
        for key in ["energy_rel", "rms_radius_rel", "centroid_over_rms"] {
            assert!(
                last[key] < first[key],
                "{key}: {} -> {}",
                first[key],
                last[key]
            );
        }
        assert!(
            last["energy_rel"] < 0.05,
            "32x32 against 128x128: {}",
            last["energy_rel"]
        );
        assert_eq!(
            r.stability
                .iter()
                .map(|c| c.case.as_str())
                .collect::<Vec<_>>(),
            [
                "grazing incidence",
                "zero-thickness element",
                "all 21 ghosts, coated, 10° off axis"
            ]
        );
        // The zero-centre biconvex's 5 mm ray must die at surface 2 (typed), not reach the sensor.
        let zero = r
            .stability
            .iter()
            .find(|c| c.case == "zero-thickness element")
            .unwrap();
        assert!(
            zero.ok && zero.detail.contains("Missed { surface: 2, pass: Forward }"),
            "{zero:?}"
        );
    }

    #[test]
    fn grid_covers_the_pupil_with_equal_cells() {
        let (rays, area) = pupil_grid(4, 2.0, 10.0, 0.0);
        assert_eq!(rays.len(), 16);
        assert!((area - 1.0).abs() < 1e-15);
        assert!((rays[0].origin() - DVec3::new(-1.5, -1.5, START_Z)).length() < 1e-12);
    }
}
