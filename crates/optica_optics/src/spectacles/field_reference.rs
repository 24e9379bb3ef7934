//! The direct reference for the voxel field: the displacement set at one
//! point, computed by tracing a dense bundle through that point.
//!
//! For a point `P`:
//! 1. find the aim whose refracted reference ray passes through `P` (Newton's
//!    method on the two aim slopes, finite-difference Jacobian, from the
//!    straight line eye → `P`; without a lens the straight line itself);
//! 2. trace the near and far bundles of that aim with many pupil rays;
//! 3. at `s` = distance of `P` along the refracted reference ray, take the
//!    set the field would store (the same region rule, [`displacement_set`]).
//!
//! It differs from the field only by what the field approximates: the voxel
//! (the field's set is the average of bundles crossing the voxel at other
//! points, evaluated at their segment midpoints), the aim sampling, and the
//! `S` pupil rays. So `field − reference` measures exactly the field's error.

use glam::{DVec2, DVec3};
use serde::Serialize;

use super::bundle::{EyePlacement, Region, Spread, displacement_set, pupil_samples, trace_bundle};
use super::error::SpectaclesError;
use super::eye::Eye;
use super::lens_design::SpectacleLens;
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

/// Pupil rays of the dense bundle by default.
pub const DEFAULT_DENSE_SAMPLES: usize = 256;

/// Most pupil rays [`reference_at`] accepts per bundle: 65,536, 256 times the
/// default (the reference's sampling error is already far below the field's
/// at the default; more would only allocate and trace without limit).
pub const MAX_DENSE_SAMPLES: usize = 1 << 16;

fn aim_of(slopes: DVec2) -> DVec3 {
    DVec3::new(slopes.x, slopes.y, 1.0).normalize()
}

/// The refracted reference ray of `aim`, or `None` when it does not get through.
fn exit_chief(lens: Option<&SpectacleLens>, placement: &EyePlacement, aim: DVec3) -> Option<Ray> {
    match lens {
        None => Some(Ray::from_unit(placement.pupil_centre(aim), aim)),
        Some(l) => l.trace_from_eye(&Ray::from_unit(placement.centre_of_rotation, aim)).exit_ray(),
    }
}

/// Offset of `p` from the ray's line, as (x, y) (the ray is within ~80° of +z).
fn miss(ray: &Ray, p: DVec3) -> DVec2 {
    let v = p - ray.origin();
    (v - ray.dir() * v.dot(ray.dir())).truncate()
}

/// Solves for the aim whose refracted reference ray passes through `p`.
fn solve_aim(lens: Option<&SpectacleLens>, placement: &EyePlacement, p: DVec3) -> Result<(DVec3, Ray), SpectaclesError> {
    let straight = p - placement.centre_of_rotation;
    if !(straight.z > 0.0) {
        return Err(SpectaclesError::Degenerate("point not in front of the eye"));
    }
    let mut x = DVec2::new(straight.x / straight.z, straight.y / straight.z);
    if lens.is_none() {
        let aim = aim_of(x);
        return Ok((aim, exit_chief(lens, placement, aim).ok_or(SpectaclesError::Degenerate("aim"))?));
    }
    let blocked = SpectaclesError::NotThroughLens("reference ray blocked by TIR, the rim or the blank");
    let resid = |x: DVec2| exit_chief(lens, placement, aim_of(x)).map(|r| (miss(&r, p), r));
    let (mut e, mut chief) = resid(x).ok_or(blocked.clone())?;
    for _ in 0..60 {
        if e.length() < 1e-12 {
            break;
        }
        let h = 1e-7;
        let col = |d: DVec2| -> Option<DVec2> { Some((resid(x + d)?.0 - resid(x - d)?.0) / (2.0 * h)) };
        let (Some(jx), Some(jy)) = (col(DVec2::new(h, 0.0)), col(DVec2::new(0.0, h))) else { return Err(blocked) };
        let det = jx.x * jy.y - jy.x * jx.y;
        if !(det.abs() > 1e-300) || !det.is_finite() {
            return Err(SpectaclesError::Degenerate("singular aim Jacobian"));
        }
        let step = DVec2::new(e.x * jy.y - jy.x * e.y, jx.x * e.y - e.x * jx.y) / det;
        // Backtrack until the residual shrinks (and the ray still gets through).
        let mut lambda = 1.0;
        let mut moved = false;
        for _ in 0..30 {
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
    if !(e.length() < 1e-9) {
        return Err(SpectaclesError::NotThroughLens("the aim iteration did not reach the point"));
    }
    Ok((aim_of(x), chief))
}

/// The reference displacement spread at `point` for `eye` at `placement`
/// through `lens` (`None`: naked eye), with `dense_samples` pupil rays.
///
/// Errors: a bad eye, placement or point; `dense_samples` outside
/// `1..=`[`MAX_DENSE_SAMPLES`] (checked before anything is allocated);
/// [`SpectaclesError::NotThroughLens`] when no reference ray through the lens
/// reaches the point or a pupil ray is blocked; a point behind the lens exit.
pub fn reference_at(
    eye: &Eye,
    placement: &EyePlacement,
    lens: Option<&SpectacleLens>,
    point: DVec3,
    dense_samples: usize,
) -> Result<PointReference, SpectaclesError> {
    Eye::new(eye.refractive_error_d, eye.accommodation_d, eye.pupil_diameter_m)?;
    if !point.is_finite() {
        return Err(SpectaclesError::NonFinite("point"));
    }
    if !placement.is_valid() {
        return Err(SpectaclesError::NonFinite("eye placement"));
    }
    if !(1..=MAX_DENSE_SAMPLES).contains(&dense_samples) {
        return Err(SpectaclesError::OutOfRange {
            what: "dense samples",
            value: dense_samples as f64,
            min: 1.0,
            max: MAX_DENSE_SAMPLES as f64,
        });
    }
    let (aim, chief) = solve_aim(lens, placement, point)?;
    let samples = pupil_samples(dense_samples);
    let rho = 0.5 * eye.pupil_diameter_m;
    let blocked = |_| SpectaclesError::NotThroughLens("a pupil ray is blocked by TIR or the rim");
    let near = trace_bundle(lens, placement, aim, rho, eye.near_point_vergence_d(), &samples).map_err(blocked)?;
    let far = trace_bundle(lens, placement, aim, rho, eye.far_point_vergence_d(), &samples).map_err(blocked)?;
    let s = (point - chief.origin()).dot(chief.dir());
    if !(s > 0.0) {
        return Err(SpectaclesError::Degenerate("point behind the lens exit"));
    }
    let (region, set) = displacement_set(&near, &far, s);
    Ok(PointReference {
        aim,
        chief,
        distance_m: s,
        miss_m: miss(&chief, point).length(),
        region,
        vergences_d: [near.vergence_d, far.vergence_d],
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
        for p in [DVec3::new(0.05, 0.02, 0.2), DVec3::new(-0.3, 0.1, 3.0), DVec3::new(0.0, 0.0, 0.9)] {
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
        let lens = design_lens(&Prescription::new(-4.0, -1.0, 45.0).unwrap(), &LensDesignParams::default()).unwrap();
        for p in [DVec3::new(0.2, -0.1, 0.5), DVec3::new(-0.6, 0.3, 1.5), DVec3::new(0.0, 0.0, 2.0)] {
            let r = reference_at(&eye, &pl, Some(&lens), p, 64).unwrap();
            assert!(r.miss_m < 1e-9, "{}", r.miss_m);
            assert!(r.spread.rms_radius_m.is_finite());
            // The lens (−4 D, −1 D cylinder) roughly corrects the −4 D eye:
            // every point blurs less than with the naked eye (e.g. at 1.5 m
            // naked ΔD = 4 − 0.67 = 3.3 D, a 20 mm disc).
            let naked = reference_at(&eye, &pl, None, p, 64).unwrap();
            assert!(r.spread.disc_diameter_m() < 0.7 * naked.spread.disc_diameter_m(), "{p}: {:?}", r.spread);
        }
        // A point far outside the lens's cone cannot be seen through it.
        assert!(matches!(
            reference_at(&eye, &pl, Some(&lens), DVec3::new(3.0, 0.0, 0.5), 16),
            Err(SpectaclesError::NotThroughLens(_))
        ));
        assert!(reference_at(&eye, &pl, None, DVec3::new(0.0, 0.0, -1.0), 16).is_err());
        assert!(reference_at(&eye, &pl, None, DVec3::NAN, 16).is_err());
        assert!(reference_at(&eye, &pl, None, DVec3::Z, 0).is_err());
    }

    #[test]
    fn field_reference_huge_dense_samples_are_typed() {
        // Rejected before `pupil_samples` allocates (usize::MAX would abort
        // on allocation; 2^40 would hang tracing).
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let pl = EyePlacement::default();
        for n in [usize::MAX, 1 << 40, MAX_DENSE_SAMPLES + 1] {
            assert!(
                matches!(reference_at(&eye, &pl, None, DVec3::Z, n), Err(SpectaclesError::OutOfRange { what: "dense samples", .. })),
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
                Err(e) => prop_assert!(matches!(e, SpectaclesError::NotThroughLens(_) | SpectaclesError::Degenerate(_)), "{:?}", e),
            }
        }
    }
}
