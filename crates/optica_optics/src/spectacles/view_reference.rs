//! The exact view through a lens, pixel by pixel (documented on
//! [`plane_seen_through_lens`]): the reference of the plugin's per-vertex
//! refraction.

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use super::lens_design::SpectacleLens;
use super::per_vertex::LensTrace;
use crate::ray::Ray;

/// For every pixel of a `size`×`size` square view with vertical field of
/// view `fov_rad`, looking along +z from `(0, 0, eye_z)` (the eye's frame:
/// +x to the wearer's left, which is the image's left; rows from the top),
/// the point `(x, y)` where the ray through the pixel's centre, traced
/// through `lens` (`None`: straight), meets the plane `z = plane_z`; `None`
/// where the ray does not leave the lens's front surface (total
/// reflection, the rim, a miss) or meets the plane behind it. Row-major.
///
/// The paper's per-vertex method traces rays at the lens's vertices only
/// and interpolates between them; this traces every pixel, exactly.
pub fn plane_seen_through_lens(
    lens: Option<&SpectacleLens>,
    eye_z: f64,
    fov_rad: f64,
    size: u32,
    plane_z: f64,
) -> Vec<Option<DVec2>> {
    let tan = (0.5 * fov_rad).tan();
    let eye = DVec3::new(0.0, 0.0, eye_z);
    (0..size * size)
        .into_par_iter()
        .map(|k| {
            let (px, py) = (k % size, k / size);
            let ndc = DVec2::new(
                (2.0 * (f64::from(px) + 0.5) / f64::from(size) - 1.0) * tan,
                (1.0 - 2.0 * (f64::from(py) + 0.5) / f64::from(size)) * tan,
            );
            let ray = Ray::new(eye, DVec3::new(-ndc.x, ndc.y, 1.0)).ok()?;
            let (origin, dir) = match lens {
                None => (eye, ray.dir()),
                Some(l) => match l.trace_from_eye(&ray) {
                    LensTrace::Exit { front, dir, .. } => (front, dir),
                    _ => return None,
                },
            };
            let t = (plane_z - origin.z) / dir.z;
            (t > 0.0 && t.is_finite()).then(|| (origin + dir * t).truncate())
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectacles::lens_design::{LensDesignParams, Prescription, design_lens};

    #[test]
    fn view_reference_straight_and_through_lenses() {
        // Straight rays: the pixel's direction times the plane's distance.
        let v = plane_seen_through_lens(None, -0.003, 0.8, 4, 2.0);
        let tan = 0.4f64.tan();
        let want = DVec2::new(-(2.0 * 0.5 / 4.0 - 1.0) * tan, (1.0 - 2.0 * 0.5 / 4.0) * tan) * 2.003;
        assert!((v[0].unwrap() - want).length() < 1e-12, "{:?}", v[0]);
        // A minus lens shows more of the plane, a plus lens less (a pixel
        // off the axis sees farther out, or nearer in).
        let lens = |s| design_lens(&Prescription::sphere(s).unwrap(), &LensDesignParams::default()).unwrap();
        let corner = |l: Option<&SpectacleLens>| plane_seen_through_lens(l, -0.003, 0.8, 16, 2.0)[0].unwrap().length();
        let (bare, minus, plus) = (corner(None), corner(Some(&lens(-4.0))), corner(Some(&lens(4.0))));
        assert!(minus > bare && plus < bare, "{minus} {bare} {plus}");
    }
}
