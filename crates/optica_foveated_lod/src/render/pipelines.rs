//! The tracer's pipelines, specialised on first use through Bevy's
//! `Specialized*Pipelines` caches (a scene without a tracer camera queues
//! none): the three tracing entry points, and the blit per target format.

use bevy::core_pipeline::FullscreenShader;
use optica_plugin_kit::fullscreen_pipeline;
use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    storage_buffer, storage_buffer_read_only, uniform_buffer,
};
use bevy::render::render_resource::{
    BindGroupLayoutDescriptor, BindGroupLayoutEntries, ComputePipelineDescriptor, PipelineCache, RenderPipelineDescriptor,
    ShaderStages, SpecializedComputePipeline, SpecializedComputePipelines,
    SpecializedRenderPipeline, SpecializedRenderPipelines, TextureFormat,
};
use bevy::render::view::ExtractedView;

use super::TracerPipelineIds;
use super::prepare::{GpuLight, GpuMesh, GpuNode, GpuObject, GpuVertex, Params};
use crate::raytrace::TracerView;

/// Where `embedded_asset!` puts the tracer's shader (the plugin embeds it).
const RAYTRACE_SHADER: &str = "embedded://optica_foveated_lod/shaders/raytrace.wgsl";

/// The layouts and shader of the tracer's passes.
#[derive(Resource)]
pub(super) struct TracerPipelines {
    pub(super) trace_layout: BindGroupLayoutDescriptor,
    pub(super) blit_layout: BindGroupLayoutDescriptor,
    fullscreen: FullscreenShader,
    shader: Handle<Shader>,
}

/// A tracing pass: which layer of the image it traces.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub(super) enum TraceKind {
    /// The middle layer (`trace_mid`): the periphery at 1/scale.
    Mid,
    /// The outer layer (`trace_outer`): the far periphery at 1/(2·scale).
    Outer,
    /// Every pixel (`trace_full`): traced where the layers do not serve.
    Full,
}

impl TraceKind {
    fn entry(self) -> &'static str {
        match self {
            TraceKind::Mid => "trace_mid",
            TraceKind::Outer => "trace_outer",
            TraceKind::Full => "trace_full",
        }
    }
}

pub(super) fn init_tracer_pipelines(
    mut commands: Commands,
    asset_server: Res<AssetServer>,
    fullscreen: Res<FullscreenShader>,
) {
    let trace_layout = BindGroupLayoutDescriptor::new(
        "optica_foveated_lod_trace",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                uniform_buffer::<Params>(false),
                storage_buffer_read_only::<Vec<GpuNode>>(false),
                storage_buffer_read_only::<Vec<UVec4>>(false),
                storage_buffer_read_only::<Vec<GpuVertex>>(false),
                storage_buffer_read_only::<Vec<GpuMesh>>(false),
                storage_buffer_read_only::<Vec<GpuObject>>(false),
                storage_buffer_read_only::<Vec<GpuLight>>(false),
                storage_buffer::<Vec<Vec4>>(false),
                storage_buffer::<Vec<Vec4>>(false),
            ),
        ),
    );
    let blit_layout = BindGroupLayoutDescriptor::new(
        "optica_foveated_lod_blit",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::FRAGMENT,
            (
                uniform_buffer::<Params>(false),
                storage_buffer_read_only::<Vec<Vec4>>(false),
            ),
        ),
    );
    commands.insert_resource(TracerPipelines {
        trace_layout,
        blit_layout,
        fullscreen: fullscreen.clone(),
        shader: asset_server.load(RAYTRACE_SHADER),
    });
}

impl SpecializedComputePipeline for TracerPipelines {
    type Key = TraceKind;

    fn specialize(&self, key: TraceKind) -> ComputePipelineDescriptor {
        ComputePipelineDescriptor {
            label: Some(format!("optica_foveated_lod_{}", key.entry()).into()),
            layout: vec![self.trace_layout.clone()],
            immediate_size: 0,
            shader: self.shader.clone(),
            // The tracing code; the blit's fragment shader leaves it out.
            shader_defs: vec!["TRACE".into()],
            entry_point: Some(key.entry().into()),
            zero_initialize_workgroup_memory: false,
        }
    }
}

impl SpecializedRenderPipeline for TracerPipelines {
    /// The view's target format.
    type Key = TextureFormat;

    fn specialize(&self, format: TextureFormat) -> RenderPipelineDescriptor {
        fullscreen_pipeline(
            "optica_foveated_lod_blit",
            &self.blit_layout,
            &self.fullscreen,
            &self.shader,
            "blit_fragment",
            vec![],
            format,
        )
    }
}

/// Specialises each tracer view's pipelines (the cache queues a pipeline
/// the first time its key is asked for).
pub(super) fn prepare_tracer_pipelines(
    mut commands: Commands,
    pipeline_cache: Res<PipelineCache>,
    pipelines: Res<TracerPipelines>,
    mut compute: ResMut<SpecializedComputePipelines<TracerPipelines>>,
    mut render: ResMut<SpecializedRenderPipelines<TracerPipelines>>,
    views: Query<(Entity, &ExtractedView), With<TracerView>>,
) {
    for (entity, view) in &views {
        let mut trace = |kind| compute.specialize(&pipeline_cache, &pipelines, kind);
        commands.entity(entity).insert(TracerPipelineIds {
            trace: [
                trace(TraceKind::Mid),
                trace(TraceKind::Outer),
                trace(TraceKind::Full),
            ],
            blit: render.specialize(&pipeline_cache, &pipelines, view.target_format),
        });
    }
}
