//! The resolve: the eye camera's view becomes the mean of the clone
//! atlas's tiles (the paper's accumulation, §4.1), written over its main
//! texture before Bevy's post-processing, so bloom, exposure and
//! tonemapping treat the blurred view as they would the sharp one. With
//! [`CloneShading::Reprojected`](crate::CloneShading) each clone's colour
//! is read from the eye camera's own (sharp) view where the clone's surface
//! point is visible in it. Pipelines are queued when the first eye camera
//! needs them; views without a [`CloneResolve`] run nothing.

use bevy::core_pipeline::{Core3d, Core3dSystems, FullscreenShader};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use bevy::render::diagnostic::RecordDiagnostics;
use bevy::render::extract_component::ExtractComponentPlugin;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::binding_types::{
    sampler, texture_2d, texture_depth_2d, texture_depth_2d_multisampled, uniform_buffer,
};
use bevy::render::render_resource::{
    BindGroupEntries, BindGroupLayoutDescriptor, BindGroupLayoutEntries, CachedRenderPipelineId,
    ColorTargetState, ColorWrites, FilterMode, FragmentState, Operations, PipelineCache,
    RenderPassColorAttachment, RenderPassDescriptor, RenderPipelineDescriptor, Sampler,
    SamplerBindingType, SamplerDescriptor, ShaderStages, ShaderType, TextureFormat,
    TextureSampleType, TextureUsages, UniformBuffer,
};
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy::render::texture::GpuImage;
use bevy::render::view::{ExtractedView, Msaa, ViewDepthTexture, ViewTarget};
use bevy::render::{Render, RenderApp, RenderStartup, RenderSystems};

use crate::CloneShading;
use crate::clones::CloneResolve;

/// Relative depth difference a reprojected clone's surface point may have
/// from the sharp view's surface and still count as visible there: 1 %,
/// well above f16's 0.1 % (the atlas's precision) and the change of depth
/// across a pixel of a surface seen at up to ~80° from face-on at 1 px
/// per 0.1° (the offset's rounding to a pixel), well below the gap
/// between an object and what lies behind it in ordinary scenes.
pub const REPROJECTION_DEPTH_TOLERANCE: f32 = 0.01;

/// The resolve's numbers (`ResolveParams` in `resolve.wgsl`).
#[derive(Clone, Copy, Debug, Default, ShaderType)]
struct ResolveParams {
    clones: u32,
    tile_cols: u32,
    tile_rows: u32,
    depth_tolerance: f32,
    background: Vec4,
}

/// Adds the resolve pass.
pub(crate) fn build(app: &mut App) {
    app.add_plugins(ExtractComponentPlugin::<CloneResolve>::default());
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
        return;
    };
    render_app
        .add_systems(RenderStartup, init_resolve)
        .add_systems(
            Render,
            prepare_resolve.in_set(RenderSystems::PrepareBindGroups),
        )
        .add_systems(
            Core3d,
            resolve_pass.in_set(Core3dSystems::EarlyPostProcess),
        );
}

/// Which resolve: the clones' colours, or reprojection from the sharp view
/// with a single- or multisampled depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Variant {
    Full,
    Reprojected { multisampled: bool },
}

/// The layouts, sampler and the pipelines (per variant and target
/// format), queued on first use.
#[derive(Resource)]
pub(crate) struct ResolveShared {
    layouts: HashMap<Variant, BindGroupLayoutDescriptor>,
    sampler: Sampler,
    /// Nearest, for the reprojection's gathers (depth textures take no
    /// filtering sampler).
    gather: Sampler,
    pipelines: HashMap<(Variant, TextureFormat), CachedRenderPipelineId>,
}

fn layout(variant: Variant) -> BindGroupLayoutDescriptor {
    let common = (
        texture_2d(TextureSampleType::Float { filterable: true }),
        sampler(SamplerBindingType::Filtering),
        uniform_buffer::<ResolveParams>(false),
    );
    let label = "optica_spectacles_resolve_layout";
    match variant {
        Variant::Full => BindGroupLayoutDescriptor::new(
            label,
            &BindGroupLayoutEntries::sequential(ShaderStages::FRAGMENT, common),
        ),
        Variant::Reprojected { multisampled } => BindGroupLayoutDescriptor::new(
            label,
            &BindGroupLayoutEntries::sequential(
                ShaderStages::FRAGMENT,
                (
                    common.0,
                    common.1,
                    common.2,
                    texture_2d(TextureSampleType::Float { filterable: false }),
                    if multisampled {
                        texture_depth_2d_multisampled()
                    } else {
                        texture_depth_2d()
                    },
                    sampler(SamplerBindingType::NonFiltering),
                ),
            ),
        ),
    }
}

fn init_resolve(mut commands: Commands, render_device: Res<RenderDevice>) {

    let layouts = [
        Variant::Full,
        Variant::Reprojected {
            multisampled: false,
        },
        Variant::Reprojected { multisampled: true },
    ]
    .into_iter()
    .map(|v| (v, layout(v)))
    .collect();
    // Bilinear: a view whose size differs from the tiles' (while the atlas
    // catches up with a resized window) is still filled.
    let sampler = render_device.create_sampler(&SamplerDescriptor {
        label: Some("optica_spectacles_resolve"),
        mag_filter: FilterMode::Linear,
        min_filter: FilterMode::Linear,
        ..default()
    });
    let gather = render_device.create_sampler(&SamplerDescriptor {
        label: Some("optica_spectacles_resolve_gather"),
        ..default()
    });
    commands.insert_resource(ResolveShared {
        layouts,
        sampler,
        gather,
        pipelines: HashMap::default(),
    });
}

/// A view's resolve for this frame.
#[derive(Component)]
pub(crate) struct ResolveBinding {
    variant: Variant,
    pipeline: CachedRenderPipelineId,
    atlas: AssetId<Image>,
    params: UniformBuffer<ResolveParams>,
}

#[allow(clippy::too_many_arguments)]
fn prepare_resolve(
    mut commands: Commands,
    views: Query<(Entity, &ExtractedView, &CloneResolve, &Msaa)>,
    mut shared: ResMut<ResolveShared>,
    pipeline_cache: Res<PipelineCache>,
    fullscreen: Res<FullscreenShader>,
    render_device: Res<RenderDevice>,
    render_queue: Res<RenderQueue>,
) {
    for (entity, view, resolve, msaa) in &views {
        let variant = match resolve.shading {
            CloneShading::Full => Variant::Full,
            CloneShading::Reprojected => Variant::Reprojected {
                multisampled: msaa.samples() > 1,
            },
        };
        let format = view.target_format;
        let layout = shared.layouts[&variant].clone();
        let pipeline = *shared
            .pipelines
            .entry((variant, format))
            .or_insert_with(|| {
                let mut shader_defs = Vec::new();
                match variant {
                    Variant::Full => shader_defs.push("FULL".into()),
                    Variant::Reprojected { multisampled: true } => {
                        shader_defs.push("MULTISAMPLED".into())
                    }
                    Variant::Reprojected { .. } => {}
                }
                pipeline_cache.queue_render_pipeline(RenderPipelineDescriptor {
                    label: Some("optica_spectacles_resolve".into()),
                    layout: vec![layout],
                    vertex: fullscreen.to_vertex_state(),
                    fragment: Some(FragmentState {
                        shader: crate::RESOLVE_SHADER,
                        shader_defs,
                        entry_point: Some("fragment".into()),
                        targets: vec![Some(ColorTargetState {
                            format,
                            blend: None,
                            write_mask: ColorWrites::ALL,
                        })],
                    }),
                    ..default()
                })
            });
        let mut params = UniformBuffer::from(ResolveParams {
            clones: resolve.clones,
            tile_cols: resolve.tiles.x,
            tile_rows: resolve.tiles.y,
            depth_tolerance: REPROJECTION_DEPTH_TOLERANCE,
            background: resolve.background,
        });
        params.write_buffer(&render_device, &render_queue);
        commands.entity(entity).insert(ResolveBinding {
            variant,
            pipeline,
            atlas: resolve.atlas,
            params,
        });
    }
}

/// Writes the clones' mean over the view's main texture.
pub(crate) fn resolve_pass(
    view: ViewQuery<(&ViewTarget, &ResolveBinding, Option<&ViewDepthTexture>)>,
    shared: Res<ResolveShared>,
    pipeline_cache: Res<PipelineCache>,
    images: Res<RenderAssets<GpuImage>>,
    mut ctx: RenderContext,
) {
    let (target, binding, depth) = view.into_inner();
    let (Some(pipeline), Some(atlas), Some(params)) = (
        pipeline_cache.get_render_pipeline(binding.pipeline),
        images.get(binding.atlas),
        binding.params.binding(),
    ) else {
        return;
    };
    // Until the eye camera's depth is bindable (a frame after the rig asks
    // for it) there is nothing to reproject from: the view stays sharp.
    let depth = depth.filter(|d| d.texture.usage().contains(TextureUsages::TEXTURE_BINDING));
    if matches!(binding.variant, Variant::Reprojected { .. }) && depth.is_none() {
        return;
    }
    let layout = pipeline_cache.get_bind_group_layout(&shared.layouts[&binding.variant]);
    let post = target.post_process_write();
    let group = match binding.variant {
        Variant::Full => ctx.render_device().create_bind_group(
            "optica_spectacles_resolve",
            &layout,
            &BindGroupEntries::sequential((&atlas.texture_view, &shared.sampler, params)),
        ),
        Variant::Reprojected { .. } => {
            let Some(depth) = depth else { return };
            ctx.render_device().create_bind_group(
                "optica_spectacles_resolve",
                &layout,
                &BindGroupEntries::sequential((
                    &atlas.texture_view,
                    &shared.sampler,
                    params,
                    post.source,
                    depth.view(),
                    &shared.gather,
                )),
            )
        }
    };
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let span = diagnostics.time_span(ctx.command_encoder(), "optica/spectacles/resolve");
    {
        let mut pass = ctx
            .command_encoder()
            .begin_render_pass(&RenderPassDescriptor {
                label: Some("optica_spectacles_resolve"),
                color_attachments: &[Some(RenderPassColorAttachment {
                    view: post.destination,
                    depth_slice: None,
                    resolve_target: None,
                    ops: Operations::default(),
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.draw(0..3, 0..1);
    }
    span.end(ctx.command_encoder());
}
