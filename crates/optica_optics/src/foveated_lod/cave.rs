//! CAVE walls and the off-axis projection from a tracked eye (documented on
//! [`CaveWall::off_axis`]).

use glam::{DMat4, DVec3, DVec4};
use serde::{Deserialize, Serialize};

use super::error::FoveatedError;
use crate::input;
use crate::ray::Ray;

/// Largest |cos| of the angle between a wall's two edges that
/// [`CaveWall::new`] accepts as a right angle. 1e-9 admits corners measured
/// or typed to nine significant digits (a 3 m wall placed to the
/// nanometre) and refuses any wall skewed by more than 0.2 milliarcseconds,
/// for which the off-axis frustum would no longer fit the wall's corners.
const RIGHT_ANGLE_TOLERANCE: f64 = 1e-9;

/// Smallest eye–wall distance, relative to the wall's size (width + height),
/// for which the off-axis frustum exists. The frustum's extents grow as
/// near/d; at d = 1e-9 wall sizes they are already 1e9 times the near
/// distance, and the projection's entries lose all precision below that.
const MIN_EYE_DISTANCE_REL: f64 = 1e-9;

/// Which depth convention the projection matrix uses (x and y are the same in all).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum DepthConvention {
    /// wgpu/Vulkan/D3D: depth in [0, 1], near → 0 (glam's `frustum_rh`).
    #[default]
    ZeroToOne,
    /// OpenGL: depth in [−1, 1] (glam's `frustum_rh_gl`).
    MinusOneToOne,
    /// Bevy's camera default: reverse-Z with an infinite far plane, near → 1,
    /// infinity → 0 (`far` is ignored).
    ReverseInfinite,
}

/// A rectangular CAVE wall (world coordinates, m), seen from its front (the
/// side its normal points to). Built by [`CaveWall::new`], so its corners are
/// finite and form a rectangle.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CaveWall {
    lower_left: DVec3,
    lower_right: DVec3,
    upper_left: DVec3,
}

/// An off-axis view and projection for one wall and one eye position.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OffAxisProjection {
    /// World → eye space (right-handed, the eye looks down −z at the wall).
    pub view: DMat4,
    /// Eye space → clip space.
    pub projection: DMat4,
    /// Frustum extents on the near plane: left, right, bottom, top.
    pub extents: [f64; 4],
    /// Eye–wall distance d (> 0).
    pub distance: f64,
}

impl OffAxisProjection {
    /// projection · view.
    pub fn view_projection(&self) -> DMat4 {
        self.projection * self.view
    }

    /// Normalised device coordinates of a world point (perspective divide).
    pub fn to_ndc(&self, p: DVec3) -> DVec3 {
        let c = self.view_projection() * DVec4::new(p.x, p.y, p.z, 1.0);
        c.truncate() / c.w
    }
}

impl CaveWall {
    /// A wall from three corners (m). Errors: [`FoveatedError::Input`] for a
    /// non-finite corner; [`FoveatedError::DegenerateWall`] for a zero edge
    /// or edges that are not perpendicular (|cos| above 1e-9): the corners
    /// must form a rectangle.
    pub fn new(
        lower_left: DVec3,
        lower_right: DVec3,
        upper_left: DVec3,
    ) -> Result<Self, FoveatedError> {
        for c in [lower_left, lower_right, upper_left] {
            input::finite_vec3("CAVE wall corner (m)", c)?;
        }
        let (e_r, e_u) = (lower_right - lower_left, upper_left - lower_left);
        let (lr, lu) = (e_r.length(), e_u.length());
        if !(lr > 0.0 && lu > 0.0) {
            return Err(FoveatedError::DegenerateWall("zero-length edge"));
        }
        if (e_r.dot(e_u) / (lr * lu)).abs() > RIGHT_ANGLE_TOLERANCE {
            return Err(FoveatedError::DegenerateWall("edges are not perpendicular"));
        }
        Ok(Self {
            lower_left,
            lower_right,
            upper_left,
        })
    }

    /// Lower-left corner p_a (m).
    pub fn lower_left(&self) -> DVec3 {
        self.lower_left
    }
    /// Lower-right corner p_b.
    pub fn lower_right(&self) -> DVec3 {
        self.lower_right
    }
    /// Upper-left corner p_c.
    pub fn upper_left(&self) -> DVec3 {
        self.upper_left
    }
    /// Upper-right corner p_b + p_c − p_a.
    pub fn upper_right(&self) -> DVec3 {
        self.lower_right + self.upper_left - self.lower_left
    }

    /// Unit axes (v_r, v_u, v_n): right, up, and the normal towards the viewer.
    pub fn basis(&self) -> (DVec3, DVec3, DVec3) {
        let vr = (self.lower_right - self.lower_left).normalize();
        let vu = (self.upper_left - self.lower_left).normalize();
        (vr, vu, vr.cross(vu).normalize())
    }

    /// Signed distance of `eye` from the wall plane along v_n (> 0 in front).
    pub fn signed_distance(&self, eye: DVec3) -> f64 {
        (eye - self.lower_left).dot(self.basis().2)
    }

    /// The wall point at fractions (s, t) ∈ [0, 1]² from the lower-left corner
    /// (s to the right, t up).
    pub fn point_at(&self, s: f64, t: f64) -> DVec3 {
        self.lower_left
            + (self.lower_right - self.lower_left) * s
            + (self.upper_left - self.lower_left) * t
    }

    /// The eye–wall distance d (m) of an eye in front of the wall.
    ///
    /// Errors: [`FoveatedError::Input`] for a non-finite eye;
    /// [`FoveatedError::EyeNotInFront`] for an eye on the wall's plane, behind
    /// it, or in front by less than 1e-9 of the wall's size (width + height),
    /// where the frustum, which divides by the distance, loses all precision.
    pub fn check_eye(&self, eye: DVec3) -> Result<f64, FoveatedError> {
        let eye = input::finite_vec3("eye position (m)", eye)?;
        let d = self.signed_distance(eye);
        let size = (self.lower_right - self.lower_left).length()
            + (self.upper_left - self.lower_left).length();
        if !(d > MIN_EYE_DISTANCE_REL * size) {
            return Err(FoveatedError::EyeNotInFront { distance: d });
        }
        Ok(d)
    }

    /// The primary ray from `eye` through the wall point at fractions (s, t)
    /// (see [`CaveWall::point_at`]): the ray-traced twin of the off-axis
    /// projection.
    ///
    /// Errors: those of [`CaveWall::check_eye`], and [`FoveatedError::Input`]
    /// for a non-finite s or t.
    pub fn ray_through(&self, eye: DVec3, s: f64, t: f64) -> Result<Ray, FoveatedError> {
        self.check_eye(eye)?;
        let s = input::finite("wall fraction s", s)?;
        let t = input::finite("wall fraction t", t)?;
        Ok(self.ray_from_checked_eye(eye, s, t))
    }

    /// [`CaveWall::ray_through`] for an eye that [`CaveWall::check_eye`] has
    /// accepted and finite (s, t): the point is on the wall's plane and the
    /// eye strictly in front of it, so the direction is finite and non-zero.
    #[inline]
    pub(crate) fn ray_from_checked_eye(&self, eye: DVec3, s: f64, t: f64) -> Ray {
        Ray::from_unit(eye, (self.point_at(s, t) - eye).normalize())
    }

    /// The off-axis ("generalised perspective") view and projection of this
    /// wall from `eye` (R. Kooima, *Generalized Perspective Projection*,
    /// Louisiana State University, 2008), in Bevy's axes: the view looks down
    /// −z at the wall, +y up; `near` and `far` in metres.
    ///
    /// The paper renders on a CAVE of front, right and floor screens (its
    /// §4.1; see [`front_right_floor`]). Each wall is a fixed rectangle in the
    /// world; the eye moves, so each wall needs its own asymmetric frustum
    /// whose edges pass through the wall's corners. With the wall's unit axes
    /// v_r (right), v_u (up) and v_n = v_r × v_u (normal, towards the viewer),
    /// corners p_a (lower left), p_b (lower right), p_c (upper left) and eye
    /// p_e:
    ///
    /// * d = −(p_a − p_e)·v_n is the eye–wall distance; the eye must be in
    ///   front, d > 0 (on the plane the frustum is infinite, behind it mirrored);
    /// * l = v_r·(p_a − p_e)·n/d, r = v_r·(p_b − p_e)·n/d,
    ///   b = v_u·(p_a − p_e)·n/d, t = v_u·(p_c − p_e)·n/d;
    /// * projection = frustum(l, r, b, t, n, f), view = Mᵀ·T(−p_e) with
    ///   M = [v_r v_u v_n].
    ///
    /// The wall's corners then project exactly to the NDC corners.
    ///
    /// Errors: those of [`CaveWall::check_eye`]; [`FoveatedError::Input`]
    /// for a near distance that is not positive and finite, or (except with
    /// [`DepthConvention::ReverseInfinite`], which ignores `far`) a far
    /// distance that is not finite; [`FoveatedError::InvalidClipPlanes`] for
    /// far ≤ near.
    pub fn off_axis(
        &self,
        eye: DVec3,
        near: f64,
        far: f64,
        depth: DepthConvention,
    ) -> Result<OffAxisProjection, FoveatedError> {
        let near = input::positive("near clip distance (m)", near)?;
        if depth != DepthConvention::ReverseInfinite {
            let far = input::finite("far clip distance (m)", far)?;
            if !(far > near) {
                return Err(FoveatedError::InvalidClipPlanes { near, far });
            }
        }
        let d = self.check_eye(eye)?;
        let (vr, vu, vn) = self.basis();
        let (va, vb, vc) = (
            self.lower_left - eye,
            self.lower_right - eye,
            self.upper_left - eye,
        );
        let k = near / d;
        let (l, r, b, t) = (
            vr.dot(va) * k,
            vr.dot(vb) * k,
            vu.dot(va) * k,
            vu.dot(vc) * k,
        );
        let projection = match depth {
            DepthConvention::ZeroToOne => DMat4::frustum_rh(l, r, b, t, near, far),
            DepthConvention::MinusOneToOne => DMat4::frustum_rh_gl(l, r, b, t, near, far),
            DepthConvention::ReverseInfinite => {
                // x, y as in glFrustum; z_clip = near, w_clip = −z_eye, so
                // depth = near/(−z_eye): 1 at the near plane, → 0 at infinity.
                DMat4::from_cols(
                    DVec4::new(2.0 * near / (r - l), 0.0, 0.0, 0.0),
                    DVec4::new(0.0, 2.0 * near / (t - b), 0.0, 0.0),
                    DVec4::new((r + l) / (r - l), (t + b) / (t - b), 0.0, -1.0),
                    DVec4::new(0.0, 0.0, near, 0.0),
                )
            }
        };
        // Mᵀ (rows v_r, v_u, v_n) then translate the eye to the origin.
        let rot_t = DMat4::from_cols(
            DVec4::new(vr.x, vu.x, vn.x, 0.0),
            DVec4::new(vr.y, vu.y, vn.y, 0.0),
            DVec4::new(vr.z, vu.z, vn.z, 0.0),
            DVec4::W,
        );
        let view = rot_t * DMat4::from_translation(-eye);
        Ok(OffAxisProjection {
            view,
            projection,
            extents: [l, r, b, t],
            distance: d,
        })
    }
}

/// The three walls of the paper's CAVE (§4.1: front, right, floor) for a cube
/// of side `size` (m) with its floor at y = 0 and centred on x = z = 0, in
/// Bevy's axes: the front wall is at z = −size/2 and faces +z (a viewer at the
/// centre looks along −Z at it), the right wall faces −x, the floor +y. All
/// normals point inwards.
///
/// Errors: [`FoveatedError::Input`] for a size that is not positive and finite.
pub fn front_right_floor(size: f64) -> Result<[CaveWall; 3], FoveatedError> {
    let size = input::positive("CAVE side (m)", size)?;
    let h = size / 2.0;
    Ok([
        CaveWall::new(
            DVec3::new(-h, 0.0, -h),
            DVec3::new(h, 0.0, -h),
            DVec3::new(-h, size, -h),
        )?,
        CaveWall::new(
            DVec3::new(h, 0.0, -h),
            DVec3::new(h, 0.0, h),
            DVec3::new(h, size, -h),
        )?,
        CaveWall::new(
            DVec3::new(-h, 0.0, h),
            DVec3::new(h, 0.0, h),
            DVec3::new(-h, 0.0, -h),
        )?,
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::{Expected, InvalidInput};
    use proptest::prelude::*;

    fn assert_corners(w: &CaveWall, eye: DVec3, depth: DepthConvention) {
        let p = w.off_axis(eye, 0.05, 100.0, depth).unwrap();
        let cases = [
            (w.lower_left(), -1.0, -1.0),
            (w.lower_right(), 1.0, -1.0),
            (w.upper_left(), -1.0, 1.0),
            (w.upper_right(), 1.0, 1.0),
        ];
        for (c, x, y) in cases {
            let n = p.to_ndc(c);
            assert!(
                (n.x - x).abs() < 1e-9 && (n.y - y).abs() < 1e-9,
                "{c} → {n}"
            );
            let z_ok = match depth {
                DepthConvention::MinusOneToOne => (-1.0..=1.0).contains(&n.z),
                _ => (0.0..=1.0).contains(&n.z),
            };
            assert!(z_ok, "depth {n}");
        }
        // The wall centre goes to the NDC point of the frustum's centre.
        let m = p.to_ndc(w.point_at(0.5, 0.5));
        assert!(m.x.abs() < 1e-9 && m.y.abs() < 1e-9);
    }

    #[test]
    fn wall_corners_project_to_ndc_corners() {
        let walls = front_right_floor(3.0).unwrap();
        for eye in [
            DVec3::new(0.0, 1.5, 0.0),
            DVec3::new(0.7, 1.2, 0.4),
            DVec3::new(-1.2, 2.5, 1.3),
        ] {
            for w in &walls {
                for depth in [
                    DepthConvention::ZeroToOne,
                    DepthConvention::MinusOneToOne,
                    DepthConvention::ReverseInfinite,
                ] {
                    assert_corners(w, eye, depth);
                }
            }
        }
    }

    #[test]
    fn centred_eye_matches_a_symmetric_perspective() {
        // Eye 1.5 m in front of the centre of a 3 m wall: fov_y = 2·atan(1.5/1.5) = 90°.
        let w = front_right_floor(3.0).unwrap()[0];
        let p = w
            .off_axis(
                DVec3::new(0.0, 1.5, 0.0),
                0.1,
                50.0,
                DepthConvention::ZeroToOne,
            )
            .unwrap();
        let q = DMat4::perspective_rh(std::f64::consts::FRAC_PI_2, 1.0, 0.1, 50.0);
        assert!(p.projection.abs_diff_eq(q, 1e-12));
        assert!((p.distance - 1.5).abs() < 1e-12);
        // The view looks down −z at a front wall at z = −1.5: identity rotation.
        assert!(
            p.view
                .abs_diff_eq(DMat4::from_translation(DVec3::new(0.0, -1.5, 0.0)), 1e-12)
        );
    }

    #[test]
    fn eye_on_or_behind_a_wall_is_an_error() {
        let w = front_right_floor(3.0).unwrap()[0];
        let on = w.off_axis(
            DVec3::new(0.3, 1.0, -1.5),
            0.1,
            10.0,
            DepthConvention::ZeroToOne,
        );
        assert!(
            matches!(on, Err(FoveatedError::EyeNotInFront { distance }) if distance.abs() < 1e-12)
        );
        let behind = w.off_axis(
            DVec3::new(0.0, 1.0, -2.0),
            0.1,
            10.0,
            DepthConvention::ZeroToOne,
        );
        assert!(matches!(behind, Err(FoveatedError::EyeNotInFront { distance }) if distance < 0.0));
        let nan = w.off_axis(
            DVec3::new(f64::NAN, 1.0, 0.0),
            0.1,
            10.0,
            DepthConvention::ZeroToOne,
        );
        assert!(matches!(nan, Err(FoveatedError::Input(e)) if e.what == "eye position (m)"));
        let inside = DVec3::new(0.0, 1.0, 0.0);
        assert_eq!(
            w.off_axis(inside, 0.0, 10.0, DepthConvention::ZeroToOne),
            Err(FoveatedError::Input(InvalidInput::new(
                "near clip distance (m)",
                0.0,
                Expected::Positive
            )))
        );
        assert_eq!(
            w.off_axis(inside, 0.1, f64::INFINITY, DepthConvention::MinusOneToOne),
            Err(FoveatedError::Input(InvalidInput::new(
                "far clip distance (m)",
                f64::INFINITY,
                Expected::Finite
            )))
        );
        assert_eq!(
            w.off_axis(inside, 0.1, 0.1, DepthConvention::ZeroToOne),
            Err(FoveatedError::InvalidClipPlanes {
                near: 0.1,
                far: 0.1
            })
        );
        assert!(
            w.off_axis(
                DVec3::new(0.0, 1.0, 0.0),
                0.1,
                f64::INFINITY,
                DepthConvention::ReverseInfinite
            )
            .is_ok()
        );
    }

    #[test]
    fn degenerate_walls_are_rejected() {
        assert_eq!(
            CaveWall::new(DVec3::ZERO, DVec3::ZERO, DVec3::Y),
            Err(FoveatedError::DegenerateWall("zero-length edge"))
        );
        assert_eq!(
            CaveWall::new(DVec3::ZERO, DVec3::X, DVec3::new(0.1, 1.0, 0.0)),
            Err(FoveatedError::DegenerateWall("edges are not perpendicular"))
        );
        let nan = CaveWall::new(DVec3::ZERO, DVec3::X, DVec3::NAN).unwrap_err();
        assert!(
            matches!(nan, FoveatedError::Input(e) if e.what == "CAVE wall corner (m)" && e.value.is_nan())
        );
        assert_eq!(
            front_right_floor(-1.0).unwrap_err(),
            FoveatedError::Input(InvalidInput::new("CAVE side (m)", -1.0, Expected::Positive))
        );
    }

    #[test]
    fn ray_through_checks_the_eye_and_the_fractions() {
        let w = front_right_floor(3.0).unwrap()[0];
        let eye = DVec3::new(0.2, 1.4, 0.3);
        // Through the wall's centre: the direction points at (0, 1.5, −1.5).
        let r = w.ray_through(eye, 0.5, 0.5).unwrap();
        let want = (DVec3::new(0.0, 1.5, -1.5) - eye).normalize();
        assert!((r.dir() - want).length() < 1e-15 && r.origin() == eye);
        assert!(matches!(
            w.ray_through(DVec3::new(0.0, 1.0, -2.0), 0.5, 0.5),
            Err(FoveatedError::EyeNotInFront { .. })
        ));
        assert_eq!(
            w.ray_through(eye, f64::INFINITY, 0.5).unwrap_err(),
            FoveatedError::Input(InvalidInput::new(
                "wall fraction s",
                f64::INFINITY,
                Expected::Finite
            ))
        );
        assert!(
            matches!(w.ray_through(eye, 0.5, f64::NAN), Err(FoveatedError::Input(e)) if e.what == "wall fraction t")
        );
    }

    proptest! {
        /// Any eye inside the CAVE cube sees every wall's corners at the NDC corners.
        #[test]
        fn corners_for_any_eye_inside(x in -1.49f64..1.49, y in 0.01f64..2.99, z in -1.49f64..1.49) {
            let eye = DVec3::new(x, y, z);
            for w in &front_right_floor(3.0).unwrap() {
                let p = w.off_axis(eye, 0.01, 100.0, DepthConvention::ZeroToOne).unwrap();
                for (c, ex, ey) in [(w.lower_left(), -1.0, -1.0), (w.upper_right(), 1.0, 1.0)] {
                    let n = p.to_ndc(c);
                    prop_assert!((n.x - ex).abs() < 1e-7 && (n.y - ey).abs() < 1e-7);
                }
            }
        }
    }
}
