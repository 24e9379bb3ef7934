//! Conforming bisection of interior edges that still break the rule after
//! the paper's strip triangulation (our addition to §3.3).
//!
//! The paper spaces its rungs by the split points of the triangle's two
//! shorter sides. Those are placed for the sides' own needs; where the
//! inside of a triangle is nearer the viewer than its sides (a ceiling seen
//! from below: the middle is near the zenith, the sides far away), rungs are
//! wider apart in angle than the sides' pieces, and the stitched diagonals
//! between them subtend several times the allowed angle (we measured 13°
//! diagonals, 4.5× the tolerance, at 0.5 px on the ceiling of an inside-out
//! room, 8 × 9 × 4.7 m, seen by a zenith camera 1.7 m above its floor).
//!
//! Fix: while an interior edge needs more than one piece under the rule,
//! bisect it at its angular midpoint (D7) and split both triangles sharing it
//! through the midpoint (longest edge first). Only edges shared by two
//! triangles of the patch are touched, so the patch boundary — the split
//! input edges that neighbours share — is never changed and the result stays
//! crack-free. A budget on the triangle count bounds the work.

use std::collections::BinaryHeap;

use glam::DVec3;

use super::arc::{split_segment, subtended_angle};
use super::triangle::{FastMap, TriMesh};

/// "No triangle" in an edge's pair of users (a boundary edge has one).
const NONE: u32 = u32::MAX;

fn key(a: u32, b: u32) -> [u32; 2] {
    if a < b { [a, b] } else { [b, a] }
}

/// Bisects interior edges of `mesh` for which `needs_split` holds, until none
/// does or the mesh has `max_triangles` triangles. Returns whether the budget
/// stopped it. Nothing is done unless one of `candidates` (the patch's
/// interior edges, as the strip triangulation made them; boundary edges
/// among them are harmless) needs a split.
pub(crate) fn bisect_interior(
    mesh: &mut TriMesh,
    candidates: &[[u32; 2]],
    needs_split: &dyn Fn(DVec3, DVec3) -> bool,
    max_triangles: usize,
) -> bool {
    // Most patches have nothing to split: find that out before building
    // the edge map.
    let position = |i: u32| mesh.positions[i as usize];
    if !candidates
        .iter()
        .any(|e| needs_split(position(e[0]), position(e[1])))
    {
        return false;
    }
    // Edge → the (at most two) triangles using it.
    let mut edges: FastMap<[u32; 2], [u32; 2]> = FastMap::default();
    let add_edge = |edges: &mut FastMap<[u32; 2], [u32; 2]>, a: u32, b: u32, t: u32| {
        let e = edges.entry(key(a, b)).or_insert([NONE, NONE]);
        if e[0] == NONE { e[0] = t } else { e[1] = t }
    };
    for (ti, t) in mesh.triangles.iter().enumerate() {
        for k in 0..3 {
            add_edge(&mut edges, t[k], t[(k + 1) % 3], ti as u32);
        }
    }
    let angle = |m: &TriMesh, e: [u32; 2]| {
        subtended_angle(m.positions[e[0] as usize], m.positions[e[1] as usize])
    };
    let mut heap: BinaryHeap<(u64, [u32; 2])> = BinaryHeap::new();
    let consider = |heap: &mut BinaryHeap<(u64, [u32; 2])>,
                    m: &TriMesh,
                    e: [u32; 2],
                    users: [u32; 2]| {
        if users[1] != NONE && needs_split(m.positions[e[0] as usize], m.positions[e[1] as usize]) {
            // Positive f64 bits sort like the values: longest first.
            heap.push((angle(m, e).to_bits(), e));
        }
    };
    for (&e, &users) in &edges {
        consider(&mut heap, mesh, e, users);
    }
    while let Some((_, e)) = heap.pop() {
        let Some(&users) = edges.get(&e) else {
            continue;
        }; // already bisected
        if mesh.triangles.len() + 2 > max_triangles {
            return true;
        }
        let (pa, pb) = (mesh.positions[e[0] as usize], mesh.positions[e[1] as usize]);
        let Ok(pts) = split_segment(pa, pb, 2) else {
            continue;
        };
        let mid = mesh.positions.len() as u32;
        mesh.positions.push(pts[1]);
        edges.remove(&e);
        let mut touched = vec![key(e[0], mid), key(mid, e[1])];
        for t in users {
            let tri = mesh.triangles[t as usize];
            // Rotate so the split edge is (x, y), in the triangle's winding.
            let k = (0..3)
                .find(|&k| key(tri[k], tri[(k + 1) % 3]) == e)
                .expect("edge of its triangle");
            let (x, y, w) = (tri[k], tri[(k + 1) % 3], tri[(k + 2) % 3]);
            let t2 = mesh.triangles.len() as u32;
            mesh.triangles[t as usize] = [x, mid, w];
            mesh.triangles.push([mid, y, w]);
            // Edge (y, w) moves from t to t2; the new edges are registered.
            if let Some(u) = edges.get_mut(&key(y, w)) {
                for s in u.iter_mut() {
                    if *s == t {
                        *s = t2;
                    }
                }
            }
            add_edge(&mut edges, x, mid, t);
            add_edge(&mut edges, mid, y, t2);
            add_edge(&mut edges, mid, w, t);
            add_edge(&mut edges, mid, w, t2);
            touched.push(key(mid, w));
        }
        for e in touched {
            if let Some(&users) = edges.get(&e) {
                consider(&mut heap, mesh, e, users);
            }
        }
    }
    false
}
