//! The lens's refraction (the paper's §3) on the adapter: its rows in the
//! `spectacles` report (series "refraction …", "moving lens").
//!
//! * Scene: a plane 2 m ahead whose texture encodes its own coordinates
//!   (linear floats, unlit), seen through a −4 D CR-39 lens, 0.8 rad
//!   vertical field of view.
//! * Knob: the lens's tessellation, rings of its back surface (segments
//!   8/3 as many; 24 × 64 is the paper's ~1,500 vertices).
//! * Reference: the exact view, every pixel's ray traced through both
//!   surfaces to the plane (`plane_seen_through_lens`; the texture's x is
//!   read in red, which the lens refracts as the C line, y in green, the
//!   d line). Error: the
//!   displacement (px) between the plane point a pixel shows and the one
//!   its exact ray meets: mean and max over the pixels whose exact point
//!   the eye's own view shows (the environment map is that view: a minus
//!   lens shows a little past its edge, where the edge pixel stands in;
//!   `outside_view` counts those pixels).
//! * Time: the lit room (see `spectacles_render`) through the lens, with
//!   the refraction against the same frame with `refraction: false`
//!   (`baseline_time_ms`); `trace_ms` the CPU trace of the lens.
//! * Moving lens: the lens slid by a millimetre every frame (retraced every
//!   frame, as the paper's 6 fps case) against the same lens still.
//! * Chromatic aberration: the lens with its colours refracted apart
//!   against the same lens without.

use bevy::prelude::*;
use optica_optics::glass::LAMBDA_C_NM;
use optica_optics::spectacles::plane_seen_through_lens;
use optica_spectacles::Spectacles;
use optica_spectacles::twins::{camera_z, trace_lens};

use super::SweepError;
use crate::{Report, Row, SweepContext};

const FOV: f32 = 0.8;
const PLANE_Z: f32 = 2.0;
const PLANE_HALF: f32 = 2.0;
const LENS_D: f32 = -4.0;

fn lens(rings: u32) -> Spectacles {
    Spectacles {
        tessellation: UVec2::new(rings, (rings * 8).div_ceil(3).max(3)),
        ..Spectacles::sphere(LENS_D)
    }
}

/// The coordinate plane seen through `spectacles`.
fn plane(spectacles: Spectacles) -> impl FnOnce(&mut App) {
    crate::fixtures::coordinate_plane(
        Some(spectacles),
        FOV,
        PLANE_Z,
        PLANE_HALF,
        [0, 1, 2],
        Color::BLACK,
    )
}

/// Slides the lens of every camera by `step_mm` each frame, back and forth.
#[derive(Resource)]
struct Slide(f32);

fn slide(slide: Res<Slide>, time: Res<Time>, mut lenses: Query<&mut Spectacles>) {
    for mut s in &mut lenses {
        s.decentration_mm.x = slide.0 * (time.elapsed_secs() * 60.0).sin();
    }
}

/// Adds the refraction series to `report`.
pub fn refraction_rows(ctx: &SweepContext, report: &mut Report) -> Result<(), SweepError> {
    let size = ctx.pick(128, 256);
    let rings: Vec<u32> = ctx.pick(vec![6, 24], vec![3, 6, 12, 24, 48]);
    let timing = ctx.pick((4, 3), (8, 15));
    let (blocks, per_block) = ctx.blocks();
    let tan = f64::from(FOV / 2.0).tan();
    let px_per_m = f64::from(size) / (2.0 * tan * f64::from(PLANE_Z));
    let total = rings.len() + 1;
    let lit_room = |s: Spectacles| super::spectacles_render::room_with(s);

    for (step, &r) in rings.iter().enumerate() {
        ctx.progress(step + 1, total, &format!("refraction, {r} rings"));
        let s = lens(r);
        let designed = s.design().map_err(|e| SweepError::Setup(e.to_string()))?;
        let frame = ctx
            .headless(size, size)
            .hdr(true)
            .frames(4)
            .render(plane(s.clone()))?;
        report.adapter.get_or_insert(frame.adapter.clone());
        let img = frame
            .hdr()
            .ok_or_else(|| SweepError::Setup("no HDR frame".into()))?;
        let plane_z = f64::from(PLANE_Z) + f64::from(camera_z());
        let exact = plane_seen_through_lens(
            Some(&designed),
            f64::from(camera_z()),
            f64::from(FOV),
            size,
            plane_z,
        );
        // Red (x) is refracted as the C line (the lens's chromatic
        // aberration), green (y) as the d line.
        let red = designed.at_wavelength(LAMBDA_C_NM);
        let exact_red = plane_seen_through_lens(
            Some(&red),
            f64::from(camera_z()),
            f64::from(FOV),
            size,
            plane_z,
        );
        // What the eye's own view shows of the plane (±half its extent there).
        let shown = tan * plane_z;
        let (mut sum, mut max, mut n, mut outside) = (0.0, 0.0f64, 0usize, 0usize);
        for y in 0..size {
            for x in 0..size {
                let i = (y * size + x) as usize;
                let (Some(hit), Some(hit_red), p) = (exact[i], exact_red[i], img.get_pixel(x, y).0)
                else {
                    continue;
                };
                if hit.x.abs() > shown || hit.y.abs() > shown {
                    outside += 1;
                    continue;
                }
                if p[2] < 0.5 {
                    continue;
                }
                let e = ((f64::from(p[0]) + hit_red.x).powi(2) + (f64::from(p[1]) - hit.y).powi(2))
                    .sqrt()
                    * px_per_m;
                sum += e;
                max = max.max(e);
                n += 1;
            }
        }
        let trace = trace_lens(
            &designed,
            optica_optics::glam::DVec3::ZERO,
            s.tessellation.x as usize,
            s.tessellation.y as usize,
            s.chromatic_aberration,
        )
        .map_err(|e| SweepError::Setup(e.to_string()))?;
        let paired = ctx.headless(size, size).time_paired(
            timing.0,
            blocks,
            per_block,
            lit_room(s.clone()),
            lit_room(Spectacles {
                refraction: false,
                ..s.clone()
            }),
        )?;
        let pass = paired.effect.pass("optica/spectacles/refraction");
        report.rows.push(
            Row::paired(f64::from(r), &paired)
                .series("refraction, −4 D (knob rings)")
                .err("refraction_mean_px", sum / n.max(1) as f64)
                .err("refraction_max_px", max)
                .work("lens_vertices", trace.vertices.len() as f64)
                .work("masked_vertices", f64::from(trace.masked))
                .work("viewpoint_mm", f64::from(trace.viewpoint.length()) * 1e3)
                .work("viewpoint_rms_mm", f64::from(trace.viewpoint_rms_m) * 1e3)
                .work("pixels", n as f64)
                .work("outside_view", outside as f64)
                .work("size_px", f64::from(size))
                .timing("trace_ms", f64::from(trace.trace_ms))
                .timing("refraction_pass_ms", pass.map_or(f64::NAN, |p| p.ms.median)),
        );
    }

    ctx.progress(total, total, "moving lens");
    let chromatic = ctx.headless(size, size).time_paired(
        timing.0,
        blocks,
        per_block,
        lit_room(lens(24)),
        lit_room(Spectacles {
            chromatic_aberration: false,
            ..lens(24)
        }),
    )?;
    report.rows.push(
        Row::paired(24.0, &chromatic)
            .series("chromatic aberration: on against off (knob rings)")
            .work("frame_ratio", chromatic.ratio.median)
            .work("size_px", f64::from(size)),
    );
    let moving = ctx.headless(size, size).time_paired(
        timing.0,
        blocks,
        per_block,
        |app: &mut App| {
            lit_room(lens(24))(app);
            app.insert_resource(Slide(1.0)).add_systems(Update, slide);
        },
        lit_room(lens(24)),
    )?;
    report.rows.push(
        Row::paired(24.0, &moving)
            .series("moving lens: retraced every frame against still (knob rings)")
            .work("frame_ratio", moving.ratio.median)
            .work("size_px", f64::from(size)),
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_refraction_rows_fall_with_tessellation() {
        let ctx = SweepContext::new("spectacles", true, true);
        let mut report = Report::cpu("spectacles", "resolution_scale");
        refraction_rows(&ctx, &mut report).expect("the refraction rows run on lavapipe");
        for r in &report.rows {
            eprintln!(
                "{} {}: {:?} {:?} {:?}",
                r.series, r.knob, r.error, r.timings, r.work
            );
        }
        assert!(report.problems().is_empty(), "{:?}", report.problems());
        let err = |rings: f64| {
            report
                .rows
                .iter()
                .find(|r| r.series.starts_with("refraction") && r.knob == rings)
                .expect("row")
                .error["refraction_mean_px"]
        };
        // Finer tessellation follows the exact trace more closely; the
        // paper's is within the half pixel.
        assert!(
            err(24.0) < err(6.0) && err(24.0) < 0.5,
            "{} {}",
            err(6.0),
            err(24.0)
        );
    }
}
