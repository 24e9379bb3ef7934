//! Triangle meshes with their own BVH, and generators for the LOD chains of
//! the test scenes (UV spheres, tori and quads at any tessellation).
//!
//! The paper uses progressive meshes of a 5,804-triangle cow (§3.2.1, §4.2);
//! a chain of the same shape generated at several tessellations stands in for
//! them: the triangle counts are known exactly and the shapes converge to a
//! smooth limit, so coarse levels have a measurable geometric error.

use std::f64::consts::{PI, TAU};

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::bvh::{Aabb, Bvh};
use super::error::FoveatedError;
use crate::ray::Ray;

/// Hits closer than this (in scene units) are ignored, so that a ray leaving
/// a surface does not hit the same surface through rounding.
pub const T_MIN: f64 = 1e-9;

/// A ray–triangle hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshHit {
    /// Distance along the ray.
    pub t: f64,
    /// Index of the triangle hit.
    pub triangle: usize,
    /// Barycentric coordinates (u, v) of the hit on that triangle.
    pub uv: (f64, f64),
}

/// An indexed triangle mesh with per-vertex normals and a BVH over its triangles.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TriangleMesh {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    bvh: Bvh,
}

impl TriangleMesh {
    /// A mesh from positions, triangles and optional per-vertex normals
    /// (area-weighted face normals when `None`). Builds the BVH.
    ///
    /// Errors: no triangle, a non-finite position or normal, an index out of
    /// range, or a normal count that differs from the position count.
    pub fn new(
        positions: Vec<DVec3>,
        normals: Option<Vec<DVec3>>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<Self, FoveatedError> {
        if triangles.is_empty() {
            return Err(FoveatedError::InvalidScene("mesh has no triangles".into()));
        }
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(FoveatedError::NonFinite("mesh position"));
        }
        let n = positions.len();
        if let Some(bad) = triangles.iter().flatten().find(|&&i| i as usize >= n) {
            return Err(FoveatedError::InvalidScene(format!("index {bad} out of {n} vertices")));
        }
        let normals = match normals {
            Some(v) => {
                if v.len() != n {
                    return Err(FoveatedError::InvalidScene(format!(
                        "{} normals for {n} vertices",
                        v.len()
                    )));
                }
                if v.iter().any(|p| !p.is_finite()) {
                    return Err(FoveatedError::NonFinite("mesh normal"));
                }
                v.into_iter().map(|v| v.normalize_or_zero()).collect()
            }
            None => {
                let mut acc = vec![DVec3::ZERO; n];
                for t in &triangles {
                    let [a, b, c] = t.map(|i| positions[i as usize]);
                    // Cross product length is twice the area: area weighting.
                    let f = (b - a).cross(c - a);
                    for &i in t {
                        acc[i as usize] += f;
                    }
                }
                acc.into_iter().map(|v| v.normalize_or_zero()).collect()
            }
        };
        let boxes: Vec<Aabb> = triangles
            .iter()
            .map(|t| Aabb::from_points(t.map(|i| positions[i as usize])))
            .collect();
        let bvh = Bvh::build(&boxes);
        Ok(Self {
            positions,
            normals,
            triangles,
            bvh,
        })
    }

    /// A UV sphere of `rings` latitude bands (≥ 2) and `segments` longitude
    /// segments (≥ 3): 2·segments·(rings − 1) triangles, exact normals.
    pub fn uv_sphere(center: DVec3, radius: f64, rings: u32, segments: u32) -> Result<Self, FoveatedError> {
        if rings < 2 || segments < 3 || !(radius > 0.0 && radius.is_finite()) {
            return Err(FoveatedError::InvalidParameter(format!(
                "sphere needs rings ≥ 2, segments ≥ 3, radius > 0 (got {rings}, {segments}, {radius})"
            )));
        }
        let (r, s) = (rings as usize, segments as usize);
        let mut dirs = vec![DVec3::Y];
        for i in 1..r {
            let theta = PI * i as f64 / r as f64;
            for j in 0..s {
                let phi = TAU * j as f64 / s as f64;
                dirs.push(DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                ));
            }
        }
        dirs.push(DVec3::NEG_Y);
        let south = (dirs.len() - 1) as u32;
        let ring = |i: usize, j: usize| (1 + (i - 1) * s + j % s) as u32;
        let mut tris = Vec::with_capacity(2 * s * (r - 1));
        for j in 0..s {
            // Counter-clockwise seen from outside.
            tris.push([0, ring(1, j + 1), ring(1, j)]);
            tris.push([south, ring(r - 1, j), ring(r - 1, j + 1)]);
        }
        for i in 1..r - 1 {
            for j in 0..s {
                let (a, b, c, d) = (ring(i, j), ring(i, j + 1), ring(i + 1, j), ring(i + 1, j + 1));
                tris.push([a, b, d]);
                tris.push([a, d, c]);
            }
        }
        let positions = dirs.iter().map(|&d| center + d * radius).collect();
        Self::new(positions, Some(dirs), tris)
    }

    /// A torus around `axis` through `center`: ring radius `major`, tube radius
    /// `minor` (< major), `major_segments`·`minor_segments`·2 triangles, exact normals.
    pub fn torus(
        center: DVec3,
        axis: DVec3,
        major: f64,
        minor: f64,
        major_segments: u32,
        minor_segments: u32,
    ) -> Result<Self, FoveatedError> {
        let axis = axis
            .try_normalize()
            .ok_or(FoveatedError::DegenerateDirection("torus axis"))?;
        if major_segments < 3 || minor_segments < 3 || !(minor > 0.0 && major > minor && major.is_finite()) {
            return Err(FoveatedError::InvalidParameter(format!(
                "torus needs segments ≥ 3 and 0 < minor < major (got {major_segments}, {minor_segments}, {major}, {minor})"
            )));
        }
        let (u, w) = axis.any_orthonormal_pair();
        let (big, small) = (major_segments as usize, minor_segments as usize);
        let mut positions = Vec::with_capacity(big * small);
        let mut normals = Vec::with_capacity(big * small);
        for i in 0..big {
            let a = TAU * i as f64 / big as f64;
            let radial = u * a.cos() + w * a.sin();
            for j in 0..small {
                let b = TAU * j as f64 / small as f64;
                let n = radial * b.cos() + axis * b.sin();
                positions.push(center + radial * major + n * minor);
                normals.push(n);
            }
        }
        let id = |i: usize, j: usize| ((i % big) * small + j % small) as u32;
        let mut tris = Vec::with_capacity(2 * big * small);
        for i in 0..big {
            for j in 0..small {
                let (a, b, c, d) = (id(i, j), id(i + 1, j), id(i, j + 1), id(i + 1, j + 1));
                tris.push([a, b, d]);
                tris.push([a, d, c]);
            }
        }
        Self::new(positions, Some(normals), tris)
    }

    /// A parallelogram `corner + s·edge_u + t·edge_v`, s, t ∈ [0, 1], as two
    /// triangles with normal edge_u × edge_v.
    pub fn quad(corner: DVec3, edge_u: DVec3, edge_v: DVec3) -> Result<Self, FoveatedError> {
        let n = edge_u.cross(edge_v);
        let len = n.length();
        if len.is_nan() || len == 0.0 {
            return Err(FoveatedError::DegenerateDirection("quad edges parallel or zero"));
        }
        let p = vec![corner, corner + edge_u, corner + edge_u + edge_v, corner + edge_v];
        Self::new(p, Some(vec![n; 4]), vec![[0, 1, 2], [0, 2, 3]])
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Bounds of the mesh.
    pub fn bounds(&self) -> Aabb {
        self.bvh.bounds()
    }

    /// Möller–Trumbore for triangle `i`: (t, u, v) with T_MIN < t < t_max.
    #[inline]
    pub fn intersect_triangle(&self, i: usize, ray: &Ray, t_max: f64) -> Option<(f64, f64, f64)> {
        let [a, b, c] = self.triangles[i].map(|k| self.positions[k as usize]);
        let e1 = b - a;
        let e2 = c - a;
        let p = ray.dir().cross(e2);
        let det = e1.dot(p);
        // Relative test: a ray in the triangle's plane (or a zero-area
        // triangle) has no unique hit.
        if det.abs() <= 1e-14 * e1.length() * e2.length() {
            return None;
        }
        let inv = 1.0 / det;
        let s = ray.origin() - a;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(e1);
        let v = ray.dir().dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = e2.dot(q) * inv;
        (t > T_MIN && t < t_max).then_some((t, u, v))
    }

    /// The closest hit below `t_max` via the BVH; adds the number of triangle
    /// tests to `tests`.
    pub fn intersect(&self, ray: &Ray, t_max: f64, tests: &mut u64) -> Option<MeshHit> {
        let mut uv = (0.0, 0.0);
        let hit = self.bvh.closest(ray, t_max, |i, tm| {
            *tests += 1;
            self.intersect_triangle(i, ray, tm).map(|(t, u, v)| {
                uv = (u, v);
                t
            })
        });
        // `uv` is of the last accepted hit, which is the closest: `closest`
        // passes the current best as `tm`, so later hits are strictly nearer.
        hit.map(|(triangle, t)| MeshHit { t, triangle, uv })
    }

    /// The closest hit by testing every triangle (the BVH's test oracle).
    pub fn intersect_brute_force(&self, ray: &Ray, t_max: f64) -> Option<MeshHit> {
        let mut best: Option<MeshHit> = None;
        let mut tm = t_max;
        for i in 0..self.triangles.len() {
            if let Some((t, u, v)) = self.intersect_triangle(i, ray, tm) {
                tm = t;
                best = Some(MeshHit {
                    t,
                    triangle: i,
                    uv: (u, v),
                });
            }
        }
        best
    }

    /// True when any triangle blocks the ray before `t_max` (shadow rays).
    pub fn occluded(&self, ray: &Ray, t_max: f64, tests: &mut u64) -> bool {
        self.bvh.any(ray, t_max, |i| {
            *tests += 1;
            self.intersect_triangle(i, ray, t_max).is_some()
        })
    }

    /// Geometric (face) normal of triangle `i`, unit, by the winding.
    pub fn face_normal(&self, i: usize) -> DVec3 {
        let [a, b, c] = self.triangles[i].map(|k| self.positions[k as usize]);
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// Interpolated shading normal at a hit (the face normal where the vertex
    /// normals cancel).
    pub fn shading_normal(&self, hit: &MeshHit) -> DVec3 {
        let [a, b, c] = self.triangles[hit.triangle].map(|k| self.normals[k as usize]);
        let (u, v) = hit.uv;
        (a * (1.0 - u - v) + b * u + c * v)
            .try_normalize()
            .unwrap_or_else(|| self.face_normal(hit.triangle))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn generator_triangle_counts() {
        // 2·s·(r − 1) and 2·M·m.
        assert_eq!(
            TriangleMesh::uv_sphere(DVec3::ZERO, 1.0, 12, 24)
                .unwrap()
                .triangle_count(),
            528
        );
        assert_eq!(
            TriangleMesh::uv_sphere(DVec3::ZERO, 1.0, 38, 76)
                .unwrap()
                .triangle_count(),
            5624
        );
        assert_eq!(
            TriangleMesh::torus(DVec3::ZERO, DVec3::Y, 1.0, 0.3, 24, 12)
                .unwrap()
                .triangle_count(),
            576
        );
        assert!(TriangleMesh::uv_sphere(DVec3::ZERO, 1.0, 1, 24).is_err());
        assert!(TriangleMesh::torus(DVec3::ZERO, DVec3::Y, 0.3, 1.0, 24, 12).is_err());
        assert!(TriangleMesh::new(vec![DVec3::NAN; 3], None, vec![[0, 1, 2]]).is_err());
        assert!(TriangleMesh::new(vec![DVec3::ZERO; 3], None, vec![[0, 1, 3]]).is_err());
    }

    #[test]
    fn sphere_is_wound_outwards_and_hit_near_the_radius() {
        let m = TriangleMesh::uv_sphere(DVec3::ZERO, 2.0, 24, 48).unwrap();
        let ray = Ray::new(DVec3::new(0.1, 0.2, -10.0), DVec3::Z).unwrap();
        let mut n = 0;
        let h = m.intersect(&ray, f64::INFINITY, &mut n).unwrap();
        // The inscribed polygon lies inside the sphere by at most
        // r(1 − cos(π/24)) ≈ 0.017 at this tessellation.
        let exact = 10.0 - (4.0f64 - 0.05).sqrt();
        assert!(h.t >= exact - 1e-9 && h.t < exact + 0.02, "{}", h.t);
        assert!(m.face_normal(h.triangle).z < 0.0, "front face points at the viewer");
        assert!(m.shading_normal(&h).z < -0.9);
        assert!(n > 0 && n < m.triangle_count() as u64 / 4, "the BVH prunes: {n} tests");
    }

    proptest! {
        /// The mesh BVH gives exactly the brute-force closest hit.
        #[test]
        fn mesh_bvh_equals_brute_force(ox in -4.0f64..4.0, oy in -4.0f64..4.0, oz in -4.0f64..4.0,
                                       dx in -1.0f64..1.0, dy in -1.0f64..1.0, dz in -1.0f64..1.0) {
            let d = DVec3::new(dx, dy, dz);
            prop_assume!(d.length() > 1e-3);
            let ray = Ray::new(DVec3::new(ox, oy, oz), d).unwrap();
            let meshes = [
                TriangleMesh::uv_sphere(DVec3::new(0.5, 0.0, 0.0), 1.5, 9, 14).unwrap(),
                TriangleMesh::torus(DVec3::ZERO, DVec3::new(0.3, 1.0, 0.1), 2.0, 0.6, 17, 7).unwrap(),
            ];
            for m in &meshes {
                let mut n = 0;
                let a = m.intersect(&ray, f64::INFINITY, &mut n);
                let b = m.intersect_brute_force(&ray, f64::INFINITY);
                prop_assert_eq!(a.map(|h| h.t), b.map(|h| h.t));
                let mut k = 0;
                prop_assert_eq!(m.occluded(&ray, 3.0, &mut k), b.is_some_and(|h| h.t < 3.0));
            }
        }
    }
}
