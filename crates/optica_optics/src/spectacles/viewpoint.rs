//! The virtual viewpoint of a set of refracted rays (documented on [`virtual_viewpoint`]).

use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};

use super::error::SpectaclesError;
use super::per_vertex::LensTrace;
use crate::input;
use crate::ray::Ray;

/// Default `λ`: pulls the solution towards the prior only along directions
/// the rays do not constrain. Per ray, `I − dᵢdᵢᵀ` constrains a direction
/// about as strongly as the square of the rays' angular spread across it,
/// so `λ = 1e-8 = (1e-4)²` leaves any spread above ~1e-4 rad (a lens of
/// more than ~0.01 D seen through its whole aperture) to the rays and holds
/// only nearly parallel bundles at the prior's depth.
pub const DEFAULT_VIEWPOINT_REGULARISATION: f64 = 1e-8;

/// A fitted virtual viewpoint.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ViewpointFit {
    /// The point.
    pub point: DVec3,
    /// Root-mean-square distance of the point from the rays' lines (m).
    pub rms_distance_m: f64,
    /// Rays used: all given, or, for [`virtual_viewpoint_of_traces`], the
    /// traces that got through the lens.
    pub rays_used: usize,
}

/// The virtual viewpoint of `rays` (paper §3.1 step (2)): the point
/// closest to all of their lines, from which the environment map is
/// rendered.
///
/// Least squares: with unit directions `dᵢ` and points `pᵢ`, the squared
/// distance of `x` from line i is `|(I − dᵢdᵢᵀ)(x − pᵢ)|²`. For nearly parallel
/// rays (a weak lens, or a lens that puts the far point at infinity) the sum
/// is singular along the common direction, so it is regularised towards a
/// prior point `x₀` (the eye):
///
/// ```text
/// minimise  Σᵢ |(I − dᵢdᵢᵀ)(x − pᵢ)|² + λ·N·|x − x₀|²
/// ⇒ (Σᵢ (I − dᵢdᵢᵀ) + λN·I)(x − x₀) = Σᵢ (I − dᵢdᵢᵀ)(pᵢ − x₀)
/// ```
///
/// solved in `f64`, relative to `x₀` so that the numbers stay small. Nothing
/// constrains `x` to lie in front: a plus lens puts the virtual viewpoint
/// behind the eye, and that is the right answer. The matrix is symmetric
/// positive definite (eigenvalues >= λN), so the solve always exists.
///
/// `prior` is where the solution goes along directions the rays leave
/// free (the eye); `regularisation` is `λ` ([`DEFAULT_VIEWPOINT_REGULARISATION`]).
///
/// Errors: [`SpectaclesError::NoRays`] for an empty set; a non-finite
/// prior or a `λ` that is not finite and positive
/// ([`SpectaclesError::Input`]); [`SpectaclesError::Degenerate`] if the
/// solve overflows (rays millions of kilometres away).
pub fn virtual_viewpoint(
    rays: &[Ray],
    prior: DVec3,
    regularisation: f64,
) -> Result<ViewpointFit, SpectaclesError> {
    let prior = input::finite_vec3("viewpoint prior (m)", prior)?;
    let regularisation = input::positive("viewpoint regularisation λ", regularisation)?;
    if rays.is_empty() {
        return Err(SpectaclesError::NoRays);
    }
    let n = rays.len() as f64;
    let mut m = DMat3::IDENTITY * (regularisation * n);
    let mut b = DVec3::ZERO;
    for r in rays {
        let d = r.dir();
        let proj = DMat3::IDENTITY - DMat3::from_cols(d * d.x, d * d.y, d * d.z);
        m += proj;
        b += proj * (r.origin() - prior);
    }
    let x = prior + m.inverse() * b;
    if !x.is_finite() {
        return Err(SpectaclesError::Degenerate(
            "virtual viewpoint solve overflowed",
        ));
    }
    let ss: f64 = rays
        .iter()
        .map(|r| {
            let v = x - r.origin();
            (v - r.dir() * v.dot(r.dir())).length_squared()
        })
        .sum();
    Ok(ViewpointFit {
        point: x,
        rms_distance_m: (ss / n).sqrt(),
        rays_used: rays.len(),
    })
}

/// The virtual viewpoint of the rays that got through the lens (the paper,
/// §3.1: "the point nearest to the extensions of a few chosen reflection or
/// refraction vectors"; any subset works). The exit rays point into the scene; the
/// viewpoint is where their backward extensions meet.
///
/// Errors: as [`virtual_viewpoint`]; [`SpectaclesError::NoRays`] when no
/// trace got through.
pub fn virtual_viewpoint_of_traces(
    traces: &[LensTrace],
    prior: DVec3,
    regularisation: f64,
) -> Result<ViewpointFit, SpectaclesError> {
    let rays: Vec<Ray> = traces.iter().filter_map(|t| t.exit_ray()).collect();
    virtual_viewpoint(&rays, prior, regularisation)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn viewpoint_recovers_a_known_point() {
        // Rays through (0.01, −0.02, −0.3): the point is recovered to the
        // regularisation's bias (λ = 1e-8, spread ~0.3 rad: bias ~1e-8·0.3).
        let c = DVec3::new(0.01, -0.02, -0.3);
        let rays: Vec<Ray> = [
            (0.1, 0.0),
            (-0.1, 0.05),
            (0.0, -0.2),
            (0.2, 0.2),
            (-0.15, -0.1),
        ]
        .iter()
        .map(|&(x, y)| {
            let d = DVec3::new(x, y, 1.0).normalize();
            Ray::new(c + d * 0.35, d).unwrap()
        })
        .collect();
        let fit = virtual_viewpoint(&rays, DVec3::ZERO, DEFAULT_VIEWPOINT_REGULARISATION).unwrap();
        assert!((fit.point - c).length() < 1e-7, "{:?}", fit.point);
        assert!(fit.rms_distance_m < 1e-7);
        // Behind the eye is allowed (z = −0.3 with a prior at 0).
        assert!(fit.point.z < -0.29);
    }

    #[test]
    fn viewpoint_parallel_rays_fall_back_to_the_prior() {
        // Exactly parallel rays: along the direction nothing is known, so the
        // prior's z is kept; across it, the rays' centroid (here x = 0.01).
        let prior = DVec3::new(0.0, 0.0, -0.0135);
        let rays: Vec<Ray> = (0..5)
            .map(|k| {
                Ray::new(
                    DVec3::new(0.01 + 0.0 * k as f64, 0.0, 0.02 + 0.001 * k as f64),
                    DVec3::Z,
                )
                .unwrap()
            })
            .collect();
        let fit = virtual_viewpoint(&rays, prior, DEFAULT_VIEWPOINT_REGULARISATION).unwrap();
        assert!(fit.point.is_finite());
        assert!((fit.point.z - prior.z).abs() < 1e-12);
        assert!((fit.point.x - 0.01).abs() < 1e-9);
        // Nearly parallel rays (1e-6 rad) converging 1 km away are not
        // resolvable against λ: the answer stays finite and near the prior's depth.
        let rays: Vec<Ray> = [-1.0, 1.0]
            .iter()
            .map(|&s| {
                Ray::new(
                    DVec3::new(s * 1e-3, 0.0, 0.0),
                    DVec3::new(-s * 1e-6, 0.0, 1.0),
                )
                .unwrap()
            })
            .collect();
        let fit = virtual_viewpoint(&rays, prior, DEFAULT_VIEWPOINT_REGULARISATION).unwrap();
        assert!(fit.point.is_finite() && fit.point.z.abs() < 1.0);
    }

    #[test]
    fn viewpoint_of_real_lenses() {
        use crate::spectacles::lens_design::{LensDesignParams, Prescription, design_lens};
        use crate::spectacles::per_vertex::refract_vertices;
        let eye = DVec3::new(0.0, 0.0, -0.003);
        let fit = |s: f64, base: Option<f64>| {
            let p = LensDesignParams::default().with_base_curve_d(base).unwrap();
            let lens = design_lens(&Prescription::sphere(s).unwrap(), &p).unwrap();
            // Paraxial zone: back-surface vertices within 2 mm of the axis.
            let verts: Vec<DVec3> = lens
                .mesh(40, 16)
                .unwrap()
                .back_positions()
                .iter()
                .copied()
                .filter(|v| v.truncate().length() < 0.002)
                .collect();
            let traces = refract_vertices(&lens, eye, &verts).unwrap();
            (
                lens,
                virtual_viewpoint_of_traces(&traces, eye, DEFAULT_VIEWPOINT_REGULARISATION)
                    .unwrap(),
            )
        };
        // A flat plate of thickness t = 2 mm, n = 1.498 shows the eye moved
        // towards it by t(1 − 1/n) = 0.6649 mm (hand: 0.002·0.498/1.498).
        let (plate, v) = fit(0.0, Some(0.0));
        let shift = plate.centre_thickness_m() * (1.0 - 1.0 / plate.index());
        assert!((shift - 0.000_664_9).abs() < 1e-7);
        // (Rays up to 7.6° off-axis: the plate's own aberration moves the
        // best point by a few µm; 10 µm bounds it, against a 665 µm shift.)
        assert!((v.point.z - (eye.z + shift)).abs() < 1e-5, "{:?}", v.point);
        assert!(v.point.truncate().length() < 1e-9 && v.rms_distance_m < 1e-6);
        // Plus lens: the viewpoint moves back (behind the eye); minus: forward.
        // Thin-lens image of the eye 15 mm behind a lens of power F:
        // 1/(1/0.015 − F) behind it — +4 D: 0.957 mm further back, −4 D:
        // 0.85 mm nearer (plus the plate shift).
        let (_, vp) = fit(4.0, None);
        let (_, vm) = fit(-4.0, None);
        assert!(vp.point.z < eye.z, "{:?}", vp.point);
        assert!(vm.point.z > eye.z + shift, "{:?}", vm.point);
        assert!(vp.point.z < v.point.z - 0.0005 && vm.point.z > v.point.z + 0.0005);
    }

    #[test]
    fn viewpoint_bad_input_is_typed() {
        assert_eq!(
            virtual_viewpoint(&[], DVec3::ZERO, 1e-8),
            Err(SpectaclesError::NoRays)
        );
        let ok = Ray::new(DVec3::ZERO, DVec3::Z).unwrap();
        let input_error = |r: Result<ViewpointFit, SpectaclesError>| match r {
            Err(SpectaclesError::Input(e)) => e.what,
            other => panic!("{other:?}"),
        };
        assert_eq!(
            input_error(virtual_viewpoint(&[ok], DVec3::NAN, 1e-8)),
            "viewpoint prior (m)"
        );
        assert_eq!(
            input_error(virtual_viewpoint(&[ok], DVec3::ZERO, 0.0)),
            "viewpoint regularisation λ"
        );
        assert_eq!(
            input_error(virtual_viewpoint(&[ok], DVec3::ZERO, f64::NAN)),
            "viewpoint regularisation λ"
        );
        // Traces none of which got through: no rays.
        assert_eq!(
            virtual_viewpoint_of_traces(&[LensTrace::Missed], DVec3::ZERO, 1e-8),
            Err(SpectaclesError::NoRays)
        );
    }

    proptest! {
        #[test]
        fn viewpoint_finite_for_any_finite_rays(
            rays in prop::collection::vec((prop::array::uniform3(-1f64..1.0), prop::array::uniform3(-1f64..1.0)), 1..12),
            lambda in 1e-12f64..1.0,
        ) {
            let rays: Vec<Ray> = rays.iter().filter_map(|(o, d)| Ray::new(DVec3::from(*o), DVec3::from(*d)).ok()).collect();
            match virtual_viewpoint(&rays, DVec3::ZERO, lambda) {
                Ok(f) => prop_assert!(f.point.is_finite() && f.rms_distance_m.is_finite()),
                Err(e) => prop_assert_eq!(e, SpectaclesError::NoRays),
            }
        }
    }
}
