//! The exact view through a lens, pixel by pixel (documented on
//! [`plane_seen_through_lens`]): the reference of the plugin's per-vertex
//! refraction.

use glam::{DAffine3, DVec2, DVec3};
use rayon::prelude::*;

use super::lens_design::SpectacleLens;
use super::mirror::CurvedMirror;
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

/// A square in the world whose texture holds its own coordinates (the
/// harness's coordinate texture): centre, unit axes `right` and `up` (its
/// face looks along `right × up`; from behind it is not seen), half side,
/// and a tag telling it from the other squares.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoordinatePlane {
    /// Centre (m).
    pub centre: DVec3,
    /// Unit axis of its texture's x.
    pub right: DVec3,
    /// Unit axis of its texture's y.
    pub up: DVec3,
    /// Half its side (m).
    pub half: f64,
    /// Which square.
    pub tag: u32,
}

impl CoordinatePlane {
    /// Distance along `ray` to the square's face and the point there in its
    /// coordinates.
    fn hit(&self, ray: &Ray) -> Option<(f64, DVec2)> {
        let n = self.right.cross(self.up);
        let dn = ray.dir().dot(n);
        if !(dn < 0.0) {
            return None;
        }
        let t = (self.centre - ray.origin()).dot(n) / dn;
        let q = ray.at(t) - self.centre;
        let at = DVec2::new(q.dot(self.right), q.dot(self.up));
        (t > 1e-9 && at.x.abs() <= self.half && at.y.abs() <= self.half).then_some((t, at))
    }
}

/// What a pixel shows of the squares.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeenPoint {
    /// The square's tag.
    pub tag: u32,
    /// The point in its coordinates.
    pub at: DVec2,
    /// Whether it is seen in the mirror.
    pub in_mirror: bool,
}

/// A pinhole camera: `size`×`size` pixels, rows from the top, looking
/// along `forward` with `right` and `up` (unit, orthogonal) across the
/// image, `tan_half_fov` the tangent of half its field of view.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pinhole {
    /// Where it is (m).
    pub eye: DVec3,
    /// Unit direction of its axis.
    pub forward: DVec3,
    /// Unit direction of the image's +x.
    pub right: DVec3,
    /// Unit direction of the image's up.
    pub up: DVec3,
    /// Tangent of half the field of view.
    pub tan_half_fov: f64,
    /// Pixels a side.
    pub size: u32,
}

impl Pinhole {
    /// The ray through pixel `(px, py)`'s centre.
    pub fn ray(&self, px: u32, py: u32) -> Option<Ray> {
        let s = f64::from(self.size);
        let x = (2.0 * (f64::from(px) + 0.5) / s - 1.0) * self.tan_half_fov;
        let y = (1.0 - 2.0 * (f64::from(py) + 0.5) / s) * self.tan_half_fov;
        Ray::new(self.eye, self.forward + self.right * x + self.up * y).ok()
    }
}

/// The exact view of `planes` and a mirror, pixel by pixel (the reference
/// of the per-vertex mirror, §3.2): each pixel's ray meets the nearest of
/// the squares and the mirror (placed by `world_from_mirror`, a rigid
/// motion); off the mirror the pixel shows the square it meets, on it the
/// square its reflected ray meets first. Row-major; `None` where a pixel
/// (or its reflection) meets no square.
pub fn seen_with_mirror(
    camera: &Pinhole,
    mirror: &CurvedMirror,
    world_from_mirror: DAffine3,
    planes: &[CoordinatePlane],
) -> Vec<Option<SeenPoint>> {
    let mirror_from_world = world_from_mirror.inverse();
    let nearest = |ray: &Ray| {
        planes
            .iter()
            .filter_map(|p| p.hit(ray).map(|(t, at)| (t, p.tag, at)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    };
    (0..camera.size * camera.size)
        .into_par_iter()
        .map(|k| {
            let ray = camera.ray(k % camera.size, k / camera.size)?;
            let direct = nearest(&ray);
            let local = Ray::new(
                mirror_from_world.transform_point3(ray.origin()),
                mirror_from_world.transform_vector3(ray.dir()),
            )
            .ok()?;
            if let Some(t) = mirror.meets(&local)
                && direct.is_none_or(|(tp, ..)| t < tp)
            {
                // The mirror's face reflects; its back hides what lies behind.
                let r = mirror.reflect(&local)?;
                let out = Ray::new(
                    world_from_mirror.transform_point3(r.origin()),
                    world_from_mirror.transform_vector3(r.dir()),
                )
                .ok()?;
                return nearest(&out).map(|(_, tag, at)| SeenPoint { tag, at, in_mirror: true });
            }
            direct.map(|(_, tag, at)| SeenPoint { tag, at, in_mirror: false })
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

    #[test]
    fn a_flat_mirror_shows_the_wall_behind_the_camera() {
        // Camera at the origin looking −z at a flat mirror 1 m away; a wall
        // 1 m behind the camera facing the mirror. The centre pixel sees the
        // wall's centre (3 m of path), and the view is a 1:3 copy of the
        // camera's own: pixel (px) sees the wall at 3 × its point on the
        // mirror, mirrored in x.
        let camera = Pinhole {
            eye: DVec3::ZERO,
            forward: DVec3::NEG_Z,
            right: DVec3::X,
            up: DVec3::Y,
            tan_half_fov: 0.2,
            size: 8,
        };
        let mirror = CurvedMirror::new(f64::INFINITY, 1.0, 1.0).unwrap();
        // The mirror's face looks along its −z, towards +z in the world: a
        // half turn about y.
        let world_from_mirror = DAffine3::from_rotation_translation(
            glam::DQuat::from_rotation_y(std::f64::consts::PI),
            DVec3::new(0.0, 0.0, -1.0),
        );
        // The wall faces −z: its right is −x seen from behind it.
        let wall = CoordinatePlane { centre: DVec3::new(0.0, 0.0, 1.0), right: DVec3::NEG_X, up: DVec3::Y, half: 5.0, tag: 1 };
        let seen = seen_with_mirror(&camera, &mirror, world_from_mirror, &[wall]);
        let p = seen[0].expect("the corner pixel sees the wall");
        assert!(p.in_mirror && p.tag == 1);
        let world_x = (2.0 * 0.5 / 8.0 - 1.0) * 0.2 * 3.0;
        let world_y = (1.0 - 2.0 * 0.5 / 8.0) * 0.2 * 3.0;
        // The wall's x runs along world −x.
        assert!((-p.at.x - world_x).abs() < 1e-9 && (p.at.y - world_y).abs() < 1e-9, "{p:?}");
    }
}
