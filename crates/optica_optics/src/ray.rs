//! Rays: an origin and a unit direction, in `f64`.
//!
//! Every tracer in the crate (lens systems, spectacles, voxel traversal) shares
//! this one type so that hits and distances mean the same thing everywhere:
//! because `dir` is unit, the parameter `t` of [`Ray::at`] is a distance.

use glam::DVec3;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// Why a ray could not be built by [`Ray::try_new`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum RayError {
    /// The origin has a NaN or infinite component.
    #[error("ray origin is not finite")]
    NonFiniteOrigin,
    /// The direction is zero, too small to normalise, or not finite.
    #[error("ray direction is zero or not finite")]
    BadDirection,
}

/// A ray `origin + t * dir` with a unit `dir`.
///
/// The fields are public for cheap construction in hot loops; code that
/// builds a ray from user numbers should use [`Ray::try_new`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Ray {
    /// Where the ray starts.
    pub origin: DVec3,
    /// Unit direction of travel.
    pub dir: DVec3,
}

impl Ray {
    /// A ray from `origin` along `dir`, normalising `dir`.
    ///
    /// Documented fallback: a zero or non-finite `dir` becomes `DVec3::ZERO`,
    /// which no surface or grid in this crate intersects (they all return
    /// `None`), so a bad ray dies instead of spreading NaN. Use
    /// [`Ray::try_new`] to get an error instead.
    pub fn new(origin: DVec3, dir: DVec3) -> Self {
        Self { origin, dir: dir.normalize_or_zero() }
    }

    /// A ray from `origin` along `dir` (normalised), or an error when the
    /// origin is not finite or the direction cannot be normalised.
    pub fn try_new(origin: DVec3, dir: DVec3) -> Result<Self, RayError> {
        if !origin.is_finite() {
            return Err(RayError::NonFiniteOrigin);
        }
        let d = dir.try_normalize().ok_or(RayError::BadDirection)?;
        Ok(Self { origin, dir: d })
    }

    /// The point at distance `t` along the ray.
    #[inline]
    pub fn at(&self, t: f64) -> DVec3 {
        self.origin + self.dir * t
    }

    /// True when the origin is finite and the direction is finite and unit
    /// (to 1e-9), i.e. when the ray can be traced.
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite()
            && self.dir.is_finite()
            && (self.dir.length_squared() - 1.0).abs() < 1e-9
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn ray_new_normalises_and_at_measures_distance() {
        let r = Ray::new(DVec3::new(1.0, 2.0, 3.0), DVec3::new(0.0, 3.0, 4.0));
        // 3-4-5 triangle: the unit direction is (0, 0.6, 0.8).
        assert!((r.dir - DVec3::new(0.0, 0.6, 0.8)).length() < 1e-15);
        assert!((r.at(5.0) - DVec3::new(1.0, 5.0, 7.0)).length() < 1e-14);
        assert!(r.is_valid());
    }

    #[test]
    fn ray_bad_direction_is_typed_or_zero() {
        assert_eq!(Ray::try_new(DVec3::ZERO, DVec3::ZERO), Err(RayError::BadDirection));
        assert_eq!(
            Ray::try_new(DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 1.0)),
            Err(RayError::BadDirection)
        );
        assert_eq!(
            Ray::try_new(DVec3::splat(f64::INFINITY), DVec3::Z),
            Err(RayError::NonFiniteOrigin)
        );
        let r = Ray::new(DVec3::ZERO, DVec3::new(f64::NAN, 1.0, 0.0));
        assert_eq!(r.dir, DVec3::ZERO);
        assert!(!r.is_valid());
    }

    proptest! {
        #[test]
        fn ray_try_new_finite_gives_unit_dir(
            o in prop::array::uniform3(-1e6f64..1e6),
            d in prop::array::uniform3(-1e3f64..1e3),
        ) {
            match Ray::try_new(DVec3::from(o), DVec3::from(d)) {
                Ok(r) => prop_assert!((r.dir.length() - 1.0).abs() < 1e-12),
                Err(e) => prop_assert_eq!(e, RayError::BadDirection),
            }
        }
    }
}
