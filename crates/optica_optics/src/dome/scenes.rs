//! Test scenes for the dome's tests and report (feature `reference`): a box
//! mesh, the face of a box a view ray meets, and seeded random edges around
//! the viewer.

use std::f64::consts::{PI, TAU};
use std::ops::Range;

use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::SplitMix64;

use super::camera::DomeProjection;
use super::triangle::TriMesh;

/// Distances of [`random_edges`]' endpoints from the viewer, metres: from
/// arm's length to across a large room, so that edges of one subtended angle
/// come in many 3D lengths and tilts.
pub const RANDOM_EDGE_DISTANCE_M: Range<f64> = 1.0..20.0;

/// The face of a cube centred on the viewer that the ray along `dir` meets,
/// as its outward unit axis (±X, ±Y or ±Z; ties go to x, then y). The
/// oracle of the dome's rendered room tests: a pixel shows the face its
/// inverse-projected direction meets.
pub fn cube_face_axis(dir: DVec3) -> DVec3 {
    let a = dir.abs();
    if a.x >= a.y && a.x >= a.z {
        DVec3::X * dir.x.signum()
    } else if a.y >= a.z {
        DVec3::Y * dir.y.signum()
    } else {
        DVec3::Z * dir.z.signum()
    }
}

impl TriMesh {
    /// An axis-aligned box as 8 shared vertices and 12 triangles (two per
    /// face), wound outwards, or inwards when `inside_out` (a room seen from
    /// inside). A test scene and a closed mesh for crack checks.
    pub fn cuboid(min: DVec3, max: DVec3, inside_out: bool) -> Self {
        let corner = |i: u32| {
            DVec3::new(
                if i & 1 == 0 { min.x } else { max.x },
                if i & 2 == 0 { min.y } else { max.y },
                if i & 4 == 0 { min.z } else { max.z },
            )
        };
        let positions = (0..8).map(corner).collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let mut triangles = Vec::with_capacity(12);
        for q in quads {
            for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
                triangles.push(if inside_out { [t[0], t[2], t[1]] } else { t });
            }
        }
        Self {
            positions,
            triangles,
        }
    }
}

/// `n` random edges around the viewer of `proj`, the same for the same
/// `seed` (SplitMix64). Each edge's midpoint direction has polar angle up to
/// `max_theta` rad from the dome axis, uniform in solid angle; the edge
/// subtends an angle drawn uniformly from `subtended_deg` (degrees), at a
/// random orientation; its endpoints lie at distances drawn from
/// [`RANDOM_EDGE_DISTANCE_M`]. Out-of-range parameters are clamped:
/// `max_theta` to [0, π], `subtended_deg` to [0°, 180°).
pub fn random_edges(
    proj: &DomeProjection,
    n: usize,
    max_theta: f64,
    subtended_deg: Range<f64>,
    seed: u64,
) -> Vec<[DVec3; 2]> {
    let mut rng = SplitMix64::seed_from_u64(seed);
    // Uniform in [lo, hi) for any lo ≤ hi (random_range panics on an empty range).
    let mut draw = |r: &Range<f64>| r.start + (r.end - r.start) * rng.random::<f64>();
    let max_theta = if max_theta.is_nan() {
        0.0
    } else {
        max_theta.clamp(0.0, PI)
    };
    let clamp_deg = |d: f64| {
        if d.is_nan() {
            0.0
        } else {
            d.clamp(0.0, 180f64.next_down())
        }
    };
    let (lo, hi) = (clamp_deg(subtended_deg.start), clamp_deg(subtended_deg.end));
    let subtended = lo.min(hi)..lo.max(hi);
    (0..n)
        .map(|_| {
            let theta = draw(&(max_theta.cos()..1.0)).acos();
            let phi = draw(&(0.0..TAU));
            let half = 0.5 * draw(&subtended).to_radians();
            let omega = draw(&(0.0..PI));
            let (st, ct) = theta.sin_cos();
            let (sp, cp) = phi.sin_cos();
            // Dome coordinates (right, up, along the axis).
            let mid = DVec3::new(st * cp, st * sp, ct);
            let e_theta = DVec3::new(ct * cp, ct * sp, -st);
            let e_phi = DVec3::new(-sp, cp, 0.0);
            let t = omega.cos() * e_theta + omega.sin() * e_phi;
            let (sh, ch) = half.sin_cos();
            let a = proj.from_dome(mid * ch - t * sh) * draw(&RANDOM_EDGE_DISTANCE_M);
            let b = proj.from_dome(mid * ch + t * sh) * draw(&RANDOM_EDGE_DISTANCE_M);
            [a, b]
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dome::arc::subtended_angle;

    #[test]
    fn a_ray_meets_the_face_of_its_dominant_axis() {
        assert_eq!(cube_face_axis(DVec3::new(0.2, -0.9, 0.1)), DVec3::NEG_Y);
        assert_eq!(cube_face_axis(DVec3::new(0.5, 0.1, -0.7)), DVec3::NEG_Z);
        assert_eq!(cube_face_axis(DVec3::new(3.0, 2.9, -2.9)), DVec3::X);
        // Ties: x before y before z.
        assert_eq!(cube_face_axis(DVec3::new(1.0, 1.0, 1.0)), DVec3::X);
        assert_eq!(cube_face_axis(DVec3::new(0.0, -1.0, 1.0)), DVec3::NEG_Y);
    }

    #[test]
    fn random_edges_are_seeded_and_within_their_ranges() {
        let p = crate::dome::test_dome(180.0, 20.0, 2048);
        let e = random_edges(&p, 500, 80f64.to_radians(), 1.0..60.0, 7);
        assert_eq!(e.len(), 500);
        assert_eq!(e, random_edges(&p, 500, 80f64.to_radians(), 1.0..60.0, 7));
        assert_ne!(e, random_edges(&p, 500, 80f64.to_radians(), 1.0..60.0, 8));
        for &[a, b] in &e {
            let alpha = subtended_angle(a, b).to_degrees();
            assert!((1.0 - 1e-9..60.0 + 1e-9).contains(&alpha), "{alpha}");
            for v in [a, b] {
                assert!((1.0 - 1e-12..20.0).contains(&v.length()));
            }
            let mid = (a.normalize() + b.normalize()).normalize();
            assert!(p.theta(mid) <= 80f64.to_radians() + 1e-9);
        }
        // Degenerate and reversed ranges: no panic, clamped.
        assert_eq!(random_edges(&p, 3, f64::NAN, 10.0..10.0, 1).len(), 3);
        assert!(
            random_edges(&p, 3, 9.0, 400.0..-5.0, 1)
                .iter()
                .flatten()
                .all(|v| v.is_finite())
        );
    }

    #[test]
    fn cuboid_is_closed_and_wound_outwards() {
        let m = TriMesh::cuboid(DVec3::splat(-1.0), DVec3::new(1.0, 2.0, 3.0), false);
        assert_eq!((m.positions().len(), m.triangles().len()), (8, 12));
        assert!(m.boundary_edges().is_empty());
        let centre = DVec3::new(0.0, 0.5, 1.0);
        for &t in m.triangles() {
            let [a, b, c] = m.corners(t);
            assert!((b - a).cross(c - a).dot(a - centre) > 0.0);
        }
        let inside = TriMesh::cuboid(DVec3::splat(-1.0), DVec3::new(1.0, 2.0, 3.0), true);
        for &t in inside.triangles() {
            let [a, b, c] = inside.corners(t);
            assert!((b - a).cross(c - a).dot(a - centre) < 0.0);
        }
    }
}
