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
        Ok(report)
    }),
    ("compound_eye", compound_eye::run),
    ("lens_flare", |ctx| {
        let mut report = lens_flare::run(ctx);
        lens_flare_render::rendered_rows(ctx, &mut report)?;
        Ok(report)
    }),
    ("spectacles", |ctx| {
        let mut report = spectacles::run(ctx);
        spectacles_render::rendered_rows(ctx, &mut report)?;
        spectacles_refraction::refraction_rows(ctx, &mut report)?;
        spectacles_mirror::mirror_rows(ctx, &mut report)?;
        Ok(report)
    }),
    ("dome", dome::run),
];

/// Series of a sweep that can also be run alone, by name only (`all` runs
/// them inside their sweep): for profiling one cost without the rest.
pub const PARTS: &[(&str, SweepFn)] = &[
    ("dome_scale", |ctx| {
        let mut report = crate::Report::cpu("dome_scale", "triangles");
        dome_scale::scene_size(&mut report, ctx);
        Ok(report)
    }),
    // The absolute GPU figures and their goals (not in `all`: it refuses a
    // CPU adapter unless --allow-cpu).
    ("gpu", gpu::run),
];
