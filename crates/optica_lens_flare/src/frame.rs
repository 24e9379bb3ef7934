//! Between the camera and the lens: where a light's rays come from in the
//! lens frame, and where the sensor's picture lands on screen.
//!
//! Lens frame (`optica_optics::lens`): mm, +z from object to sensor. The
//! camera looks along its −Z, so light travelling towards it travels along
//! view +Z: the lens frame is the view frame (x right, y up, z towards the
//! sensor behind the lens). A lens forms an inverted image on its sensor,
//! and the picture is shown upright, so a sensor point (x, y) appears at
//! NDC −(x, y) over the sensor's half-height and half-width.

use bevy::math::{DVec2, DVec3, Vec3};
use optica_optics::lens_flare::MIN_LIGHT_Z;

/// The direction of travel, in the lens frame, of light that travels along
/// `travel` in the camera's view space; `None` when it does not enter the
/// lens (from behind or beside the camera, or not a direction).
pub fn light_in_lens(travel: Vec3) -> Option<DVec3> {
    let d = travel.as_dvec3().try_normalize()?;
    (d.z > MIN_LIGHT_Z).then_some(d)
}

/// How the lens's sensor fills the camera's picture: the sensor is sized so
/// that the lens's field of view is the camera's (a sensor half-height of
/// `EFL · tan(fov_y / 2)`), so the primary image of a light lands where the
/// camera draws the light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorMapping {
    /// Half the sensor's height, mm (NDC y = 1).
    pub half_height_mm: f64,
    /// Width over height of the picture.
    pub aspect: f64,
}

impl SensorMapping {
    /// The mapping for a lens of effective focal length `efl_mm` on a
    /// perspective camera of vertical field of view `fov_y_rad` and
    /// `aspect`; `None` for values that are not finite and positive (or a
    /// field of view of 180° or more).
    pub fn new(efl_mm: f64, fov_y_rad: f64, aspect: f64) -> Option<Self> {
        let ok = |v: f64| v.is_finite() && v > 0.0;
        if !(ok(efl_mm) && ok(fov_y_rad) && fov_y_rad < std::f64::consts::PI && ok(aspect)) {
            return None;
        }
        Some(Self {
            half_height_mm: efl_mm * (0.5 * fov_y_rad).tan(),
            aspect,
        })
    }

    /// NDC of a sensor point, mm.
    pub fn ndc(&self, sensor_mm: DVec2) -> DVec2 {
        -sensor_mm / DVec2::new(self.half_height_mm * self.aspect, self.half_height_mm)
    }
}
