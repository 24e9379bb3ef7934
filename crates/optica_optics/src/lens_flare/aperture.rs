//! The shape of the aperture stop, tested at the (interpolated) position where
//! a ray crosses the stop plane — the blog's "開口部通過位置" that the GPU
//! looks up in an aperture texture per pixel.

use glam::DVec2;

use super::FlareError;
use crate::lens::LensPrescription;

/// Outline of the stop opening.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ApertureShape {
    /// A round iris.
    Circle,
    /// A regular polygon of `blades` straight blades (3 or more; fewer is
    /// taken as a circle), one vertex at angle `rotation_rad` from +x.
    Polygon {
        /// Number of blades.
        blades: u32,
        /// Rotation of the first vertex, radians.
        rotation_rad: f64,
    },
}

/// The stop opening: a shape and its circumradius in mm.
///
/// `radius_mm <= 0` (or NaN) is a closed iris: nothing passes (the "zero
/// aperture" case gives an all-black ghost, never NaN).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aperture {
    /// Outline.
    pub shape: ApertureShape,
    /// Circumradius in mm, in the stop plane.
    pub radius_mm: f64,
}

impl Aperture {
    /// A round aperture of `radius_mm`.
    pub fn circle(radius_mm: f64) -> Self {
        Self { shape: ApertureShape::Circle, radius_mm }
    }

    /// The prescription's own stop, round (the shape `r_rel` already tests).
    pub fn of_stop(prescription: &LensPrescription) -> Self {
        let r = prescription.stop_index().map(|k| prescription.surfaces[k].semi_aperture_mm).unwrap_or(0.0);
        Self::circle(r)
    }

    /// A polygonal aperture of `blades` blades inscribed in `radius_mm`.
    pub fn polygon(blades: u32, rotation_rad: f64, radius_mm: f64) -> Self {
        Self { shape: ApertureShape::Polygon { blades, rotation_rad }, radius_mm }
    }

    /// `true` when the stop-plane point `p` lies in the opening (boundary included).
    pub fn contains(&self, p: DVec2) -> bool {
        let r = self.radius_mm;
        if !(r > 0.0) || !p.is_finite() {
            return false;
        }
        match self.shape {
            ApertureShape::Polygon { blades, rotation_rad } if blades >= 3 && rotation_rad.is_finite() => {
                // Inside a regular polygon: the projection on every edge normal
                // is at most the inradius r cos(π/b). Edge normals sit halfway
                // between vertices.
                let b = blades as f64;
                let half = std::f64::consts::PI / b;
                let inradius = r * half.cos();
                (0..blades).all(|k| {
                    let a = rotation_rad + (2.0 * k as f64 + 1.0) * half;
                    p.x * a.cos() + p.y * a.sin() <= inradius
                })
            }
            _ => p.length_squared() <= r * r,
        }
    }
}

/// The prescription with its stop semi-aperture multiplied by `opening` in
/// (0, 1] — stopping the iris down. Done on the prescription (not only on the
/// aperture test) so that `r_rel` clips every crossing of the stop, including
/// the second and third crossings of a ghost that passes the stop three times.
pub fn stopped_down(prescription: &LensPrescription, opening: f64) -> Result<LensPrescription, FlareError> {
    if !(opening > 0.0 && opening <= 1.0) {
        return Err(FlareError::InvalidOpening(opening));
    }
    let mut p = prescription.clone();
    if let Some(k) = p.stop_index() {
        p.surfaces[k].semi_aperture_mm *= opening;
    }
    Ok(p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn circle_and_hexagon_by_hand() {
        let c = Aperture::circle(2.0);
        assert!(c.contains(DVec2::new(2.0, 0.0)));
        assert!(!c.contains(DVec2::new(1.5, 1.5))); // |p| = 2.12
        // Hexagon of circumradius 2 with a vertex on +x: inradius 2 cos 30° = 1.732.
        let h = Aperture::polygon(6, 0.0, 2.0);
        assert!(h.contains(DVec2::new(1.99, 0.0)), "near a vertex");
        assert!(h.contains(DVec2::new(0.0, 1.73)));
        assert!(!h.contains(DVec2::new(0.0, 1.74)), "beyond the flat edge at y = 1.732");
    }

    #[test]
    fn closed_or_nan_aperture_passes_nothing() {
        assert!(!Aperture::circle(0.0).contains(DVec2::ZERO));
        assert!(!Aperture::circle(f64::NAN).contains(DVec2::ZERO));
        assert!(!Aperture::circle(1.0).contains(DVec2::new(f64::NAN, 0.0)));
    }

    #[test]
    fn stopped_down_scales_only_the_stop() {
        let p = crate::lens::builtin::tessar();
        let q = stopped_down(&p, 0.5).unwrap();
        assert_eq!(q.surfaces[3].semi_aperture_mm, 7.5); // stop of US 2,854,889: 15.0 mm
        assert_eq!(q.surfaces[0].semi_aperture_mm, 19.2);
        assert!(stopped_down(&p, 0.0).is_err());
        assert!(stopped_down(&p, f64::NAN).is_err());
    }
}
