//! The spectacles' passes in each view's `Core3d` schedule, before Bevy's
//! post-processing: the clones' resolve, then the lens's march and draw
//! (`optica/spectacles/resolve`, `optica/spectacles/refraction`), on an
//! eye camera; a mirror's march on its environment camera
//! (`optica/spectacles/mirror`); a cube face's copy into its cube.

use bevy::prelude::*;
use bevy::render::diagnostic::RecordDiagnostics;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::{
    BindGroup, BindGroupEntries, CachedComputePipelineId, ComputePassDescriptor, Extent3d,
    IndexFormat, Origin3d, PipelineCache, RenderPassColorAttachment, RenderPassDescriptor,
    TexelCopyTextureInfo, TextureAspect, TextureView,
};
use bevy::render::renderer::{RenderContext, ViewQuery};
use bevy::render::texture::GpuImage;
use bevy::render::view::{ViewDepthTexture, ViewTarget};

use super::pipelines::SpectaclesPipelines;
use super::prepare::{MirrorMarch, RefractionBuffers, ResolveBuffers};
use super::{
    MirrorMarchBinding, MirrorPipelineIds, RefractionMarchBinding, RefractionPipelineIds,
    ResolveFullBinding, ResolvePipelineIds, Variant,
};
use crate::mirror::CubeFace;

/// A pass that writes `view` whole (every pixel drawn over).
fn onto(view: &TextureView) -> [Option<RenderPassColorAttachment<'_>>; 1] {
    [Some(RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: default(),
    })]
}

/// Records a compute pass of `threads` threads in groups of 64.
fn march(ctx: &mut RenderContext, label: &str, pipeline: CachedComputePipelineId, group: &BindGroup, threads: u32, cache: &PipelineCache) -> bool {
    let Some(pipeline) = cache.get_compute_pipeline(pipeline) else {
        return false;
    };
    let mut pass = ctx
        .command_encoder()
        .begin_compute_pass(&ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: None,
        });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, group, &[]);
    pass.dispatch_workgroups(threads.div_ceil(64), 1, 1);
    true
}

/// Writes the clones' mean over the view's main texture.
pub(super) fn resolve_pass(
    view: ViewQuery<(
        &ViewTarget,
        &ResolvePipelineIds,
        &ResolveBuffers,
        Option<&ResolveFullBinding>,
        Option<&ViewDepthTexture>,
    )>,
    pipelines: Res<SpectaclesPipelines>,
    pipeline_cache: Res<PipelineCache>,
    images: Res<RenderAssets<GpuImage>>,
    mut ctx: RenderContext,
) {
    let (target, ids, buffers, full, depth) = view.into_inner();
    let (Some(pipeline), Some(atlas), Some(params)) = (
        pipeline_cache.get_render_pipeline(ids.id),
        images.get(buffers.atlas),
        buffers.params.binding(),
    ) else {
        return;
    };
    let post = target.post_process_write();
    // The reprojection reads the sharp view (this pass's source), so its
    // bind group is made here; until the eye camera's depth is bindable (a
    // frame after the rig asks for it) there is nothing to reproject from:
    // the view stays sharp.
    let reprojected;
    let group = match (ids.variant, full) {
        (Variant::Full, Some(ResolveFullBinding(group))) => group,
        (Variant::Reprojected { .. }, _) => {
            let Some(depth) = depth.filter(|d| {
                d.texture
                    .usage()
                    .contains(bevy::render::render_resource::TextureUsages::TEXTURE_BINDING)
            }) else {
                return;
            };
            reprojected = ctx.render_device().create_bind_group(
                "optica_spectacles_resolve",
                &pipeline_cache.get_bind_group_layout(pipelines.resolve_layout(ids.variant)),
                &BindGroupEntries::sequential((
                    &atlas.texture_view,
                    &pipelines.linear,
                    params,
                    post.source,
                    depth.view(),
                    &pipelines.gather,
                )),
            );
            &reprojected
        }
        _ => return,
    };
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let span = diagnostics.time_span(ctx.command_encoder(), "optica/spectacles/resolve");
    {
        let mut pass = ctx
            .command_encoder()
            .begin_render_pass(&RenderPassDescriptor {
                label: Some("optica_spectacles_resolve"),
                color_attachments: &onto(post.destination),
                ..default()
            });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..3, 0..1);
    }
    span.end(ctx.command_encoder());
}

/// The lens's exit rays found in the view's depth, then the view copied
/// and the lens drawn over it with them.
pub(super) fn refraction_pass(
    view: ViewQuery<(
        &ViewTarget,
        &RefractionBuffers,
        &RefractionPipelineIds,
        &RefractionMarchBinding,
    )>,
    pipelines: Res<SpectaclesPipelines>,
    pipeline_cache: Res<PipelineCache>,
    mut ctx: RenderContext,
) {
    let (target, buffers, ids, RefractionMarchBinding(march_group)) = view.into_inner();
    let (Some(copy), Some(lens), Some(params), Some(vertices)) = (
        pipeline_cache.get_render_pipeline(ids.copy),
        pipeline_cache.get_render_pipeline(ids.lens),
        buffers.params.binding(),
        buffers.vertices.binding(),
    ) else {
        return;
    };
    if pipeline_cache.get_compute_pipeline(ids.march).is_none() {
        return;
    }
    // The draw reads the view (this pass's source).
    let post = target.post_process_write();
    let draw_group = ctx.render_device().create_bind_group(
        "optica_spectacles_lens_draw",
        &pipeline_cache.get_bind_group_layout(&pipelines.draw_layout),
        &BindGroupEntries::sequential((
            params,
            vertices,
            buffers.coords.as_entire_binding(),
            post.source,
            &pipelines.linear,
        )),
    );
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let span = diagnostics.time_span(ctx.command_encoder(), "optica/spectacles/refraction");
    march(
        &mut ctx,
        "optica_spectacles_lens_march",
        ids.march,
        march_group,
        buffers.march_threads(),
        &pipeline_cache,
    );
    {
        let mut pass = ctx
            .command_encoder()
            .begin_render_pass(&RenderPassDescriptor {
                label: Some("optica_spectacles_lens_draw"),
                color_attachments: &onto(post.destination),
                ..default()
            });
        pass.set_bind_group(0, &draw_group, &[]);
        pass.set_pipeline(copy);
        pass.draw(0..3, 0..1);
        pass.set_pipeline(lens);
        // The raw pass takes wgpu's own buffer slice.
        pass.set_index_buffer(
            std::ops::Deref::deref(&buffers.indices).slice(..),
            IndexFormat::Uint32,
        );
        pass.draw_indexed(0..buffers.index_count, 0, 0..1);
    }
    span.end(ctx.command_encoder());
}

/// A per-vertex mirror's reflected rays found in its environment camera's
/// depth, their coordinates written where the mirror's material reads them.
pub(super) fn mirror_march(
    view: ViewQuery<(&MirrorMarch, &MirrorPipelineIds, &MirrorMarchBinding)>,
    pipeline_cache: Res<PipelineCache>,
    mut ctx: RenderContext,
) {
    let (m, ids, MirrorMarchBinding(group)) = view.into_inner();
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let span = diagnostics.time_span(ctx.command_encoder(), "optica/spectacles/mirror");
    march(
        &mut ctx,
        "optica_spectacles_mirror_march",
        ids.march,
        group,
        m.count,
        &pipeline_cache,
    );
    span.end(ctx.command_encoder());
}

/// Copies a cube face camera's view (linear HDR, before any
/// post-processing) into its layer of the cube.
pub(super) fn copy_cube_face(
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
