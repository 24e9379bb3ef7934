//! The naked eye's clone displacements at any point, in closed form
//! (documented on [`naked_eye_displacements`]).

use glam::{DMat2, DVec2, DVec3};

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
/// bundle of the field uses. Clone `i` of pupil sample `qᵢ = (xᵢ, yᵢ)` is
///
/// ```text
/// vᵢ = ρ·(e₁ e₂)·K·qᵢ,  ρ = A/2,   K = k(s)·I + s·Δ
/// k  = 1 − s·P_near   where s·P_near < 1   (nearer than the near point)
///    = 1 − s·P_far    where s·P_far  > 1   (beyond the far point)
///    = 0              otherwise             (in focus)
/// ```
///
/// with `Δ` the eye's astigmatic part across the sight line
/// ([`Eye::astigmatic_matrix`], zero for a stigmatic eye): the ray from
/// pupil point `r` towards the focused vergence `V` (a matrix,
/// [`Eye::vergence_matrix`]) meets the plane at `s` at `(I − s·V)·r`, and
/// the eye accommodates by `a ∈ [0, Amp]` to make `tr(I − s·V)` zero, the
/// circle of least confusion. For a stigmatic eye the set is the disc of
/// diameter `A·s·ΔD` of eqs. (1) and (2) ([`Eye::blur_disc_diameter_m`]) —
/// the set the field's naked-eye bundles give at `s` exactly, without the
/// field's voxel quantisation; for an astigmatic one, an ellipse, which is
/// the circle of least confusion (diameter `A·s·|C|/2`) where the eye can
/// focus. Emmetropes,
/// `Amp = 0` and hyperopes need no special case.
///
/// Beyond the far point `k` is negative: clone `i` lies opposite pupil
/// point `i` (the rays have crossed). The set is the same disc, and `K` is
/// continuous in `s`, so a triangle across the far point is not torn;
/// the field mirrors its far sets instead ([`Region::Far`](super::Region)),
/// for its averaging over voxels.
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
    let m = (DMat2::IDENTITY * k + eye.astigmatic_matrix(e1, e2) * s) * (0.5 * eye.pupil_diameter_m());
    samples
        .iter()
        .map(|p| {
            let q = m * *p;
            e1 * q.x + e2 * q.y
        })
        .collect()
}

/// `k(s)` of [`naked_eye_displacements`]: the blur disc's signed radius per
/// unit pupil radius at distance `s` (m), from the near and far vergences
/// (D): `1 − s·V` for the vergence `V ∈ [P_far, P_near]` the eye focuses
/// nearest `1/s`. Written without dividing, so that `P ≤ 0` (a point at or
/// beyond infinity, a hyperope's virtual point) needs no special case.
pub fn defocus_factor(s: f64, p_near: f64, p_far: f64) -> f64 {
    if s * p_near < 1.0 {
        1.0 - s * p_near
    } else if s * p_far > 1.0 {
        1.0 - s * p_far
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
        // the same point (their spread at s), and its
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
                far.displacements(s).collect()
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
        assert!((defocus_factor(2.0, 1.0, 1.0) + 1.0).abs() < 1e-15);
        let far = naked_eye_displacements(&hyperope, &pl, DVec3::new(0.0, 0.0, 100.0), &samples);
        assert!(far.iter().all(|v| v.is_finite() && v.length() > 0.0));
    }

    /// The principal axes of a set of vectors in the eye's x–y plane:
    /// (the unit direction of the longest, its RMS length, the RMS length
    /// across it).
    fn ellipse(set: &[DVec3]) -> (DVec2, f64, f64) {
        let n = set.len() as f64;
        let (mut xx, mut xy, mut yy) = (0.0, 0.0, 0.0);
        for v in set {
            xx += v.x * v.x / n;
            xy += v.x * v.y / n;
            yy += v.y * v.y / n;
        }
        let m = glam::DMat2::from_cols(DVec2::new(xx, xy), DVec2::new(xy, yy));
        let half = 0.5 * (xx - yy);
        let root = (half * half + xy * xy).sqrt();
        let (big, small) = (0.5 * (xx + yy) + root, 0.5 * (xx + yy) - root);
        let dir = if root > 0.0 {
            (m - glam::DMat2::IDENTITY * small).col(0).try_normalize()
                .or_else(|| (m - glam::DMat2::IDENTITY * small).col(1).try_normalize())
                .unwrap()
        } else {
            DVec2::X
        };
        (dir, big.max(0.0).sqrt(), small.max(0.0).sqrt())
    }

    #[test]
    fn naked_astigmat_blurs_across_the_axis_in_the_optometric_convention() {
        // "plano / −2.00 × θ", no accommodation, a point 20 m straight
        // ahead: the meridian across the axis (θ + 90°, from +x, the
        // wearer's left, towards +y, up, as the examiner sees the eye) is
        // 2 D myopic, the axis meridian emmetropic. Each meridian spreads
        // by ρ·|1 − s·V|: V = 2 D across the axis (ρ·39 at 20 m), V = 0
        // along it (ρ·1), an ellipse 39 times longer across the axis.
        let pl = EyePlacement::default();
        let samples = pupil_samples(256);
        let a = 0.004;
        let rho = 0.5 * a;
        let p = DVec3::new(0.0, 0.0, 20.0);
        let s = (p - pl.pupil_centre(DVec3::Z)).length();
        for axis in [0.0, 30.0, 90.0, 135.0] {
            let eye = Eye::new(0.0, 0.0, a).unwrap().with_astigmatism(-2.0, axis).unwrap();
            let set = naked_eye_displacements(&eye, &pl, p, &samples);
            let (dir, big, small) = ellipse(&set);
            let across = (axis + 90.0f64).to_radians();
            let want = DVec2::new(across.cos(), across.sin());
            assert!(dir.dot(want).abs() > 0.9999, "axis {axis}: blur along {dir}, want {want}");
            // Points uniform on the unit disc have an RMS of 1/2 along any axis.
            let per_axis = |k: f64| rho * k.abs() * 0.5;
            let (want_big, want_small) = (per_axis(1.0 - 2.0 * s), per_axis(1.0));
            assert!((big / want_big - 1.0).abs() < 0.02, "{big} vs {want_big}");
            assert!((small / want_small - 1.0).abs() < 0.05, "{small} vs {want_small}");
        }
        // Within the eye's range it focuses the spherical equivalent, and
        // the meridians are ±|C|/2 out of focus: the circle of least
        // confusion, a disc of radius ρ·s·|C|/2 (RMS half that per axis).
        let eye = Eye::new(-1.0, 4.0, a).unwrap().with_astigmatism(-2.0, 90.0).unwrap();
        let p = DVec3::new(0.0, 0.0, 0.4);
        let s = (p - pl.pupil_centre(DVec3::Z)).length();
        let (_, big, small) = ellipse(&naked_eye_displacements(&eye, &pl, p, &samples));
        let disc = rho * s * 1.0 * 0.5;
        assert!((big / disc - 1.0).abs() < 0.02 && (small / disc - 1.0).abs() < 0.02, "{big} {small} {disc}");
        // A stigmatic eye is unchanged by a zero cylinder at any axis.
        let plain = Eye::new(-3.0, 1.0, a).unwrap();
        let zero_cyl = plain.with_astigmatism(0.0, 77.0).unwrap();
        let q = DVec3::new(0.3, -0.2, 4.0);
        assert_eq!(
            naked_eye_displacements(&plain, &pl, q, &samples),
            naked_eye_displacements(&zero_cyl, &pl, q, &samples)
        );
    }
}
