//! A curved mirror seen by the per-vertex method (documented on
//! [`CurvedMirror`]).

use glam::{DVec2, DVec3};
use rayon::prelude::*;
use serde::Serialize;

use super::error::SpectaclesError;
use super::viewpoint::{ViewpointFit, virtual_viewpoint};
use crate::input::{self, Expected, InvalidInput};
use crate::ray::Ray;
use crate::surface::{SphericalSurface, reflect};

/// Most grid cells across either side of a mirror's mesh.
pub const MAX_MIRROR_CELLS: usize = 512;

/// A rectangular spherical mirror: the paper's §3.2 (Fig. 2, a car's door
/// mirror), drawn by the same per-vertex ray tracing as the lens.
///
/// Its frame: the mirror's vertex (centre) at the origin, its reflecting
/// face looking along −z (the viewer is on the −z side), the rectangle
/// spanning `±half_size` in x and y. `radius_m > 0` is convex as the viewer
/// sees it (it bulges towards −z: a door mirror, a shop's safety mirror),
/// `< 0` concave (a shaving mirror), `±∞` flat. Paraxially it images like a
/// lens of focal length `−R/2`: a convex mirror of `R` = 1.2 m shows the
/// world minified, as from a point 0.6 m behind it for distant things.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CurvedMirror {
    surface: SphericalSurface,
    half_size: DVec2,
}

impl CurvedMirror {
    /// A `width_m` × `height_m` mirror of radius of curvature `radius_m`
    /// (`+` convex, `−` concave, `±∞` flat).
    ///
    /// Errors: a zero or NaN radius, a size that is not finite and
    /// positive, or a rectangle whose corners lie beyond the sphere's
    /// equator (`half-diagonal ≥ |R|`).
    pub fn new(radius_m: f64, width_m: f64, height_m: f64) -> Result<Self, SpectaclesError> {
        let surface = SphericalSurface::from_radius(0.0, radius_m)?;
        let half_size = DVec2::new(
            input::positive("mirror width (m)", width_m)?,
            input::positive("mirror height (m)", height_m)?,
        ) * 0.5;
        if !(surface.curvature().abs() * half_size.length() < 1.0) {
            return Err(InvalidInput::new(
                "mirror radius of curvature (m), against its half-diagonal",
                radius_m,
                Expected::AtLeast(half_size.length()),
            )
            .into());
        }
        Ok(Self { surface, half_size })
    }

    /// The mirror's surface (vertex at z = 0; its normal points to −z at
    /// the vertex, towards the viewer).
    pub fn surface(&self) -> &SphericalSurface {
        &self.surface
    }

    /// Half its width and height (m).
    pub fn half_size(&self) -> DVec2 {
        self.half_size
    }

    /// The point of the surface over `(x, y)`.
    pub fn point_at(&self, x: f64, y: f64) -> DVec3 {
        // Inside the rectangle the sag exists (checked in `new`).
        DVec3::new(x, y, self.surface.sag(x.hypot(y)).unwrap_or(0.0))
    }

    /// A grid of `(columns + 1) × (rows + 1)` vertices over the rectangle,
    /// row by row from the top (+y), each row from −x to +x; and its
    /// triangles, counter-clockwise seen from the reflecting face (−z).
    ///
    /// Errors: no cells, or more than [`MAX_MIRROR_CELLS`] a side.
    pub fn mesh(
        &self,
        columns: usize,
        rows: usize,
    ) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), SpectaclesError> {
        for (what, n) in [("mirror mesh columns", columns), ("mirror mesh rows", rows)] {
            if n == 0 || n > MAX_MIRROR_CELLS {
                return Err(InvalidInput::new(
                    what,
                    n as f64,
                    Expected::Range {
                        min: 1.0,
                        max: MAX_MIRROR_CELLS as f64,
                    },
                )
                .into());
            }
        }
        let h = self.half_size;
        let mut positions = Vec::with_capacity((columns + 1) * (rows + 1));
        for j in 0..=rows {
            let y = h.y * (1.0 - 2.0 * j as f64 / rows as f64);
            for i in 0..=columns {
                let x = h.x * (2.0 * i as f64 / columns as f64 - 1.0);
                positions.push(self.point_at(x, y));
            }
        }
        let w = columns as u32 + 1;
        let mut triangles = Vec::with_capacity(2 * columns * rows);
        for j in 0..rows as u32 {
            for i in 0..columns as u32 {
                let (a, b, c, d) = (
                    j * w + i,
                    j * w + i + 1,
                    (j + 1) * w + i,
                    (j + 1) * w + i + 1,
                );
                triangles.push([a, b, c]);
                triangles.push([b, d, c]);
            }
        }
        // (a, b, c) turns from +x to −y: clockwise seen from +z, so
        // counter-clockwise seen from the reflecting face.
        Ok((positions, triangles))
    }

    /// Whether `p` (on the surface) lies within the rectangle.
    fn covers(&self, p: DVec3) -> bool {
        p.x.abs() <= self.half_size.x && p.y.abs() <= self.half_size.y
    }

    /// Distance along `ray` to where it meets the mirror, from either side,
    /// within the rectangle (its back is opaque).
    pub fn meets(&self, ray: &Ray) -> Option<f64> {
        let hit = self.surface.intersect(ray)?;
        self.covers(hit.point).then_some(hit.t)
    }

    /// The reflection of `ray` (travelling towards the reflecting face):
    /// from the point where it meets the mirror, in the mirrored direction.
    /// `None` when it misses the rectangle or meets the mirror from behind.
    pub fn reflect(&self, ray: &Ray) -> Option<Ray> {
        let hit = self.surface.intersect(ray)?;
        if !self.covers(hit.point) || ray.dir().dot(hit.normal) >= 0.0 {
            return None;
        }
        Some(Ray::from_unit(
            hit.point,
            reflect(ray.dir(), hit.normal).normalize(),
        ))
    }

    /// The paper's §3.1 step (1) for a mirror: at every vertex (points of
    /// the surface, from [`CurvedMirror::mesh`]) the ray from `eye`
    /// reflected there. `None` where the eye sees the vertex from behind
    /// the mirror (or stands on it).
    pub fn reflect_vertices(&self, eye: DVec3, vertices: &[DVec3]) -> Vec<Option<Ray>> {
        vertices
            .par_iter()
            .map(|&v| {
                let d = (v - eye).try_normalize()?;
                let n = self.surface.normal_at(v);
                (d.dot(n) < 0.0).then(|| Ray::from_unit(v, reflect(d, n).normalize()))
            })
            .collect()
    }

    /// The virtual viewpoint of reflected rays (§3.1 step (2)): where their
    /// backward extensions meet, behind the mirror. Regularised towards
    /// the eye's image in the mirror's tangent plane, which is exact for a
    /// flat mirror.
    ///
    /// Errors: as [`virtual_viewpoint`] (no rays: [`SpectaclesError::NoRays`]).
    pub fn virtual_viewpoint(
        &self,
        eye: DVec3,
        rays: &[Option<Ray>],
        regularisation: f64,
    ) -> Result<ViewpointFit, SpectaclesError> {
        let eye = input::finite_vec3("eye position (m)", eye)?;
        let rays: Vec<Ray> = rays.iter().flatten().copied().collect();
        virtual_viewpoint(&rays, DVec3::new(eye.x, eye.y, -eye.z), regularisation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectacles::DEFAULT_VIEWPOINT_REGULARISATION;
    use proptest::prelude::*;

    #[test]
    fn a_flat_mirror_images_the_eye_exactly() {
        let m = CurvedMirror::new(f64::INFINITY, 0.4, 0.3).unwrap();
        let (v, t) = m.mesh(8, 6).unwrap();
        assert_eq!((v.len(), t.len()), (63, 96));
        let eye = DVec3::new(0.1, -0.05, -1.0);
        let rays = m.reflect_vertices(eye, &v);
        let fit = m
            .virtual_viewpoint(eye, &rays, DEFAULT_VIEWPOINT_REGULARISATION)
            .unwrap();
        assert!(
            (fit.point - DVec3::new(0.1, -0.05, 1.0)).length() < 1e-9,
            "{:?}",
            fit.point
        );
        assert!(fit.rms_distance_m < 1e-9);
    }

    #[test]
    fn a_convex_mirror_images_the_eye_by_the_mirror_equation() {
        // 1/v + 1/u = 2/R: an eye 1 m before a mirror of R = 1.2 m sees
        // its image 0.375 m behind it (paraxially: a small mirror).
        let m = CurvedMirror::new(1.2, 0.02, 0.02).unwrap();
        let (v, _) = m.mesh(4, 4).unwrap();
        let eye = DVec3::new(0.0, 0.0, -1.0);
        let fit = m
            .virtual_viewpoint(
                eye,
                &m.reflect_vertices(eye, &v),
                DEFAULT_VIEWPOINT_REGULARISATION,
            )
            .unwrap();
        assert!((fit.point.z - 0.375).abs() < 1e-3, "{:?}", fit.point);
        // Concave, R = −1.2 m: a real image in front, 1.5 m away.
        let m = CurvedMirror::new(-1.2, 0.02, 0.02).unwrap();
        let fit = m
            .virtual_viewpoint(
                eye,
                &m.reflect_vertices(eye, &v),
                DEFAULT_VIEWPOINT_REGULARISATION,
            )
            .unwrap();
        assert!((fit.point.z + 1.5).abs() < 5e-3, "{:?}", fit.point);
    }

    #[test]
    fn the_mesh_faces_the_viewer() {
        let m = CurvedMirror::new(1.0, 0.3, 0.2).unwrap();
        let (v, t) = m.mesh(3, 2).unwrap();
        for [a, b, c] in t {
            let n = (v[b as usize] - v[a as usize]).cross(v[c as usize] - v[a as usize]);
            assert!(n.z < 0.0, "{n:?}");
        }
    }

    #[test]
    fn impossible_mirrors_are_refused() {
        assert!(CurvedMirror::new(0.0, 0.2, 0.1).is_err());
        assert!(CurvedMirror::new(f64::NAN, 0.2, 0.1).is_err());
        assert!(
            CurvedMirror::new(0.1, 0.2, 0.2).is_err(),
            "corners past the equator"
        );
        assert!(CurvedMirror::new(1.0, -0.2, 0.1).is_err());
        let m = CurvedMirror::new(1.0, 0.2, 0.1).unwrap();
        assert!(m.mesh(0, 4).is_err() && m.mesh(4, MAX_MIRROR_CELLS + 1).is_err());
    }

    proptest! {
        /// The reflection of a ray aimed at a vertex is the vertex's own
        /// reflected ray, and the law of reflection holds.
        #[test]
        fn per_pixel_and_per_vertex_agree(
            r in prop_oneof![0.3f64..5.0, -5.0f64..-0.3],
            x in -0.1f64..0.1, y in -0.07f64..0.07,
            ex in -0.5f64..0.5, ey in -0.5f64..0.5, ez in -3.0f64..-0.2,
        ) {
            let m = CurvedMirror::new(r, 0.2, 0.14).unwrap();
            let p = m.point_at(x, y);
            let eye = DVec3::new(ex, ey, ez);
            let Some(v) = m.reflect_vertices(eye, &[p])[0] else { return Ok(()) };
            let ray = Ray::new(eye, p - eye).unwrap();
            let exact = m.reflect(&ray).expect("the vertex is seen from the front");
            prop_assert!((exact.origin() - p).length() < 1e-9);
            prop_assert!((exact.dir() - v.dir()).length() < 1e-9);
            let n = m.surface().normal_at(p);
            prop_assert!((ray.dir().dot(n) + v.dir().dot(n)).abs() < 1e-9);
        }
    }
}
