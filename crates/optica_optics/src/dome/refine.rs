//! Refinement of line primitives (paper §3.2): segment and polyline in,
//! clipped and split polylines out.
//!
//! Steps per segment: clip (see [`clip_segment`]), compute its subtended angle
//! and the number of pieces from the rule (§3.2 step 1, D4–D6), generate the
//! new vertices at equal angles along the arc (step 2, D7) and join them
//! (step 3). Output vertices are 3D view-space points on the original segment,
//! so a renderer projects them with the same per-vertex projection and keeps
//! correct radial depth.

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::arc::{ArcError, split_by};
use super::camera::DomeProjection;
use super::clip::clip_parts;
use super::error::DomeError;
use super::rule::SplitRule;

/// What a batch refinement did. Bad primitives are counted here, one counter
/// per cause, instead of failing the batch (the documented fallback: they
/// are left out). Nothing is dropped for the antipode: segments are clipped
/// before it ([`clipped_away`](Self::clipped_away)) and sub-triangles
/// covering it are culled ([`culled`](Self::culled)).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RefineStats {
    /// Input primitives (segments or triangles).
    pub input: usize,
    /// Output primitives (segments or triangles).
    pub emitted: usize,
    /// Inputs left out for a NaN or infinite vertex coordinate.
    pub dropped_nonfinite: usize,
    /// Inputs left out (for triangles: wholly or in part) because a vertex,
    /// or a vertex made by clipping, is at the camera origin, where no
    /// direction is defined.
    pub dropped_at_origin: usize,
    /// Inputs left out (for triangles: wholly or in part) because a segment
    /// or an edge passes through the viewer (its ends are seen in opposite
    /// directions).
    pub dropped_through_viewer: usize,
    /// Inputs removed entirely by clipping (behind the view plane or inside
    /// the antipode guard cone).
    pub clipped_away: usize,
    /// Refined sub-triangles culled at the antipode guard (FOV > 180°).
    pub culled: usize,
    /// Triangles added as rim skirts past the view plane (FOV > 178°, see
    /// [`DomeProjection::rim_skirt_rad`](super::DomeProjection::rim_skirt_rad)).
    pub skirt: usize,
    /// Edges whose piece count hit [`MAX_PIECES`](super::MAX_PIECES).
    pub capped_edges: usize,
}

impl RefineStats {
    /// Sums two records (for batches refined in parallel).
    pub fn merge(self, o: Self) -> Self {
        Self {
            input: self.input + o.input,
            emitted: self.emitted + o.emitted,
            dropped_nonfinite: self.dropped_nonfinite + o.dropped_nonfinite,
            dropped_at_origin: self.dropped_at_origin + o.dropped_at_origin,
            dropped_through_viewer: self.dropped_through_viewer + o.dropped_through_viewer,
            clipped_away: self.clipped_away + o.clipped_away,
            culled: self.culled + o.culled,
            skirt: self.skirt + o.skirt,
            capped_edges: self.capped_edges + o.capped_edges,
        }
    }

    /// Counts one input left out for `cause`.
    pub(crate) fn drop_for(&mut self, cause: ArcError) {
        match cause {
            ArcError::NonFinite(_) => self.dropped_nonfinite += 1,
            ArcError::AtOrigin => self.dropped_at_origin += 1,
            ArcError::ThroughViewer => self.dropped_through_viewer += 1,
        }
    }
}

/// One segment after clipping and splitting.
#[derive(Clone, Debug, PartialEq)]
pub struct RefinedSegment {
    /// Zero, one or two polylines (clipping can cut a segment in two when
    /// FOV > 180°), oriented like the input.
    pub strips: Vec<Vec<DVec3>>,
    /// Whether a piece count hit [`MAX_PIECES`](super::MAX_PIECES).
    pub capped: bool,
}

impl RefinedSegment {
    /// Number of output segments.
    pub fn segment_count(&self) -> usize {
        self.strips.iter().map(|s| s.len().saturating_sub(1)).sum()
    }
}

/// Clips and refines segment a→b. Errors: a non-finite vertex
/// ([`DomeError::Input`]), an endpoint at the origin, a segment through the
/// viewer.
pub fn refine_segment(
    proj: &DomeProjection,
    a: DVec3,
    b: DVec3,
    rule: SplitRule,
) -> Result<RefinedSegment, DomeError> {
    Ok(refine_one(proj, a, b, rule)?)
}

/// [`refine_segment`] with the failure's cause.
fn refine_one(
    proj: &DomeProjection,
    a: DVec3,
    b: DVec3,
    rule: SplitRule,
) -> Result<RefinedSegment, ArcError> {
    let mut capped = false;
    let mut strips = Vec::new();
    for [p, q] in clip_parts(proj, a, b)? {
        let (strip, cap) = split_by(p, q, |arc| rule.pieces_of_arc(proj, arc))?;
        capped |= cap;
        strips.push(strip);
    }
    Ok(RefinedSegment { strips, capped })
}

/// Refined line primitives: polylines and what happened.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RefinedLines {
    /// Output polylines.
    pub strips: Vec<Vec<DVec3>>,
    /// Counters (inputs are segments).
    pub stats: RefineStats,
}

/// Refines a polyline (consecutive points joined). Segments that fail
/// (non-finite vertex, at the origin, through the viewer) are left out and
/// counted per cause; the polyline continues as a new strip after them.
pub fn refine_polyline(proj: &DomeProjection, points: &[DVec3], rule: SplitRule) -> RefinedLines {
    let mut out = RefinedLines::default();
    for w in points.windows(2) {
        out.stats.input += 1;
        match refine_one(proj, w[0], w[1], rule) {
            Err(cause) => out.stats.drop_for(cause),
            Ok(seg) => {
                out.stats.capped_edges += usize::from(seg.capped);
                if seg.strips.is_empty() {
                    out.stats.clipped_away += 1;
                }
                out.stats.emitted += seg.segment_count();
                for strip in seg.strips {
                    // Continue the previous strip when this one starts where it ended.
                    match out.strips.last_mut() {
                        Some(last) if last.last() == strip.first() => {
                            last.extend_from_slice(&strip[1..])
                        }
                        _ => out.strips.push(strip),
                    }
                }
            }
        }
    }
    out
}

/// Refines independent segments in parallel; one or two strips per kept
/// segment, in input order. Bad segments are left out and counted per
/// cause, not fatal.
pub fn refine_segments(
    proj: &DomeProjection,
    segments: &[[DVec3; 2]],
    rule: SplitRule,
) -> RefinedLines {
    refine_batch(segments, |a, b| refine_one(proj, a, b, rule))
}

/// Refines independent segments in parallel with `refine`; its strips in
/// input order, bad segments left out and counted per cause.
pub(crate) fn refine_batch(
    segments: &[[DVec3; 2]],
    refine: impl Fn(DVec3, DVec3) -> Result<RefinedSegment, ArcError> + Sync,
) -> RefinedLines {
    let parts: Vec<(Vec<Vec<DVec3>>, RefineStats)> = segments
        .par_iter()
        .map(|&[a, b]| {
            let mut st = RefineStats {
                input: 1,
                ..Default::default()
            };
            match refine(a, b) {
                Err(cause) => {
                    st.drop_for(cause);
                    (Vec::new(), st)
                }
                Ok(seg) => {
                    st.capped_edges = usize::from(seg.capped);
                    st.clipped_away = usize::from(seg.strips.is_empty());
                    st.emitted = seg.segment_count();
                    (seg.strips, st)
                }
            }
        })
        .collect();
    let mut out = RefinedLines::default();
    for (strips, st) in parts {
        out.strips.extend(strips);
        out.stats = out.stats.merge(st);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::Expected;

    fn dome(fov: f64) -> DomeProjection {
        crate::dome::test_dome(fov, 0.0, 4096)
    }

    fn chord_gap(tolerance_px: f64) -> SplitRule {
        SplitRule::chord_gap(tolerance_px).unwrap()
    }

    #[test]
    fn polyline_across_the_view_plane_is_cut_and_joined() {
        let p = dome(170.0);
        let rule = chord_gap(1.0);
        // Square loop around the viewer at z = -1 then dipping behind it.
        let pts = [
            DVec3::new(-2.0, -2.0, -1.0),
            DVec3::new(2.0, -2.0, -1.0),
            DVec3::new(2.0, 2.0, -1.0),
            DVec3::new(-2.0, 2.0, 1.0),
            DVec3::new(-2.0, -2.0, -1.0),
        ];
        let out = refine_polyline(&p, &pts, rule);
        assert_eq!(out.stats.input, 4);
        // The first two segments join into one strip; the third is cut at
        // z = 0 and ends there; the fourth starts on z = 0: two strips.
        assert_eq!(out.strips.len(), 2);
        assert!(out.strips.iter().flatten().all(|v| v.z <= 0.0));
        assert_eq!(
            out.stats.emitted,
            out.strips.iter().map(|s| s.len() - 1).sum::<usize>()
        );
        assert!(out.stats.emitted > 4);
    }

    #[test]
    fn bad_segments_are_counted_per_cause() {
        let p = dome(180.0);
        let rule = chord_gap(1.0);
        let segs = [
            [DVec3::new(1.0, 0.0, -1.0), DVec3::new(f64::NAN, 0.0, -1.0)],
            [DVec3::new(1.0, 0.0, -1.0), DVec3::new(-1.0, 0.0, 1.0)],
            [DVec3::new(1.0, 0.0, -1.0), DVec3::ZERO],
            [DVec3::new(1.0, 0.0, -1.0), DVec3::new(-1.0, 0.0, -1.0)],
            [DVec3::new(1.0, 0.0, 1.0), DVec3::new(-1.0, 0.0, 1.0)],
        ];
        let out = refine_segments(&p, &segs, rule);
        let want = RefineStats {
            input: 5,
            emitted: out.strips[0].len() - 1,
            dropped_nonfinite: 1,
            dropped_at_origin: 1,
            dropped_through_viewer: 1,
            clipped_away: 1,
            culled: 0,
            skirt: 0,
            capped_edges: 0,
        };
        assert_eq!(out.stats, want);
        assert_eq!(out.strips.len(), 1);
        // The same causes, typed, for one segment.
        match refine_segment(&p, segs[0][0], segs[0][1], rule) {
            Err(DomeError::Input(e)) => assert_eq!(e.expected, Expected::FiniteVector),
            other => panic!("{other:?}"),
        }
        assert_eq!(
            refine_segment(&p, segs[1][0], segs[1][1], rule),
            Err(DomeError::ThroughViewer)
        );
        assert_eq!(
            refine_segment(&p, segs[2][0], segs[2][1], rule),
            Err(DomeError::AtOrigin)
        );
        // And in a polyline, which restarts after each bad segment.
        let line = [
            segs[3][0],
            segs[3][1],
            DVec3::ZERO,
            DVec3::new(0.0, 1.0, -1.0),
            DVec3::new(1.0, 1.0, -1.0),
        ];
        let out = refine_polyline(&p, &line, rule);
        assert_eq!((out.stats.input, out.stats.dropped_at_origin), (4, 2));
        assert_eq!(out.strips.len(), 2);
    }

    #[test]
    fn zero_length_segment_is_one_piece() {
        let p = dome(180.0);
        let a = DVec3::new(0.3, 0.2, -1.0);
        let r = refine_segment(&p, a, a, chord_gap(0.1)).unwrap();
        assert_eq!(r.strips, vec![vec![a, a]]);
    }

    #[test]
    fn sub_micro_pixel_tolerance_hits_the_cap_with_finite_output() {
        // A 90° edge near the rim at 1e-9 px: MAX_PIECES pieces, capped, finite.
        let p = dome(180.0);
        let (a, b) = (DVec3::new(1.0, 0.0, -0.02), DVec3::new(0.0, 1.0, -0.02));
        let r = refine_segment(&p, a, b, chord_gap(1e-9)).unwrap();
        assert!(r.capped);
        assert_eq!(r.segment_count(), crate::dome::MAX_PIECES as usize);
        assert!(r.strips.iter().flatten().all(|v| v.is_finite()));
        let lines = refine_segments(&p, &[[a, b]], chord_gap(1e-9));
        assert_eq!(lines.stats.capped_edges, 1);
    }
}
