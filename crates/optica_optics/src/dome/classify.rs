//! The paper's classification of primitives (§3.1) and pre-subdivision.
//!
//! The paper sorts a planetarium's primitives into three classes:
//!
//! | primitive | examples (paper) | treatment |
//! |---|---|---|
//! | lines | constellation lines, coordinate grids | split per frame by the view (geometry shader) |
//! | triangles whose apparent size changes | large stars, satellites, vehicles, buildings, scenery | split per frame by the view |
//! | triangles of nearly constant apparent size | small stars, images, photos, constellation art | split once in advance, drawn without the geometry shader |
//!
//! Why the last class can be split once: its subtended angles do not change
//! (the objects keep their distance from the viewer and only the view turns),
//! and the paper's rule (D4) depends on the subtended angle alone, so one
//! subdivision with the worst-case step
//! ([`SplitRule::visual_angle_for_tolerance`](super::SplitRule::visual_angle_for_tolerance))
//! serves every view direction. [`pre_subdivide`] does that.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use std::f64::consts::PI;

use super::arc::Arc;
use super::camera::DomeProjection;
use super::refine::RefineStats;
use super::rule::{SplitRule, count_pieces};
use super::triangle::{RefinedMesh, TriMesh, Welder, subdivide_triangle};
use crate::input::{self, InvalidInput};

/// Kind of primitive (paper §3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum PrimitiveKind {
    /// A line or polyline (the paper's "fragments represented by straight
    /// lines", 直線で表されるフラグメント).
    Line,
    /// A triangle (the paper's "fragments represented by triangles",
    /// 三角形で表されるフラグメント).
    Triangle,
}

/// Whether the apparent size of a primitive changes while the app runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ApparentSize {
    /// It moves relative to the viewer, so its subtended angles change.
    Changing,
    /// It keeps its distance to the viewer (sky objects): only the view turns.
    NearlyConstant,
}

/// How a primitive is refined (paper §3.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Treatment {
    /// Split every frame from the current view ([`refine_segment`](super::refine_segment),
    /// [`refine_mesh`](super::refine_mesh)).
    Dynamic,
    /// Split once in advance ([`pre_subdivide`]) and drawn as is.
    PreSubdivided,
}

/// The paper's classification: lines and triangles of changing size are
/// dynamic; triangles of nearly constant size are pre-subdivided.
pub fn classify(kind: PrimitiveKind, size: ApparentSize) -> Treatment {
    match (kind, size) {
        (PrimitiveKind::Triangle, ApparentSize::NearlyConstant) => Treatment::PreSubdivided,
        _ => Treatment::Dynamic,
    }
}

/// The piece size for [`pre_subdivide`] that serves every view direction of
/// `proj` at `tolerance_px`: the paper's calibrated step
/// ([`SplitRule::visual_angle_for_tolerance`]), at most
/// [`DomeProjection::max_unclipped_piece_rad`] (pre-subdivided geometry is
/// not clipped; a renderer drops its vertices past
/// [`DomeProjection::theta_draw_limit`], and pieces that small cannot wrap
/// around the antipode). Errors: `tolerance_px` not finite and positive.
pub fn pre_subdivision_piece_rad(
    proj: &DomeProjection,
    tolerance_px: f64,
) -> Result<f64, InvalidInput> {
    let step = SplitRule::visual_angle_for_tolerance(proj, tolerance_px)?
        .max_piece_rad()
        .unwrap_or(PI);
    Ok(step.min(proj.max_unclipped_piece_rad()))
}

/// Splits a mesh once with the paper's rule, pieces of at most
/// `max_piece_rad` subtended at the origin (the viewer's position; the
/// mesh is in viewer-centred coordinates, any orientation). No clipping: the
/// result is meant to be drawn from every view direction, and is crack-free
/// like [`refine_mesh`](super::refine_mesh). Triangles with a non-finite
/// vertex, a vertex at the origin or an edge through the viewer are left out
/// and counted per cause. Errors: `max_piece_rad` not finite and positive.
pub fn pre_subdivide(mesh: &TriMesh, max_piece_rad: f64) -> Result<RefinedMesh, InvalidInput> {
    let max_piece_rad = input::positive("maximum piece angle (rad)", max_piece_rad)?;
    let pieces = |arc: &Arc| count_pieces(arc.alpha / max_piece_rad);
    let parts: Vec<(TriMesh, RefineStats)> = mesh
        .triangles
        .par_iter()
        .map(|&t| {
            let mut st = RefineStats {
                input: 1,
                ..Default::default()
            };
            match subdivide_triangle(mesh.corners(t), &pieces, true) {
                Ok((m, capped)) => {
                    st.capped_edges = usize::from(capped);
                    (m, st)
                }
                Err(cause) => {
                    st.drop_for(cause);
                    (TriMesh::default(), st)
                }
            }
        })
        .collect();
    let mut out = RefinedMesh::default();
    let mut welder = Welder::default();
    for (m, st) in &parts {
        welder.add(m);
        out.stats = out.stats.merge(*st);
    }
    out.mesh = welder.into_mesh();
    out.stats.emitted = out.mesh.triangles.len();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dome::{EdgeErrors, SplitRule};
    use glam::{DQuat, DVec3};
    use proptest::prelude::*;

    #[test]
    fn paper_classes() {
        use ApparentSize::*;
        use PrimitiveKind::*;
        assert_eq!(classify(Line, Changing), Treatment::Dynamic);
        assert_eq!(classify(Line, NearlyConstant), Treatment::Dynamic);
        assert_eq!(classify(Triangle, Changing), Treatment::Dynamic);
        assert_eq!(classify(Triangle, NearlyConstant), Treatment::PreSubdivided);
    }

    /// A "constellation art" quad on the sky sphere: 40° × 30° at radius 100.
    fn sky_quad() -> TriMesh {
        let d = |az: f64, el: f64| {
            let (az, el) = (az.to_radians(), el.to_radians());
            DVec3::new(el.cos() * az.sin(), el.sin(), -el.cos() * az.cos()) * 100.0
        };
        let positions = vec![
            d(-20.0, -15.0),
            d(20.0, -15.0),
            d(20.0, 15.0),
            d(-20.0, 15.0),
        ];
        TriMesh::new(positions, vec![[0, 1, 2], [0, 2, 3]]).unwrap()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        #[test]
        fn pre_subdivided_sky_art_is_within_tolerance_in_every_view(
            ax in -1.0f64..1.0, ay in -1.0f64..1.0, az in -1.0f64..1.0, angle in 0.0f64..6.3,
        ) {
            // Subdivide once with the worst-case step for 1 px at 4K/180°,
            // then turn the view arbitrarily: every edge kept in front of the
            // view plane is within 1 px.
            let proj = crate::dome::test_dome(180.0, 0.0, 4096);
            let rule = SplitRule::visual_angle_for_tolerance(&proj, 1.0).unwrap();
            let once = pre_subdivide(&sky_quad(), rule.max_piece_rad().unwrap()).unwrap();
            prop_assume!(DVec3::new(ax, ay, az).length() > 0.1);
            let q = DQuat::from_axis_angle(DVec3::new(ax, ay, az).normalize(), angle);
            let edges: Vec<[DVec3; 2]> = once.mesh.edges().iter()
                .map(|e| e.map(|i| q * once.mesh.positions()[i as usize]))
                .filter(|e| e.iter().all(|v| v.z <= 0.0))
                .collect();
            let err = EdgeErrors::of_edges(&proj, &edges);
            prop_assert!(err.max_px <= 1.0, "{:?}", err);
        }
    }

    #[test]
    fn pre_subdivision_piece_is_the_paper_step_or_the_antipode_cap() {
        // 4K/180° at 0.5 px: the calibrated step, 2.53°. A 1000 px
        // tolerance would allow pieces of tens of degrees: capped at half
        // the gap between the draw limit and the antipode (5.6° at 180°).
        let p = crate::dome::test_dome(180.0, 0.0, 4096);
        let fine = pre_subdivision_piece_rad(&p, 0.5).unwrap();
        assert!(
            (fine.to_degrees() - 2.53).abs() < 0.01,
            "{}",
            fine.to_degrees()
        );
        let coarse = pre_subdivision_piece_rad(&p, 1000.0).unwrap();
        assert_eq!(coarse, p.max_unclipped_piece_rad());
        assert!((coarse.to_degrees() - 5.625).abs() < 1e-9);
        let e = pre_subdivision_piece_rad(&p, f64::NAN).unwrap_err();
        assert_eq!(e.what, "pixel tolerance (px)");
    }

    #[test]
    fn pre_subdivision_is_crack_free_and_counts_bad_input_per_cause() {
        let m = TriMesh::cuboid(DVec3::splat(-1.0), DVec3::splat(1.0), true);
        let r = pre_subdivide(&m, 5f64.to_radians()).unwrap();
        assert!(r.mesh.boundary_edges().is_empty());
        assert!(r.mesh.triangles().len() > 12 * 50);
        assert_eq!(r.stats.input, 12);
        // Vertex 3 of the cube is NaN: every triangle using it is dropped as
        // non-finite. Then one triangle with a corner at the origin and one
        // with an edge through the viewer.
        let (mut positions, mut triangles) = m.clone().into_parts();
        let uses_3 = triangles.iter().filter(|t| t.contains(&3)).count();
        positions[3] = DVec3::splat(f64::NAN);
        let n = positions.len() as u32;
        positions.extend([
            DVec3::ZERO,
            DVec3::new(1.0, 0.0, -3.0),
            DVec3::new(0.0, 1.0, -3.0),
        ]);
        triangles.push([n, n + 1, n + 2]);
        positions.extend([
            DVec3::new(-1.0, 0.0, -1.0),
            DVec3::new(1.0, 0.0, 1.0),
            DVec3::new(0.0, 1.0, -1.0),
        ]);
        triangles.push([n + 3, n + 4, n + 5]);
        let bad = TriMesh::new(positions, triangles).unwrap();
        let r = pre_subdivide(&bad, 0.1).unwrap();
        assert_eq!(r.stats.input, 14);
        assert_eq!(r.stats.dropped_nonfinite, uses_3);
        assert_eq!(r.stats.dropped_at_origin, 1);
        assert_eq!(r.stats.dropped_through_viewer, 1);
        assert!(r.mesh.positions().iter().all(|v| v.is_finite()));
        let e = pre_subdivide(&m, 0.0).unwrap_err();
        assert_eq!((e.what, e.value), ("maximum piece angle (rad)", 0.0));
    }
}
