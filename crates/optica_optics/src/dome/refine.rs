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

use super::arc::{Arc, canonical_less, split_segment};
use super::camera::DomeProjection;
use super::clip::clip_segment;
use super::error::DomeError;
use super::rule::SplitRule;

/// What a batch refinement did. Bad primitives are counted here instead of
/// failing the batch (the documented fallback: they are left out).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RefineStats {
    /// Input primitives (segments or triangles).
    pub input: usize,
    /// Output primitives (segments or triangles).
    pub emitted: usize,
    /// Inputs left out for a NaN or infinite vertex.
    pub dropped_nonfinite: usize,
    /// Inputs left out for passing through the viewer or touching the origin.
    pub dropped_through_viewer: usize,
    /// Inputs removed entirely by clipping (behind the view plane or inside
    /// the antipode guard cone).
    pub clipped_away: usize,
    /// Refined sub-triangles culled at the antipode guard (FOV > 180°).
    pub culled: usize,
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
            dropped_through_viewer: self.dropped_through_viewer + o.dropped_through_viewer,
            clipped_away: self.clipped_away + o.clipped_away,
            culled: self.culled + o.culled,
            capped_edges: self.capped_edges + o.capped_edges,
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

/// Clips and refines segment a→b. Errors: an invalid rule, a non-finite
/// vertex, an endpoint at the origin, a segment through the viewer.
pub fn refine_segment(proj: &DomeProjection, a: DVec3, b: DVec3, rule: SplitRule) -> Result<RefinedSegment, DomeError> {
    rule.validate()?;
    let mut capped = false;
    let mut strips = Vec::new();
    for [p, q] in clip_segment(proj, a, b)? {
        let (c0, c1) = if canonical_less(q, p) { (q, p) } else { (p, q) };
        let pieces = rule.pieces_of_arc(proj, &Arc::new(c0, c1)?);
        capped |= pieces.capped;
        strips.push(split_segment(p, q, pieces.n)?);
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

fn account(stats: &mut RefineStats, e: DomeError) {
    match e {
        DomeError::NonFiniteVertex => stats.dropped_nonfinite += 1,
        _ => stats.dropped_through_viewer += 1,
    }
}

/// Refines a polyline (consecutive points joined). Segments that fail
/// (non-finite vertex, through the viewer) are left out and counted; the
/// polyline continues as a new strip after them. Errs only on a bad rule.
pub fn refine_polyline(proj: &DomeProjection, points: &[DVec3], rule: SplitRule) -> Result<RefinedLines, DomeError> {
    rule.validate()?;
    let mut out = RefinedLines::default();
    for w in points.windows(2) {
        out.stats.input += 1;
        match refine_segment(proj, w[0], w[1], rule) {
            Err(e) => account(&mut out.stats, e),
            Ok(seg) => {
                out.stats.capped_edges += usize::from(seg.capped);
                if seg.strips.is_empty() {
                    out.stats.clipped_away += 1;
                }
                out.stats.emitted += seg.segment_count();
                for strip in seg.strips {
                    // Continue the previous strip when this one starts where it ended.
                    match out.strips.last_mut() {
                        Some(last) if last.last() == strip.first() => last.extend_from_slice(&strip[1..]),
                        _ => out.strips.push(strip),
                    }
                }
            }
        }
    }
    Ok(out)
}

/// Refines independent segments in parallel; one or two strips per kept
/// segment, in input order. Bad segments are counted, not fatal.
pub fn refine_segments(
    proj: &DomeProjection,
    segments: &[[DVec3; 2]],
    rule: SplitRule,
) -> Result<RefinedLines, DomeError> {
    rule.validate()?;
    let parts: Vec<(Vec<Vec<DVec3>>, RefineStats)> = segments
        .par_iter()
        .map(|&[a, b]| {
            let mut st = RefineStats { input: 1, ..Default::default() };
            match refine_segment(proj, a, b, rule) {
                Err(e) => {
                    account(&mut st, e);
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
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dome::DomeCamera;

    fn dome(fov: f64) -> DomeProjection {
        DomeCamera::new(fov, 0.0, 4096).unwrap().projection().unwrap()
    }

    #[test]
    fn polyline_across_the_view_plane_is_cut_and_joined() {
        let p = dome(180.0);
        let rule = SplitRule::ChordGap { tolerance_px: 1.0 };
        // Square loop around the viewer at z = -1 then dipping behind it.
        let pts = [
            DVec3::new(-2.0, -2.0, -1.0),
            DVec3::new(2.0, -2.0, -1.0),
            DVec3::new(2.0, 2.0, -1.0),
            DVec3::new(-2.0, 2.0, 1.0),
            DVec3::new(-2.0, -2.0, -1.0),
        ];
        let out = refine_polyline(&p, &pts, rule).unwrap();
        assert_eq!(out.stats.input, 4);
        // The first two segments join into one strip; the third is cut at
        // z = 0 and ends there; the fourth starts on z = 0: two strips.
        assert_eq!(out.strips.len(), 2);
        assert!(out.strips.iter().flatten().all(|v| v.z <= 0.0));
        assert_eq!(out.stats.emitted, out.strips.iter().map(|s| s.len() - 1).sum::<usize>());
        assert!(out.stats.emitted > 4);
    }

    #[test]
    fn bad_segments_are_counted_not_fatal() {
        let p = dome(180.0);
        let rule = SplitRule::ChordGap { tolerance_px: 1.0 };
        let segs = [
            [DVec3::new(1.0, 0.0, -1.0), DVec3::new(f64::NAN, 0.0, -1.0)],
            [DVec3::new(1.0, 0.0, -1.0), DVec3::new(-1.0, 0.0, 1.0)],
            [DVec3::new(1.0, 0.0, -1.0), DVec3::new(-1.0, 0.0, -1.0)],
            [DVec3::new(1.0, 0.0, 1.0), DVec3::new(-1.0, 0.0, 1.0)],
        ];
        let out = refine_segments(&p, &segs, rule).unwrap();
        assert_eq!(out.stats.dropped_nonfinite, 1);
        assert_eq!(out.stats.dropped_through_viewer, 1);
        assert_eq!(out.stats.clipped_away, 1);
        assert_eq!(out.strips.len(), 1);
        assert!(refine_segments(&p, &segs, SplitRule::ChordGap { tolerance_px: -1.0 }).is_err());
        assert_eq!(refine_segment(&p, segs[0][0], segs[0][1], rule), Err(DomeError::NonFiniteVertex));
    }

    #[test]
    fn zero_length_segment_is_one_piece() {
        let p = dome(180.0);
        let a = DVec3::new(0.3, 0.2, -1.0);
        let r = refine_segment(&p, a, a, SplitRule::ChordGap { tolerance_px: 0.1 }).unwrap();
        assert_eq!(r.strips, vec![vec![a, a]]);
    }
}
