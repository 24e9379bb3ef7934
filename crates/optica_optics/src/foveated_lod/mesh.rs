//! Triangle meshes with their own BVH, and generators for the LOD chains of
//! the test scenes (UV spheres, tori and quads at any tessellation).
//!
//! The paper uses progressive meshes of a 5,804-triangle cow (§3.2.1, §4.2);
//! a chain of the same shape generated at several tessellations stands in for
//! them: the triangle counts are known exactly and the shapes converge to a
//! smooth limit, so coarse levels have a measurable geometric error.

use std::f64::consts::{PI, TAU};

use glam::DVec3;
use serde::Serialize;

use super::bvh::{Aabb, Bvh};
use super::error::FoveatedError;
use crate::input::{self, Expected, InvalidInput};
use crate::ray::Ray;

/// Hits closer than this (m) are ignored. The tracer already starts
/// secondary rays off the surface (`tracer::SECONDARY_RAY_OFFSET_REL`); this
/// only drops a hit at the ray's own origin that rounding puts a hair in
/// front of it. 1 nm is far above the rounding of the test scenes'
/// coordinates (about 1e-15 m at 10 m) and far below any of their features.
const T_MIN: f64 = 1e-9;

/// The Möller–Trumbore determinant (the sine of the angle between the ray
/// and the triangle's plane, times the edge lengths) below which, relative to
/// |e1|·|e2|, a ray counts as lying in the plane: there is no unique hit, and
/// the determinant's own rounding error (a few ulps of |e1|·|e2|, 2.2e-16
/// each) would decide its sign. 1e-14 is about 45 ulps.
const PARALLEL_DET_REL: f64 = 1e-14;

/// A ray–triangle hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct MeshHit {
    /// Distance along the ray.
    pub(crate) t: f64,
    /// Index of the triangle hit.
    pub(crate) triangle: usize,
    /// Barycentric coordinates (u, v) of the hit on that triangle.
    pub(crate) uv: (f64, f64),
}

/// An indexed triangle mesh (m) with per-vertex normals and a BVH over its
/// triangles: one entry of an object's LOD chain in the reference tracer.
///
/// The paper uses progressive meshes of a 5,804-triangle cow (§3.2.1,
/// §4.2); a chain of the same shape generated at several tessellations
/// ([`TriangleMesh::uv_sphere`], [`TriangleMesh::torus`]) stands in for them:
/// the triangle counts are known exactly and the shapes converge to a smooth
/// limit, so coarse levels have a measurable geometric error.
#[derive(Debug, Clone, PartialEq, Serialize)]
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
    /// Errors: [`FoveatedError::Input`] for a non-finite position or normal;
    /// [`FoveatedError::InvalidScene`] for no triangle or an index out of
    /// range; [`FoveatedError::LengthMismatch`] for a normal count that
    /// differs from the position count.
    pub fn new(
        positions: Vec<DVec3>,
        normals: Option<Vec<DVec3>>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<Self, FoveatedError> {
        if triangles.is_empty() {
            return Err(FoveatedError::InvalidScene("mesh has no triangles".into()));
        }
        for &p in &positions {
            input::finite_vec3("mesh position (m)", p)?;
        }
        let n = positions.len();
        if let Some(bad) = triangles.iter().flatten().find(|&&i| i as usize >= n) {
            return Err(FoveatedError::InvalidScene(format!(
                "index {bad} out of {n} vertices"
            )));
        }
        let normals = match normals {
            Some(v) => {
                if v.len() != n {
                    return Err(FoveatedError::LengthMismatch {
                        what: "mesh normals",
                        expected: n,
                        got: v.len(),
                    });
                }
                for &p in &v {
                    input::finite_vec3("mesh normal", p)?;
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

    /// A UV sphere of `radius` (m), `rings` latitude bands (≥ 2) and
    /// `segments` longitude segments (≥ 3): 2·segments·(rings − 1)
    /// triangles, exact normals. Errors: [`FoveatedError::Input`] naming the
    /// number out of range.
    pub fn uv_sphere(
        center: DVec3,
        radius: f64,
        rings: u32,
        segments: u32,
    ) -> Result<Self, FoveatedError> {
        input::finite_vec3("sphere centre (m)", center)?;
        input::positive("sphere radius (m)", radius)?;
        at_least("sphere rings", rings, 2)?;
        at_least("sphere segments", segments, 3)?;
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
                let (a, b, c, d) = (
                    ring(i, j),
                    ring(i, j + 1),
                    ring(i + 1, j),
                    ring(i + 1, j + 1),
                );
                tris.push([a, b, d]);
                tris.push([a, d, c]);
            }
        }
        let positions = dirs.iter().map(|&d| center + d * radius).collect();
        Self::new(positions, Some(dirs), tris)
    }

    /// A torus around `axis` (any length) through `center`: ring radius
    /// `major` (m), tube radius `minor` (m, 0 < minor ≤ major),
    /// 2·`major_segments`·`minor_segments` triangles (each ≥ 3), exact
    /// normals. Errors: [`FoveatedError::Input`] naming the number out of range.
    pub fn torus(
        center: DVec3,
        axis: DVec3,
        major: f64,
        minor: f64,
        major_segments: u32,
        minor_segments: u32,
    ) -> Result<Self, FoveatedError> {
        input::finite_vec3("torus centre (m)", center)?;
        let axis = input::direction("torus axis", axis)?;
        let major = input::positive("torus ring radius (m)", major)?;
        input::positive("torus tube radius (m)", minor)?;
        input::in_range("torus tube radius (m)", minor, 0.0, major)?;
        at_least("torus ring segments", major_segments, 3)?;
        at_least("torus tube segments", minor_segments, 3)?;
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

    /// A parallelogram `corner + s·edge_u + t·edge_v` (m), s, t ∈ [0, 1], as
    /// two triangles with normal edge_u × edge_v. Errors:
    /// [`FoveatedError::Input`] for a non-finite corner or edge;
    /// [`FoveatedError::DegenerateDirection`] for parallel or zero edges.
    pub fn quad(corner: DVec3, edge_u: DVec3, edge_v: DVec3) -> Result<Self, FoveatedError> {
        input::finite_vec3("quad corner (m)", corner)?;
        input::finite_vec3("quad edge (m)", edge_u)?;
        input::finite_vec3("quad edge (m)", edge_v)?;
        let n = edge_u.cross(edge_v);
        if !(n.length() > 0.0) {
            return Err(FoveatedError::DegenerateDirection(
                "quad edges parallel or zero",
            ));
        }
        let p = vec![
            corner,
            corner + edge_u,
            corner + edge_u + edge_v,
            corner + edge_v,
        ];
        Self::new(p, Some(vec![n; 4]), vec![[0, 1, 2], [0, 2, 3]])
    }

    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Vertex positions (m).
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// Unit vertex normals (zero where the given normal was zero).
    pub fn normals(&self) -> &[DVec3] {
        &self.normals
    }

    /// Triangles as vertex indices.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// The BVH over the triangles.
    pub(crate) fn bvh(&self) -> &Bvh {
        &self.bvh
    }

    /// Bounds of the mesh.
    pub(crate) fn bounds(&self) -> Aabb {
        self.bvh.bounds()
    }

    /// Möller–Trumbore for triangle `i`: (t, u, v) with T_MIN < t < t_max.
    #[inline]
    pub(crate) fn intersect_triangle(
        &self,
        i: usize,
        ray: &Ray,
        t_max: f64,
    ) -> Option<(f64, f64, f64)> {
        let [a, b, c] = self.triangles[i].map(|k| self.positions[k as usize]);
        let e1 = b - a;
        let e2 = c - a;
        let p = ray.dir().cross(e2);
        let det = e1.dot(p);
        // Relative test: a ray in the triangle's plane (or a zero-area
        // triangle) has no unique hit.
        if det.abs() <= PARALLEL_DET_REL * e1.length() * e2.length() {
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
    pub(crate) fn intersect(&self, ray: &Ray, t_max: f64, tests: &mut u64) -> Option<MeshHit> {
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
    #[cfg(test)]
    pub(crate) fn intersect_brute_force(&self, ray: &Ray, t_max: f64) -> Option<MeshHit> {
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
    pub(crate) fn occluded(&self, ray: &Ray, t_max: f64, tests: &mut u64) -> bool {
        self.bvh.any(ray, t_max, |i| {
            *tests += 1;
            self.intersect_triangle(i, ray, t_max).is_some()
        })
    }

    /// Geometric (face) normal of triangle `i`, unit, by the winding.
    pub(crate) fn face_normal(&self, i: usize) -> DVec3 {
        let [a, b, c] = self.triangles[i].map(|k| self.positions[k as usize]);
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// Interpolated shading normal at a hit (the face normal where the vertex
    /// normals cancel).
    pub(crate) fn shading_normal(&self, hit: &MeshHit) -> DVec3 {
        let [a, b, c] = self.triangles[hit.triangle].map(|k| self.normals[k as usize]);
        let (u, v) = hit.uv;
        (a * (1.0 - u - v) + b * u + c * v)
            .try_normalize()
            .unwrap_or_else(|| self.face_normal(hit.triangle))
    }
}

/// `n` if it is at least `min` (a tessellation count).
fn at_least(what: &'static str, n: u32, min: u32) -> Result<u32, InvalidInput> {
    if n >= min {
        Ok(n)
    } else {
        Err(InvalidInput::new(
            what,
            n as f64,
            Expected::Range {
                min: min as f64,
                max: u32::MAX as f64,
            },
        ))
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
    }

    #[test]
    fn bad_meshes_are_rejected_naming_the_input() {
        let what = |r: Result<TriangleMesh, FoveatedError>| match r {
            Err(FoveatedError::Input(e)) => e.what,
            other => panic!("expected an input error, got {other:?}"),
        };
        assert_eq!(
            what(TriangleMesh::uv_sphere(DVec3::ZERO, 1.0, 1, 24)),
            "sphere rings"
        );
        assert_eq!(
            what(TriangleMesh::uv_sphere(DVec3::ZERO, 1.0, 12, 2)),
            "sphere segments"
        );
        assert_eq!(
            what(TriangleMesh::uv_sphere(DVec3::ZERO, f64::NAN, 12, 24)),
            "sphere radius (m)"
        );
        // A tube wider than its ring.
        let e = TriangleMesh::torus(DVec3::ZERO, DVec3::Y, 0.3, 1.0, 24, 12).unwrap_err();
        assert_eq!(
            e,
            FoveatedError::Input(InvalidInput::new(
                "torus tube radius (m)",
                1.0,
                Expected::Range { min: 0.0, max: 0.3 }
            ))
        );
        assert_eq!(
            what(TriangleMesh::torus(
                DVec3::ZERO,
                DVec3::ZERO,
                1.0,
                0.3,
                24,
                12
            )),
            "torus axis"
        );
        assert_eq!(
            what(TriangleMesh::torus(DVec3::ZERO, DVec3::Y, 1.0, 0.3, 24, 2)),
            "torus tube segments"
        );
        assert_eq!(
            what(TriangleMesh::new(
                vec![DVec3::NAN; 3],
                None,
                vec![[0, 1, 2]]
            )),
            "mesh position (m)"
        );
        assert!(matches!(
            TriangleMesh::new(vec![DVec3::ZERO; 3], None, vec![[0, 1, 3]]),
            Err(FoveatedError::InvalidScene(m)) if m == "index 3 out of 3 vertices"
        ));
        assert!(matches!(
            TriangleMesh::new(vec![DVec3::ZERO; 3], None, vec![]),
            Err(FoveatedError::InvalidScene(_))
        ));
        assert_eq!(
            TriangleMesh::new(
                vec![DVec3::ZERO; 3],
                Some(vec![DVec3::Y; 2]),
                vec![[0, 1, 2]]
            ),
            Err(FoveatedError::LengthMismatch {
                what: "mesh normals",
                expected: 3,
                got: 2
            })
        );
        assert_eq!(
            TriangleMesh::quad(DVec3::ZERO, DVec3::X, DVec3::X * 2.0),
            Err(FoveatedError::DegenerateDirection(
                "quad edges parallel or zero"
            ))
        );
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
        assert!(
            m.face_normal(h.triangle).z < 0.0,
            "front face points at the viewer"
        );
        assert!(m.shading_normal(&h).z < -0.9);
        assert!(
            n > 0 && n < m.triangle_count() as u64 / 4,
            "the BVH prunes: {n} tests"
        );
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
