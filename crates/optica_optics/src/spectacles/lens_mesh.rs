//! A triangle mesh of a designed lens (documented on [`LensMesh`]).

use std::f64::consts::PI;
use std::ops::Range;

use glam::DVec3;
use serde::Serialize;

use super::error::{LensSide, SpectaclesError};
use super::lens_design::SpectacleLens;
use crate::input::{Expected, InvalidInput};

/// A triangle mesh of a designed lens in the eye's frame (metres), made by
/// [`SpectacleLens::mesh`]: back surface, front surface and rim, with
/// outward normals, for rendering and for the per-vertex trace.
///
/// Each surface is a polar grid: the vertex on the axis, then `rings` rings
/// of `segments` vertices at radii `r_k = rim·k/rings`. The paper's lens had
/// about 1,500 vertices per surface ([`LensMesh::PAPER_RINGS`] ×
/// [`LensMesh::PAPER_SEGMENTS`] + 1 = 1,537). The rim is a band of two rings
/// with its own vertices (radial normals), so the edge stays sharp.
/// Triangles are counter-clockwise seen from outside.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LensMesh {
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    back: Range<usize>,
    front: Range<usize>,
    rim: Range<usize>,
}

impl LensMesh {
    /// Rings of the paper-sized mesh.
    pub const PAPER_RINGS: usize = 24;
    /// Segments of the paper-sized mesh.
    pub const PAPER_SEGMENTS: usize = 64;

    /// Vertex positions (m).
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// Unit outward normals, one per vertex.
    pub fn normals(&self) -> &[DVec3] {
        &self.normals
    }

    /// Triangles (indices into [`LensMesh::positions`]), counter-clockwise
    /// seen from outside.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Indices of the back (eye-side) surface's vertices; the first is on
    /// the axis, then ring by ring outwards.
    pub fn back(&self) -> Range<usize> {
        self.back.clone()
    }

    /// Indices of the front surface's vertices, laid out as the back's.
    pub fn front(&self) -> Range<usize> {
        self.front.clone()
    }

    /// Indices of the rim band's vertices: the back's outermost ring, then
    /// the front's, each with radial normals.
    pub fn rim(&self) -> Range<usize> {
        self.rim.clone()
    }

    /// Back-surface vertices (what the eye sees; the per-vertex trace's input).
    pub fn back_positions(&self) -> &[DVec3] {
        &self.positions[self.back.clone()]
    }
}

/// Largest polar layout accepted, for a mesh surface
/// ([`SpectacleLens::mesh`]) or a voxel field's aims: 4,194,304 points,
/// 2,700 times the paper's 1,537 (a mesh surface of that size is already
/// ~200 MB of positions and normals, a field's aims that many bundle pairs).
pub const MAX_POLAR_POINTS: usize = 1 << 22;

/// `1 + rings × segments`, the number of points of the polar layout, or
/// `None` when it overflows or exceeds [`MAX_POLAR_POINTS`].
pub(crate) fn polar_point_count(rings: usize, segments: usize) -> Option<usize> {
    rings
        .checked_mul(segments)?
        .checked_add(1)
        .filter(|&n| n <= MAX_POLAR_POINTS)
}

/// The error for a polar layout of more than [`MAX_POLAR_POINTS`] points.
pub(crate) fn too_many_points(what: &'static str, rings: usize, segments: usize) -> InvalidInput {
    // The product in f64 cannot overflow; it is only reported.
    let value = 1.0 + rings as f64 * segments as f64;
    InvalidInput::new(
        what,
        value,
        Expected::Range {
            min: 1.0,
            max: MAX_POLAR_POINTS as f64,
        },
    )
}

/// Polar sample points `(x, y)` of a disc of radius `radius`: the centre,
/// then `rings × segments` points (the mesh's vertex layout).
///
/// Errors: more than [`MAX_POLAR_POINTS`] points (checked before anything is
/// multiplied or allocated).
pub(crate) fn polar_points(
    radius: f64,
    rings: usize,
    segments: usize,
) -> Result<Vec<(f64, f64)>, InvalidInput> {
    let n = polar_point_count(rings, segments)
        .ok_or_else(|| too_many_points("polar points 1 + rings × segments", rings, segments))?;
    let mut v = Vec::with_capacity(n);
    v.push((0.0, 0.0));
    for k in 1..=rings {
        let r = radius * k as f64 / rings as f64;
        for j in 0..segments {
            let phi = 2.0 * PI * j as f64 / segments as f64;
            v.push((r * phi.cos(), r * phi.sin()));
        }
    }
    Ok(v)
}

/// Fewest rings of a mesh: one ring round the axis vertex.
const MIN_MESH_RINGS: usize = 1;
/// Fewest segments of a mesh: a triangle is the smallest closed ring.
const MIN_MESH_SEGMENTS: usize = 3;

impl SpectacleLens {
    /// The mesh at `rings × segments` resolution: back surface, front
    /// surface and rim, with outward normals (layout: see [`LensMesh`]). [`LensMesh::PAPER_RINGS`] × [`LensMesh::PAPER_SEGMENTS`]
    /// gives the paper's ~1,500 vertices per surface.
    ///
    /// Errors: `rings < 1` or `segments < 3`, or more than
    /// [`MAX_POLAR_POINTS`] vertices per surface (checked before any size
    /// is computed; it keeps every index within `u32`).
    pub fn mesh(&self, rings: usize, segments: usize) -> Result<LensMesh, SpectaclesError> {
        let unbounded = |min: usize| Expected::Range {
            min: min as f64,
            max: f64::INFINITY,
        };
        if rings < MIN_MESH_RINGS {
            return Err(
                InvalidInput::new("mesh rings", rings as f64, unbounded(MIN_MESH_RINGS)).into(),
            );
        }
        if segments < MIN_MESH_SEGMENTS {
            return Err(InvalidInput::new(
                "mesh segments",
                segments as f64,
                unbounded(MIN_MESH_SEGMENTS),
            )
            .into());
        }
        let too_many = || {
            too_many_points(
                "mesh vertices per surface 1 + rings × segments",
                rings,
                segments,
            )
        };
        let per_surface = polar_point_count(rings, segments).ok_or_else(too_many)?;
        // per_surface <= 2^22 and segments < per_surface: no overflow, and
        // total < 2^24 fits u32.
        let total = 2 * per_surface + 2 * segments;
        let pts = polar_points(self.rim_radius_m(), rings, segments)?;
        let mut positions = Vec::with_capacity(total);
        let mut normals = Vec::with_capacity(total);
        // Back: outward is towards the eye (−z), the surfaces' own normal.
        let (back, front) = (self.back(), self.front());
        for &(x, y) in &pts {
            let p = back
                .point(x, y)
                .ok_or_else(|| self.not_to_rim(LensSide::Back))?;
            positions.push(p);
            normals.push(back.normal_at(p));
        }
        // Front: outward is into the scene (+z), minus the surface normal.
        for &(x, y) in &pts {
            let z = front.vertex_z()
                + front
                    .sag((x * x + y * y).sqrt())
                    .ok_or_else(|| self.not_to_rim(LensSide::Front))?;
            let p = DVec3::new(x, y, z);
            positions.push(p);
            normals.push(-front.normal_at(p));
        }
        // Rim band: copies of the outermost rings with radial normals.
        let outer = 1 + (rings - 1) * segments;
        for j in 0..segments {
            let p = positions[outer + j];
            positions.push(p);
            normals.push(DVec3::new(p.x, p.y, 0.0).normalize());
        }
        for j in 0..segments {
            let p = positions[per_surface + outer + j];
            positions.push(p);
            normals.push(DVec3::new(p.x, p.y, 0.0).normalize());
        }
        let mut triangles = Vec::with_capacity(4 * rings * segments + 2 * segments);
        let ring_vertex = |base: usize, k: usize, j: usize| -> usize {
            if k == 0 {
                base
            } else {
                base + 1 + (k - 1) * segments + j % segments
            }
        };
        for (base, outward) in [(0, -1.0), (per_surface, 1.0)] {
            for k in 0..rings {
                for j in 0..segments {
                    let a = ring_vertex(base, k, j);
                    let b = ring_vertex(base, k, j + 1);
                    let c = ring_vertex(base, k + 1, j);
                    let d = ring_vertex(base, k + 1, j + 1);
                    if k == 0 {
                        triangles.push([a, c, d]);
                    } else {
                        triangles.push([a, c, d]);
                        triangles.push([a, d, b]);
                    }
                }
            }
            // The polar grid winds counter-clockwise seen from +z; flip the
            // back surface's triangles so that they face −z.
            if outward < 0.0 {
                let start = 0;
                let end = triangles.len();
                for t in &mut triangles[start..end] {
                    t.swap(1, 2);
                }
            }
        }
        let rim_back = 2 * per_surface;
        let rim_front = rim_back + segments;
        for j in 0..segments {
            let (b0, b1) = (rim_back + j, rim_back + (j + 1) % segments);
            let (f0, f1) = (rim_front + j, rim_front + (j + 1) % segments);
            triangles.push([b0, b1, f1]);
            triangles.push([b0, f1, f0]);
        }
        Ok(LensMesh {
            positions,
            normals,
            triangles: triangles.into_iter().map(|t| t.map(|i| i as u32)).collect(),
            back: 0..per_surface,
            front: per_surface..2 * per_surface,
            rim: rim_back..total,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectacles::lens_design::{LensDesignParams, Prescription, design_lens};

    #[test]
    fn lens_mesh_counts_and_orientation() {
        let lens = design_lens(
            &Prescription::new(-3.0, -1.0, 20.0).unwrap(),
            &LensDesignParams::default(),
        )
        .unwrap();
        let m = lens
            .mesh(LensMesh::PAPER_RINGS, LensMesh::PAPER_SEGMENTS)
            .unwrap();
        // 1 + 24·64 = 1,537 vertices per surface (the paper: ~1,500).
        assert_eq!(m.back().len(), 1537);
        assert_eq!(m.front().len(), 1537);
        assert_eq!(m.positions().len(), 2 * 1537 + 2 * 64);
        // Per surface: 64 fan triangles + 2·64·23 quads' triangles; rim 2·64.
        assert_eq!(m.triangles().len(), 2 * (64 + 2 * 64 * 23) + 2 * 64);
        for n in m.normals() {
            assert!((n.length() - 1.0).abs() < 1e-12);
        }
        // Every triangle's geometric normal agrees with its vertices' outward normals.
        for t in m.triangles() {
            let [a, b, c] = t.map(|i| m.positions()[i as usize]);
            let g = (b - a).cross(c - a);
            let avg: DVec3 = t.iter().map(|&i| m.normals()[i as usize]).sum();
            assert!(g.dot(avg) > 0.0, "{t:?}");
        }
        // Vertices lie on their surfaces; back normals face the eye, front the scene.
        for &p in m.back_positions() {
            assert!((p.z - lens.back().point(p.x, p.y).unwrap().z).abs() < 1e-15);
        }
        assert!(m.normals()[m.back().start].z < -0.999 && m.normals()[m.front().start].z > 0.999);
        // Closed: the signed volume (divergence theorem) is positive and
        // close to the lens volume π r² × mean thickness (−3/−4 D: 2–5 mm).
        let vol: f64 = m
            .triangles()
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions()[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum();
        let disc = PI * 0.025f64.powi(2);
        assert!(vol > disc * 0.002 && vol < disc * 0.006, "{vol}");
        assert!(
            matches!(lens.mesh(0, 8), Err(SpectaclesError::Input(e)) if e.what == "mesh rings")
        );
        assert!(
            matches!(lens.mesh(4, 2), Err(SpectaclesError::Input(e)) if e.what == "mesh segments")
        );
        // The rim band: the outermost rings again, with radial normals.
        assert_eq!(m.rim(), 2 * 1537..m.positions().len());
        for i in m.rim() {
            let (p, n) = (m.positions()[i], m.normals()[i]);
            assert!((p.truncate().length() - lens.rim_radius_m()).abs() < 1e-15 && n.z == 0.0);
        }
    }

    #[test]
    fn lens_mesh_huge_sizes_are_typed_errors() {
        // Sizes whose product overflows usize, or is merely huge, are
        // rejected before any arithmetic or allocation (no overflow panic,
        // no multi-gigabyte allocation).
        let lens = design_lens(
            &Prescription::sphere(-2.0).unwrap(),
            &LensDesignParams::default(),
        )
        .unwrap();
        let too_big = |r: Result<LensMesh, SpectaclesError>| matches!(r, Err(SpectaclesError::Input(e)) if e.what.starts_with("mesh vertices per surface"));
        assert!(too_big(lens.mesh(usize::MAX, 3)));
        assert!(too_big(lens.mesh(3, usize::MAX)));
        assert!(too_big(lens.mesh(1 << 32, 1 << 32)));
        assert!(too_big(lens.mesh(1 << 20, 64)));
        assert_eq!(
            polar_points(0.025, usize::MAX, usize::MAX)
                .unwrap_err()
                .expected,
            Expected::Range {
                min: 1.0,
                max: MAX_POLAR_POINTS as f64
            }
        );
        assert_eq!(
            polar_points(0.025, MAX_POLAR_POINTS, 1).unwrap_err().value,
            1.0 + MAX_POLAR_POINTS as f64
        );
        assert_eq!(polar_point_count(usize::MAX, 2), None);
        assert_eq!(polar_point_count(usize::MAX, 1), None);
        assert_eq!(
            polar_point_count(MAX_POLAR_POINTS - 1, 1),
            Some(MAX_POLAR_POINTS)
        );
        assert_eq!(polar_points(0.025, 24, 64).unwrap().len(), 1537);
    }
}
