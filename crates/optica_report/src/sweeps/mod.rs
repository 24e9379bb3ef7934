//! One module per sweep, listed in [`SWEEPS`] under the name the command
//! line takes. A CPU-only sweep exposes `pub fn run(ctx: &SweepContext) ->
//! Report`; a rendering sweep returns `Result<Report, SweepError>`, since the
//! adapter can be missing or fail.

use crate::{Report, SweepContext};

pub mod compound_eye;
pub mod dome;
pub mod dome_panorama;
pub mod dome_render;
pub mod dome_scale;
pub mod dome_textured;
pub mod foveated_lod;
pub mod foveated_lod_mesh;
pub mod foveated_lod_raytrace;
pub mod gpu;
pub mod lens_flare;
pub mod lens_flare_render;
pub mod optics;
pub mod render;
pub mod spectacles;
pub mod spectacles_mirror;
pub mod spectacles_refraction;
pub mod spectacles_render;

/// Why a sweep could not run.
#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    /// A headless run failed (no adapter, the wrong adapter, a wgpu error).
    #[error(transparent)]
    Harness(#[from] optica_harness::HarnessError),
    /// The sweep's own scene or reference could not be set up.
    #[error("setup: {0}")]
    Setup(String),
}

/// A named sweep.
pub type SweepFn = fn(&SweepContext) -> Result<Report, SweepError>;

/// Every sweep the runner knows, in the order `all` runs them.
pub const SWEEPS: &[(&str, SweepFn)] = &[
    ("optics", |ctx| Ok(optics::run(ctx))),
    ("render", render::run),
    ("foveated_lod", |ctx| {
        let mut report = foveated_lod::run(ctx);
        foveated_lod_mesh::mesh_rows(ctx, &mut report)?;
        foveated_lod_raytrace::raytrace_rows(ctx, &mut report)?;
        report.main_errors = errors(&["rmse_beyond_30deg", "rmse_5_30deg", "gaze_weighted_rmse"]);
        Ok(report)
    }),
    ("compound_eye", |ctx| {
        let mut report = compound_eye::run(ctx)?;
        report.main_errors = errors(&["flip_mean", "psnr_db", "centroid_facets"]);
        Ok(report)
    }),
    ("lens_flare", |ctx| {
        let mut report = lens_flare::run(ctx);
        lens_flare_render::rendered_rows(ctx, &mut report)?;
        report.main_errors = errors(&["rel_l1", "flip_mean", "rel_energy"]);
        Ok(report)
    }),
    ("spectacles", |ctx| {
        let mut report = spectacles::run(ctx);
        spectacles_render::rendered_rows(ctx, &mut report)?;
        spectacles_refraction::refraction_rows(ctx, &mut report)?;
        spectacles_mirror::mirror_rows(ctx, &mut report)?;
        report.main_errors = errors(&["mean_mrad", "flip_mean", "mirror_mean_px"]);
        Ok(report)
    }),
    ("dome", |ctx| {
        let mut report = dome::run(ctx)?;
        report.main_errors = errors(&["max_px", "mean_px", "flip_mean"]);
        Ok(report)
    }),
];

/// The errors a report's tables and summary lead with.
fn errors(names: &[&str]) -> Vec<String> {
    names.iter().map(|n| n.to_string()).collect()
}

/// Series of a sweep that can also be run alone, by name only (`all` runs
/// them inside their sweep): for profiling one cost without the rest.
pub const PARTS: &[(&str, SweepFn)] = &[
    ("dome_scale", |ctx| {
        let mut report = crate::Report::cpu("dome_scale", "triangles");
        dome_scale::scene_size(&mut report, ctx);
        Ok(report)
    }),
    ("dome_textured", |ctx| {
        let mut report = crate::Report::cpu("dome_textured", "tolerance_px (cube mode: face_px)");
        dome_textured::textured_rows(ctx, &mut report)?;
        report.main_errors = errors(&["flip_mean", "flip_point"]);
        Ok(report)
    }),
    // The absolute GPU figures and their goals (not in `all`: it refuses a
    // CPU adapter unless --allow-cpu).
    ("gpu", gpu::run),
];
