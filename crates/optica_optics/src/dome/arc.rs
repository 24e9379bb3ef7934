//! The great-circle arc a straight 3D segment subtends at the viewer, and
//! points on the segment at a given angle along that arc.
//!
//! Every function that splits a segment orders its endpoints canonically
//! first (lexicographic on x, y, z), so the two triangles sharing an edge
//! compute bit-identical split points from either side: that is what makes
//! the refinement crack-free.

use std::cmp::Ordering;
use std::f64::consts::PI;

use glam::DVec3;

use super::error::DomeError;
use crate::input::{self, InvalidInput};

/// Relative size of |a × b| (against |a|·|b|, i.e. the sine of the subtended
/// angle) below which the segment is taken to be collinear with the viewer
/// (radial towards it, or through it). The cross product of f64 vectors is
/// accurate to a few 1e-16 relative; 1e-12 leaves four digits of margin over
/// that noise, and a 1e-12 rad arc is 1e-8 px even at 8K, so nothing visible
/// is lost by treating it as a point.
const COLLINEAR_REL: f64 = 1e-12;

/// What a non-finite segment endpoint is reported as.
const VERTEX: &str = "vertex (view space)";

/// The paper's "visual angle" (視野角) of a segment (§3.2 step 1, D4): the
/// angle it subtends at the viewer, `atan2(|a × b|, a·b)` ∈ [0, π]. Accurate for tiny
/// and for nearly 180° angles, unlike `acos` of the normalised dot product.
/// Zero when an endpoint is at the origin (callers pass finite points).
pub(crate) fn subtended_angle(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

/// Whether `a` comes before `b` in the canonical (lexicographic, total) order.
pub(crate) fn canonical_less(a: DVec3, b: DVec3) -> bool {
    a.x.total_cmp(&b.x)
        .then(a.y.total_cmp(&b.y))
        .then(a.z.total_cmp(&b.z))
        == Ordering::Less
}

/// Range of the polar angle (from a unit axis) over an arc.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ThetaRange {
    /// Smallest polar angle on the arc.
    pub min: f64,
    /// Largest polar angle on the arc.
    pub max: f64,
}

/// Why a segment has no arc: the failures of [`Arc::new`], one per cause, so
/// that the batch refiners can count each (see
/// [`RefineStats`](super::RefineStats)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum ArcError {
    /// An endpoint is not finite.
    NonFinite(InvalidInput),
    /// An endpoint is at the origin.
    AtOrigin,
    /// The segment passes through the viewer.
    ThroughViewer,
}

impl From<ArcError> for DomeError {
    fn from(e: ArcError) -> Self {
        match e {
            ArcError::NonFinite(e) => DomeError::Input(e),
            ArcError::AtOrigin => DomeError::AtOrigin,
            ArcError::ThroughViewer => DomeError::ThroughViewer,
        }
    }
}

/// A segment a→b seen from the origin: the arc from â towards b̂.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Arc {
    pub a: DVec3,
    pub b: DVec3,
    /// Unit direction of `a`.
    pub a_hat: DVec3,
    /// Unit vector ⟂ â in the plane (0, a, b), towards b; zero for a point arc.
    pub w_hat: DVec3,
    /// Subtended angle α ∈ [0, π).
    pub alpha: f64,
    len_a: f64,
    len_b: f64,
}

impl Arc {
    /// The arc of segment a→b. Errors: non-finite endpoints
    /// ([`DomeError::Input`]), an endpoint at the origin, and segments
    /// through the viewer (endpoints in opposite directions).
    pub fn new(a: DVec3, b: DVec3) -> Result<Self, ArcError> {
        input::finite_vec3(VERTEX, a).map_err(ArcError::NonFinite)?;
        input::finite_vec3(VERTEX, b).map_err(ArcError::NonFinite)?;
        let (len_a, len_b) = (a.length(), b.length());
        if len_a == 0.0 || len_b == 0.0 {
            return Err(ArcError::AtOrigin);
        }
        let a_hat = a / len_a;
        let n = a.cross(b);
        let n_len = n.length();
        let dot = a.dot(b);
        if n_len <= COLLINEAR_REL * len_a * len_b {
            if dot < 0.0 {
                return Err(ArcError::ThroughViewer);
            }
            // Radial towards the viewer (or zero length): the image is a point.
            return Ok(Self {
                a,
                b,
                a_hat,
                w_hat: DVec3::ZERO,
                alpha: 0.0,
                len_a,
                len_b,
            });
        }
        let w_hat = n.cross(a).normalize();
        let alpha = n_len.atan2(dot);
        Ok(Self {
            a,
            b,
            a_hat,
            w_hat,
            alpha,
            len_a,
            len_b,
        })
    }

    /// Whether the whole segment is seen in one direction.
    pub fn is_point(&self) -> bool {
        self.alpha == 0.0
    }

    /// Unit direction at angle β along the arc from â (the reference
    /// measures and the tests sample arcs with it; the refiner does not).
    #[cfg(any(test, feature = "reference"))]
    pub fn dir(&self, beta: f64) -> DVec3 {
        let (s, c) = beta.sin_cos();
        c * self.a_hat + s * self.w_hat
    }

    /// Unit normal of the arc's plane (â × ŵ); zero for a point arc.
    pub fn pole(&self) -> DVec3 {
        self.a_hat.cross(self.w_hat)
    }

    /// Parameter t ∈ [0, 1] of the point on the segment seen at angle β (D7):
    /// `t = |a| sin β / (|a| sin β + |b| sin(α − β))`.
    pub fn t_at(&self, beta: f64) -> f64 {
        if self.is_point() {
            return if beta > 0.0 { 1.0 } else { 0.0 };
        }
        let num = self.len_a * beta.sin();
        let den = num + self.len_b * (self.alpha - beta).sin();
        if den > 0.0 {
            (num / den).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// The 3D point on the segment seen at angle β along the arc.
    pub fn point(&self, beta: f64) -> DVec3 {
        self.a + self.t_at(beta) * (self.b - self.a)
    }

    /// Polar angle range over the arc from the unit `axis`. Along the great
    /// circle `cos θ(β) = A cos β + B sin β` (A = â·axis, B = ŵ·axis), so the
    /// extremes are at the ends or where the circle comes nearest to the
    /// axis (the direction (A, B) in its plane, at θ = atan2(|n̂·axis|,
    /// √(A² + B²)), n̂ the circle's pole) or farthest from it (the opposite
    /// direction, π minus that), when those lie on the arc.
    pub fn theta_range(&self, axis: DVec3) -> ThetaRange {
        let theta_of = |d: DVec3| d.cross(axis).length().atan2(d.dot(axis));
        let t0 = theta_of(self.a_hat);
        if self.is_point() {
            return ThetaRange { min: t0, max: t0 };
        }
        let (sine, cosine) = self.alpha.sin_cos();
        let t1 = theta_of(cosine * self.a_hat + sine * self.w_hat);
        let (mut min, mut max) = (t0.min(t1), t0.max(t1));
        let (ca, cb) = (self.a_hat.dot(axis), self.w_hat.dot(axis));
        // Whether the direction (x, y) in the arc's plane (x along â, y
        // along ŵ) is on the arc: at an angle β ∈ [0, α] from â (α < π),
        // that is sin β ≥ 0 and sin(β − α) ≤ 0.
        let on_arc =
            |x: f64, y: f64| (y > 0.0 || (y == 0.0 && x > 0.0)) && cosine * y - sine * x <= 0.0;
        let (nearest, farthest) = (on_arc(ca, cb), on_arc(-ca, -cb));
        if nearest || farthest {
            let theta = self.pole().dot(axis).abs().atan2(ca.hypot(cb));
            if nearest {
                min = min.min(theta);
            }
            if farthest {
                max = max.max(PI - theta);
            }
        }
        ThetaRange { min, max }
    }
}

/// Splits segment a→b into `n` pieces of equal subtended angle (D7) and
/// returns the `n + 1` points from `a` to `b` (endpoints copied exactly).
/// Bit-identical for (a, b) and (b, a), reversed. `n` is clamped to
/// 1 ..= [`MAX_PIECES`](super::MAX_PIECES). Errors: a non-finite endpoint
/// ([`DomeError::Input`]), an endpoint at the origin, a segment through the
/// viewer.
pub fn split_segment(a: DVec3, b: DVec3, n: u32) -> Result<Vec<DVec3>, DomeError> {
    Ok(split_points(a, b, n.clamp(1, super::MAX_PIECES))?)
}

/// [`split_segment`] with the failure's cause, for any `n ≥ 1`.
pub(crate) fn split_points(a: DVec3, b: DVec3, n: u32) -> Result<Vec<DVec3>, ArcError> {
    let swap = canonical_less(b, a);
    let (p, q) = if swap { (b, a) } else { (a, b) };
    Ok(points_of_arc(&Arc::new(p, q)?, n, swap))
}

/// The `n + 1` points of [`split_points`] on `arc` (built in canonical
/// order), from its start, or from its end when `reversed`.
pub(crate) fn points_of_arc(arc: &Arc, n: u32, reversed: bool) -> Vec<DVec3> {
    let n = n.max(1);
    let (p, q) = (arc.a, arc.b);
    let mut pts = Vec::with_capacity(n as usize + 1);
    pts.push(p);
    for i in 1..n {
        let beta = arc.alpha * f64::from(i) / f64::from(n);
        let pt = if arc.is_point() {
            p + (f64::from(i) / f64::from(n)) * (q - p)
        } else {
            arc.point(beta)
        };
        pts.push(pt);
    }
    pts.push(q);
    if reversed {
        pts.reverse();
    }
    pts
}

/// Segment p→q split into the pieces `pieces` gives its arc (asked of the
/// canonically ordered arc, so both orders split alike): its points from p
/// to q, and whether the count was capped.
pub(crate) fn split_by(
    p: DVec3,
    q: DVec3,
    pieces: impl Fn(&Arc) -> super::Pieces,
) -> Result<(Vec<DVec3>, bool), ArcError> {
    let swap = canonical_less(q, p);
    let arc = if swap {
        Arc::new(q, p)?
    } else {
        Arc::new(p, q)?
    };
    let n = pieces(&arc);
    Ok((points_of_arc(&arc, n.n, swap), n.capped))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn subtended_angle_known_values() {
        assert!((subtended_angle(DVec3::X, DVec3::Y) - PI / 2.0).abs() < 1e-15);
        assert!(
            (subtended_angle(DVec3::X * 3.0, DVec3::new(1.0, 1.0, 0.0)) - PI / 4.0).abs() < 1e-15
        );
        // 1e-9 rad apart: acos(dot) would return 0 or ~1.5e-8 here.
        let b = DVec3::new(1.0, 1e-9, 0.0);
        assert!((subtended_angle(DVec3::X, b) - 1e-9).abs() < 1e-20);
    }

    #[test]
    fn split_points_are_equal_in_angle_and_on_the_segment() {
        let a = DVec3::new(-3.0, 1.0, -1.0);
        let b = DVec3::new(4.0, 0.5, -2.0);
        let pts = split_segment(a, b, 7).unwrap();
        assert_eq!(pts.len(), 8);
        assert_eq!(pts[0], a);
        assert_eq!(pts[7], b);
        let step = subtended_angle(a, b) / 7.0;
        for w in pts.windows(2) {
            assert!((subtended_angle(w[0], w[1]) - step).abs() < 1e-12);
            // On the segment: collinear with a and b.
            let off = (w[1] - a).cross(b - a).length() / (b - a).length();
            assert!(off < 1e-12);
        }
    }

    #[test]
    fn degenerate_segments() {
        let a = DVec3::new(1.0, 2.0, -3.0);
        assert_eq!(split_segment(a, a, 3).unwrap(), vec![a, a, a, a]);
        assert_eq!(split_segment(a, -2.0 * a, 2), Err(DomeError::ThroughViewer));
        assert_eq!(split_segment(a, DVec3::ZERO, 2), Err(DomeError::AtOrigin));
        match split_segment(a, DVec3::new(0.0, f64::INFINITY, 0.0), 2) {
            Err(DomeError::Input(e)) => {
                assert_eq!(
                    (e.what, e.value, e.expected),
                    (VERTEX, f64::INFINITY, input::Expected::FiniteVector)
                )
            }
            other => panic!("{other:?}"),
        }
        // The piece count is clamped to 1 ..= MAX_PIECES.
        let b = DVec3::new(-2.0, 1.0, -3.0);
        assert_eq!(split_segment(a, b, 0).unwrap(), vec![a, b]);
        assert_eq!(
            split_segment(a, b, u32::MAX).unwrap().len(),
            super::super::MAX_PIECES as usize + 1
        );
        // Radial towards the viewer: a point arc, split linearly, finite.
        let pts = split_segment(a, 0.25 * a, 4).unwrap();
        assert!(pts.iter().all(|p| p.is_finite()));
    }

    #[test]
    fn theta_range_of_an_arc_over_the_axis() {
        // Arc from 40° on one side to 30° on the other side of the -Z axis:
        // passes through the axis (θ = 0), max θ is 40°.
        let axis = DVec3::NEG_Z;
        let d = |deg: f64| DVec3::new(deg.to_radians().sin(), 0.0, -deg.to_radians().cos());
        let arc = Arc::new(d(-40.0) * 2.0, d(30.0) * 5.0).unwrap();
        let r = arc.theta_range(axis);
        assert!(r.min.abs() < 1e-12);
        assert!((r.max - 40f64.to_radians()).abs() < 1e-12);
        // Arc along the horizon but tilted: its farthest point is interior.
        let arc = Arc::new(DVec3::new(1.0, -1.0, 0.2), DVec3::new(1.0, 1.0, 0.2)).unwrap();
        let r = arc.theta_range(axis);
        let mid = DVec3::new(1.0, 0.0, 0.2);
        let want = mid.cross(axis).length().atan2(mid.dot(axis));
        assert!((r.max - want).abs() < 1e-12);
    }

    #[test]
    fn theta_range_bounds_the_arc_sampled_densely() {
        // Random arcs and axes: the range holds every sampled point's polar
        // angle and its ends are reached (to the sampling's resolution).
        let mut uniform = crate::dome::test_uniform(0xA11CE);
        let mut next = move || uniform() * 2.0 - 1.0;
        for _ in 0..500 {
            let axis = DVec3::new(next(), next(), next()).normalize();
            let a = 3.0 * DVec3::new(next(), next(), next());
            let b = 3.0 * DVec3::new(next(), next(), next());
            let Ok(arc) = Arc::new(a, b) else { continue };
            let r = arc.theta_range(axis);
            let theta = |d: DVec3| d.cross(axis).length().atan2(d.dot(axis));
            let samples: Vec<f64> = (0..=4000)
                .map(|k| theta(arc.dir(arc.alpha * f64::from(k) / 4000.0)))
                .collect();
            let lo = samples.iter().copied().fold(f64::MAX, f64::min);
            let hi = samples.iter().copied().fold(0.0, f64::max);
            assert!(
                r.min <= lo + 1e-12 && r.max >= hi - 1e-12,
                "{r:?} vs {lo}..{hi}"
            );
            // (θ moves at most as fast as β along the arc: the sampled
            // extremes are within half a step of the true ones.)
            let step = arc.alpha / 4000.0;
            assert!(
                lo - r.min <= step && r.max - hi <= step,
                "{r:?} vs {lo}..{hi}"
            );
        }
    }

    proptest! {
        #[test]
        fn split_is_symmetric_bit_for_bit(ax in -5.0f64..5.0, ay in -5.0f64..5.0, az in -5.0f64..5.0,
                                          bx in -5.0f64..5.0, by in -5.0f64..5.0, bz in -5.0f64..5.0,
                                          n in 1u32..40) {
            let (a, b) = (DVec3::new(ax, ay, az), DVec3::new(bx, by, bz));
            if let Ok(fwd) = split_segment(a, b, n) {
                let mut back = split_segment(b, a, n).unwrap();
                back.reverse();
                prop_assert_eq!(fwd, back);
            }
        }
    }
}
