//! The render world: per flare camera, a compute pass reads each light's
//! visibility from the depth, a compute pass traces every ghost grid of
//! [`FlareDraws`] into a storage buffer (only when what the rays depend on
//! changed), a compute pass colours each cell and writes the triangles of
//! those that add light, and a draw pass adds them (indexed: each ray
//! shaded once, with the ringing), at the ghosts' resolution, and each
//! light's starburst to the HDR view target before tonemapping (so that
//! bloom and tonemapping treat the flare as light). Pipelines are queued
//! when the first flare camera needs them; views without `FlareDraws` (or
//! with no grid this frame) run no pass.
//!
//! In bloom's shape: [`pipelines`] specialises each view's pipelines
//! (`RenderSystems::Prepare`), [`prepare`] writes its buffers and targets
//! (`PrepareResources`) and makes its bind groups (`PrepareBindGroups`)
//! into a [`FlareBinding`], and [`passes`] records them in the view's `Core3d`
//! schedule, before bloom.

use bevy::core_pipeline::tonemapping::tonemapping;
use bevy::core_pipeline::{Core3d, Core3dSystems};
use bevy::post_process::bloom::bloom;
use bevy::prelude::*;
use optica_plugin_kit::prepare_systems;
use bevy::render::extract_component::ExtractComponentPlugin;
use bevy::render::render_resource::{
    BindGroup, Buffer, CachedComputePipelineId, CachedRenderPipelineId,
    SpecializedComputePipelines, SpecializedRenderPipelines, TextureFormat, TextureView,
};
use bevy::render::{GpuResourceAppExt, Render, RenderApp, RenderStartup};

use crate::draws::FlareDraws;

mod passes;
mod pipelines;
mod prepare;

use passes::flare_passes;
use pipelines::{FlarePipelines, init_flare_pipelines, prepare_flare_pipelines};
use prepare::{prepare_flare_bind_groups, prepare_flare_resources};

/// Bytes per traced ray (`RayOut`: 12 floats).
const RAY_BYTES: u64 = 48;
/// The format the ghosts are added up in at a reduced resolution (HDR, and
/// filterable everywhere).
const GHOST_FORMAT: TextureFormat = TextureFormat::Rgba16Float;
/// Bytes per cell of the index buffer (two triangles of `u32`s).
const CELL_INDEX_BYTES: u64 = 24;
/// Bytes per ray of the cell colours (`vec4<f32>`).
const CELL_COLOR_BYTES: u64 = 16;

/// Adds the passes.
pub(crate) struct FlareRenderPlugin;

impl Plugin for FlareRenderPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins(ExtractComponentPlugin::<FlareDraws>::default());
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        render_app
            .init_gpu_resource::<SpecializedComputePipelines<FlarePipelines>>()
            .init_gpu_resource::<SpecializedRenderPipelines<FlarePipelines>>()
            .add_systems(RenderStartup, init_flare_pipelines)
            .add_systems(
                Render,
                prepare_systems(
                    prepare_flare_pipelines,
                    prepare_flare_resources,
                    prepare_flare_bind_groups,
                ),
            )
            .add_systems(
                Core3d,
                flare_passes
                    .in_set(Core3dSystems::PostProcess)
                    .before(bloom)
                    .before(tonemapping),
            );
    }
}

/// One view's buffers, bind groups and pipelines for this frame.
#[derive(Component)]
struct FlareBinding {
    /// Whether the rays are traced and their cells coloured this frame
    /// (else last frame's stand).
    retrace: bool,
    trace_group: BindGroup,
    cells_group: BindGroup,
    draw_group: BindGroup,
    trace: CachedComputePipelineId,
    fill: CachedComputePipelineId,
    cells: CachedComputePipelineId,
    draw: CachedRenderPipelineId,
    /// The starburst's pipeline, when it is drawn.
    starburst: Option<CachedRenderPipelineId>,
    /// The occlusion pass, when the view reads its depth.
    occlusion: Option<(BindGroup, CachedComputePipelineId)>,
    /// With reduced-resolution ghosts: their target, and the bind group
    /// and pipeline that add it to the view.
    reduced: Option<(TextureView, BindGroup, CachedRenderPipelineId)>,
    /// With large ghosts: their target, the bind group and pipeline that
    /// add it to the ghosts' target, and their pipeline.
    coarse: Option<(
        TextureView,
        BindGroup,
        CachedRenderPipelineId,
        CachedRenderPipelineId,
    )>,
    /// The cells added up at the ghosts' resolution (the rest are the
    /// large ghosts').
    fine_cells: u32,
    threads: u32,
    /// The rays (the fill pass's threads).
    rays: u32,
    /// The cells, and the cell pass's threads.
    cell_count: u32,
    spans: u32,
    /// The cells' triangles.
    indices: Buffer,
    lights: u32,
}
