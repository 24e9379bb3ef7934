//! Refraction into and out of one sphere lens (thesis §6.5, eq. 6.28), and
//! the ball lens's focal length.
//!
//! Written as the shader will be: no loops, no allocation, the chord length
//! in closed form instead of a second intersection.

use glam::DVec3;

use super::lattice::LensParams;
use crate::fresnel::fresnel_unpolarized;
use crate::ray::Ray;
use crate::surface::{Refraction, refract};

/// Effective focal length of a ball lens of radius `r` and relative index
/// `n`, measured from its centre: `f = n·r / (2(n−1))`.
///
/// Derivation: the thick-lens equation (e.g. E. Hecht, *Optics*, 5th ed.,
/// Pearson 2017, §6.1) `1/f = (n−1)[1/R₁ − 1/R₂ + (n−1)t/(n·R₁R₂)]` with
/// `R₁ = r`, `R₂ = −r` and thickness `t = 2r` gives
/// `1/f = (n−1)(2/r)(1 − (n−1)/n) = 2(n−1)/(n·r)`; by symmetry both principal
/// planes pass through the centre, so `f` is measured from there. Infinite
/// for `n = 1`, negative (virtual) for `n < 1`. With `n = 1.5` the focus
/// lies `1.5r` beyond the centre, `2.5r` below the polygon the lens touches.
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
    /// The unpolarised power transmitted by both surfaces,
    /// `(1 − R_entry)(1 − R_exit)` (Fresnel, cos form,
    /// [`crate::fresnel::fresnel_unpolarized`]): what is left for the
    /// pigment when the lens's reflections are counted.
    pub transmittance: f64,
}

impl BallExit {
    /// The ray leaving the lens: from [`BallExit::exit`] along [`BallExit::dir`]
    /// (finite and unit when [`refract_through_ball`] made it).
    pub(crate) fn ray(&self) -> Ray {
        Ray::from_unit(self.exit, self.dir)
    }
}

/// Why a ray has no exit from a ball lens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BallFailure {
    /// Total internal reflection at the entry surface (possible only for `n < 1`).
    ReflectedAtEntry,
    /// Total internal reflection at the exit surface (impossible for a sphere
    /// in exact arithmetic, since the exit angle equals the refracted entry
    /// angle; kept for round-off).
    ReflectedAtExit,
    /// The lens centre is not finite, or the entry lies so far from it
    /// (~1e300) that the geometry overflows `f64`.
    Overflow,
}

/// Refracts `incoming` (its origin is the entry point, re-projected onto the
/// sphere of radius `lens.radius()` around `centre`) into the sphere of
/// relative index `lens.index()`, across the chord and out again.
///
/// Eq. 6.28: `N_D = (D − C)/‖D − C‖` at the entry, the same form at the exit;
/// Snell by [`crate::surface::refract`]. The chord from a point on the sphere
/// along the inward direction `t` is `−2 (D − C)·t`. An entry point *at* the
/// centre has no normal; it is taken as the ray through the centre, which
/// passes undeviated.
pub fn refract_through_ball(
    incoming: &Ray,
    centre: DVec3,
    lens: &LensParams,
) -> Result<BallExit, BallFailure> {
    let (radius, index, dir) = (lens.radius(), lens.index(), incoming.dir());
    let offset = incoming.origin() - centre;
    if !offset.is_finite() {
        return Err(BallFailure::Overflow);
    }
    let n_d = offset.try_normalize().unwrap_or(-dir); // (6.28)
    let d = centre + radius * n_d;
    let inside = match refract(dir, n_d, 1.0, index) {
        Refraction::Transmitted(t) => t,
        Refraction::TotalInternalReflection => return Err(BallFailure::ReflectedAtEntry),
    };
    let chord = (-2.0 * radius * n_d.dot(inside)).max(0.0);
    let exit = d + chord * inside;
    let n_x = (exit - centre).try_normalize().unwrap_or(inside); // (6.28) at the exit
    match refract(inside, n_x, index, 1.0) {
        Refraction::Transmitted(out) if d.is_finite() && exit.is_finite() && out.is_finite() => {
            let r_in = fresnel_unpolarized(dir.dot(n_d), 1.0, index);
            let r_out = fresnel_unpolarized(inside.dot(n_x), index, 1.0);
            Ok(BallExit {
                entry: d,
                exit,
                dir: out,
                transmittance: (1.0 - r_in) * (1.0 - r_out),
            })
        }
        Refraction::Transmitted(_) => Err(BallFailure::Overflow),
        Refraction::TotalInternalReflection => Err(BallFailure::ReflectedAtExit),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::surface::intersect_sphere;

    fn lens(r: f64, n: f64) -> LensParams {
        LensParams::thesis(r, n).unwrap()
    }

    /// Distance from the centre at which a paraxial ray at height `h`,
    /// parallel to the axis, crosses the axis after the ball.
    fn axis_crossing(r: f64, n: f64, h: f64) -> f64 {
        let ray = Ray::new(DVec3::new(h, 0.0, 10.0 * r), -DVec3::Z).unwrap();
        let hits = intersect_sphere(&ray, DVec3::ZERO, r).unwrap();
        let entry = Ray::new(ray.at(hits.t_near), ray.dir()).unwrap();
        let out = refract_through_ball(&entry, DVec3::ZERO, &lens(r, n)).unwrap();
        // x(t) = exit.x + t·dir.x = 0.
        let t = -out.exit.x / out.dir.x;
        -(out.exit.z + t * out.dir.z)
    }

    #[test]
    fn paraxial_focus_matches_n_r_over_2_n_minus_1() {
        // f = n r / (2(n−1)): n = 1.5 → 1.5 r; n = 2 → r (the back surface).
        assert_eq!(ball_focal_length(1.0, 1.5), 1.5);
        assert_eq!(ball_focal_length(1.0, 2.0), 1.0);
        for (r, n) in [(1.0, 1.5), (0.5, 1.33), (2.0, 1.8), (0.008, 2.0)] {
            let f = ball_focal_length(r, n);
            let got = axis_crossing(r, n, 1e-4 * r);
            assert!(
                ((got - f) / f).abs() < 1e-6,
                "r {r} n {n}: traced {got}, formula {f}"
            );
            // Spherical aberration: marginal rays focus shorter (monotone in height).
            assert!(axis_crossing(r, n, 0.5 * r) < got);
        }
    }

    #[test]
    fn ray_through_centre_is_undeviated_and_n_1_is_identity() {
        let dir = DVec3::new(0.3, -0.2, -0.9).normalize();
        // Unit sphere at the origin, ray through its centre.
        let out = refract_through_ball(&Ray::new(-dir, dir).unwrap(), DVec3::ZERO, &lens(1.0, 1.6))
            .unwrap();
        assert!((out.dir - dir).length() < 1e-15);
        assert!((out.exit - dir).length() < 1e-15);
        assert_eq!(out.ray().origin(), out.exit);
        // An entry at the centre is the ray through the centre.
        let at_centre = refract_through_ball(
            &Ray::new(DVec3::ZERO, dir).unwrap(),
            DVec3::ZERO,
            &lens(1.0, 1.6),
        )
        .unwrap();
        assert!((at_centre.entry + dir).length() < 1e-15 && (at_centre.dir - dir).length() < 1e-15);
        let entry = Ray::new(DVec3::new(0.6, 0.0, 0.8), DVec3::new(0.0, 0.1, -1.0)).unwrap();
        let out = refract_through_ball(&entry, DVec3::ZERO, &lens(1.0, 1.0)).unwrap();
        assert!((out.dir - entry.dir()).length() < 1e-15);
    }

    #[test]
    fn low_index_ball_reflects_grazing_rays() {
        // n = 0.7: critical angle asin(0.7) = 44.4°; 60° incidence is reflected.
        let dir = DVec3::new(60f64.to_radians().sin(), 0.0, -60f64.to_radians().cos());
        let apex = Ray::new(DVec3::Z, dir).unwrap();
        assert_eq!(
            refract_through_ball(&apex, DVec3::ZERO, &lens(1.0, 0.7)),
            Err(BallFailure::ReflectedAtEntry)
        );
    }

    #[test]
    fn a_centre_out_of_range_is_overflow_not_nan() {
        let apex = Ray::new(DVec3::Z, -DVec3::Z).unwrap();
        let high = Ray::new(DVec3::new(0.0, 0.0, 1e308), -DVec3::Z).unwrap();
        for (ray, centre) in [
            (apex, DVec3::new(f64::NAN, 0.0, 0.0)),
            (high, DVec3::new(0.0, 0.0, -1e308)),
        ] {
            assert_eq!(
                refract_through_ball(&ray, centre, &lens(1.0, 1.5)),
                Err(BallFailure::Overflow)
            );
        }
    }
}
