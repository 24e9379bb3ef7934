//! Refraction into and out of one sphere lens (thesis §6.5, eq. 6.28), and
//! the ball lens's focal length.
//!
//! Written as the shader will be: no loops, no allocation, the chord length
//! in closed form instead of a second intersection.

use glam::DVec3;

use crate::surface::{Refraction, refract};

/// Effective focal length of a ball lens of radius `r` and relative index
/// `n`, measured from its centre (both principal planes pass through it):
/// `f = n·r / (2(n−1))` (REFERENCE.md; e.g. Hecht, *Optics*, thick lens with
/// `R1 = r`, `R2 = −r`, `d = 2r`). Infinite for `n = 1`, negative (virtual)
/// for `n < 1`.
pub fn ball_focal_length(radius: f64, index: f64) -> f64 {
    index * radius / (2.0 * (index - 1.0))
}

/// A ray after passing through a ball lens.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallExit {
    /// Entry point `D` on the sphere.
    pub entry: DVec3,
    /// Exit point on the sphere.
    pub exit: DVec3,
    /// Unit direction after the exit refraction.
    pub dir: DVec3,
}

/// Where a ball lens reflected the ray totally instead of refracting it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BallTir {
    /// At the entry surface (possible only for `n < 1`).
    AtEntry,
    /// At the exit surface (impossible for a sphere in exact arithmetic,
    /// since the exit angle equals the refracted entry angle; kept for round-off).
    AtExit,
}

/// Refracts the unit direction `dir` arriving at `entry` (a point on the
/// sphere `centre`, `radius`; re-projected onto it) into the sphere of
/// relative index `index`, across the chord and out again.
///
/// Eq. 6.28: `N_D = (D − C)/‖D − C‖` at the entry, the same form at the exit;
/// Snell by [`crate::surface::refract`]. The chord from a point on the sphere
/// along the inward direction `t` is `−2 (D − C)·t`.
pub fn refract_through_ball(entry: DVec3, dir: DVec3, centre: DVec3, radius: f64, index: f64) -> Result<BallExit, BallTir> {
    let n_d = (entry - centre).normalize_or_zero(); // (6.28)
    let d = centre + radius * n_d;
    let inside = match refract(dir, n_d, 1.0, index) {
        Refraction::Transmitted(t) => t,
        Refraction::TotalInternalReflection => return Err(BallTir::AtEntry),
    };
    let chord = (-2.0 * radius * n_d.dot(inside)).max(0.0);
    let exit = d + chord * inside;
    let n_x = (exit - centre).normalize_or_zero(); // (6.28) at the exit
    match refract(inside, n_x, index, 1.0) {
        Refraction::Transmitted(out) => Ok(BallExit { entry: d, exit, dir: out }),
        Refraction::TotalInternalReflection => Err(BallTir::AtExit),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ray::Ray;
    use crate::surface::intersect_sphere;

    /// Distance from the centre at which a paraxial ray at height `h`,
    /// parallel to the axis, crosses the axis after the ball.
    fn axis_crossing(r: f64, n: f64, h: f64) -> f64 {
        let ray = Ray::new(DVec3::new(h, 0.0, 10.0 * r), -DVec3::Z).unwrap();
        let hits = intersect_sphere(&ray, DVec3::ZERO, r).unwrap();
        let out = refract_through_ball(ray.at(hits.t_near), ray.dir(), DVec3::ZERO, r, n).unwrap();
        // x(t) = exit.x + t·dir.x = 0.
        let t = -out.exit.x / out.dir.x;
        -(out.exit.z + t * out.dir.z)
    }

    #[test]
    fn paraxial_focus_matches_n_r_over_2_n_minus_1() {
        // f = n r / (2(n−1)) (REFERENCE.md): n = 1.5 → 1.5 r; n = 2 → r (the back surface).
        assert_eq!(ball_focal_length(1.0, 1.5), 1.5);
        assert_eq!(ball_focal_length(1.0, 2.0), 1.0);
        for (r, n) in [(1.0, 1.5), (0.5, 1.33), (2.0, 1.8), (0.008, 2.0)] {
            let f = ball_focal_length(r, n);
            let got = axis_crossing(r, n, 1e-4 * r);
            assert!(((got - f) / f).abs() < 1e-6, "r {r} n {n}: traced {got}, formula {f}");
            // Spherical aberration: marginal rays focus shorter (monotone in height).
            assert!(axis_crossing(r, n, 0.5 * r) < got);
        }
    }

    #[test]
    fn ray_through_centre_is_undeviated_and_n_1_is_identity() {
        let dir = DVec3::new(0.3, -0.2, -0.9).normalize();
        let entry = -dir; // unit sphere at the origin, ray through its centre
        let out = refract_through_ball(entry, dir, DVec3::ZERO, 1.0, 1.6).unwrap();
        assert!((out.dir - dir).length() < 1e-15);
        assert!((out.exit - dir).length() < 1e-15);
        let entry = DVec3::new(0.6, 0.0, 0.8);
        let dir = DVec3::new(0.0, 0.1, -1.0).normalize();
        let out = refract_through_ball(entry, dir, DVec3::ZERO, 1.0, 1.0).unwrap();
        assert!((out.dir - dir).length() < 1e-15);
    }

    #[test]
    fn low_index_ball_reflects_grazing_rays() {
        // n = 0.7: critical angle asin(0.7) = 44.4°; 60° incidence is reflected.
        let normal = DVec3::new(0.0, 0.0, 1.0);
        let dir = DVec3::new(60f64.to_radians().sin(), 0.0, -60f64.to_radians().cos());
        assert_eq!(refract_through_ball(normal, dir, DVec3::ZERO, 1.0, 0.7), Err(BallTir::AtEntry));
    }
}
