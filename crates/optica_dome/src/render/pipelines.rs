//! The resampling pipeline, specialised per target format on first use
//! through Bevy's `SpecializedRenderPipelines` cache.

use bevy::core_pipeline::FullscreenShader;
use optica_plugin_kit::fullscreen_pipeline;
use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{sampler, texture_2d, uniform_buffer};
use bevy::render::render_resource::{
    BindGroupLayoutDescriptor, BindGroupLayoutEntries, FilterMode,
    PipelineCache, RenderPipelineDescriptor, Sampler, SamplerBindingType,
    SamplerDescriptor, ShaderStages, SpecializedRenderPipeline, SpecializedRenderPipelines,
    TextureFormat, TextureSampleType,
};
use bevy::render::renderer::RenderDevice;
use bevy::render::view::ExtractedView;

use super::ResamplePipelineId;
use crate::cube::{CubeParams, DomeCubeSampling};

/// Where `embedded_asset!` puts the resampling shader.
const SHADER_PATH: &str = "embedded://optica_dome/shaders/cube_resample.wgsl";

/// The resampling pass's layout, sampler and shader.
#[derive(Resource)]
pub(super) struct ResamplePipeline {
    pub(super) layout: BindGroupLayoutDescriptor,
    /// Bilinear across each face (the faces carry a texel of margin, so
    /// every footprint lies inside one face).
    pub(super) sampler: Sampler,
    fullscreen: FullscreenShader,
    shader: Handle<Shader>,
}

pub(super) fn init_resample_pipeline(
    mut commands: Commands,
    render_device: Res<RenderDevice>,
    asset_server: Res<AssetServer>,
    fullscreen: Res<FullscreenShader>,
) {
    let layout = BindGroupLayoutDescriptor::new(
        "optica_dome_cube_resample_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::FRAGMENT,
            (
                texture_2d(TextureSampleType::Float { filterable: true }),
                texture_2d(TextureSampleType::Float { filterable: true }),
                texture_2d(TextureSampleType::Float { filterable: true }),
                texture_2d(TextureSampleType::Float { filterable: true }),
                texture_2d(TextureSampleType::Float { filterable: true }),
                texture_2d(TextureSampleType::Float { filterable: true }),
                sampler(SamplerBindingType::Filtering),
                uniform_buffer::<CubeParams>(false),
            ),
        ),
    );
    let sampler = render_device.create_sampler(&SamplerDescriptor {
        label: Some("optica_dome_cube_sampler"),
        mag_filter: FilterMode::Linear,
        min_filter: FilterMode::Linear,
        ..default()
    });
    commands.insert_resource(ResamplePipeline {
        layout,
        sampler,
        fullscreen: fullscreen.clone(),
        shader: asset_server.load(SHADER_PATH),
    });
}

impl SpecializedRenderPipeline for ResamplePipeline {
    /// The view's target format.
    type Key = TextureFormat;

    fn specialize(&self, format: TextureFormat) -> RenderPipelineDescriptor {
        fullscreen_pipeline(
            "optica_dome_cube_resample",
            &self.layout,
            &self.fullscreen,
            &self.shader,
            "fragment",
            vec![],
            format,
        )
    }
}

/// Specialises each cube-mode view's pipeline.
pub(super) fn prepare_resample_pipelines(
    mut commands: Commands,
    pipeline_cache: Res<PipelineCache>,
    pipeline: Res<ResamplePipeline>,
    mut pipelines: ResMut<SpecializedRenderPipelines<ResamplePipeline>>,
    views: Query<(Entity, &ExtractedView), With<DomeCubeSampling>>,
) {
    for (entity, view) in &views {
        let id = pipelines.specialize(&pipeline_cache, &pipeline, view.target_format);
        commands.entity(entity).insert(ResamplePipelineId(id));
    }
}
