//! Mirrors in the render world: on a per-vertex mirror's environment
//! camera, after its main pass, the lens's march finds each reflected ray
//! in that camera's depth and writes the vertex's texture coordinate into
//! the buffer the mirror's material reads; on a cube-map face camera its
//! view is copied into its layer of the cube. Spans:
//! `optica/spectacles/mirror`.

use bevy::core_pipeline::{Core3d, Core3dSystems};
use bevy::prelude::*;
use bevy::render::diagnostic::RecordDiagnostics;
use bevy::render::extract_component::ExtractComponentPlugin;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::{
    BindGroupEntries, CachedComputePipelineId, ComputePassDescriptor, Extent3d, Origin3d,
    PipelineCache, StorageBuffer, TexelCopyTextureInfo, TextureAspect, UniformBuffer,
};
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy::render::storage::GpuShaderBuffer;
use bevy::render::texture::GpuImage;
use bevy::render::view::{ExtractedView, ViewDepthTexture, ViewTarget};
use bevy::render::{Render, RenderApp, RenderSystems};

use super::refraction::{EDGE, LensParams, MARCH_STEPS, RefractionShared};
use crate::mirror::{CubeFace, MirrorEnvironment};
use crate::refraction::LensVertex;

pub(crate) fn build(app: &mut App) {
    app.add_plugins((
        ExtractComponentPlugin::<MirrorEnvironment>::default(),
        ExtractComponentPlugin::<CubeFace>::default(),
    ));
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
        return;
    };
    render_app
        .add_systems(
            Render,
            prepare_mirror_march.in_set(RenderSystems::PrepareBindGroups),
        )
        .add_systems(
            Core3d,
            (mirror_march, copy_cube_face).in_set(Core3dSystems::EarlyPostProcess),
        );
}

/// An environment camera's march inputs, kept between frames; the
/// vertices are rewritten only when the mirror was retraced.
#[derive(Component)]
struct MirrorMarch {
    params: UniformBuffer<LensParams>,
    vertices: StorageBuffer<Vec<LensVertex>>,
    pipeline: CachedComputePipelineId,
    count: u32,
    traced: Vec<LensVertex>,
}

fn prepare_mirror_march(
    mut commands: Commands,
    mut views: Query<(Entity, &ExtractedView, &MirrorEnvironment, Option<&mut MirrorMarch>)>,
    mut shared: ResMut<RefractionShared>,
    pipeline_cache: Res<PipelineCache>,
    render_device: Res<RenderDevice>,
    render_queue: Res<RenderQueue>,
) {
    for (entity, view, environment, march) in &mut views {
        if environment.vertices.is_empty() {
            continue;
        }
        let pipeline = shared.march_pipeline(&pipeline_cache, false);
        let params = LensParams {
            clip_from_view: view.clip_from_view,
            near: view.clip_from_view.w_axis.z,
            vertices: environment.vertices.len() as u32,
            steps: MARCH_STEPS,
            edge: EDGE,
            colours: 1,
        };
        match march {
            Some(mut m) if m.traced == environment.vertices => {
                m.params.set(params);
                m.params.write_buffer(&render_device, &render_queue);
            }
            _ => {
                let mut uniform = UniformBuffer::from(params);
                uniform.write_buffer(&render_device, &render_queue);
                let mut vertices = StorageBuffer::from(environment.vertices.clone());
                vertices.write_buffer(&render_device, &render_queue);
                commands.entity(entity).insert(MirrorMarch {
                    params: uniform,
                    vertices,
                    pipeline,
                    count: environment.vertices.len() as u32,
                    traced: environment.vertices.clone(),
                });
            }
        }
    }
}

fn mirror_march(
    view: ViewQuery<(&MirrorEnvironment, &MirrorMarch, &ViewDepthTexture)>,
    shared: Res<RefractionShared>,
    pipeline_cache: Res<PipelineCache>,
    buffers: Res<RenderAssets<GpuShaderBuffer>>,
    mut ctx: RenderContext,
) {
    let (environment, march, depth) = view.into_inner();
    let (Some(pipeline), Some(coords), Some(params), Some(vertices)) = (
        pipeline_cache.get_compute_pipeline(march.pipeline),
        buffers.get(&environment.coords),
        march.params.binding(),
        march.vertices.binding(),
    ) else {
        return;
    };
    let device = ctx.render_device().clone();
    let group = device.create_bind_group(
        "optica_spectacles_mirror_march",
        &pipeline_cache.get_bind_group_layout(&shared.march_layouts[0]),
        &BindGroupEntries::sequential((
            params,
            vertices,
            coords.buffer.as_entire_binding(),
            depth.view(),
        )),
    );
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let span = diagnostics.time_span(ctx.command_encoder(), "optica/spectacles/mirror");
    {
        let mut pass = ctx
            .command_encoder()
            .begin_compute_pass(&ComputePassDescriptor {
                label: Some("optica_spectacles_mirror_march"),
                timestamp_writes: None,
            });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(march.count.div_ceil(64), 1, 1);
    }
    span.end(ctx.command_encoder());
}

/// Copies a cube face camera's view (linear HDR, before any
/// post-processing) into its layer of the cube.
fn copy_cube_face(
    view: ViewQuery<(&CubeFace, &ViewTarget)>,
    images: Res<RenderAssets<GpuImage>>,
    mut ctx: RenderContext,
) {
    let (face, target) = view.into_inner();
    let Some(cube) = images.get(&face.cube) else {
        return;
    };
    let source = target.main_texture();
    let size = source.size();
    if cube.texture.width() != size.width || cube.texture.format() != source.format() {
        return;
    }
    ctx.command_encoder().copy_texture_to_texture(
        source.as_image_copy(),
        TexelCopyTextureInfo {
            texture: &cube.texture,
            mip_level: 0,
            origin: Origin3d {
                x: 0,
                y: 0,
                z: face.layer,
            },
            aspect: TextureAspect::All,
        },
        Extent3d {
            width: size.width,
            height: size.height,
            depth_or_array_layers: 1,
        },
    );
}
