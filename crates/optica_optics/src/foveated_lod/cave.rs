//! CAVE walls and the off-axis ("generalised perspective") projection from a
//! tracked eye (Kooima, *Generalized Perspective Projection*, 2008).
//!
//! The paper renders on a CAVE of front, right and floor screens (§4.1). Each
//! wall is a fixed rectangle in the world; the eye moves, so each wall needs
//! its own asymmetric frustum whose edges pass through the wall's corners.
//! With the wall's unit axes v_r (right), v_u (up) and v_n = v_r × v_u (normal,
//! towards the viewer), corners p_a (lower left), p_b (lower right), p_c (upper
//! left) and eye p_e:
//!
//! * d = −(p_a − p_e)·v_n is the eye–wall distance; the eye must be in front,
//!   d > 0 (on the plane the frustum is infinite, behind it mirrored);
//! * l = v_r·(p_a − p_e)·n/d, r = v_r·(p_b − p_e)·n/d,
//!   b = v_u·(p_a − p_e)·n/d, t = v_u·(p_c − p_e)·n/d;
//! * projection = frustum(l, r, b, t, n, f), view = Mᵀ·T(−p_e) with M = [v_r v_u v_n].
//!
//! The wall's corners then project exactly to the NDC corners (tested).

use glam::{DMat4, DVec3, DVec4};
use serde::{Deserialize, Serialize};

use super::error::FoveatedError;
use crate::ray::Ray;

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

/// A rectangular CAVE wall, seen from its front (the side its normal points to).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
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
    /// A wall from three corners. Errors: non-finite corners, a zero edge, or
    /// edges that are not perpendicular (to 1e-9 relative): the corners must
    /// form a rectangle.
    pub fn new(lower_left: DVec3, lower_right: DVec3, upper_left: DVec3) -> Result<Self, FoveatedError> {
        if !(lower_left.is_finite() && lower_right.is_finite() && upper_left.is_finite()) {
            return Err(FoveatedError::NonFinite("wall corner"));
        }
        let (e_r, e_u) = (lower_right - lower_left, upper_left - lower_left);
        let (lr, lu) = (e_r.length(), e_u.length());
        if !(lr > 0.0 && lu > 0.0) {
            return Err(FoveatedError::DegenerateWall("zero-length edge"));
        }
        if (e_r.dot(e_u) / (lr * lu)).abs() > 1e-9 {
            return Err(FoveatedError::DegenerateWall("edges are not perpendicular"));
        }
        Ok(Self {
            lower_left,
            lower_right,
            upper_left,
        })
    }

    /// Lower-left corner p_a.
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
        self.lower_left + (self.lower_right - self.lower_left) * s + (self.upper_left - self.lower_left) * t
    }

    /// Checks that the eye is finite and in front of the wall by more than
    /// 1e-9 of the wall's size (the frustum divides by the distance).
    pub fn check_eye(&self, eye: DVec3) -> Result<f64, FoveatedError> {
        if !eye.is_finite() {
            return Err(FoveatedError::NonFinite("eye position"));
        }
        let d = self.signed_distance(eye);
        let size = (self.lower_right - self.lower_left).length() + (self.upper_left - self.lower_left).length();
        if d.is_nan() || d <= 1e-9 * size {
            return Err(FoveatedError::EyeNotInFront { distance: d });
        }
        Ok(d)
    }

    /// The primary ray from `eye` through the wall point (s, t); `None` when
    /// the eye is not finite or on the wall point. The eye is not checked
    /// against the wall here; [`CaveWall::check_eye`] once per frame.
    pub fn ray_through(&self, eye: DVec3, s: f64, t: f64) -> Option<Ray> {
        Ray::new(eye, self.point_at(s, t) - eye).ok()
    }

    /// The off-axis view and projection of this wall from `eye` (module docs).
    pub fn off_axis(
        &self,
        eye: DVec3,
        near: f64,
        far: f64,
        depth: DepthConvention,
    ) -> Result<OffAxisProjection, FoveatedError> {
        let far_ok = depth == DepthConvention::ReverseInfinite || (far > near && far.is_finite());
        if !(near > 0.0 && near.is_finite() && far_ok) {
            return Err(FoveatedError::InvalidClipPlanes { near, far });
        }
        let d = self.check_eye(eye)?;
        let (vr, vu, vn) = self.basis();
        let (va, vb, vc) = (self.lower_left - eye, self.lower_right - eye, self.upper_left - eye);
        let k = near / d;
        let (l, r, b, t) = (vr.dot(va) * k, vr.dot(vb) * k, vu.dot(va) * k, vu.dot(vc) * k);
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
/// of side `size` with its floor at y = 0 and centred on x = z = 0; the front
/// wall faces +z, the right wall −x, the floor +y. All normals point inwards.
pub fn front_right_floor(size: f64) -> Result<[CaveWall; 3], FoveatedError> {
    if !(size > 0.0 && size.is_finite()) {
        return Err(FoveatedError::InvalidParameter(format!("CAVE size {size} must be > 0")));
    }
    let h = size / 2.0;
    Ok([
        CaveWall::new(
            DVec3::new(-h, 0.0, -h),
            DVec3::new(h, 0.0, -h),
            DVec3::new(-h, size, -h),
        )?,
        CaveWall::new(DVec3::new(h, 0.0, -h), DVec3::new(h, 0.0, h), DVec3::new(h, size, -h))?,
        CaveWall::new(DVec3::new(-h, 0.0, h), DVec3::new(h, 0.0, h), DVec3::new(-h, 0.0, -h))?,
    ])
}

#[cfg(test)]
mod tests {
    use super::*;
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
            assert!((n.x - x).abs() < 1e-9 && (n.y - y).abs() < 1e-9, "{c} → {n}");
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
            .off_axis(DVec3::new(0.0, 1.5, 0.0), 0.1, 50.0, DepthConvention::ZeroToOne)
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
        let on = w.off_axis(DVec3::new(0.3, 1.0, -1.5), 0.1, 10.0, DepthConvention::ZeroToOne);
        assert!(matches!(on, Err(FoveatedError::EyeNotInFront { distance }) if distance.abs() < 1e-12));
        let behind = w.off_axis(DVec3::new(0.0, 1.0, -2.0), 0.1, 10.0, DepthConvention::ZeroToOne);
        assert!(matches!(behind, Err(FoveatedError::EyeNotInFront { distance }) if distance < 0.0));
        let nan = w.off_axis(DVec3::new(f64::NAN, 1.0, 0.0), 0.1, 10.0, DepthConvention::ZeroToOne);
        assert!(matches!(nan, Err(FoveatedError::NonFinite(_))));
        assert!(matches!(
            w.off_axis(DVec3::new(0.0, 1.0, 0.0), 0.0, 10.0, DepthConvention::ZeroToOne),
            Err(FoveatedError::InvalidClipPlanes { .. })
        ));
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
        assert!(CaveWall::new(DVec3::ZERO, DVec3::ZERO, DVec3::Y).is_err());
        assert!(CaveWall::new(DVec3::ZERO, DVec3::X, DVec3::new(0.1, 1.0, 0.0)).is_err());
        assert!(CaveWall::new(DVec3::ZERO, DVec3::X, DVec3::NAN).is_err());
        assert!(front_right_floor(-1.0).is_err());
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
