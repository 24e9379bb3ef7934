//! The direct reference for the voxel field (documented on [`reference_at`]).

use glam::{DVec2, DVec3};
use serde::Serialize;

use super::bundle::{
    EyePlacement, Region, Spread, displacement_set, perpendicular_frame, pupil_samples,
    trace_astigmatic_bundle,
};
use super::error::SpectaclesError;
use super::eye::Eye;
use super::lens_design::SpectacleLens;
use crate::input::{self, Expected, InvalidInput};
use crate::ray::Ray;

/// The reference at one point.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PointReference {
    /// Unit aim from the centre of rotation.
    pub aim: DVec3,
    /// The refracted reference ray (exit point, direction).
    pub chief: Ray,
    /// Distance of the point along `chief` (m).
    pub distance_m: f64,
    /// Distance of the point from `chief`'s line (m): the chief solve's residual.
    pub miss_m: f64,
    /// Which bundle applies.
    pub region: Region,
    /// Fitted vergences `[W_near, W_far]` (D) after the lens.
    pub vergences_d: [f64; 2],
    /// The spread of the dense displacement set.
    pub spread: Spread,
}

/// Pupil rays of the dense bundle by default: 256, 25 times the paper's
/// `S = 10`, so that the reference's own sampling of the pupil is small
/// beside the field's.
pub const DEFAULT_DENSE_SAMPLES: usize = 256;

/// Most pupil rays [`reference_at`] accepts per bundle: 65,536, 256 times the
/// default (the reference's sampling error is already far below the field's
/// at the default; more would only allocate and trace without limit).
pub const MAX_DENSE_SAMPLES: usize = 1 << 16;

/// Most Newton steps of the aim solve. From the straight line eye → point
/// the solve converges quadratically in a handful of steps through any
/// spectacle lens; 60 only bounds the loop.
const AIM_MAX_STEPS: usize = 60;

/// The aim solve stops once the reference ray passes within this of the
/// point (m): 1 pm, the round-off of metre-scale coordinates.
const AIM_STOP_MISS_M: f64 = 1e-12;

/// The aim solve succeeds if the reference ray passes within this of the
/// point (m): 1 nm, a millionth of a millimetre-sized blur disc, so the
/// solve's residual never shows in the error the reference measures.
const AIM_ACCEPT_MISS_M: f64 = 1e-9;

/// Finite-difference step of the aim Jacobian (in aim slope, i.e. rad near
/// the axis): about the square root of f64's epsilon times the slopes' scale
/// (≤ 1), the step that balances truncation against round-off in a central
/// difference.
const AIM_JACOBIAN_STEP: f64 = 1e-7;

/// A Jacobian determinant (m², miss per unit of aim slope, squared) below
/// this is singular: only an exact caustic (a neighbourhood of aims mapped
/// onto a line) comes this close to zero. For a point at distance `z` the
/// determinant is about `z²` (1e-2 m² at 10 cm); dividing by anything
/// smaller than this would overflow.
const AIM_SINGULAR_DETERMINANT: f64 = 1e-300;

/// Backtracking halvings of a Newton step before the solve gives up:
/// 2⁻³⁰ ≈ 1e-9 of a step.
const AIM_BACKTRACK_HALVINGS: usize = 30;

fn aim_of(slopes: DVec2) -> DVec3 {
    DVec3::new(slopes.x, slopes.y, 1.0).normalize()
}

/// The refracted reference ray of `aim`, or `None` when it does not get through.
fn exit_chief(lens: Option<&SpectacleLens>, placement: &EyePlacement, aim: DVec3) -> Option<Ray> {
    match lens {
        None => Some(Ray::from_unit(placement.pupil_centre(aim), aim)),
        Some(l) => l
            .trace_from_eye(&Ray::from_unit(placement.centre_of_rotation(), aim))
            .exit_ray(),
    }
}

/// Offset of `p` from the ray's line, as (x, y) (the ray is within ~80° of +z).
fn miss(ray: &Ray, p: DVec3) -> DVec2 {
    let v = p - ray.origin();
    (v - ray.dir() * v.dot(ray.dir())).truncate()
}

/// Solves for the aim whose refracted reference ray passes through `p`.
fn solve_aim(
    lens: Option<&SpectacleLens>,
    placement: &EyePlacement,
    p: DVec3,
) -> Result<(DVec3, Ray), SpectaclesError> {
    let straight = p - placement.centre_of_rotation();
    if !(straight.z > 0.0) {
        let what = "point depth in front of the centre of rotation (m)";
        return Err(InvalidInput::new(what, straight.z, Expected::Positive).into());
    }
    let mut x = DVec2::new(straight.x / straight.z, straight.y / straight.z);
    let blocked = SpectaclesError::NotThroughLens(
        "the reference ray towards it is blocked by the rim, total reflection or the blank's edge",
    );
    if lens.is_none() {
        let aim = aim_of(x);
        return Ok((aim, exit_chief(lens, placement, aim).ok_or(blocked)?));
    }
    let resid = |x: DVec2| exit_chief(lens, placement, aim_of(x)).map(|r| (miss(&r, p), r));
    let (mut e, mut chief) = resid(x).ok_or(blocked.clone())?;
    for _ in 0..AIM_MAX_STEPS {
        if e.length() < AIM_STOP_MISS_M {
            break;
        }
        let h = AIM_JACOBIAN_STEP;
        let col =
            |d: DVec2| -> Option<DVec2> { Some((resid(x + d)?.0 - resid(x - d)?.0) / (2.0 * h)) };
        let (Some(jx), Some(jy)) = (col(DVec2::new(h, 0.0)), col(DVec2::new(0.0, h))) else {
            return Err(blocked);
        };
        let det = jx.x * jy.y - jy.x * jx.y;
        if !(det.abs() > AIM_SINGULAR_DETERMINANT) || !det.is_finite() {
            return Err(SpectaclesError::Degenerate(
                "singular aim Jacobian (a caustic of the lens)",
            ));
        }
        let step = DVec2::new(e.x * jy.y - jy.x * e.y, jx.x * e.y - e.x * jx.y) / det;
        // Backtrack until the residual shrinks (and the ray still gets through).
        let mut lambda = 1.0;
        let mut moved = false;
        for _ in 0..AIM_BACKTRACK_HALVINGS {
            let xn = x - step * lambda;
            if let Some((en, cn)) = resid(xn)
                && en.length() < e.length()
            {
                (x, e, chief) = (xn, en, cn);
                moved = true;
                break;
            }
            lambda *= 0.5;
        }
        if !moved {
            break;
        }
    }
    if !(e.length() < AIM_ACCEPT_MISS_M) {
        return Err(SpectaclesError::NotThroughLens(
            "no reference ray through the lens reaches it",
        ));
    }
    Ok((aim_of(x), chief))
}

/// The reference displacement spread at `point` (m, eye frame) for `eye`
/// at `placement` through `lens` (`None`: naked eye), with `dense_samples`
/// pupil rays per bundle ([`DEFAULT_DENSE_SAMPLES`]).
///
/// The direct reference for the voxel field: the displacement set at one
/// point, computed by tracing a dense bundle through that point.
///
/// For a point `P`:
/// 1. find the aim whose refracted reference ray passes through `P` (Newton's
///    method on the two aim slopes, finite-difference Jacobian, from the
///    straight line eye → `P`; without a lens the straight line itself);
/// 2. trace the near and far bundles of that aim with many pupil rays;
/// 3. at `s` = distance of `P` along the refracted reference ray, take the
///    set the field would store (the same region rule).
///
/// It differs from the field only by what the field approximates: the voxel
/// (the field's set is the average of bundles crossing the voxel at other
/// points, evaluated at their segment midpoints), the aim sampling, and the
/// `S` pupil rays. So `field − reference` measures exactly the field's error.
///
/// Errors: a non-finite point, or one not in front of the centre of
/// rotation, and `dense_samples` outside `1..=`[`MAX_DENSE_SAMPLES`]
/// (checked before anything is allocated) are [`SpectaclesError::Input`];
/// [`SpectaclesError::NotThroughLens`] when no reference ray through the
/// lens reaches the point or the point lies between the eye and the lens
/// exit; [`SpectaclesError::BundleBlocked`] when a pupil ray of the dense
/// bundle does not get through; [`SpectaclesError::Degenerate`] at a
/// caustic.
pub fn reference_at(
    eye: &Eye,
    placement: &EyePlacement,
    lens: Option<&SpectacleLens>,
    point: DVec3,
    dense_samples: usize,
) -> Result<PointReference, SpectaclesError> {
    let point = input::finite_vec3("reference point (m)", point)?;
    if !(1..=MAX_DENSE_SAMPLES).contains(&dense_samples) {
        let range = Expected::Range {
            min: 1.0,
            max: MAX_DENSE_SAMPLES as f64,
        };
        return Err(InvalidInput::new("dense samples", dense_samples as f64, range).into());
    }
    let (aim, chief) = solve_aim(lens, placement, point)?;
    let s = (point - chief.origin()).dot(chief.dir());
    if !(s > 0.0) {
        return Err(SpectaclesError::NotThroughLens(
            "it lies between the eye and the lens exit",
        ));
    }
    let samples = pupil_samples(dense_samples);
    let rho = 0.5 * eye.pupil_diameter_m();
    let (e1, e2) = perpendicular_frame(aim);
    let bundle = |accommodation: f64| {
        let v = eye.vergence_matrix(e1, e2, accommodation);
        trace_astigmatic_bundle(lens, placement, aim, rho, v, &samples)
    };
    let near = bundle(eye.accommodation_d())?;
    let far = bundle(0.0)?;
    let (region, set) = displacement_set(&near, &far, s, eye.cylinder_d() != 0.0);
    Ok(PointReference {
        aim,
        chief,
        distance_m: s,
        miss_m: miss(&chief, point).length(),
        region,
        vergences_d: [near.vergence_d(), far.vergence_d()],
        spread: Spread::of(set),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectacles::lens_design::{LensDesignParams, Prescription, design_lens};
    use proptest::prelude::*;

    #[test]
    fn field_reference_naked_eye_is_the_analytic_disc() {
        // Naked eye: the dense reference is A·z·ΔD (eqs. 1, 2) with z the
        // distance from the pupil, for any direction.
        let eye = Eye::from_near_far(0.5, 1.3, 0.012).unwrap();
        let pl = EyePlacement::default();
        for p in [
            DVec3::new(0.05, 0.02, 0.2),
            DVec3::new(-0.3, 0.1, 3.0),
            DVec3::new(0.0, 0.0, 0.9),
        ] {
            let r = reference_at(&eye, &pl, None, p, 128).unwrap();
            let z = (p - pl.pupil_centre(r.aim)).length();
            assert!((r.distance_m - z).abs() < 1e-12);
            let want = eye.blur_disc_diameter_m(z).unwrap();
            assert!((r.spread.disc_diameter_m() - want).abs() < 1e-12, "{p}");
        }
    }

    #[test]
    fn field_reference_chief_goes_through_the_point() {
        let eye = Eye::new(-4.0, 1.0, 0.004).unwrap();
        let pl = EyePlacement::default();
        let lens = design_lens(
            &Prescription::new(-4.0, -1.0, 45.0).unwrap(),
            &LensDesignParams::default(),
        )
        .unwrap();
        for p in [
            DVec3::new(0.2, -0.1, 0.5),
            DVec3::new(-0.6, 0.3, 1.5),
            DVec3::new(0.0, 0.0, 2.0),
        ] {
            let r = reference_at(&eye, &pl, Some(&lens), p, 64).unwrap();
            assert!(r.miss_m < 1e-9, "{}", r.miss_m);
            assert!(r.spread.rms_radius_m.is_finite());
            // The lens (−4 D, −1 D cylinder) roughly corrects the −4 D eye:
            // every point blurs less than with the naked eye (e.g. at 1.5 m
            // naked ΔD = 4 − 0.67 = 3.3 D, a 20 mm disc).
            let naked = reference_at(&eye, &pl, None, p, 64).unwrap();
            assert!(
                r.spread.disc_diameter_m() < 0.7 * naked.spread.disc_diameter_m(),
                "{p}: {:?}",
                r.spread
            );
        }
        // A point far outside the lens's cone cannot be seen through it.
        assert!(matches!(
            reference_at(&eye, &pl, Some(&lens), DVec3::new(3.0, 0.0, 0.5), 16),
            Err(SpectaclesError::NotThroughLens(_))
        ));
        let input_error = |r: Result<PointReference, SpectaclesError>| match r {
            Err(SpectaclesError::Input(e)) => e.what,
            other => panic!("{other:?}"),
        };
        let behind = reference_at(&eye, &pl, None, DVec3::new(0.0, 0.0, -1.0), 16);
        assert_eq!(
            input_error(behind),
            "point depth in front of the centre of rotation (m)"
        );
        assert_eq!(
            input_error(reference_at(&eye, &pl, None, DVec3::NAN, 16)),
            "reference point (m)"
        );
        assert_eq!(
            input_error(reference_at(&eye, &pl, None, DVec3::Z, 0)),
            "dense samples"
        );
        // In front of the eye but inside the lens (z = 13 mm, lens 12–14 mm).
        assert!(matches!(
            reference_at(&eye, &pl, Some(&lens), DVec3::new(0.0, 0.0, 0.013), 16),
            Err(SpectaclesError::NotThroughLens(_))
        ));
    }

    #[test]
    fn field_reference_huge_dense_samples_are_typed() {
        // Rejected before `pupil_samples` allocates (usize::MAX would abort
        // on allocation; 2^40 would hang tracing).
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let pl = EyePlacement::default();
        for n in [usize::MAX, 1 << 40, MAX_DENSE_SAMPLES + 1] {
            assert!(
                matches!(reference_at(&eye, &pl, None, DVec3::Z, n), Err(SpectaclesError::Input(e)) if e.what == "dense samples"),
                "{n}"
            );
        }
        assert!(reference_at(&eye, &pl, None, DVec3::Z, MAX_DENSE_SAMPLES).is_ok());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn field_reference_finite_or_typed(
            s in -8f64..6.0, r in -8f64..8.0, amp in 0f64..4.0, a in 0f64..0.008,
            x in -2f64..2.0, y in -2f64..2.0, z in -0.5f64..4.0,
        ) {
            let eye = Eye::new(r, amp, a).unwrap();
            let lens = design_lens(&Prescription::sphere(s).unwrap(), &LensDesignParams::default()).unwrap();
            match reference_at(&eye, &EyePlacement::default(), Some(&lens), DVec3::new(x, y, z), 16) {
                Ok(p) => {
                    prop_assert!(p.spread.rms_radius_m.is_finite() && p.spread.centroid.is_finite());
                    prop_assert!(p.distance_m > 0.0 && p.miss_m < 1e-9);
                }
                // Points behind the eye are input errors; the rest are not
                // seen through the lens, or a pupil ray of the bundle misses
                // it (the reference ray got through in the solve).
                Err(e) => prop_assert!(
                    matches!(
                        e,
                        SpectaclesError::NotThroughLens(_)
                            | SpectaclesError::BundleBlocked(crate::spectacles::BlockedRay::Pupil)
                            | SpectaclesError::Degenerate(_)
                    ) || matches!(e, SpectaclesError::Input(i) if i.what == "point depth in front of the centre of rotation (m)"),
                    "{:?}", e
                ),
            }
        }
    }
}
