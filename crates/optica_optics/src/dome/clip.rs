//! Removing geometry the projection cannot draw, before refinement.
//!
//! * FOV ≤ 180°: everything visible lies in front of the view plane of the
//!   dome frame (`p·axis ≥ 0`, z = 0 in dome coordinates), a convex
//!   half-space, so segments and triangles are clipped against that plane in
//!   3D before projection. Without it a floor under a zenith camera has
//!   vertices behind the viewer and near the antipode, and its projected
//!   triangles cover the whole disk (seen on a software rasteriser,
//!   lavapipe, with a camera inside a room). What lies between the rim and
//!   the plane projects outside the image circle and is discarded per
//!   fragment. (Next to 180°, triangles get a rim skirt past the cut: see
//!   [`DomeProjection::rim_skirt_rad`].)
//! * FOV > 180°: the visible set θ ≤ FOV/2 is not convex (its complement is a
//!   cone around the antipode). Segments are clipped exactly to the cone
//!   θ ≤ θ_guard = (θ_max + π)/2 along their great-circle arc (at most two
//!   pieces remain). Triangles are not clipped: they are refined whole and
//!   the refined sub-triangles reaching past θ_guard, or covering the
//!   antipode, are culled (see [`refine_triangle`](super::refine_triangle));
//!   pieces leaving the cone are capped
//!   ([`DomeProjection::guard_piece_rad`]) so that culled ones start
//!   outside the image circle.
//!
//! Cut points are computed with the edge's endpoints in canonical order, so
//! two triangles sharing an edge cut it at the same bits.

use std::f64::consts::{PI, TAU};

use glam::DVec3;

use super::arc::{Arc, ArcError, canonical_less};
use super::camera::DomeProjection;
use super::error::DomeError;

/// The point where segment p–q crosses the plane, from signed distances
/// `dp`, `dq` of opposite strict signs; symmetric in (p, q) bit for bit.
fn plane_cut(p: DVec3, q: DVec3, dp: f64, dq: f64) -> DVec3 {
    let (p, q, dp, dq) = if canonical_less(q, p) {
        (q, p, dq, dp)
    } else {
        (p, q, dp, dq)
    };
    let t = dp / (dp - dq);
    p + t * (q - p)
}

/// Clips segment a→b to the part [`DomeProjection`] can draw (see the module
/// docs): zero, one or two sub-segments, each oriented like a→b.
/// Errors as [`split_segment`](super::split_segment).
pub fn clip_segment(
    proj: &DomeProjection,
    a: DVec3,
    b: DVec3,
) -> Result<Vec<[DVec3; 2]>, DomeError> {
    Ok(clip_parts(proj, a, b)?)
}

/// [`clip_segment`] with the failure's cause.
pub(crate) fn clip_parts(
    proj: &DomeProjection,
    a: DVec3,
    b: DVec3,
) -> Result<Vec<[DVec3; 2]>, ArcError> {
    let swap = canonical_less(b, a);
    let (p, q) = if swap { (b, a) } else { (a, b) };
    // Validates and rejects through-the-viewer segments for both branches.
    let arc = Arc::new(p, q)?;
    let mut out = if proj.clips_at_view_plane() {
        clip_segment_plane(proj.axis(), p, q)
    } else {
        clip_segment_cone(&arc, proj.axis(), proj.theta_clip())
    };
    if swap {
        out.reverse();
        for s in &mut out {
            s.swap(0, 1);
        }
    }
    Ok(out)
}

/// Keeps the part with `p·axis ≥ 0`.
fn clip_segment_plane(axis: DVec3, p: DVec3, q: DVec3) -> Vec<[DVec3; 2]> {
    let (dp, dq) = (p.dot(axis), q.dot(axis));
    match (dp >= 0.0, dq >= 0.0) {
        (true, true) => vec![[p, q]],
        (false, false) => vec![],
        (true, false) => vec![[p, plane_cut(p, q, dp, dq)]],
        (false, true) => vec![[plane_cut(p, q, dp, dq), q]],
    }
}

/// Keeps the part of the arc with θ ≤ `theta_clip` (> 90°). Along the great
/// circle cos θ(β) = R cos(β − β₀); it is below cos θ_clip on one interval
/// of the full circle, which is removed from [0, α].
fn clip_segment_cone(arc: &Arc, axis: DVec3, theta_clip: f64) -> Vec<[DVec3; 2]> {
    let theta_of = |d: DVec3| d.cross(axis).length().atan2(d.dot(axis));
    if arc.is_point() {
        return if theta_of(arc.a_hat) <= theta_clip {
            vec![[arc.a, arc.b]]
        } else {
            vec![]
        };
    }
    let (ca, cb) = (arc.a_hat.dot(axis), arc.w_hat.dot(axis));
    let r = ca.hypot(cb);
    let kappa = theta_clip.cos();
    if r == 0.0 || kappa / r <= -1.0 {
        return vec![[arc.a, arc.b]];
    }
    let gamma = (kappa / r).acos();
    let beta0 = cb.atan2(ca);
    let start = (beta0 + gamma).rem_euclid(TAU);
    let width = 2.0 * (PI - gamma);
    let mut keep = vec![(0.0, arc.alpha)];
    for k in [-1.0, 0.0, 1.0] {
        let (lo, hi) = (start + k * TAU, start + k * TAU + width);
        keep = keep
            .into_iter()
            .flat_map(|(s, e): (f64, f64)| {
                if hi <= s || lo >= e {
                    vec![(s, e)]
                } else {
                    let mut v = Vec::new();
                    if lo > s {
                        v.push((s, lo));
                    }
                    if hi < e {
                        v.push((hi, e));
                    }
                    v
                }
            })
            .collect();
    }
    let at = |beta: f64| {
        if beta <= 0.0 {
            arc.a
        } else if beta >= arc.alpha {
            arc.b
        } else {
            arc.point(beta)
        }
    };
    keep.into_iter()
        .filter(|(s, e)| e > s)
        .map(|(s, e)| [at(s), at(e)])
        .collect()
}

/// Clips triangle (a, b, c) against the view plane `p·axis ≥ 0`
/// (Sutherland–Hodgman) and fans the result: zero, one or two triangles with
/// the input's winding. Used for FOV ≤ 180° only.
pub(crate) fn clip_triangle_plane(axis: DVec3, tri: [DVec3; 3]) -> Vec<[DVec3; 3]> {
    let (poly, n) = clip_polygon_plane(axis, tri);
    (1..n.saturating_sub(1))
        .map(|k| [poly[0], poly[k], poly[k + 1]])
        .collect()
}

/// The polygon [`clip_triangle_plane`] fans: its first `n` corners, in the
/// input's winding (fewer than three when nothing with an area is left:
/// none, or the one or two corners lying on the plane).
pub(crate) fn clip_polygon_plane(axis: DVec3, tri: [DVec3; 3]) -> ([DVec3; 4], usize) {
    let d = tri.map(|p| p.dot(axis));
    if d.iter().all(|&x| x >= 0.0) {
        return ([tri[0], tri[1], tri[2], DVec3::ZERO], 3);
    }
    // (A triangle cut by a plane is a polygon of at most four corners.)
    let (mut poly, mut n) = ([DVec3::ZERO; 4], 0);
    if d.iter().all(|&x| x < 0.0) {
        return (poly, 0);
    }
    for i in 0..3 {
        let j = (i + 1) % 3;
        if d[i] >= 0.0 {
            poly[n] = tri[i];
            n += 1;
        }
        // Strict signs: a vertex on the plane is kept and never duplicated.
        if (d[i] > 0.0 && d[j] < 0.0) || (d[i] < 0.0 && d[j] > 0.0) {
            poly[n] = plane_cut(tri[i], tri[j], d[i], d[j]);
            n += 1;
        }
    }
    (poly, n)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dome(fov: f64) -> DomeProjection {
        crate::dome::test_dome(fov, 0.0, 4096)
    }

    #[test]
    fn plane_clip_of_segments() {
        // 170°: the plane clip (next to 180° the guard cone takes over).
        let p = dome(170.0);
        // Entirely behind the viewer (z > 0 in view space, axis −Z).
        assert!(
            clip_segment(&p, DVec3::new(1.0, 0.0, 1.0), DVec3::new(-1.0, 2.0, 3.0))
                .unwrap()
                .is_empty()
        );
        // Crossing: the kept end is in front and the cut is on z = 0.
        let s = clip_segment(&p, DVec3::new(1.0, 0.0, 1.0), DVec3::new(-1.0, 0.5, -1.0)).unwrap();
        assert_eq!(s.len(), 1);
        assert_eq!(s[0][0], DVec3::new(0.0, 0.25, 0.0));
        assert_eq!(s[0][1], DVec3::new(-1.0, 0.5, -1.0));
        // In front: unchanged.
        let a = DVec3::new(1.0, 2.0, -3.0);
        let b = DVec3::new(-1.0, 0.5, -0.1);
        assert_eq!(clip_segment(&p, a, b).unwrap(), vec![[a, b]]);
    }

    #[test]
    fn cone_clip_removes_the_antipode_side() {
        // 250° FOV: guard at (125° + 180°)/2 = 152.5°. A segment from 120° on
        // one side to 120° on the other passes the antipode: two pieces, each
        // ending on the guard cone.
        let p = dome(250.0);
        let guard = p.theta_clip();
        assert!((guard.to_degrees() - 152.5).abs() < 1e-12);
        let d = |deg: f64| DVec3::new(deg.to_radians().sin(), 0.0, -deg.to_radians().cos());
        let a = d(120.0) * 2.0;
        let b = d(-120.0) * 3.0;
        let s = clip_segment(&p, a, b).unwrap();
        assert_eq!(s.len(), 2);
        assert_eq!(s[0][0], a);
        assert_eq!(s[1][1], b);
        assert!((p.theta(s[0][1]) - guard).abs() < 1e-9);
        assert!((p.theta(s[1][0]) - guard).abs() < 1e-9);
        // Entirely near the antipode: removed.
        assert!(clip_segment(&p, d(170.0), d(-175.0)).unwrap().is_empty());
        // Entirely visible: unchanged.
        assert_eq!(
            clip_segment(&p, d(10.0), d(100.0)).unwrap(),
            vec![[d(10.0), d(100.0)]]
        );
    }

    #[test]
    fn triangle_plane_clip() {
        let axis = DVec3::NEG_Z;
        // One vertex behind: a quad (2 triangles), all kept vertices in front.
        let t = [
            DVec3::new(0.0, 0.0, -2.0),
            DVec3::new(2.0, 0.0, -2.0),
            DVec3::new(1.0, 0.0, 2.0),
        ];
        let out = clip_triangle_plane(axis, t);
        assert_eq!(out.len(), 2);
        for tri in &out {
            assert!(tri.iter().all(|v| v.z <= 0.0));
        }
        // Two vertices behind: one triangle.
        let t = [
            DVec3::new(0.0, 1.0, -2.0),
            DVec3::new(2.0, 0.0, 2.0),
            DVec3::new(1.0, 0.0, 2.0),
        ];
        assert_eq!(clip_triangle_plane(axis, t).len(), 1);
        // A vertex on the plane is not duplicated.
        let t = [
            DVec3::new(0.0, 1.0, -2.0),
            DVec3::new(2.0, 0.0, 0.0),
            DVec3::new(1.0, 0.0, 2.0),
        ];
        let out = clip_triangle_plane(axis, t);
        assert_eq!(out.len(), 1);
        assert!(out[0][0] != out[0][1] && out[0][1] != out[0][2] && out[0][0] != out[0][2]);
    }
}
