//! The GPU side of the ray tracer: the scene's buffers (uploaded when
//! [`TracedScene`](crate::raytrace::TracedScene) changes), per view a
//! parameter block and two ray buffers, and the passes of `raytrace.wgsl`
//! (coarse periphery, full image, copy into the view) before Bevy's
//! post-processing. Nothing is queued or run for a scene without a
//! [`GazeRayTracer`](crate::GazeRayTracer) camera.
//!
//! In the lens flare's (and bloom's) shape: [`pipelines`] specialises each
//! tracer view's pipelines (`RenderSystems::Prepare`), [`prepare`] uploads
//! the scene and writes the view's buffers (`PrepareResources`) and makes
//! its bind groups (`PrepareBindGroups`) into a [`TracerBinding`], and
//! [`passes`] records the trace (compute) and the blit (render) in the
//! view's `Core3d` schedule. Spans: `optica/foveated_lod` round both,
//! `trace` and `blit` within it.

use bevy::core_pipeline::{Core3d, Core3dSystems};
use bevy::prelude::*;
use optica_plugin_kit::prepare_systems;
use bevy::render::extract_component::ExtractComponentPlugin;
use bevy::render::extract_resource::ExtractResourcePlugin;
use bevy::render::render_resource::{
    BindGroup, CachedComputePipelineId, CachedRenderPipelineId, SpecializedComputePipelines,
    SpecializedRenderPipelines,
};
use bevy::render::{GpuResourceAppExt, Render, RenderApp, RenderStartup};

use crate::raytrace::{TracedScene, TracerView};

mod passes;
mod pipelines;
mod prepare;

use passes::trace_pass;
use pipelines::{TracerPipelines, init_tracer_pipelines, prepare_tracer_pipelines};
use prepare::{prepare_scene, prepare_tracer_bind_groups, prepare_views};

/// Adds the tracer's extraction and passes.
pub(crate) struct TracerRenderPlugin;

impl Plugin for TracerRenderPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins((
            ExtractComponentPlugin::<TracerView>::default(),
            ExtractResourcePlugin::<TracedScene>::default(),
        ));
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        render_app
            .init_gpu_resource::<SpecializedComputePipelines<TracerPipelines>>()
            .init_gpu_resource::<SpecializedRenderPipelines<TracerPipelines>>()
            .add_systems(RenderStartup, init_tracer_pipelines)
            .add_systems(
                Render,
                prepare_systems(
                    prepare_tracer_pipelines,
                    (prepare_scene, prepare_views).chain(),
                    prepare_tracer_bind_groups,
                ),
            )
            .add_systems(Core3d, trace_pass.in_set(Core3dSystems::EarlyPostProcess));
    }
}

/// One tracer view's pipelines (specialised in `RenderSystems::Prepare`).
#[derive(Component, Clone, Copy)]
struct TracerPipelineIds {
    /// `trace_mid`, `trace_outer` and `trace_full`.
    trace: [CachedComputePipelineId; 3],
    /// The copy into the view's target format.
    blit: CachedRenderPipelineId,
}

/// One tracer view's bind groups for this frame (the trace's and the
/// blit's; neither depends on the view's post-process textures).
#[derive(Component)]
struct TracerBinding {
    trace_group: BindGroup,
    blit_group: BindGroup,
}
