//! The naked eye's clone displacements at any point, in closed form
//! (documented on [`naked_eye_displacements`]).

use glam::{DVec2, DVec3};

use super::bundle::{EyePlacement, perpendicular_frame};
use super::eye::Eye;

/// The `S` clone displacements (m, eye frame) of the naked eye at `point`
/// (paper §4.2, Fig. 5), one per pupil sample (`samples` on the unit disc,
/// e.g. [`pupil_samples`](super::pupil_samples)), with no voxel field: what
/// the plugin's vertex shader computes per vertex when no lens is worn.
///
/// The eye turns to look at the point (the reference ray runs from the
/// centre of rotation through it, as in the field): `a` = the unit aim,
/// the pupil centre `c = C + a·offset`, `s = |point − c|` the distance
/// along the line of sight, `(e₁, e₂)` the frame across it that every
/// bundle of the field uses. Clone `i` of pupil sample `(xᵢ, yᵢ)` is
///
/// ```text
/// vᵢ = ρ·(xᵢ e₁ + yᵢ e₂)·k(s),  ρ = A/2
/// k  = 1 − s·P_near   where s·P_near < 1   (nearer than the near point)
///    = s·P_far − 1    where s·P_far  > 1   (beyond the far point, mirrored)
///    = 0              otherwise             (in focus)
/// ```
///
/// so that the set is the disc of diameter `A·s·ΔD` of eqs. (1) and (2)
/// ([`Eye::blur_disc_diameter_m`]) — the set the field's naked-eye bundles
/// give at `s` exactly (their fitted vergences are `P_near` and `P_far`),
/// without the field's voxel quantisation. Emmetropes, `Amp = 0` and
/// hyperopes need no special case.
///
/// Documented fallback: a point at the pupil centre, or not finite, has no
/// line of sight and gets zero displacements (it is not blurred).
pub fn naked_eye_displacements(
    eye: &Eye,
    placement: &EyePlacement,
    point: DVec3,
    samples: &[DVec2],
) -> Vec<DVec3> {
    let zero = || vec![DVec3::ZERO; samples.len()];
    let Some(aim) = (point - placement.centre_of_rotation()).try_normalize() else {
        return zero();
    };
    let s = (point - placement.pupil_centre(aim)).length();
    if !s.is_finite() {
        return zero();
    }
    let k = defocus_factor(s, eye.near_point_vergence_d(), eye.far_point_vergence_d());
    let (e1, e2) = perpendicular_frame(aim);
    let rho = 0.5 * eye.pupil_diameter_m();
    samples
        .iter()
        .map(|p| (e1 * p.x + e2 * p.y) * (rho * k))
        .collect()
}

/// `k(s)` of [`naked_eye_displacements`]: the blur disc's radius per unit
/// pupil radius at distance `s` (m), from the near and far vergences (D).
/// Written without dividing, so that `P ≤ 0` (a point at or beyond
/// infinity, a hyperope's virtual point) needs no special case.
pub fn defocus_factor(s: f64, p_near: f64, p_far: f64) -> f64 {
    if s * p_near < 1.0 {
        1.0 - s * p_near
    } else if s * p_far > 1.0 {
        s * p_far - 1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectacles::bundle::{pupil_samples, trace_bundle};

    #[test]
    fn naked_equals_the_naked_bundles_and_eq_1_2() {
        // The closed form is the set the field's naked-eye bundles give at
        // the same point (their spread at s, far sets mirrored), and its
        // longest vector spans the disc A·z·ΔD of eqs. (1)–(2).
        let eye = Eye::from_near_far(0.5, 1.3, 0.012).unwrap();
        let pl = EyePlacement::default();
        let samples = pupil_samples(10);
        let rho = 0.5 * eye.pupil_diameter_m();
        for point in [
            DVec3::new(0.02, -0.01, 0.2),
            DVec3::new(-0.3, 0.1, 0.8),
            DVec3::new(0.5, 0.4, 3.0),
            DVec3::new(0.0, 0.0, 40.0),
        ] {
            let got = naked_eye_displacements(&eye, &pl, point, &samples);
            let aim = (point - pl.centre_of_rotation()).normalize();
            let s = (point - pl.pupil_centre(aim)).length();
            let near =
                trace_bundle(None, &pl, aim, rho, eye.near_point_vergence_d(), &samples).unwrap();
            let far =
                trace_bundle(None, &pl, aim, rho, eye.far_point_vergence_d(), &samples).unwrap();
            let want: Vec<DVec3> = if s * near.vergence_d() < 1.0 {
                near.displacements(s).collect()
            } else if s * far.vergence_d() > 1.0 {
                far.displacements(s).map(|v| -v).collect()
            } else {
                vec![DVec3::ZERO; samples.len()]
            };
            for (g, w) in got.iter().zip(&want) {
                assert!((*g - *w).length() < 1e-15, "{point}: {g} vs {w}");
                // Perpendicular to the line of sight.
                assert!(g.dot(aim).abs() < 1e-15);
            }
            // The disc: a sample of radius r has length r·(A/2)·s·ΔD... i.e.
            // |v|/|sample| = A·s·ΔD/2, the disc's radius.
            let disc = eye.blur_disc_diameter_m(s).unwrap();
            for (g, p) in got.iter().zip(&samples) {
                assert!((g.length() - 0.5 * disc * p.length()).abs() < 1e-15);
            }
        }
        // In focus (0.5–1.3 m): zero.
        let p = DVec3::new(0.0, 0.0, 0.9);
        assert!(
            naked_eye_displacements(&eye, &pl, p, &samples)
                .iter()
                .all(|v| *v == DVec3::ZERO)
        );
    }

    #[test]
    fn naked_degenerate_points_fall_back_to_sharp() {
        let eye = Eye::new(-3.0, 1.0, 0.004).unwrap();
        let pl = EyePlacement::default();
        let samples = pupil_samples(4);
        for p in [
            pl.centre_of_rotation(),
            DVec3::NAN,
            DVec3::new(f64::INFINITY, 0.0, 1.0),
        ] {
            let v = naked_eye_displacements(&eye, &pl, p, &samples);
            assert_eq!(v, vec![DVec3::ZERO; 4], "{p}");
        }
        // A zero pupil: no blur anywhere.
        let pinhole = Eye::new(-3.0, 1.0, 0.0).unwrap();
        let v = naked_eye_displacements(&pinhole, &pl, DVec3::new(0.0, 0.0, 5.0), &samples);
        assert!(v.iter().all(|v| *v == DVec3::ZERO));
        // A hyperope sees infinity blurred (k = 1 − s·P_near > 0 everywhere).
        let hyperope = Eye::new(2.0, 0.0, 0.004).unwrap();
        assert!((defocus_factor(1e6, -2.0, -2.0) - (1.0 + 2e6)).abs() < 1e-6);
        let far = naked_eye_displacements(&hyperope, &pl, DVec3::new(0.0, 0.0, 100.0), &samples);
        assert!(far.iter().all(|v| v.is_finite() && v.length() > 0.0));
    }
}
