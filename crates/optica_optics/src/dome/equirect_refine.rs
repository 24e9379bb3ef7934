//! Triangles and segments refined for an equirectangular panorama: cut into
//! quarters of longitude, split by the chord-gap rule in the panorama's own
//! image (E2), seam and pole vertices moved to their side (see
//! `equirect.rs`).
//!
//! Work is done in the panorama's frame (right, up, forward) so that the
//! cut planes x = 0 and z = 0 are coordinate planes and cut points lie on
//! them exactly; every cut orders its edge canonically first, so two
//! triangles sharing an edge cut it at the same bits and the welded result
//! has no crack.

use glam::DVec3;
use rayon::prelude::*;

use super::arc::{Arc, ArcError, canonical_less, split_by};
use super::equirect::{EquirectProjection, SEAM_NUDGE_RAD};
use super::error::DomeError;
use super::refine::{RefineStats, RefinedLines, RefinedSegment, refine_batch};
use super::rule::SplitRule;
use super::triangle::{RefinedMesh, TriMesh, Welder, subdivide_triangle};
use crate::input;

/// Points this close to a pole's axis (relative: √(x² + z²) ≤ this·|q|)
/// are put on it. A vertex meant to be on a pole (the zenith of a sky
/// computed in f32) lands ~1e-7 off it, at a longitude that is rounding
/// noise; left there, the edges to it would run a meridian up to the pole's
/// row and then along that row to the noise's longitude, which the
/// curvature rule cannot follow (N grows as 1/h² there). On the axis, it is
/// fanned out like any pole vertex. The move is invisible: 1e-6 rad is
/// 0.003 px of latitude at 8K.
pub const POLE_SNAP_RAD: f64 = 1e-6;

/// `q` put on a pole's axis when it lies within [`POLE_SNAP_RAD`] of it.
fn snap_to_pole(q: DVec3) -> DVec3 {
    if q.x.hypot(q.z) <= POLE_SNAP_RAD * q.length() && q.y != 0.0 {
        DVec3::new(0.0, q.y, 0.0)
    } else {
        q
    }
}

/// The cut of edge p–q by the coordinate plane `c` (0: x, 2: z), from the
/// canonically ordered edge, the cut coordinate set to exactly 0 (and the
/// point put on a pole's axis when it lies next to it).
fn cut(p: DVec3, q: DVec3, c: usize) -> DVec3 {
    let (p, q) = if canonical_less(q, p) { (q, p) } else { (p, q) };
    let t = p[c] / (p[c] - q[c]);
    let mut r = p + t * (q - p);
    r[c] = 0.0;
    snap_to_pole(r)
}

/// The part of a convex polygon on the `side` (±1) of coordinate plane `c`
/// (Sutherland–Hodgman; points on the plane belong to both sides).
fn clip_polygon(poly: &[DVec3], c: usize, side: f64) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (i, &p) in poly.iter().enumerate() {
        let q = poly[(i + 1) % poly.len()];
        let (dp, dq) = (side * p[c], side * q[c]);
        if dp >= 0.0 {
            out.push(p);
        }
        if (dp > 0.0 && dq < 0.0) || (dp < 0.0 && dq > 0.0) {
            out.push(cut(p, q, c));
        }
    }
    out
}

/// The four quarters of longitude: (side of x, side of z).
const QUARTERS: [(f64, f64); 4] = [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)];

/// Whether `q` lies on a pole's axis.
fn on_pole(q: DVec3) -> bool {
    q.x == 0.0 && q.z == 0.0
}

/// A pole vertex `p` moved [`SEAM_NUDGE_RAD`] towards the longitude of `a`.
fn towards(p: DVec3, a: DVec3) -> Option<DVec3> {
    let h = DVec3::new(a.x, 0.0, a.z);
    let len = h.length();
    (len > 0.0).then(|| p + (SEAM_NUDGE_RAD * p.length() / len) * h)
}

/// A vertex on the seam (x = 0, z < 0) moved to the `side` of x.
fn off_seam(q: DVec3, side: f64) -> DVec3 {
    if q.x == 0.0 && q.z < 0.0 {
        DVec3::new(side * SEAM_NUDGE_RAD * -q.z, q.y, q.z)
    } else {
        q
    }
}

/// Replaces every pole vertex of a refined part by one vertex per
/// neighbouring longitude and moves seam vertices to the part's `side`:
/// the triangle (pole, A, B) becomes (pole→A, A, B) and (pole→A, B,
/// pole→B), the wedge between the meridians of A and B. Triangles with two
/// corners on the axis are edge-on and left out.
fn mend_poles_and_seam(part: &TriMesh, side: f64, out: &mut Welder) {
    let mut local = TriMesh::default();
    let push = |local: &mut TriMesh, t: [DVec3; 3]| {
        let base = local.positions.len() as u32;
        local.positions.extend(t.iter().map(|&q| off_seam(q, side)));
        local.triangles.push([base, base + 1, base + 2]);
    };
    for &t in part.triangles() {
        let v = part.corners(t);
        let poles: Vec<usize> = (0..3).filter(|&i| on_pole(v[i])).collect();
        match poles[..] {
            [] => push(&mut local, v),
            [i] => {
                let (p, a, b) = (v[i], v[(i + 1) % 3], v[(i + 2) % 3]);
                let (Some(pa), Some(pb)) = (towards(p, a), towards(p, b)) else {
                    continue;
                };
                push(&mut local, [pa, a, b]);
                if pa != pb {
                    push(&mut local, [pa, b, pb]);
                }
            }
            _ => {}
        }
    }
    out.add(&local);
}

/// One triangle (frame coordinates, finite) into `out`.
fn refine_in_frame(
    proj: &EquirectProjection,
    tri: [DVec3; 3],
    rule: SplitRule,
    out: &mut Welder,
    stats: &mut RefineStats,
) {
    let tri = tri.map(snap_to_pole);
    let pieces = |arc: &Arc| proj.pieces_of_arc(rule, arc);
    for (sx, sz) in QUARTERS {
        let poly = clip_polygon(&clip_polygon(&tri, 0, sx), 2, sz);
        // Fewer than three corners, or all on a cut plane: nothing this
        // quarter draws (the plane is seen edge-on).
        let flat = |c: usize| poly.iter().all(|q| q[c] == 0.0);
        if poly.len() < 3 || flat(0) || flat(2) {
            continue;
        }
        for k in 1..poly.len() - 1 {
            match subdivide_triangle([poly[0], poly[k], poly[k + 1]], &pieces, false) {
                Ok((part, capped)) => {
                    stats.capped_edges += usize::from(capped);
                    mend_poles_and_seam(&part, sx, out);
                }
                Err(cause) => stats.drop_for(cause),
            }
        }
    }
}

/// Refines one triangle (view space) for a panorama: cut at the seam and
/// the poles' meridian planes, split by `rule` in the panorama's image,
/// seam and pole vertices moved to their side (module docs). Errors: a
/// non-finite vertex ([`DomeError::Input`]). Parts touching the origin or
/// with an edge through the viewer are left out and counted.
pub fn refine_triangle_equirect(
    proj: &EquirectProjection,
    tri: [DVec3; 3],
    rule: SplitRule,
) -> Result<RefinedMesh, DomeError> {
    for v in tri {
        input::finite_vec3("vertex (view space)", v)?;
    }
    Ok(refine_one_triangle(proj, tri, rule))
}

/// One triangle with finite corners (view space), welded and back in view
/// space.
fn refine_one_triangle(proj: &EquirectProjection, tri: [DVec3; 3], rule: SplitRule) -> RefinedMesh {
    let mut stats = RefineStats {
        input: 1,
        ..Default::default()
    };
    let mut welder = Welder::default();
    refine_in_frame(
        proj,
        tri.map(|v| proj.to_frame(v)),
        rule,
        &mut welder,
        &mut stats,
    );
    let (positions, triangles) = welder.into_mesh().into_parts();
    stats.emitted = triangles.len();
    let positions = positions.into_iter().map(|q| proj.from_frame(q)).collect();
    RefinedMesh {
        mesh: TriMesh::new(positions, triangles).expect("welded indices are in range"),
        stats,
    }
}

/// Refines every triangle of a mesh (view space) for a panorama, in
/// parallel, and welds the result by exact position (crack-free: shared
/// edges are cut and split at the same bits from both sides). Bad
/// triangles are left out and counted per cause.
pub fn refine_mesh_equirect(
    proj: &EquirectProjection,
    mesh: &TriMesh,
    rule: SplitRule,
) -> RefinedMesh {
    let patches: Vec<RefinedMesh> = mesh
        .triangles()
        .par_iter()
        .map(|&t| {
            let tri = mesh.corners(t);
            if tri.iter().all(|v| v.is_finite()) {
                refine_one_triangle(proj, tri, rule)
            } else {
                RefinedMesh {
                    mesh: TriMesh::default(),
                    stats: RefineStats {
                        input: 1,
                        dropped_nonfinite: 1,
                        ..Default::default()
                    },
                }
            }
        })
        .collect();
    // Welded in view space: shared corners and cuts map from the frame
    // alike from both sides, so they stay the same bits.
    let mut welder = Welder::default();
    let mut stats = RefineStats::default();
    for p in &patches {
        welder.add(&p.mesh);
        stats = stats.merge(p.stats);
    }
    let mesh = welder.into_mesh();
    stats.emitted = mesh.triangles().len();
    RefinedMesh { mesh, stats }
}

/// The parts of segment a–b (frame coordinates) in each quarter, in order
/// from a to b, with the side of x each lies on.
fn segment_parts(a: DVec3, b: DVec3) -> Vec<([DVec3; 2], f64)> {
    let mut pts = vec![a, b];
    for c in [0, 2] {
        let mut next = vec![pts[0]];
        for w in pts.windows(2) {
            let (p, q) = (w[0], w[1]);
            if (p[c] > 0.0 && q[c] < 0.0) || (p[c] < 0.0 && q[c] > 0.0) {
                next.push(cut(p, q, c));
            }
            next.push(q);
        }
        pts = next;
    }
    pts.windows(2)
        .map(|w| {
            let x = w[0].x + w[1].x;
            ([w[0], w[1]], if x < 0.0 { -1.0 } else { 1.0 })
        })
        .collect()
}

/// [`refine_segment_equirect`] in frame coordinates, with the cause of a
/// failure.
fn refine_segment_in_frame(
    proj: &EquirectProjection,
    a: DVec3,
    b: DVec3,
    rule: SplitRule,
) -> Result<RefinedSegment, ArcError> {
    let mut capped = false;
    let mut strips = Vec::new();
    for ([p, q], side) in segment_parts(a, b) {
        let (mut strip, cap) = split_by(p, q, |arc| proj.pieces_of_arc(rule, arc))?;
        capped |= cap;
        let last = strip.len() - 1;
        if on_pole(strip[0]) {
            strip[0] = towards(strip[0], strip[1]).unwrap_or(strip[0]);
        }
        if on_pole(strip[last]) {
            strip[last] = towards(strip[last], strip[last - 1]).unwrap_or(strip[last]);
        }
        strips.push(
            strip
                .into_iter()
                .map(|v| proj.from_frame(off_seam(v, side)))
                .collect(),
        );
    }
    Ok(RefinedSegment { strips, capped })
}

/// Refines segment a→b (view space) for a panorama: one polyline per
/// quarter of longitude it crosses, oriented like the input, seam and pole
/// ends moved to their side. Errors: a non-finite vertex
/// ([`DomeError::Input`]), an endpoint at the origin, a segment through
/// the viewer.
pub fn refine_segment_equirect(
    proj: &EquirectProjection,
    a: DVec3,
    b: DVec3,
    rule: SplitRule,
) -> Result<RefinedSegment, DomeError> {
    Ok(refine_segment_in_frame(
        proj,
        snap_to_pole(proj.to_frame(a)),
        snap_to_pole(proj.to_frame(b)),
        rule,
    )?)
}

/// Refines independent segments (view space) in parallel for a panorama;
/// bad segments are left out and counted per cause.
pub fn refine_segments_equirect(
    proj: &EquirectProjection,
    segments: &[[DVec3; 2]],
    rule: SplitRule,
) -> RefinedLines {
    refine_batch(segments, |a, b| {
        let (a, b) = (proj.to_frame(a), proj.to_frame(b));
        refine_segment_in_frame(proj, snap_to_pole(a), snap_to_pole(b), rule)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dome::{EquirectSettings, equirect_chord_error_px};
    use glam::DVec2;
    use proptest::prelude::*;

    fn pano(tilt: f64) -> EquirectProjection {
        EquirectProjection::new(&EquirectSettings {
            width_px: 1024,
            tilt_deg: tilt,
            ..Default::default()
        })
        .unwrap()
    }

    fn chord_gap(tol: f64) -> SplitRule {
        SplitRule::chord_gap(tol).unwrap()
    }

    /// Whether `v` is a pole vertex moved towards a longitude: the edges
    /// from it are not images of 3D edges but the sides of the wedge the
    /// pole's triangles cover (a meridian and a diagonal of the wedge).
    fn at_pole(p: &EquirectProjection, v: DVec3) -> bool {
        let q = p.to_frame(v);
        q.x.hypot(q.z) < 2.0 * SEAM_NUDGE_RAD * q.length()
    }

    fn px(p: &EquirectProjection, v: DVec3) -> DVec2 {
        p.pixel_of_direction(v).expect("no output vertex on a pole")
    }

    /// Signed pixel area of every triangle, and the largest chord error
    /// and longitude span of any edge.
    fn image_measures(p: &EquirectProjection, m: &TriMesh) -> (f64, f64, f64) {
        let (mut area, mut err, mut span) = (0.0, 0.0f64, 0.0f64);
        for &t in m.triangles() {
            let v = m.corners(t);
            let q = v.map(|x| px(p, x));
            area += 0.5 * (q[1] - q[0]).perp_dot(q[2] - q[0]);
            for i in 0..3 {
                let (a, b) = (v[i], v[(i + 1) % 3]);
                if !(at_pole(p, a) || at_pole(p, b)) {
                    err = err.max(equirect_chord_error_px(p, a, b).unwrap());
                }
                span = span.max((q[i].x - q[(i + 1) % 3].x).abs());
            }
        }
        (area, err, span)
    }

    #[test]
    fn a_room_around_the_viewer_covers_the_panorama_once() {
        // An inside-out box around the viewer, tilted or not: its refined
        // image tiles the whole 1024 × 512 image (signed area W·H, up to
        // the chords' sag along the boundary), no edge jumps across the
        // seam, every edge within the tolerance, and the only open edges
        // are where the image itself ends (seam columns, pole rows).
        for tilt in [0.0, 23.0] {
            let p = pano(tilt);
            let room = TriMesh::cuboid(
                DVec3::new(-4.0, -1.7, -3.0),
                DVec3::new(3.0, 2.5, 5.0),
                true,
            );
            for tol in [2.0, 0.5] {
                let r = refine_mesh_equirect(&p, &room, chord_gap(tol));
                assert_eq!(
                    r.stats.dropped_at_origin + r.stats.dropped_through_viewer,
                    0
                );
                let (area, err, span) = image_measures(&p, &r.mesh);
                // Pixel rows grow downwards: front faces wind clockwise.
                let area = -area;
                let whole = 1024.0 * 512.0;
                assert!(
                    (area / whole - 1.0).abs() < 0.002,
                    "tilt {tilt} tol {tol}: area {area} of {whole}"
                );
                assert!(
                    err <= tol * 1.05,
                    "tilt {tilt} tol {tol}: chord error {err}"
                );
                assert!(span < 300.0, "an edge spans {span} px");
                for [a, b] in r.mesh.boundary_edges() {
                    let (qa, qb) = (px(&p, r.mesh.corner(a)), px(&p, r.mesh.corner(b)));
                    let at_edge = |q: DVec2| q.x < 0.5 || q.x > 1023.5 || q.y < 0.5 || q.y > 511.5;
                    assert!(at_edge(qa) && at_edge(qb), "open edge {qa} – {qb}");
                }
            }
        }
    }

    #[test]
    fn shared_edges_are_cut_and_split_identically_from_both_sides() {
        // Two triangles sharing an edge that crosses the seam: the welded
        // result has no open edge away from the seam.
        let p = pano(0.0);
        let (a, b) = (DVec3::new(-2.0, -1.0, 3.0), DVec3::new(2.5, 0.5, 2.0));
        let mesh = TriMesh::new(
            vec![a, b, DVec3::new(0.3, 3.0, 4.0), DVec3::new(0.2, -3.0, 1.0)],
            vec![[0, 1, 2], [1, 0, 3]],
        )
        .unwrap();
        let r = refine_mesh_equirect(&p, &mesh, chord_gap(0.5));
        assert!(r.mesh.triangles().len() > 8);
        for [i, j] in r.mesh.boundary_edges() {
            let (qa, qb) = (r.mesh.corner(i), r.mesh.corner(j));
            // Outer boundary: on an edge of the input other than a–b, or on
            // the seam.
            let on = |u: DVec3, v: DVec3, x: DVec3| (x - u).cross(v - u).length() < 1e-9;
            let outer = |x: DVec3| {
                on(b, mesh.corner(2), x)
                    || on(mesh.corner(2), a, x)
                    || on(a, mesh.corner(3), x)
                    || on(mesh.corner(3), b, x)
                    || px(&p, x).x < 0.5
                    || px(&p, x).x > 1023.5
            };
            assert!(outer(qa) && outer(qb), "crack at {qa} – {qb}");
        }
    }

    #[test]
    fn segments_across_the_seam_and_over_a_pole() {
        let p = pano(0.0);
        let rule = chord_gap(0.5);
        // Behind the viewer, right to left: two polylines, one ending on
        // each side of the seam.
        let s = refine_segment_equirect(
            &p,
            DVec3::new(1.0, 0.2, 2.0),
            DVec3::new(-1.0, 0.3, 2.0),
            rule,
        )
        .unwrap();
        assert_eq!(s.strips.len(), 2);
        let ends = [
            px(&p, *s.strips[0].last().unwrap()).x,
            px(&p, s.strips[1][0]).x,
        ];
        assert!(ends[0] > 1023.9 && ends[1] < 0.1, "{ends:?}");
        // Over the north pole from front to back: up one meridian, down the
        // other, each polyline vertical (constant u).
        let s = refine_segment_equirect(
            &p,
            DVec3::new(0.3, 2.0, -1.0),
            DVec3::new(-0.3, 2.0, 1.0),
            rule,
        )
        .unwrap();
        for st in &s.strips {
            for w in st
                .windows(2)
                .filter(|w| !at_pole(&p, w[0]) && !at_pole(&p, w[1]))
            {
                let e = equirect_chord_error_px(&p, w[0], w[1]).unwrap();
                assert!(e <= 0.5 * 1.05, "{e}");
            }
        }
        let tops: Vec<f64> = s.strips.iter().flatten().map(|&v| px(&p, v).y).collect();
        assert!(tops.iter().cloned().fold(f64::MAX, f64::min) < 0.1);
        // Bad input is typed.
        assert!(refine_segment_equirect(&p, DVec3::NAN, DVec3::X, rule).is_err());
        assert!(refine_segment_equirect(&p, DVec3::ZERO, DVec3::X, rule).is_err());
        assert!(refine_triangle_equirect(&p, [DVec3::X, DVec3::Y, DVec3::INFINITY], rule).is_err());
    }

    #[test]
    fn stiff_cases_stay_finite_and_in_place() {
        let p = pano(0.0);
        let rule = chord_gap(0.5);
        // A ground 1e5 wide, 1.6 below: the southern half of the image,
        // across the seam and down to the nadir's row.
        let g = 5e4;
        let ground = TriMesh::new(
            vec![
                DVec3::new(-g, -1.6, -g),
                DVec3::new(g, -1.6, -g),
                DVec3::new(g, -1.6, g),
                DVec3::new(-g, -1.6, g),
            ],
            vec![[0, 2, 1], [0, 3, 2]],
        )
        .unwrap();
        let r = refine_mesh_equirect(&p, &ground, rule);
        let (area, _, span) = image_measures(&p, &r.mesh);
        let half = 1024.0 * 256.0;
        assert!(
            (area.abs() / half - 1.0).abs() < 0.01,
            "ground covers {area} of {half}"
        );
        assert!(span < 300.0);
        // A vertex exactly on each pole, a triangle 0.1 mm across round the
        // zenith 2 m up, one of 1e-100 and one of 1e150: finite pixels, the
        // tiny ones whole. (A micrometre one would lie within
        // POLE_SNAP_RAD of the pole and be put on it: nothing to draw.)
        let tiny = |s: f64, y: f64| {
            [
                DVec3::new(-s, y, -s),
                DVec3::new(s, y, -s),
                DVec3::new(0.0, y, s),
            ]
        };
        for tri in [
            [
                DVec3::new(0.0, 3.0, 0.0),
                DVec3::new(1.0, 3.0, -1.0),
                DVec3::new(-1.0, 3.0, -1.0),
            ],
            [
                DVec3::new(0.0, -3.0, 0.0),
                DVec3::new(-1.0, -3.0, 1.0),
                DVec3::new(1.0, -3.0, 1.0),
            ],
            tiny(1e-4, 2.0),
            tiny(1e-100, 1e-99),
            tiny(1e150, 1e151),
        ] {
            let r = refine_triangle_equirect(&p, tri, rule).unwrap();
            assert!(!r.mesh.triangles().is_empty(), "{tri:?} vanished");
            for &v in r.mesh.positions() {
                let pixel = p.pixel_of_direction(v).expect("off the poles");
                assert!(
                    pixel.is_finite() && pixel.y >= 0.0 && pixel.y <= 512.0,
                    "{v}"
                );
            }
        }
        // At 1e-300 lengths underflow: the triangle is at the origin as far
        // as f64 can tell, left out and counted.
        let r = refine_triangle_equirect(&p, tiny(1e-300, 1e-299), rule).unwrap();
        assert!(r.mesh.triangles().is_empty() && r.stats.dropped_at_origin > 0);
    }

    #[test]
    fn a_meridian_ending_next_to_the_zenith_stays_a_meridian() {
        // The zenith as f32 trigonometry gives it: 4.4e-8 rad off the pole,
        // at a longitude of rounding noise (here 2 rad away from the
        // meridian's own). Its last piece must still be vertical, not a
        // chord across the image to the noise's longitude.
        let p = pano(0.0);
        let lon: f64 = 0.3;
        let a = DVec3::new(lon.sin(), 1.0, -lon.cos());
        let zenith = DVec3::new(4.4e-8 * 2.3f64.sin(), 1.0, -4.4e-8 * 2.3f64.cos());
        let s = refine_segment_equirect(&p, a, zenith, chord_gap(0.5)).unwrap();
        let xs: Vec<f64> = s.strips.iter().flatten().map(|&v| px(&p, v).x).collect();
        let spread = xs.iter().cloned().fold(f64::MIN, f64::max)
            - xs.iter().cloned().fold(f64::MAX, f64::min);
        assert!(
            spread < 0.1,
            "the meridian wanders over {spread} px: {xs:?}"
        );
    }

    proptest! {
        // Each case measures every output edge at 512 samples.
        #![proptest_config(ProptestConfig::with_cases(64))]

        #[test]
        fn random_triangles_meet_the_tolerance_without_wrapping(
            c in prop::array::uniform9(-3.0f64..3.0), tol in 0.3f64..3.0, tilt in -40.0f64..40.0,
        ) {
            let p = pano(tilt);
            let tri = [
                DVec3::new(c[0], c[1], c[2]),
                DVec3::new(c[3], c[4], c[5]),
                DVec3::new(c[6], c[7], c[8]),
            ];
            prop_assume!(tri.iter().all(|v| v.length() > 0.3));
            let r = refine_triangle_equirect(&p, tri, chord_gap(tol)).unwrap();
            prop_assume!(r.stats.capped_edges == 0);
            for &t in r.mesh.triangles() {
                let v = r.mesh.corners(t);
                for i in 0..3 {
                    let (a, b) = (v[i], v[(i + 1) % 3]);
                    if at_pole(&p, a) || at_pole(&p, b) {
                        continue;
                    }
                    let e = equirect_chord_error_px(&p, a, b).unwrap();
                    prop_assert!(e <= tol * 1.05 + 0.05, "edge error {} at tol {}", e, tol);
                    let du = (px(&p, a).x - px(&p, b).x).abs();
                    prop_assert!(du < 512.0, "edge wraps: {}", du);
                }
            }
        }
    }
}
