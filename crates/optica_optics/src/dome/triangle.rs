//! Refinement of triangles (paper §3.3) and of indexed meshes.
//!
//! The paper's steps, as implemented for every triangle by [`refine_triangle`]
//! (after clipping) and [`pre_subdivide`](super::pre_subdivide):
//!
//! 1. Compute the subtended angle of the three edges (D4).
//! 2. Split each edge by the rule (D5/D6, D7). Let AB be the edge of largest
//!    angle and C the opposite corner (the corner of largest angle).
//! 3. Join the new vertices of the two shorter edges AC (points P₀ = A … P_m = C)
//!    and BC (Q₀ = B … Q_k = C) by "rungs", starting nearest AB. The paper
//!    pairs them one to one; when m ≠ k we pair Pⱼ with Q⌊j·k/m⌋ (or the
//!    mirror), j = 1 … max(m, k) − 1, so every vertex of the longer side gets
//!    a rung, rungs never cross, the last rung ends at P_{m−1} and Q_{k−1}, and
//!    consecutive rungs differ by at most one vertex on each side.
//! 4. Split every rung by the rule.
//! 5. Triangulate the strip between AB and the first rung by walking both
//!    polylines alternately (where their vertex counts differ, advancing on
//!    the side that gives the shorter diagonal).
//! 6. Repeat for every pair of consecutive rungs, so neighbouring strips
//!    share the split rung.
//! 7. Fan the corner C with the last rung.
//!
//! Every edge is split from its canonically ordered endpoints, so a boundary
//! edge shared with a neighbour gets bit-identical vertices from both sides:
//! welding the output by exact position gives a crack-free mesh (a closed
//! input mesh stays closed). All sub-triangles keep the input's winding.
//!
//! Then (our addition, `interior.rs`) interior edges that still need more
//! than one piece — stitched diagonals and rung pieces where the inside of
//! the triangle is nearer the viewer than its sides — are bisected
//! conformingly, never touching the patch boundary.

use std::collections::HashMap;

use glam::DVec3;
use rayon::prelude::*;

use super::arc::{Arc, ArcError, canonical_less, points_of_arc, subtended_angle};
use super::camera::DomeProjection;
use super::clip::{clip_polygon_plane, clip_triangle_plane};
use super::error::DomeError;
use super::interior::bisect_interior;
use super::lens::FisheyeLens;
use super::refine::RefineStats;
use super::rule::{Pieces, SplitRule};
use crate::input;

/// The interior bisection of a patch (our addition, `interior.rs`) may grow
/// it to this many times the triangles of the paper's triangulation, plus
/// [`INTERIOR_BUDGET_EXTRA`]; reaching the budget is reported as a capped
/// edge. In this module's tests (rooms at 0.3–4 px, random triangles at
/// 0.5–8 px, FOV 90°–250°) the bisection grew a patch by at most ~5×
/// (1412 → 6972 triangles); 16× leaves room above that and stops only a
/// runaway (a rule that can never be met, as with a sub-micro-pixel
/// tolerance).
const INTERIOR_BUDGET_FACTOR: usize = 16;

/// Fixed part of the interior budget, so that a triangle the paper's steps
/// leave as one piece can still get its interior bisected (a triangle with
/// short sides seen nearly edge-on): 4096 triangles, four times what
/// [`MAX_PIECES`](super::MAX_PIECES) allows along one edge.
const INTERIOR_BUDGET_EXTRA: usize = 4096;

/// A vertex of a clipped part closer to the origin than this fraction of the
/// triangle's largest vertex distance is taken to be at the origin (its
/// direction is noise): the view plane passes through the origin, so a
/// clip cut there comes out at ~1e-16 relative, never exactly 0. 1e-12 is
/// four orders of magnitude above that rounding.
const AT_ORIGIN_REL: f64 = 1e-12;

/// An indexed triangle mesh in view space (or viewer-centred space), metres.
/// Built by [`TriMesh::new`], which checks that every index refers to a
/// vertex, so the refiners never re-check it. Vertex coordinates are not
/// checked here: a refiner leaves a triangle with a non-finite vertex out
/// and counts it ([`RefineStats::dropped_nonfinite`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    pub(super) positions: Vec<DVec3>,
    pub(super) triangles: Vec<[u32; 3]>,
}

impl TriMesh {
    /// A mesh of `triangles` (indices into `positions`, counter-clockwise or
    /// not: the winding is kept). Errors: [`DomeError::IndexOutOfRange`]
    /// for the first index that refers to no vertex.
    pub fn new(positions: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Result<Self, DomeError> {
        let len = positions.len();
        if let Some(&index) = triangles.iter().flatten().find(|&&i| i as usize >= len) {
            return Err(DomeError::IndexOutOfRange { index, len });
        }
        Ok(Self {
            positions,
            triangles,
        })
    }

    /// Vertex positions.
    pub fn positions(&self) -> &[DVec3] {
        &self.positions
    }

    /// Triangles as indices into [`positions`](Self::positions).
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// The positions and triangles, to build a GPU mesh without copying.
    pub fn into_parts(self) -> (Vec<DVec3>, Vec<[u32; 3]>) {
        (self.positions, self.triangles)
    }

    /// The three corners of triangle `t` (an index triple of this mesh).
    pub(crate) fn corners(&self, t: [u32; 3]) -> [DVec3; 3] {
        t.map(|i| self.corner(i))
    }

    /// The position of vertex `i` (an index of this mesh).
    pub(crate) fn corner(&self, i: u32) -> DVec3 {
        self.positions[i as usize]
    }
}

/// A refined mesh and what happened.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RefinedMesh {
    /// Output mesh, vertices welded by exact position.
    pub mesh: TriMesh,
    /// Counters (inputs are triangles).
    pub stats: RefineStats,
}

/// The refiner's maps, with a fast fixed hasher: every refined triangle
/// welds its pieces (and a few build edge tables), and SipHash took more
/// time than the geometry.
pub(crate) type FastMap<K, V> = HashMap<K, V, foldhash::fast::FixedState>;

/// Welds vertices by exact bits (−0 and +0 are one vertex).
#[derive(Default)]
pub(crate) struct Welder {
    /// Every vertex's key, by index; looked up by a scan while there are
    /// few (one refined triangle welds a handful of points, and building a
    /// hash map cost more than its geometry), through `map` past that.
    keys: Vec<[u64; 3]>,
    map: FastMap<[u64; 3], u32>,
    mesh: TriMesh,
    /// Where [`Self::add`] maps the added mesh's vertices (kept between
    /// calls).
    scratch: Vec<u32>,
}

/// Vertices a [`Welder`] finds by scanning before it builds its map.
const WELD_SCAN: usize = 16;

/// A point's identity for welding: its coordinates' bits, −0 as +0.
fn weld_key(p: DVec3) -> [u64; 3] {
    [p.x, p.y, p.z].map(|c| (c + 0.0).to_bits())
}

/// Whether `p` lies on the view plane (normal `axis`) for the rim skirt:
/// within a relative 1e-9, as cut points computed by interpolation do.
fn on_view_plane(p: DVec3, axis: DVec3) -> bool {
    p.dot(axis).abs() <= 1e-9 * p.length()
}

impl Welder {
    fn vertex(&mut self, p: DVec3) -> u32 {
        let key = weld_key(p);
        if self.keys.len() < WELD_SCAN {
            if let Some(i) = self.keys.iter().position(|k| *k == key) {
                return i as u32;
            }
        } else {
            if self.map.is_empty() {
                self.map = self
                    .keys
                    .iter()
                    .enumerate()
                    .map(|(i, k)| (*k, i as u32))
                    .collect();
            }
            if let Some(&i) = self.map.get(&key) {
                return i;
            }
            self.map.insert(key, self.keys.len() as u32);
        }
        self.keys.push(key);
        self.mesh.positions.push(p);
        (self.mesh.positions.len() - 1) as u32
    }

    pub(crate) fn into_mesh(self) -> TriMesh {
        self.mesh
    }

    /// Adds the triangles of `m` and the vertices they use (unused vertices,
    /// e.g. of culled triangles, are left out).
    pub(crate) fn add(&mut self, m: &TriMesh) {
        // (Room for all of `m` at once: one allocation, not one per growth.)
        self.keys.reserve(m.positions.len());
        self.mesh.positions.reserve(m.positions.len());
        self.mesh.triangles.reserve(m.triangles.len());
        let mut idx = std::mem::take(&mut self.scratch);
        idx.clear();
        idx.resize(m.positions.len(), u32::MAX);
        for t in &m.triangles {
            let t = t.map(|i| {
                if idx[i as usize] == u32::MAX {
                    idx[i as usize] = self.vertex(m.positions[i as usize]);
                }
                idx[i as usize]
            });
            if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                self.mesh.triangles.push(t);
            }
        }
        self.scratch = idx;
    }
}

/// Paper §3.3 on one triangle, with no clipping: `pieces` gives the piece
/// count of an edge (it is called with canonically ordered endpoints, so it
/// may be any deterministic function). Returns the local mesh and whether a
/// piece count was capped. Errors from the arcs (origin, through the viewer).
/// `rung_pieces_whole`: whether every piece of an arc `pieces` split is
/// one piece itself (true when the count grows with the arc's angle and
/// its largest polar angle only: the visual angle, the equidistant lens's
/// chord gap), which spares checking them for the interior bisection.
pub(crate) fn subdivide_triangle(
    tri: [DVec3; 3],
    pieces: &(impl Fn(&Arc) -> Pieces + ?Sized),
    rung_pieces_whole: bool,
) -> Result<(TriMesh, bool), ArcError> {
    // Each edge's arc, in canonical order (both triangles sharing an edge
    // build the same one).
    let canonical = |p: DVec3, q: DVec3| {
        if canonical_less(q, p) {
            Arc::new(q, p)
        } else {
            Arc::new(p, q)
        }
    };
    let arcs = [0, 1, 2].map(|i| canonical(tri[i], tri[(i + 1) % 3]));
    // The longest edge by subtended angle: an arc's α is that angle bit
    // for bit, except for arcs seen as a point (α = 0) or not built.
    let alphas = match &arcs {
        [Ok(x), Ok(y), Ok(z)] if ![x, y, z].iter().any(|a| a.is_point()) => {
            [x.alpha, y.alpha, z.alpha]
        }
        _ => [0, 1, 2].map(|i| subtended_angle(tri[i], tri[(i + 1) % 3])),
    };
    let mut e = 0;
    for i in 1..3 {
        if alphas[i] > alphas[e] {
            e = i;
        }
    }
    // (A, B, C) is a rotation of the input, so it keeps the winding.
    let (a, b, c) = (tri[e], tri[(e + 1) % 3], tri[(e + 2) % 3]);
    // The sides' piece counts first (errors in the order AB, AC, BC): a
    // triangle whose sides all stay whole (most of those cut at the view
    // plane) is its own subdivision, with no strip to build.
    let mut capped = false;
    let mut count = |arc: Result<Arc, ArcError>, p: DVec3, q: DVec3| {
        let arc = arc?;
        let pc = pieces(&arc);
        capped |= pc.capped;
        Ok::<_, ArcError>((arc, pc.n, canonical_less(q, p)))
    };
    let sides = [
        count(arcs[e], a, b)?,
        count(arcs[(e + 2) % 3], a, c)?,
        count(arcs[(e + 1) % 3], b, c)?,
    ];
    if sides.iter().all(|s| s.1 == 1) {
        let mesh = TriMesh {
            positions: vec![a, b, c],
            triangles: vec![[0, 1, 2]],
        };
        return Ok((mesh, capped));
    }
    let mut verts = vec![a, b, c];
    let on_side = |verts: &mut Vec<DVec3>, (arc, n, swap): (Arc, u32, bool), i0: u32, i1: u32| {
        if n == 1 {
            return vec![i0, i1];
        }
        let pts = points_of_arc(&arc, n, swap);
        let mut idx = Vec::with_capacity(pts.len());
        idx.push(i0);
        for &x in &pts[1..pts.len() - 1] {
            idx.push(verts.len() as u32);
            verts.push(x);
        }
        idx.push(i1);
        idx
    };
    let ab = on_side(&mut verts, sides[0], 0, 1);
    let side_p = on_side(&mut verts, sides[1], 0, 2); // A → C
    let side_q = on_side(&mut verts, sides[2], 1, 2); // B → C
    let mut split = |verts: &mut Vec<DVec3>, i0: u32, i1: u32| -> Result<Vec<u32>, ArcError> {
        let (p, q) = (verts[i0 as usize], verts[i1 as usize]);
        let rung = count(canonical(p, q), p, q)?;
        Ok(on_side(verts, rung, i0, i1))
    };
    let (m, k) = (side_p.len() - 1, side_q.len() - 1);
    let rungs = m.max(k);
    let mut tris = Vec::new();
    // The interior edges that may be too long, for the bisection's first
    // check: the edges joining two rungs (and the apex), and the rungs'
    // pieces unless they are whole by the rule's form.
    let mut interior = Vec::new();
    let mut lower = ab;
    for j in 1..rungs {
        let (pi, qi) = if m >= k {
            (j, j * k / m)
        } else {
            (j * m / k, j)
        };
        let upper = split(&mut verts, side_p[pi], side_q[qi])?;
        stitch(&verts, &lower, &upper, &mut tris, &mut interior);
        if !rung_pieces_whole {
            interior.extend(upper.windows(2).map(|w| [w[0], w[1]]));
        }
        lower = upper;
    }
    for w in lower.windows(2) {
        push_tri(&mut tris, [w[0], w[1], 2]);
        interior.push([w[1], 2]);
    }
    let mut mesh = TriMesh {
        positions: verts,
        triangles: tris,
    };
    // Our addition: interior edges that still need pieces are bisected
    // (see interior.rs); the boundary is never touched.
    let needs_split = |p: DVec3, q: DVec3| canonical(p, q).is_ok_and(|arc| pieces(&arc).n > 1);
    // A triangle left whole has no interior edge (the common case for
    // distant geometry): skip the bisection's bookkeeping.
    if mesh.triangles.len() > 1 {
        let budget = INTERIOR_BUDGET_FACTOR * mesh.triangles.len() + INTERIOR_BUDGET_EXTRA;
        capped |= bisect_interior(&mut mesh, &interior, &needs_split, budget);
    }
    Ok((mesh, capped))
}

fn push_tri(tris: &mut Vec<[u32; 3]>, t: [u32; 3]) {
    if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
        tris.push(t);
    }
}

/// Zigzag between two polylines running from the A side to the B side,
/// `upper` nearer C (paper §3.3 steps 5–6: "trace [the vertices] alternately
/// and connect them", 交互にたどり結合する). The paper
/// alternates; with unequal vertex counts we advance on the side whose new
/// diagonal subtends the smaller angle (greedy shortest diagonal), which
/// equals alternation on a regular strip and keeps diagonals short when the
/// two polylines are split differently. Between two polylines with distinct
/// ends (a convex quad) any advance order is a valid triangulation; when the
/// polylines share their first or last vertex (a wedge: consecutive rungs
/// that end on the same side vertex) that vertex gets exactly one triangle,
/// else the walk could join three collinear points of one polyline.
/// Winding follows (A, B, C).
fn stitch(
    verts: &[DVec3],
    lower: &[u32],
    upper: &[u32],
    tris: &mut Vec<[u32; 3]>,
    diagonals: &mut Vec<[u32; 2]>,
) {
    let (mut l, mut u) = (lower, upper);
    if l[0] == u[0] {
        push_tri(tris, [l[0], l[1], u[1]]);
        diagonals.push([l[1], u[1]]);
        (l, u) = (&l[1..], &u[1..]);
    }
    let shared_end = l.len() > 1 && u.len() > 1 && l.last() == u.last();
    if shared_end {
        let (nl, nu) = (l.len() - 1, u.len() - 1);
        push_tri(tris, [l[nl - 1], l[nl], u[nu - 1]]);
        (l, u) = (&l[..nl], &u[..nu]);
    }
    let (nl, nu) = (l.len() - 1, u.len() - 1);
    let v = |i: u32| verts[i as usize];
    let (mut i, mut j) = (0, 0);
    while i < nl || j < nu {
        let advance_lower = if i == nl {
            false
        } else if j == nu {
            true
        } else {
            shorter_or_equal((v(l[i + 1]), v(u[j])), (v(l[i]), v(u[j + 1])))
        };
        if advance_lower {
            push_tri(tris, [l[i], l[i + 1], u[j]]);
            diagonals.push([l[i + 1], u[j]]);
            i += 1;
        } else {
            push_tri(tris, [l[i], u[j + 1], u[j]]);
            diagonals.push([l[i], u[j + 1]]);
            j += 1;
        }
    }
}

/// Whether segment p subtends at most the angle segment q does, without
/// the angles: for α = atan2(s, c) with s = |a × b| ≥ 0 and c = a·b, the
/// sign of sin(α_q − α_p) (both angles in [0, π]) is that of
/// s_q·c_p − s_p·c_q, whatever the lengths of the points.
fn shorter_or_equal(p: (DVec3, DVec3), q: (DVec3, DVec3)) -> bool {
    let (sp, cp) = (p.0.cross(p.1).length(), p.0.dot(p.1));
    let (sq, cq) = (q.0.cross(q.1).length(), q.0.dot(q.1));
    sq * cp - sp * cq >= 0.0
}

/// Whether the ray from the origin along `d` passes through triangle `t`.
fn covers_direction(t: &[DVec3; 3], d: DVec3) -> bool {
    let det = t[0].dot(t[1].cross(t[2]));
    if det == 0.0 {
        return false;
    }
    let l0 = d.dot(t[1].cross(t[2])) / det;
    let l1 = t[0].dot(d.cross(t[2])) / det;
    let l2 = t[0].dot(t[1].cross(d)) / det;
    l0 >= 0.0 && l1 >= 0.0 && l2 >= 0.0
}

/// Whether [`refine_triangle`] gives `tri` (finite corners) back as it
/// is: wholly in front of the view plane (FOV ≤ 180°), off the origin, and
/// each edge whole under the rule's own short-arc test (the one the full
/// path applies first, so a neighbour refined the long way splits the
/// shared edge alike). Most triangles of a large scene are such; a
/// renderer can keep them as they are without calling the refiner.
pub fn is_left_whole(proj: &DomeProjection, tri: [DVec3; 3], rule: SplitRule) -> bool {
    if !proj.clips_at_view_plane() || !tri.iter().all(|v| v.dot(proj.axis()) >= 0.0) {
        return false;
    }
    let lengths = tri.map(|v| v.length());
    let scale = lengths.iter().fold(0.0, |m: f64, &l| m.max(l));
    lengths.iter().all(|&l| l > AT_ORIGIN_REL * scale)
        && (0..3).all(|i| edge_is_short(proj, tri[i], tri[(i + 1) % 3], rule))
}

/// Whether the edge a–b (finite, off the origin) stays one piece wherever
/// it lies: the rule's short-arc test, the one the full path applies
/// first, so a neighbour refined the long way splits the shared edge alike.
fn edge_is_short(proj: &DomeProjection, a: DVec3, b: DVec3, rule: SplitRule) -> bool {
    // tan α = |a × b|/(a·b) ≥ α bounds the angle without atan2 (a third of
    // the cost of a whole triangle), squared without a root: short by the
    // bound is short by the angle (the margin covers the rounding). An edge
    // the bound cannot clear gets the exact test.
    let (sine_sq, cosine) = (a.cross(b).length_squared(), a.dot(b));
    (cosine > 0.0 && rule.is_short_squared(proj, sine_sq / (cosine * cosine) * (1.0 + 1e-11)))
        || rule.is_short(proj, subtended_angle(a, b))
}

/// [`refine_triangle`] for a triangle cut at the view plane whose clipped
/// parts all stay whole (most of those at the horizon of a large scene),
/// built directly: the clipped polygon fanned, and the rim skirt's quad
/// along its cut. The same triangles, with the same winding and vertex
/// bits, as the full path makes (which splits, skirts and welds each part
/// on its own; the test `cut_triangles_left_whole_match_the_full_path`
/// holds them together), at a fraction of its cost. `None` where the full
/// path is needed: a part to split, a corner at the origin, repeated
/// corners, or a cut that is not one edge of two points on the plane.
fn cut_left_whole(
    proj: &DomeProjection,
    tri: [DVec3; 3],
    rule: SplitRule,
    scale: f64,
    skirt: Option<(f64, DVec3)>,
) -> Option<RefinedMesh> {
    let axis = proj.axis();
    let (poly, n) = clip_polygon_plane(axis, tri);
    let poly = &poly[..n];
    if n < 3 || poly.iter().any(|p| p.length() <= AT_ORIGIN_REL * scale) {
        return None;
    }
    if (0..n).any(|i| (i + 1..n).any(|j| weld_key(poly[i]) == weld_key(poly[j]))) {
        return None;
    }
    // Every edge of every fan triangle (the polygon's sides and diagonals).
    let short = |i: usize, j: usize| edge_is_short(proj, poly[i], poly[j], rule);
    if !(0..n).all(|i| short(i, (i + 1) % n)) || !(2..n - 1).all(|k| short(0, k)) {
        return None;
    }
    // (Room for the skirt's two points and two triangles up front.)
    let mut positions = Vec::with_capacity(n + 2);
    positions.extend_from_slice(poly);
    let mut triangles: Vec<[u32; 3]> = Vec::with_capacity(n);
    triangles.extend((1..n as u32 - 1).map(|k| [0, k, k + 1]));
    let mut skirt_triangles = 0;
    if let Some((angle, direction)) = skirt {
        // The skirt's edges: those with both ends on the plane; the fast
        // path takes only the one the cut makes.
        let on_plane = |p: DVec3| on_view_plane(p, axis);
        let cut: Vec<usize> = (0..n)
            .filter(|&i| on_plane(poly[i]) && on_plane(poly[(i + 1) % n]))
            .collect();
        if poly.iter().filter(|p| on_plane(**p)).count() != 2 || cut.len() != 1 {
            return None;
        }
        let (a, b) = (cut[0], (cut[0] + 1) % n);
        let (tan, behind) = (angle.tan(), -direction.dot(axis));
        let past = |p: DVec3| p + (tan * p.length() / behind).min(4.0 * p.length()) * direction;
        let (pa, pb) = (past(poly[a]), past(poly[b]));
        if weld_key(pa) == weld_key(pb) {
            return None;
        }
        positions.extend([pa, pb]);
        let (a, b, a2, b2) = (a as u32, b as u32, n as u32, n as u32 + 1);
        triangles.extend([[b, a, a2], [b, a2, b2]]);
        skirt_triangles = 2;
    }
    let stats = RefineStats {
        input: 1,
        emitted: triangles.len(),
        skirt: skirt_triangles,
        ..Default::default()
    };
    Some(RefinedMesh {
        mesh: TriMesh {
            positions,
            triangles,
        },
        stats,
    })
}

/// Clips at the view plane (FOV ≤ 180°; next to 180° with a rim skirt, see
/// [`DomeProjection::rim_skirt_rad`]), refines (paper §3.3) and, for wider
/// FOVs, culls at the guard cone one triangle (see
/// [`clip_segment`](super::clip_segment) docs). Errors: a non-finite vertex ([`DomeError::Input`]). Parts touching
/// the origin or with an edge through the viewer are left out and counted.
pub fn refine_triangle(
    proj: &DomeProjection,
    tri: [DVec3; 3],
    rule: SplitRule,
) -> Result<RefinedMesh, DomeError> {
    for v in tri {
        input::finite_vec3("vertex (view space)", v)?;
    }
    Ok(refine_finite_triangle(proj, tri, rule))
}

/// [`refine_triangle`] for a triangle with finite vertices.
fn refine_finite_triangle(proj: &DomeProjection, tri: [DVec3; 3], rule: SplitRule) -> RefinedMesh {
    refine_finite_triangle_by(proj, tri, rule, Path::Short)
}

/// Which way [`refine_finite_triangle_by`] refines a cut triangle that needs
/// no split.
#[derive(Clone, Copy, PartialEq)]
enum Path {
    /// Built directly (`cut_left_whole`).
    Short,
    /// Split, skirted and welded part by part like every other triangle
    /// (for the test that holds the two ways together).
    #[cfg_attr(not(test), allow(dead_code))]
    Full,
}

/// [`refine_finite_triangle`], taking `path` for cut triangles.
fn refine_finite_triangle_by(
    proj: &DomeProjection,
    tri: [DVec3; 3],
    rule: SplitRule,
    path: Path,
) -> RefinedMesh {
    let mut stats = RefineStats {
        input: 1,
        ..Default::default()
    };
    let lengths = tri.map(|v| v.length());
    let scale = lengths.iter().fold(0.0, |m: f64, &l| m.max(l));
    if proj.clips_at_view_plane() && tri.iter().all(|v| v.dot(proj.axis()) < 0.0) {
        // Wholly behind the view plane (half of every scene around a
        // dome): nothing to clip or split.
        stats.clipped_away = 1;
        return RefinedMesh {
            mesh: TriMesh::default(),
            stats,
        };
    }
    if is_left_whole(proj, tri, rule) {
        stats.emitted = 1;
        return RefinedMesh {
            mesh: TriMesh {
                positions: tri.to_vec(),
                triangles: vec![[0, 1, 2]],
            },
            stats,
        };
    }
    // A triangle cut at a view plane next to the rim gets a skirt along the
    // cut, in its own plane (see `add_rim_skirt`).
    let cut = tri.iter().any(|v| v.dot(proj.axis()) < 0.0);
    let skirt = proj
        .rim_skirt_rad()
        .filter(|_| cut)
        .and_then(|angle| Some((angle, skirt_direction(tri, proj.axis())?)));
    if path == Path::Short
        && cut
        && proj.clips_at_view_plane()
        && let Some(done) = cut_left_whole(proj, tri, rule, scale, skirt)
    {
        return done;
    }
    let parts = if proj.clips_at_view_plane() {
        clip_triangle_plane(proj.axis(), tri)
    } else {
        vec![tri]
    };
    if parts.is_empty() {
        stats.clipped_away = 1;
    }
    let pieces = |arc: &Arc| rule.pieces_of_arc(proj, arc);
    let mut welder = Welder::default();
    // One count per input triangle and cause, however many parts it hits.
    let mut dropped = RefineStats::default();
    let single = parts.len() == 1;
    for part in parts {
        let subdivided = if part.iter().any(|v| v.length() <= AT_ORIGIN_REL * scale) {
            Err(ArcError::AtOrigin)
        } else {
            // Errors: an edge through the viewer; or, for huge finite
            // coordinates, a product that overflows (counted as non-finite).
            subdivide_triangle(part, &pieces, proj.lens() == FisheyeLens::Equidistant)
        };
        let (mut local, capped) = match subdivided {
            Ok(r) => r,
            Err(cause) => {
                dropped.drop_for(cause);
                continue;
            }
        };
        stats.capped_edges += usize::from(capped);
        if let Some((angle, direction)) = skirt {
            stats.skirt += add_rim_skirt(&mut local, proj.axis(), direction, angle);
        }
        if !proj.clips_at_view_plane() {
            let limit = proj.theta_clip();
            let anti = -proj.axis();
            let before = local.triangles.len();
            let pos = &local.positions;
            local.triangles.retain(|t| {
                let v = t.map(|i| pos[i as usize]);
                v.iter().all(|&p| proj.theta(p) <= limit) && !covers_direction(&v, anti)
            });
            stats.culled += before - local.triangles.len();
        }
        // One part left whole (most distant geometry): nothing to weld.
        let [a, b, c] = local.positions[..] else {
            welder.add(&local);
            continue;
        };
        if single && local.triangles.len() == 1 && a != b && b != c && a != c {
            welder.mesh = local;
            continue;
        }
        welder.add(&local);
    }
    stats.dropped_nonfinite = dropped.dropped_nonfinite.min(1);
    stats.dropped_at_origin = dropped.dropped_at_origin.min(1);
    stats.dropped_through_viewer = dropped.dropped_through_viewer.min(1);
    stats.emitted = welder.mesh.triangles.len();
    RefinedMesh {
        mesh: welder.mesh,
        stats,
    }
}

/// The direction in the plane of `tri`, across the view plane (normal
/// `axis`) and away from the front: where the triangle goes on behind its
/// cut. `None` for a degenerate triangle or one nearly parallel to the
/// view plane (its cut is a sliver at most).
fn skirt_direction(tri: [DVec3; 3], axis: DVec3) -> Option<DVec3> {
    let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
    let along_cut = n.cross(axis);
    let d = n.cross(along_cut).try_normalize()?;
    let d = if d.dot(axis) > 0.0 { -d } else { d };
    (d.dot(axis) < -1e-6).then_some(d)
}

/// Adds to `m` (a refined part of a triangle cut at the view plane) a skirt
/// along its cut: each boundary edge lying on the plane gets a quad that
/// carries the triangle on in `direction` (in its plane, behind the view
/// plane) until its vertices are `angle` past the plane. Why: the cut's
/// chords join points on the rim of a 180° dome and sag inside the image
/// circle by up to the tolerance; the skirt covers that ring with the
/// triangle's own surface, and its far edge, `angle` outside the rim, sags
/// nowhere near the circle (its pieces are as short as the cut's). No
/// crack: the skirt only adds triangles along edges no other triangle of
/// the input uses; neighbours' skirts meet at the shared cut point on the
/// rim. Returns the number of triangles added.
fn add_rim_skirt(m: &mut TriMesh, axis: DVec3, direction: DVec3, angle: f64) -> usize {
    let on_plane = |p: DVec3| on_view_plane(p, axis);
    // Every edge as (low, high) index, sorted: an edge used once is a
    // boundary edge. (A sort, not a hash map: most inputs are one or two
    // triangles.)
    let on_cut = |t: [u32; 3], k: usize| {
        on_plane(m.positions[t[k] as usize]) && on_plane(m.positions[t[(k + 1) % 3] as usize])
    };
    if !m.triangles.iter().any(|&t| (0..3).any(|k| on_cut(t, k))) {
        return 0;
    }
    let key = |a: u32, b: u32| [a.min(b), a.max(b)];
    let mut edges = Vec::with_capacity(3 * m.triangles.len());
    for t in &m.triangles {
        edges.extend((0..3).map(|k| key(t[k], t[(k + 1) % 3])));
    }
    edges.sort_unstable();
    let used_once = |e: [u32; 2]| {
        let at = edges.partition_point(|x| *x < e);
        edges.get(at + 1) != Some(&e)
    };
    // How far to go along `direction` from p for `angle` past the plane,
    // at most 4|p| (a triangle nearly parallel to the view plane would
    // otherwise run far out sideways).
    let (tan, behind) = (angle.tan(), -direction.dot(axis));
    let mut beyond = vec![u32::MAX; m.positions.len()];
    // (Quads go straight onto the triangle list: only the triangles there
    // before are looked at.)
    let before = m.triangles.len();
    for ti in 0..before {
        let t = m.triangles[ti];
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            let (pa, pb) = (m.positions[a as usize], m.positions[b as usize]);
            if !on_plane(pa) || !on_plane(pb) || !used_once(key(a, b)) {
                continue;
            }
            let mut past = |i: u32| {
                if beyond[i as usize] == u32::MAX {
                    let p = m.positions[i as usize];
                    let s = (tan * p.length() / behind).min(4.0 * p.length());
                    m.positions.push(p + s * direction);
                    beyond[i as usize] = (m.positions.len() - 1) as u32;
                }
                beyond[i as usize]
            };
            let (a2, b2) = (past(a), past(b));
            // The quad b → a → a' → b', wound like its neighbour (which
            // runs a → b).
            m.triangles.extend([[b, a, a2], [b, a2, b2]]);
        }
    }
    m.triangles.len() - before
}

/// Refines every triangle of a mesh in parallel and welds the result by exact
/// position. Triangles with a non-finite vertex, a vertex at the origin or an
/// edge through the viewer are left out and counted per cause in the stats.
pub fn refine_mesh(proj: &DomeProjection, mesh: &TriMesh, rule: SplitRule) -> RefinedMesh {
    let patches: Vec<RefinedMesh> = mesh
        .triangles
        .par_iter()
        .map(|&t| {
            let tri = mesh.corners(t);
            if tri.iter().all(|v| v.is_finite()) {
                refine_finite_triangle(proj, tri, rule)
            } else {
                let stats = RefineStats {
                    input: 1,
                    dropped_nonfinite: 1,
                    ..Default::default()
                };
                RefinedMesh {
                    mesh: TriMesh::default(),
                    stats,
                }
            }
        })
        .collect();
    let mut welder = Welder::default();
    let mut stats = RefineStats::default();
    for p in &patches {
        welder.add(&p.mesh);
        stats = stats.merge(p.stats);
    }
    stats.emitted = welder.mesh.triangles.len();
    RefinedMesh {
        mesh: welder.mesh,
        stats,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dome::RIM_MARGIN_DEG;
    use crate::input::Expected;
    use proptest::prelude::*;

    fn dome(fov: f64) -> DomeProjection {
        crate::dome::test_dome(fov, 0.0, 4096)
    }

    fn chord_gap(tolerance_px: f64) -> SplitRule {
        SplitRule::chord_gap(tolerance_px).unwrap()
    }

    fn box_mesh(min: DVec3, max: DVec3, inside_out: bool) -> TriMesh {
        TriMesh::cuboid(min, max, inside_out)
    }

    fn area_normal(m: &TriMesh, t: [u32; 3]) -> DVec3 {
        let p = t.map(|i| m.positions()[i as usize]);
        (p[1] - p[0]).cross(p[2] - p[0])
    }

    #[test]
    fn closed_mesh_stays_closed() {
        // A box in front of the viewer at 180°: nothing is clipped, so a
        // crack-free refinement of a closed mesh is closed (every edge used
        // by exactly two triangles).
        let p = dome(180.0);
        let m = box_mesh(
            DVec3::new(-3.0, -2.0, -6.0),
            DVec3::new(2.0, 3.0, -1.5),
            false,
        );
        for tol in [4.0, 1.0, 0.3] {
            let r = refine_mesh(&p, &m, chord_gap(tol));
            assert!(r.mesh.triangles.len() > 12);
            assert!(r.mesh.boundary_edges().is_empty(), "tol {tol}");
        }
    }

    #[test]
    fn shared_edge_split_identically_from_both_sides() {
        // Two triangles sharing edge (a, b) with very different opposite
        // corners: the split points on the edge are the same bits.
        let p = dome(180.0);
        let rule = chord_gap(0.5);
        let (a, b) = (DVec3::new(-3.0, -1.0, -1.0), DVec3::new(3.0, -0.5, -0.6));
        let r1 = refine_triangle(&p, [a, b, DVec3::new(0.0, 4.0, -1.0)], rule).unwrap();
        let r2 = refine_triangle(&p, [b, a, DVec3::new(0.1, -3.0, -0.2)], rule).unwrap();
        let on_edge = |m: &TriMesh| {
            let mut v: Vec<[u64; 3]> = m
                .positions
                .iter()
                .filter(|&&x| (x - a).cross(b - a).length() < 1e-12)
                .map(|x| [x.x.to_bits(), x.y.to_bits(), x.z.to_bits()])
                .collect();
            v.sort_unstable();
            v
        };
        let (e1, e2) = (on_edge(&r1.mesh), on_edge(&r2.mesh));
        assert!(e1.len() > 4);
        assert_eq!(e1, e2);
    }

    #[test]
    fn winding_is_kept_and_area_conserved() {
        let p = dome(180.0);
        let tri = [
            DVec3::new(-2.0, -1.0, -1.0),
            DVec3::new(3.0, -0.5, -0.6),
            DVec3::new(0.5, 4.0, -0.8),
        ];
        let n0 = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let r = refine_triangle(&p, tri, chord_gap(0.5)).unwrap();
        let mut area = 0.0;
        for &t in &r.mesh.triangles {
            let n = area_normal(&r.mesh, t);
            assert!(n.dot(n0) > 0.0);
            area += n.length();
        }
        assert!(
            (area / n0.length() - 1.0).abs() < 1e-9,
            "area ratio {}",
            area / n0.length()
        );
    }

    #[test]
    fn unequal_sides_and_tiny_triangles() {
        // A long thin triangle (sides with very different piece counts) and
        // a triangle too small to split: valid fans, area conserved.
        let p = dome(180.0);
        let rule = chord_gap(0.5);
        for tri in [
            [
                DVec3::new(-4.0, 0.0, -1.0),
                DVec3::new(4.0, 0.1, -1.0),
                DVec3::new(4.0, 0.6, -1.2),
            ],
            [
                DVec3::new(0.0, 0.0, -10.0),
                DVec3::new(0.01, 0.0, -10.0),
                DVec3::new(0.0, 0.01, -10.0),
            ],
        ] {
            let n0 = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
            let r = refine_triangle(&p, tri, rule).unwrap();
            let area: f64 = r
                .mesh
                .triangles
                .iter()
                .map(|&t| area_normal(&r.mesh, t).length())
                .sum();
            assert!((area / n0.length() - 1.0).abs() < 1e-9);
            assert!(
                r.mesh
                    .triangles
                    .iter()
                    .all(|&t| area_normal(&r.mesh, t).dot(n0) > 0.0)
            );
            assert!(r.mesh.boundary_edges().len() >= 3);
        }
    }

    #[test]
    fn inside_out_room_clipped_at_view_plane() {
        // The case that broke an unclipped lavapipe render: a zenith camera inside a box. The
        // floor (behind the viewer) is clipped away, walls are cut at z = 0;
        // the only open boundary lies on the view plane (170°: next to 180°
        // the guard cone takes over, see the next test).
        let p = dome(170.0);
        let m = box_mesh(
            DVec3::new(-4.0, -6.0, -3.0),
            DVec3::new(4.0, 3.0, 1.7),
            true,
        );
        let r = refine_mesh(&p, &m, chord_gap(2.0));
        assert_eq!(r.stats.clipped_away, 2);
        assert!(r.mesh.positions.iter().all(|v| v.z <= 0.0));
        let b = r.mesh.boundary_edges();
        assert!(!b.is_empty());
        for [i, j] in b {
            assert!(
                r.mesh.positions()[i as usize].z.abs() < 1e-12
                    && r.mesh.positions[j as usize].z.abs() < 1e-12
            );
        }
    }

    #[test]
    fn the_rim_of_a_180_degree_dome_is_covered() {
        // The same room at 180° and 0.5 px. Cut at the view plane, the walls
        // end in chords between points on the rim, sagging up to the
        // tolerance inside the image circle: an uncovered ring. Their rim
        // skirts, 1° on past the plane, make the drawn triangles (straight
        // in the image) cover every point of the circle just inside the rim.
        let p = dome(180.0);
        assert_eq!(p.rim_skirt_rad(), Some(RIM_MARGIN_DEG.to_radians()));
        let m = box_mesh(
            DVec3::new(-4.0, -6.0, -3.0),
            DVec3::new(4.0, 3.0, 1.7),
            true,
        );
        let r = refine_mesh(&p, &m, chord_gap(0.5));
        assert_eq!(r.stats.clipped_away, 2);
        assert!(r.stats.skirt > 0);
        let px = |v: DVec3| p.project(v).image_point().unwrap().pixel;
        let tris: Vec<[glam::DVec2; 3]> = r
            .mesh
            .triangles
            .iter()
            .map(|t| t.map(|i| px(r.mesh.positions()[i as usize])))
            .collect();
        let inside = |t: &[glam::DVec2; 3], q: glam::DVec2| {
            let s = |a: glam::DVec2, b: glam::DVec2| (b - a).perp_dot(q - a);
            let (d0, d1, d2) = (s(t[0], t[1]), s(t[1], t[2]), s(t[2], t[0]));
            (d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0) || (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0)
        };
        let (c, rim) = (p.centre_px(), p.rim_radius_px());
        for k in 0..2000 {
            let phi = std::f64::consts::TAU * f64::from(k) / 2000.0;
            let q = c + (rim - 0.05) * glam::DVec2::from_angle(phi);
            assert!(tris.iter().any(|t| inside(t, q)), "{q} uncovered");
        }
        // The skirt reaches about 1° past the rim, no further; at 178° the
        // view plane is already 1° outside the rim and no skirt is added.
        let reach = r
            .mesh
            .positions()
            .iter()
            .map(|&v| p.theta(v).to_degrees())
            .fold(0.0, f64::max);
        assert!(reach > 90.9 && reach < 91.01, "{reach}°");
        let p178 = dome(178.0);
        assert_eq!(refine_mesh(&p178, &m, chord_gap(0.5)).stats.skirt, 0);
    }

    /// The triangles of a refined mesh as sets of corner bits, each
    /// rotated to start at its smallest corner (the full path rotates a
    /// part to its longest edge first): equal sets are the same triangles
    /// with the same winding, whatever the vertex order.
    fn triangle_set(r: &RefinedMesh) -> Vec<[[u64; 3]; 3]> {
        let mut set: Vec<[[u64; 3]; 3]> = r
            .mesh
            .triangles
            .iter()
            .map(|t| {
                let c = t.map(|i| weld_key(r.mesh.positions[i as usize]));
                let k = (0..3).min_by_key(|&k| c[k]).expect("three corners");
                [c[k], c[(k + 1) % 3], c[(k + 2) % 3]]
            })
            .collect();
        set.sort_unstable();
        set
    }

    #[test]
    fn cut_triangles_left_whole_match_the_full_path() {
        // Triangles of all sizes straddling the view plane of a 180° dome
        // (skirted), a 170° one (no skirt) and a tilted one, with corners
        // on the plane and corners at repeated points: the short path gives
        // the full path's triangles bit for bit, or leaves them to it.
        let mut uniform = crate::dome::test_uniform(0x5EED);
        let mut next = move || uniform() - 0.5;
        let (mut short, mut full) = (0, 0);
        for (fov, tilt) in [(180.0, 0.0), (170.0, 0.0), (180.0, 20.0)] {
            let p = crate::dome::test_dome(fov, tilt, 4096);
            let axis = p.axis();
            for i in 0..3000 {
                let size = 10f64.powf(-2.0 + 3.0 * (next() + 0.5));
                let centre = 20.0 * DVec3::new(next(), next(), next());
                let centre = centre - centre.dot(axis) * axis;
                let mut tri = [0; 3].map(|_| centre + size * DVec3::new(next(), next(), next()));
                match i % 10 {
                    // A corner exactly on the plane.
                    7 => tri[0] -= tri[0].dot(axis) * axis,
                    // Two corners at one point.
                    8 => tri[2] = tri[1],
                    _ => {}
                }
                let d = tri.map(|v| v.dot(axis));
                if !(d.iter().any(|&x| x < 0.0) && d.iter().any(|&x| x > 0.0)) {
                    continue;
                }
                for tol in [0.5, 4.0] {
                    let rule = chord_gap(tol);
                    let fast = refine_finite_triangle_by(&p, tri, rule, Path::Short);
                    let slow = refine_finite_triangle_by(&p, tri, rule, Path::Full);
                    assert_eq!(
                        triangle_set(&fast),
                        triangle_set(&slow),
                        "{tri:?} at {fov}°"
                    );
                    assert_eq!(fast.stats, slow.stats, "{tri:?}");
                    let scale = tri.iter().map(|v| v.length()).fold(0.0, f64::max);
                    let skirt = p
                        .rim_skirt_rad()
                        .and_then(|a| Some((a, skirt_direction(tri, axis)?)));
                    match cut_left_whole(&p, tri, rule, scale, skirt) {
                        Some(_) => short += 1,
                        None => full += 1,
                    }
                }
            }
        }
        // Both ways were exercised.
        assert!(short > 1000 && full > 1000, "{short} short, {full} full");
    }

    #[test]
    fn wide_fov_culls_only_near_the_antipode() {
        // 250°: no clipping; the floor under the zenith camera is refined and
        // the sub-triangles near the antipode (beyond 152.5°) are culled. Every
        // kept vertex is finite and inside the guard cone; everything inside
        // the image circle (θ ≤ 125°) of the floor is kept: it is still
        // covered by sub-triangles (checked on a grid of floor points).
        let p = dome(250.0);
        let m = box_mesh(
            DVec3::new(-4.0, -6.0, -3.0),
            DVec3::new(4.0, 3.0, 1.7),
            true,
        );
        let r = refine_mesh(&p, &m, chord_gap(2.0));
        assert!(r.stats.culled > 0);
        assert!(r.mesh.positions.iter().all(|v| v.is_finite()));
        for t in &r.mesh.triangles {
            for &i in t {
                assert!(p.theta(r.mesh.positions()[i as usize]) <= p.theta_clip() + 1e-12);
            }
        }
        let floor: Vec<[DVec3; 3]> = r
            .mesh
            .triangles
            .iter()
            .map(|t| t.map(|i| r.mesh.positions()[i as usize]))
            .filter(|v| v.iter().all(|q| (q.z - 1.7).abs() < 1e-9))
            .collect();
        for i in 0..16 {
            for j in 0..18 {
                // Cell centres: off the floor's own edges, where barycentric
                // round-off could say "outside".
                let q = DVec3::new(-3.75 + 0.5 * f64::from(i), -5.75 + 0.5 * f64::from(j), 1.7);
                if p.theta(q) <= p.theta_max() {
                    assert!(
                        floor.iter().any(|v| covers_direction(v, q)),
                        "{q} not covered"
                    );
                }
            }
        }
    }

    #[test]
    fn out_of_range_index_is_refused_when_the_mesh_is_built() {
        let pos = vec![DVec3::X, DVec3::Y, DVec3::Z];
        assert_eq!(
            TriMesh::new(pos.clone(), vec![[0, 1, 2], [0, 1, 3]]),
            Err(DomeError::IndexOutOfRange { index: 3, len: 3 })
        );
        assert_eq!(
            TriMesh::new(vec![], vec![[0, 0, 0]]),
            Err(DomeError::IndexOutOfRange { index: 0, len: 0 })
        );
        let m = TriMesh::new(pos.clone(), vec![[2, 1, 0]]).unwrap();
        assert_eq!((m.positions(), m.triangles()), (&pos[..], &[[2, 1, 0]][..]));
        assert_eq!(m.into_parts(), (pos, vec![[2, 1, 0]]));
    }

    #[test]
    fn bad_triangles_are_counted_per_cause() {
        let p = dome(170.0);
        let rule = chord_gap(1.0);
        // A box in front of the viewer with vertex 0 NaN: the triangles using
        // it are dropped as non-finite, the others refined.
        let (mut positions, mut triangles) = box_mesh(
            DVec3::splat(-1.0) - DVec3::Z * 3.0,
            DVec3::splat(1.0) - DVec3::Z * 3.0,
            false,
        )
        .into_parts();
        let uses_0 = triangles.iter().filter(|t| t.contains(&0)).count();
        positions[0] = DVec3::new(f64::NAN, 0.0, 0.0);
        // A triangle with a corner at the origin, and one with an edge
        // through the viewer, (−1, 0, 0) … (1, 0, 0), in the view plane.
        let n = positions.len() as u32;
        positions.extend([
            DVec3::ZERO,
            DVec3::new(1.0, 0.0, -3.0),
            DVec3::new(0.0, 1.0, -3.0),
        ]);
        positions.extend([DVec3::NEG_X, DVec3::X, DVec3::new(0.0, 1.0, -1.0)]);
        triangles.extend([[n, n + 1, n + 2], [n + 3, n + 4, n + 5]]);
        let r = refine_mesh(&p, &TriMesh::new(positions, triangles).unwrap(), rule);
        assert_eq!(r.stats.input, 14);
        assert_eq!(r.stats.dropped_nonfinite, uses_0);
        assert_eq!(r.stats.dropped_at_origin, 1);
        assert_eq!(r.stats.dropped_through_viewer, 1);
        assert!(r.stats.emitted > 12 - uses_0);
        assert!(r.mesh.positions().iter().all(|v| v.is_finite()));

        // One triangle: a non-finite vertex is an error naming it ...
        let nan = [
            DVec3::new(f64::NAN, 0.0, -1.0),
            DVec3::NEG_Z,
            DVec3::X - DVec3::Z,
        ];
        match refine_triangle(&p, nan, rule) {
            Err(DomeError::Input(e)) => assert_eq!(
                (e.what, e.expected),
                ("vertex (view space)", Expected::FiniteVector)
            ),
            other => panic!("{other:?}"),
        }
        // ... while the singular places are counted. An edge through the
        // viewer: unclipped at 250°; at 170° the view plane cuts it at the
        // viewer, so its part in front has a corner at the origin.
        let t = [
            DVec3::new(-1.0, 0.0, -1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 1.0, -1.0),
        ];
        let r = refine_triangle(&dome(250.0), t, rule).unwrap();
        assert_eq!(
            (r.stats.dropped_through_viewer, r.stats.dropped_at_origin),
            (1, 0)
        );
        let r = refine_triangle(&p, t, rule).unwrap();
        assert_eq!(
            (r.stats.dropped_through_viewer, r.stats.dropped_at_origin),
            (0, 1)
        );
        assert!(r.mesh.positions().iter().all(|v| v.is_finite()));
        let t = [
            DVec3::ZERO,
            DVec3::new(1.0, 0.0, -3.0),
            DVec3::new(0.0, 1.0, -3.0),
        ];
        let r = refine_triangle(&p, t, rule).unwrap();
        assert_eq!(
            (
                r.stats.dropped_through_viewer,
                r.stats.dropped_at_origin,
                r.stats.emitted
            ),
            (0, 1, 0)
        );
        // Behind the viewer: clipped away, not dropped.
        let t = [
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(1.0, 0.0, 3.0),
            DVec3::new(0.0, 1.0, 3.0),
        ];
        let r = refine_triangle(&p, t, rule).unwrap();
        assert_eq!((r.stats.clipped_away, r.stats.emitted), (1, 0));
    }

    fn v3() -> impl Strategy<Value = DVec3> {
        (-5.0f64..5.0, -5.0f64..5.0, -5.0f64..5.0).prop_map(|(x, y, z)| DVec3::new(x, y, z))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        #[test]
        fn refined_triangle_edges_are_within_tolerance(
            fov in 90.0f64..250.0, tilt in -30.0f64..30.0, tol in 0.5f64..8.0,
            a in v3(), b in v3(), c in v3(),
        ) {
            let p = crate::dome::test_dome(fov, tilt, 4096);
            let r = refine_triangle(&p, [a, b, c], chord_gap(tol)).unwrap();
            prop_assert!(r.mesh.positions.iter().all(|v| v.is_finite()));
            // Every sub-triangle keeps the input's winding and has area: no
            // collinear triples (they would hide T-junctions).
            let n0 = (b - a).cross(c - a);
            if n0.length() > 1e-3 {
                for &t in &r.mesh.triangles {
                    prop_assert!(area_normal(&r.mesh, t).dot(n0) > 0.0);
                }
            }
            if r.stats.capped_edges == 0 {
                let e = crate::dome::EdgeErrors::of_mesh(&p, &r.mesh);
                prop_assert_eq!(e.failed, 0);
                prop_assert!(e.max_px <= tol, "{:?} tol {}", e, tol);
            }
        }

        #[test]
        fn every_lens_meets_the_tolerance(
            lens in 0usize..5, fov in 60.0f64..250.0, tilt in -30.0f64..30.0, tol in 0.5f64..8.0,
            a in v3(), b in v3(), c in v3(),
        ) {
            // As above, for every radial lens (D10 sampled along each arc).
            let lens = crate::dome::rule::tests::TEST_LENSES[lens];
            let fov = fov.min(lens.max_fov_deg());
            let p = crate::dome::test_lens_dome(lens, fov, tilt, 4096);
            let r = refine_triangle(&p, [a, b, c], chord_gap(tol)).unwrap();
            prop_assert!(r.mesh.positions.iter().all(|v| v.is_finite()));
            if r.stats.capped_edges == 0 {
                let e = crate::dome::EdgeErrors::of_mesh(&p, &r.mesh);
                prop_assert_eq!(e.failed, 0);
                prop_assert!(e.max_px <= tol, "{:?} {:?} tol {}", lens, e, tol);
            }
        }

        #[test]
        fn two_triangles_sharing_an_edge_leave_no_crack(
            fov in 90.0f64..250.0, tilt in -30.0f64..30.0, tol in 0.5f64..8.0,
            a in v3(), b in v3(), c in v3(), d in v3(),
        ) {
            // Triangles (a, b, c) and (b, a, d) share edge a–b. Refined
            // separately, the open pieces each leaves on a–b must not have a
            // vertex of the other strictly inside them (a T-junction, i.e. a
            // crack). With FOV ≤ 180° both keep the same clipped part of a–b,
            // so the pieces must be identical and the welded pair has no open
            // piece on a–b at all. (With FOV > 180° each side may cull
            // different sub-triangles beyond the rim.)
            let p = crate::dome::test_dome(fov, tilt, 4096);
            let rule = chord_gap(tol);
            let ab = b - a;
            prop_assume!(ab.length() > 1e-3);
            let param = |v: DVec3| (v - a).dot(ab) / ab.length_squared();
            let open_on_ab = |m: &TriMesh| {
                let mut s: Vec<[f64; 2]> = m.boundary_edges().into_iter()
                    .map(|e| e.map(|i| m.positions()[i as usize]))
                    .filter(|e| e.iter().all(|&v| (v - a).cross(ab).length() <= 1e-9 * ab.length() * (1.0 + a.length())))
                    .map(|e| { let (s0, s1) = (param(e[0]), param(e[1])); [s0.min(s1), s0.max(s1)] })
                    .collect();
                s.sort_by(|x, y| x[0].total_cmp(&y[0]));
                s
            };
            let one = refine_mesh(&p, &TriMesh { positions: vec![a, b, c], triangles: vec![[0, 1, 2]] }, rule);
            let other = refine_mesh(&p, &TriMesh { positions: vec![a, b, d], triangles: vec![[1, 0, 2]] }, rule);
            let (s1, s2) = (open_on_ab(&one.mesh), open_on_ab(&other.mesh));
            for (x, y) in [(&s1, &s2), (&s2, &s1)] {
                for piece in x {
                    for q in y {
                        for v in q {
                            prop_assert!(!(piece[0] < *v && *v < piece[1]), "T-junction at {} in {:?}", v, piece);
                        }
                    }
                }
            }
            if p.clips_at_view_plane() {
                prop_assert_eq!(&s1, &s2);
                let both = refine_mesh(&p, &TriMesh { positions: vec![a, b, c, d], triangles: vec![[0, 1, 2], [1, 0, 3]] }, rule);
                prop_assert!(open_on_ab(&both.mesh).is_empty());
            }
        }
    }
}
