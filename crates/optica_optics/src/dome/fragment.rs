//! D11: exact attributes inside a refined triangle, per fragment (ours).
//!
//! Refinement places a triangle's *edges* within the tolerance, but the
//! rasteriser fills the inside by interpolating the vertices' attributes
//! across the triangle's image (perspective-correct with w = |p|), which
//! no choice of w makes exact under a fisheye: texture inside a refined
//! triangle lands up to a few pixels from where the lens puts it.
//!
//! Each fragment can recover its exact attributes from what it already has.
//! Its interpolated position `p` is a weighted mean of the triangle's
//! corners, so it lies in the triangle's plane — only at the wrong place in
//! it. Its screen differences `∂p/∂x`, `∂p/∂y` (the rasteriser's quad
//! differences) lie in the plane too. The pixel's own ray (the lens's
//! inverse) meets that plane at the true point
//!
//! `t = ((p − o)·n)/(d·n)`, `p* = o + t·d`, `n = ∂p/∂x × ∂p/∂y`,
//!
//! and `p* − p = a·∂p/∂x + b·∂p/∂y` (least squares on the 2 × 2 Gram
//! matrix, exact since both sides lie in the plane). Every attribute a
//! that the refinement mixed by barycentric weights is an affine function
//! of the position on the triangle, and is interpolated with the same
//! weights as `p`, so `a* = a + a·∂a/∂x + b·∂a/∂y` exactly: texture
//! coordinates, normals, colours. Refinement then only has to place edges.
//!
//! The WGSL twin is `plane_step` in the dome crate's `projection.wgsl`,
//! applied to Bevy's fragment input by the plugin's shader patch.

use glam::{DVec2, DVec3};

/// The largest step, in pixels along either screen axis, that a fragment
/// takes. Refined triangles are within a few pixels of their true image;
/// a larger step means the quad's differences are nearly parallel (a
/// triangle seen edge-on), where the plane is not known well enough to
/// move along it, and the fragment keeps its interpolated attributes.
pub const MAX_STEP_PX: f64 = 64.0;

/// Below this |sin| of the angle between the ray and the plane, or between
/// the two screen differences, the step is not taken.
const GRAZING_SIN: f64 = 1.0e-4;

/// The step `(a, b)` that moves a fragment's interpolated position `p`
/// along its screen differences `dp_dx`, `dp_dy` to where the ray from
/// `origin` along `ray` meets their plane (D11): `p + a·dp_dx + b·dp_dy`
/// is on the ray. Any attribute interpolated with `p` moves by the same
/// step along its own differences.
///
/// `None` — keep the interpolated attributes — when the input is not
/// finite, the differences are (nearly) parallel, the ray grazes the
/// plane or meets it behind the origin, or the step is longer than
/// [`MAX_STEP_PX`].
pub fn plane_step(
    origin: DVec3,
    ray: DVec3,
    p: DVec3,
    dp_dx: DVec3,
    dp_dy: DVec3,
) -> Option<DVec2> {
    // As the shader does it (no square roots): the conditions on squares.
    let n = dp_dx.cross(dp_dy);
    let nn = n.length_squared();
    let (xx, xy, yy) = (dp_dx.dot(dp_dx), dp_dx.dot(dp_dy), dp_dy.dot(dp_dy));
    let eps2 = GRAZING_SIN * GRAZING_SIN;
    let across = ray.dot(n);
    if !(nn > eps2 * xx * yy && across * across > eps2 * nn * ray.length_squared()) {
        return None;
    }
    let to_p = p - origin;
    let t = to_p.dot(n) / across;
    if !(t > 0.0) {
        return None;
    }
    let delta = t * ray - to_p;
    let (rx, ry) = (delta.dot(dp_dx), delta.dot(dp_dy));
    // The Gram determinant xx·yy − xy² is |n|² (Lagrange's identity).
    let step = DVec2::new(yy * rx - xy * ry, xx * ry - xy * rx) / nn;
    (step.is_finite() && step.abs().max_element() <= MAX_STEP_PX).then_some(step)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dome::DomeProjection;
    use proptest::prelude::*;

    /// What the rasteriser hands a fragment at `pixel` of the triangle
    /// `corners` (view space) carrying `values`: the position and value
    /// interpolated perspective-correctly with w = |p| (the dome's clip
    /// w) between the corners' projected pixels.
    fn rasterised(
        dome: &DomeProjection,
        corners: [DVec3; 3],
        values: [DVec2; 3],
        pixel: DVec2,
    ) -> Option<(DVec3, DVec2)> {
        let s = corners.map(|c| dome.pixel_of_direction(c));
        let [Some(s0), Some(s1), Some(s2)] = s else {
            return None;
        };
        let area = (s1 - s0).perp_dot(s2 - s0);
        let l1 = (pixel - s0).perp_dot(s2 - s0) / area;
        let l2 = (s1 - s0).perp_dot(pixel - s0) / area;
        let screen = [1.0 - l1 - l2, l1, l2];
        let over_w: [f64; 3] = std::array::from_fn(|i| screen[i] / corners[i].length());
        let sum: f64 = over_w.iter().sum();
        let mu = over_w.map(|v| v / sum);
        let p = mu[0] * corners[0] + mu[1] * corners[1] + mu[2] * corners[2];
        let v = mu[0] * values[0] + mu[1] * values[1] + mu[2] * values[2];
        Some((p, v))
    }

    /// The value at the point where the pixel's ray meets the triangle's
    /// plane (barycentric weights of that point in 3D).
    fn exact(
        dome: &DomeProjection,
        corners: [DVec3; 3],
        values: [DVec2; 3],
        pixel: DVec2,
    ) -> DVec2 {
        let d = dome.unproject(pixel).expect("inside the image");
        let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
        let q = d * (corners[0].dot(n) / d.dot(n));
        let w1 = (q - corners[0]).cross(corners[2] - corners[0]).dot(n) / n.length_squared();
        let w2 = (corners[1] - corners[0]).cross(q - corners[0]).dot(n) / n.length_squared();
        (1.0 - w1 - w2) * values[0] + w1 * values[1] + w2 * values[2]
    }

    /// Interpolated and corrected values' largest error, in units of the
    /// values, over the pixels of a grid inside the triangle's image.
    fn errors(dome: &DomeProjection, corners: [DVec3; 3], values: [DVec2; 3]) -> (f64, f64, usize) {
        let s = corners.map(|c| dome.pixel_of_direction(c).expect("visible"));
        let (lo, hi) = (s[0].min(s[1]).min(s[2]), s[0].max(s[1]).max(s[2]));
        let (mut interpolated, mut corrected, mut n) = (0.0f64, 0.0f64, 0);
        let mut y = lo.y.floor() + 0.5;
        while y < hi.y {
            let mut x = lo.x.floor() + 0.5;
            while x < hi.x {
                let pixel = DVec2::new(x, y);
                // The pixel and its right and lower neighbours, as a quad
                // of the rasteriser would take its differences.
                let here = rasterised(dome, corners, values, pixel);
                let right = rasterised(dome, corners, values, pixel + DVec2::X);
                let below = rasterised(dome, corners, values, pixel + DVec2::Y);
                let inside = {
                    let area = (s[1] - s[0]).perp_dot(s[2] - s[0]);
                    let l1 = (pixel - s[0]).perp_dot(s[2] - s[0]) / area;
                    let l2 = (s[1] - s[0]).perp_dot(pixel - s[0]) / area;
                    l1 >= 0.0 && l2 >= 0.0 && l1 + l2 <= 1.0
                };
                if let (true, Some((p, v)), Some((px, vx)), Some((py, vy))) =
                    (inside, here, right, below)
                {
                    let truth = exact(dome, corners, values, pixel);
                    let ray = dome.unproject(pixel).expect("inside");
                    let step = plane_step(DVec3::ZERO, ray, p, px - p, py - p)
                        .expect("a step for a triangle facing the camera");
                    let fixed = v + step.x * (vx - v) + step.y * (vy - v);
                    interpolated = interpolated.max((v - truth).length());
                    corrected = corrected.max((fixed - truth).length());
                    n += 1;
                }
                x += 1.0;
            }
            y += 1.0;
        }
        (interpolated, corrected, n)
    }

    #[test]
    fn a_large_triangle_near_the_rim_gets_exact_texture_coordinates() {
        // A 60° triangle low on a 512-px, 180° dome: its interpolated
        // texture coordinates are off by several texels of a 256² texture.
        let dome = crate::dome::test_dome(180.0, 0.0, 512);
        let corners = [
            DVec3::new(-2.0, -3.0, -0.8),
            DVec3::new(2.0, -3.0, -0.8),
            DVec3::new(0.0, -2.0, -3.0),
        ];
        let values = [DVec2::ZERO, DVec2::X, DVec2::Y];
        let (interpolated, corrected, n) = errors(&dome, corners, values);
        assert!(n > 1000, "{n} pixels");
        assert!(interpolated > 0.02, "interpolated error {interpolated}");
        assert!(corrected < 1.0e-9, "corrected error {corrected}");
    }

    #[test]
    fn edge_on_and_behind_keep_the_interpolated_values() {
        let (o, p) = (DVec3::ZERO, DVec3::new(0.0, 0.0, -2.0));
        // Parallel differences: no plane.
        assert_eq!(plane_step(o, -DVec3::Z, p, DVec3::X, 2.0 * DVec3::X), None);
        // A ray along the plane.
        assert_eq!(plane_step(o, DVec3::X, p, DVec3::X, DVec3::Y), None);
        // A plane met behind the origin.
        assert_eq!(plane_step(o, DVec3::Z, p, DVec3::X, DVec3::Y), None);
        // Not finite.
        assert_eq!(plane_step(o, -DVec3::Z, p, DVec3::NAN, DVec3::Y), None);
        // A step longer than the cap.
        let far = DVec3::new(0.1, 0.0, -1.0);
        assert_eq!(
            plane_step(o, far, p, 1.0e-4 * DVec3::X, 1.0e-4 * DVec3::Y),
            None
        );
        // The ray through p itself: no step.
        let still = plane_step(o, p, p, DVec3::X, DVec3::Y).expect("a step");
        assert!(still.length() < 1e-12, "{still}");
    }

    proptest! {
        #[test]
        fn any_visible_triangle_facing_the_camera_is_exact_inside(
            fov in 120.0f64..220.0,
            tilt in -30.0f64..30.0,
            polar in prop::array::uniform3(0.0f64..60.0),
            azimuth in prop::array::uniform3(0.0f64..360.0),
            distance in prop::array::uniform3(0.5f64..5.0),
        ) {
            let dome = crate::dome::test_dome(fov, tilt, 96);
            // Corners within 60° of the dome's axis, in view space.
            let corners: [DVec3; 3] = std::array::from_fn(|i| {
                let (t, f) = (polar[i].to_radians(), azimuth[i].to_radians());
                let q = DVec3::new(t.sin() * f.cos(), t.sin() * f.sin(), t.cos());
                distance[i] * dome.from_dome(q)
            });
            let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]);
            // Not edge-on to the viewer, and covering some pixels.
            prop_assume!(n.dot(corners[0]).abs() > 0.3 * n.length() * corners[0].length());
            let s = corners.map(|c| dome.pixel_of_direction(c).expect("visible"));
            prop_assume!((s[1] - s[0]).perp_dot(s[2] - s[0]).abs() > 20.0);
            let values = [DVec2::ZERO, DVec2::X, DVec2::Y];
            let (_, corrected, _) = errors(&dome, corners, values);
            prop_assert!(corrected < 1.0e-7, "corrected error {}", corrected);
        }
    }
}
