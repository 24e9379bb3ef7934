//! The resampling pass's uniform (`PrepareResources`: the view's size
//! added to the camera's parameters) and bind group (`PrepareBindGroups`:
//! the six faces' images), each rewritten only when what it was made from
//! changed.

use bevy::prelude::*;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::{
    BindGroup, BindGroupEntries, PipelineCache, TextureViewId, UniformBuffer,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::texture::GpuImage;
use bevy::render::view::ExtractedView;

use super::pipelines::ResamplePipeline;
use crate::cube::{CubeParams, DomeCubeSampling};

/// A cube-mode view's uniform and the parameters it holds.
#[derive(Component)]
pub(super) struct ResampleUniform {
    params: CubeParams,
    buffer: UniformBuffer<CubeParams>,
}

/// A cube-mode view's bind group and what it was made from.
#[derive(Component)]
pub(super) struct ResampleBinding {
    pub(super) bind_group: BindGroup,
    made_from: ([TextureViewId; 6], CubeParams),
}

/// Writes each cube-mode view's uniform when its parameters changed.
pub(super) fn prepare_resample_resources(
    mut commands: Commands,
    views: Query<(
        Entity,
        &ExtractedView,
        &DomeCubeSampling,
        Option<&ResampleUniform>,
    )>,
    render_device: Res<RenderDevice>,
    render_queue: Res<RenderQueue>,
) {
    for (entity, view, sampling, uniform) in &views {
        let params = sampling.params.for_view(view.viewport.zw());
        if uniform.is_some_and(|u| u.params == params) {
            continue;
        }
        let mut buffer = UniformBuffer::from(params);
        buffer.write_buffer(&render_device, &render_queue);
        commands
            .entity(entity)
            .insert(ResampleUniform { params, buffer });
    }
}

/// Makes each cube-mode view's bind group once its faces are on the GPU.
pub(super) fn prepare_resample_bind_groups(
    mut commands: Commands,
    views: Query<(
        Entity,
        &DomeCubeSampling,
        &ResampleUniform,
        Option<&ResampleBinding>,
    )>,
    pipeline: Res<ResamplePipeline>,
    pipeline_cache: Res<PipelineCache>,
    gpu_images: Res<RenderAssets<GpuImage>>,
    render_device: Res<RenderDevice>,
) {
    for (entity, sampling, uniform, binding) in &views {
        let textures: Option<Vec<_>> = sampling
            .images
            .iter()
            .map(|h| gpu_images.get(h).map(|g| &g.texture_view))
            .collect();
        let (Some(textures), Some(params)) = (textures, uniform.buffer.binding()) else {
            // The faces are not on the GPU yet.
            commands.entity(entity).remove::<ResampleBinding>();
            continue;
        };
        let made_from = (std::array::from_fn(|k| textures[k].id()), uniform.params);
        if binding.is_some_and(|b| b.made_from == made_from) {
            continue;
        }
        let bind_group = render_device.create_bind_group(
            "optica_dome_cube_resample",
            &pipeline_cache.get_bind_group_layout(&pipeline.layout),
            &BindGroupEntries::sequential((
                textures[0],
                textures[1],
                textures[2],
                textures[3],
                textures[4],
                textures[5],
                &pipeline.sampler,
                params,
            )),
        );
        commands.entity(entity).insert(ResampleBinding {
            bind_group,
            made_from,
        });
    }
}
