//! Rays: an origin and a unit direction, in `f64`.
//!
//! Every tracer in the crate (lens systems, spectacles, voxel traversal) shares
//! this one type so that hits and distances mean the same thing everywhere:
//! because the direction is unit, the parameter `t` of [`Ray::at`] is a
//! distance. The fields are private and [`Ray::new`] is the only public
//! constructor, so a `Ray` is always traceable and no tracer re-checks it.

use glam::DVec3;
use serde::Serialize;

use crate::input::{self, InvalidInput};

/// A ray `origin + t * dir` with a finite origin and a unit `dir`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Ray {
    origin: DVec3,
    dir: DVec3,
}

impl Ray {
    /// A ray from `origin` along `dir`, which is normalised: any finite,
    /// non-zero length is accepted. A non-finite origin, or a direction that
    /// is zero or not finite, is an [`InvalidInput`].
    pub fn new(origin: DVec3, dir: DVec3) -> Result<Self, InvalidInput> {
        let origin = input::finite_vec3("ray origin", origin)?;
        let dir = input::direction("ray direction", dir)?;
        Ok(Self { origin, dir })
    }

    /// A ray whose direction the crate's own code has just made unit
    /// (normalised, refracted or reflected a unit vector): no check in
    /// release builds, where the tracers' inner loops build millions.
    #[inline]
    pub(crate) fn from_unit(origin: DVec3, dir: DVec3) -> Self {
        debug_assert!(origin.is_finite(), "ray origin {origin} is not finite");
        debug_assert!(
            (dir.length_squared() - 1.0).abs() < 1e-9,
            "ray direction {dir} is not unit"
        );
        Self { origin, dir }
    }

    /// Where the ray starts.
    #[inline]
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// The unit direction of travel.
    #[inline]
    pub fn dir(&self) -> DVec3 {
        self.dir
    }

    /// The point at distance `t` along the ray.
    #[inline]
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::Expected;
    use proptest::prelude::*;

    #[test]
    fn ray_new_normalises_and_at_measures_distance() {
        let r = Ray::new(DVec3::new(1.0, 2.0, 3.0), DVec3::new(0.0, 3.0, 4.0)).unwrap();
        // 3-4-5 triangle: the unit direction is (0, 0.6, 0.8).
        assert!((r.dir() - DVec3::new(0.0, 0.6, 0.8)).length() < 1e-15);
        assert!((r.at(5.0) - DVec3::new(1.0, 5.0, 7.0)).length() < 1e-14);
    }

    #[test]
    fn bad_rays_are_errors_naming_the_part() {
        let zero = Ray::new(DVec3::ZERO, DVec3::ZERO).unwrap_err();
        assert_eq!(
            (zero.what, zero.expected),
            ("ray direction", Expected::Direction)
        );
        let nan = Ray::new(DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 1.0)).unwrap_err();
        assert_eq!(nan.what, "ray direction");
        let origin = Ray::new(DVec3::splat(f64::INFINITY), DVec3::Z).unwrap_err();
        assert_eq!(
            (origin.what, origin.expected),
            ("ray origin", Expected::FiniteVector)
        );
    }

    proptest! {
        #[test]
        fn ray_new_finite_gives_unit_dir(
            o in prop::array::uniform3(-1e6f64..1e6),
            d in prop::array::uniform3(-1e3f64..1e3),
        ) {
            let d = DVec3::from(d);
            match Ray::new(DVec3::from(o), d) {
                Ok(r) => prop_assert!((r.dir().length() - 1.0).abs() < 1e-12),
                // Only a direction too short to normalise may be refused.
                Err(e) => {
                    prop_assert_eq!(e.expected, Expected::Direction);
                    prop_assert!(d.length() < 1e-150, "{d} refused");
                }
            }
        }
    }
}
