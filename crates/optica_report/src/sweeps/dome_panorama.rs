//! The `lens: equirectangular` series of the dome report: the chord-gap
//! rule in the equirectangular panorama's own image (E2), on random edges
//! all around the viewer and on the inside-out room, measured exactly in
//! that image.
//!
//! * Camera: a 4096 × 2048 panorama, untilted.
//! * Scene: the random edges of the lens series, but with midpoints over
//!   the whole sphere (up to 179° from the image centre's direction), and
//!   the dome sweep's inside-out room.
//! * Knob: `tolerance_px`.
//! * Errors: `max_px`, `mean_px` — per input edge the worst exact chord
//!   error of its pieces (`equirect_chord_error_px`); `mesh_max_px` — every
//!   edge of the refined room but the sides of the wedges that fill a
//!   pole's row (not images of 3D edges); `room_area_err` — how far the
//!   refined room's image area is from the whole image's (it must tile the
//!   panorama once); `unrefined_max_px`, `unrefined_mean_px` — each edge
//!   drawn as one chord per quarter of longitude (cut at the seam, nothing
//!   else).
//! * Work: segments emitted, room triangles. time_ms: cut + refine +
//!   project every output vertex; baseline: project both ends of every
//!   edge.

use optica_optics::dome::{
    DomeProjection, DomeSettings, EquirectProjection, EquirectSettings, FisheyeLens,
    SEAM_NUDGE_RAD, SplitRule, equirect_chord_error_px, random_edges, refine_mesh_equirect,
    refine_segment_equirect, refine_segments_equirect,
};
use optica_optics::glam::DVec3;

use crate::{Report, Row, SweepContext, time_paired_ms};

/// The panorama of the series.
fn panorama() -> EquirectProjection {
    EquirectProjection::new(&EquirectSettings {
        width_px: 4096,
        ..Default::default()
    })
    .expect("valid panorama")
}

/// Random edges with midpoints over the whole sphere: the generator of the
/// lens series given a 358° frame whose axis is the panorama's centre.
fn edges_all_round(n: usize) -> Vec<[DVec3; 2]> {
    let frame = DomeProjection::new(&DomeSettings {
        fov_deg: 358.0,
        lens: FisheyeLens::Equidistant,
        ..Default::default()
    })
    .expect("valid frame");
    random_edges(&frame, n, 179f64.to_radians(), 1.0..60.0, 0x00D0_3E02)
}

/// Per input edge: the worst exact chord error of its pieces under `rule`
/// (max, mean).
fn per_edge_errors(p: &EquirectProjection, edges: &[[DVec3; 2]], rule: SplitRule) -> (f64, f64) {
    let (mut max, mut sum, mut n) = (0.0f64, 0.0, 0);
    for &[a, b] in edges {
        let Ok(r) = refine_segment_equirect(p, a, b, rule) else {
            continue;
        };
        let e = r
            .strips
            .iter()
            .flat_map(|s| s.windows(2))
            .filter_map(|w| equirect_chord_error_px(p, w[0], w[1]).ok())
            .fold(0.0, f64::max);
        max = max.max(e);
        sum += e;
        n += 1;
    }
    (max, sum / n.max(1) as f64)
}

/// Whether `v` is a pole vertex fanned out towards a longitude.
fn at_pole(p: &EquirectProjection, v: DVec3) -> bool {
    let q = p.to_frame(v);
    q.x.hypot(q.z) < 2.0 * SEAM_NUDGE_RAD * q.length()
}

/// The rows.
pub fn panorama_rows(report: &mut Report, ctx: &SweepContext, tolerances: &[f64]) {
    let p = panorama();
    let n_edges = ctx.pick(200, 2000);
    let (runs, budget) = ctx.pick((2, 20.0), (5, 200.0));
    let edges = edges_all_round(n_edges);
    let room = super::dome::room();
    // The baseline, timed against each tolerance in alternating blocks.
    let unrefined = || {
        edges
            .iter()
            .flatten()
            .filter_map(|v| p.pixel_of_direction(*v))
            .count()
    };
    // One piece per quarter: the visual-angle rule with a piece of 180°.
    let whole = SplitRule::visual_angle(std::f64::consts::PI).expect("valid rule");
    let (un_max, un_mean) = per_edge_errors(&p, &edges, whole);
    let size = p.size_px();
    for (k, &tol) in tolerances.iter().enumerate() {
        ctx.progress(
            k + 1,
            tolerances.len(),
            &format!("equirectangular, {tol} px"),
        );
        let rule = SplitRule::chord_gap(tol).expect("valid tolerance");
        let (timed, emitted) = time_paired_ms(
            ctx.blocks().0,
            runs,
            budget,
            || {
                let r = refine_segments_equirect(&p, &edges, rule);
                let projected = r
                    .strips
                    .iter()
                    .flatten()
                    .filter_map(|v| p.pixel_of_direction(*v))
                    .count();
                (r.stats.emitted, projected)
            },
            unrefined,
        );
        let (max, mean) = per_edge_errors(&p, &edges, rule);
        let mesh = refine_mesh_equirect(&p, &room, rule).mesh;
        let (mut mesh_max, mut area) = (0.0f64, 0.0);
        for &t in mesh.triangles() {
            let v = t.map(|i| mesh.positions()[i as usize]);
            let q = v.map(|x| p.pixel_of_direction(x).expect("off the poles"));
            area += 0.5 * (q[1] - q[0]).perp_dot(q[2] - q[0]);
            for i in 0..3 {
                let (a, b) = (v[i], v[(i + 1) % 3]);
                if !(at_pole(&p, a) || at_pole(&p, b)) {
                    let e = equirect_chord_error_px(&p, a, b).unwrap_or(f64::INFINITY);
                    mesh_max = mesh_max.max(e);
                }
            }
        }
        // Pixel rows grow downwards: the room's inward faces wind clockwise.
        let room_area_err = (-area / (size.x * size.y) - 1.0).abs();
        report.rows.push(
            Row::paired_cpu(tol, &timed)
                .series("lens: equirectangular 360°")
                .err("max_px", max)
                .err("mean_px", mean)
                .err("mesh_max_px", mesh_max)
                .err("room_area_err", room_area_err)
                .err("unrefined_max_px", un_max)
                .err("unrefined_mean_px", un_mean)
                .work("segments", emitted.0 as f64)
                .work("input_edges", edges.len() as f64)
                .work("mesh_triangles", mesh.triangles().len() as f64),
        );
    }
}
