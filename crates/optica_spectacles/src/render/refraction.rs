//! The lens's refraction drawn over the eye camera's view (after the
//! clones' resolve, so the lens shows the blurred view): a compute pass
//! finds each lens vertex's exit ray in the view's depth and stores its
//! texture coordinate; a render pass copies the view and draws the lens's
//! back surface over it with those coordinates (`lens_refraction.wgsl`).
//! Spans: `optica/spectacles/refraction`.

use bevy::core_pipeline::{Core3d, Core3dSystems, FullscreenShader};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use bevy::render::diagnostic::RecordDiagnostics;
use bevy::render::extract_component::ExtractComponentPlugin;
use bevy::render::render_resource::binding_types::{
    sampler, storage_buffer, storage_buffer_read_only, texture_2d, texture_depth_2d,
    texture_depth_2d_multisampled, uniform_buffer,
};
use bevy::render::render_resource::{
    BindGroupEntries, BindGroupLayoutDescriptor, BindGroupLayoutEntries, Buffer,
    BufferDescriptor, BufferUsages, CachedComputePipelineId, CachedRenderPipelineId,
    ColorTargetState, ColorWrites, ComputePassDescriptor, ComputePipelineDescriptor,
    FilterMode, FragmentState, Operations, PipelineCache, RenderPassColorAttachment,
    RenderPassDescriptor, RenderPipelineDescriptor, Sampler, SamplerBindingType,
    SamplerDescriptor, ShaderStages, ShaderType, StorageBuffer, TextureFormat,
    TextureSampleType, TextureUsages, UniformBuffer, VertexState,
};
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy::render::view::{ExtractedView, Msaa, ViewDepthTexture, ViewTarget};
use bevy::render::{Render, RenderApp, RenderStartup, RenderSystems};

use crate::refraction::{LensRefraction, LensVertex};

/// Geometric steps of an exit ray's march through the depth (2 cm to 2 km,
/// a factor of 1.2 apart), before 16 bisections.
pub const MARCH_STEPS: u32 = 64;

/// The lens's dark edge where its rays do not get through (linear).
pub(crate) const EDGE: f32 = 0.02;

/// `LensParams` in `lens_refraction.wgsl`.
#[derive(Clone, Copy, Debug, Default, ShaderType)]
pub(crate) struct LensParams {
    pub(crate) clip_from_view: Mat4,
    pub(crate) near: f32,
    pub(crate) vertices: u32,
    pub(crate) steps: u32,
    pub(crate) edge: f32,
    /// 3 when the lens parts the colours (a march per colour), else 1 (the
    /// green march stands for all three).
    pub(crate) colours: u32,
}

pub(crate) fn build(app: &mut App) {
    app.add_plugins(ExtractComponentPlugin::<LensRefraction>::default());
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
        return;
    };
    render_app
        .add_systems(RenderStartup, init_refraction)
        .add_systems(
            Render,
            prepare_refraction.in_set(RenderSystems::PrepareBindGroups),
        )
        .add_systems(
            Core3d,
            refraction_pass
                .in_set(Core3dSystems::EarlyPostProcess)
                .after(super::resolve::resolve_pass),
        );
}

#[derive(Resource)]
pub(crate) struct RefractionShared {
    /// The march's layouts: single-sampled depth, then MSAA.
    pub(crate) march_layouts: [BindGroupLayoutDescriptor; 2],
    draw_layout: BindGroupLayoutDescriptor,
    sampler: Sampler,
    march: [Option<CachedComputePipelineId>; 2],
    /// Per target format: the copy and the lens pipelines.
    draws: HashMap<TextureFormat, [CachedRenderPipelineId; 2]>,
}

impl RefractionShared {
    /// The march's pipeline for single-sampled or MSAA depth, queued once.
    pub(crate) fn march_pipeline(
        &mut self,
        pipeline_cache: &PipelineCache,
        multisampled: bool,
    ) -> CachedComputePipelineId {
        let layout = self.march_layouts[usize::from(multisampled)].clone();
        *self.march[usize::from(multisampled)].get_or_insert_with(|| {
            pipeline_cache.queue_compute_pipeline(ComputePipelineDescriptor {
                label: Some("optica_spectacles_lens_march".into()),
                layout: vec![layout],
                immediate_size: 0,
                shader: crate::LENS_SHADER,
                shader_defs: if multisampled {
                    vec!["MARCH".into(), "MULTISAMPLED".into()]
                } else {
                    vec!["MARCH".into()]
                },
                entry_point: Some("march".into()),
                zero_initialize_workgroup_memory: false,
            })
        })
    }
}

fn march_layout(multisampled: bool) -> BindGroupLayoutDescriptor {
    BindGroupLayoutDescriptor::new(
        "optica_spectacles_lens_march",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                uniform_buffer::<LensParams>(false),
                storage_buffer_read_only::<Vec<LensVertex>>(false),
                storage_buffer::<Vec<Vec4>>(false),
                if multisampled {
                    texture_depth_2d_multisampled()
                } else {
                    texture_depth_2d()
                },
            ),
        ),
    )
}

fn init_refraction(mut commands: Commands, render_device: Res<RenderDevice>) {
    let draw_layout = BindGroupLayoutDescriptor::new(
        "optica_spectacles_lens_draw",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::VERTEX_FRAGMENT,
            (
                uniform_buffer::<LensParams>(false),
                storage_buffer_read_only::<Vec<LensVertex>>(false),
                storage_buffer_read_only::<Vec<Vec4>>(false),
                texture_2d(TextureSampleType::Float { filterable: true }),
                sampler(SamplerBindingType::Filtering),
            ),
        ),
    );
    let sampler = render_device.create_sampler(&SamplerDescriptor {
        label: Some("optica_spectacles_lens"),
        mag_filter: FilterMode::Linear,
        min_filter: FilterMode::Linear,
        ..default()
    });
    commands.insert_resource(RefractionShared {
        march_layouts: [march_layout(false), march_layout(true)],
        draw_layout,
        sampler,
        march: [None, None],
        draws: HashMap::default(),
    });
}

/// A view's lens on the GPU, kept between frames; the vertices are
/// rewritten only when the lens was retraced.
#[derive(Component)]
struct RefractionBuffers {
    params: UniformBuffer<LensParams>,
    vertices: StorageBuffer<Vec<LensVertex>>,
    coords: Buffer,
    indices: Buffer,
    index_count: u32,
    /// The trace the buffers hold (its vertices, compared to see a retrace).
    traced: Vec<LensVertex>,
    /// Marches per vertex (`LensParams::colours`).
    colours: u32,
}

/// This frame's pipelines of a view.
#[derive(Component)]
struct RefractionPipelines {
    march: CachedComputePipelineId,
    multisampled: bool,
    copy: CachedRenderPipelineId,
    lens: CachedRenderPipelineId,
}

#[allow(clippy::too_many_arguments)]
fn prepare_refraction(
    mut commands: Commands,
    mut views: Query<(
        Entity,
        &ExtractedView,
        &LensRefraction,
        &Msaa,
        Option<&mut RefractionBuffers>,
    )>,
    mut shared: ResMut<RefractionShared>,
    pipeline_cache: Res<PipelineCache>,
    fullscreen: Res<FullscreenShader>,
    render_device: Res<RenderDevice>,
    render_queue: Res<RenderQueue>,
) {
    for (entity, view, lens, msaa, buffers) in &mut views {
        if lens.vertices.is_empty() || lens.indices.is_empty() {
            continue;
        }
        let multisampled = msaa.samples() > 1;
        let march = shared.march_pipeline(&pipeline_cache, multisampled);
        let format = view.target_format;
        let draw_layout = shared.draw_layout.clone();
        let [copy, lens_pipeline] = *shared.draws.entry(format).or_insert_with(|| {
            let target = Some(ColorTargetState {
                format,
                blend: None,
                write_mask: ColorWrites::ALL,
            });
            let copy = pipeline_cache.queue_render_pipeline(RenderPipelineDescriptor {
                label: Some("optica_spectacles_lens_copy".into()),
                layout: vec![draw_layout.clone()],
                vertex: fullscreen.to_vertex_state(),
                fragment: Some(FragmentState {
                    shader: crate::LENS_SHADER,
                    entry_point: Some("copy_fragment".into()),
                    targets: vec![target.clone()],
                    ..default()
                }),
                ..default()
            });
            let lens = pipeline_cache.queue_render_pipeline(RenderPipelineDescriptor {
                label: Some("optica_spectacles_lens_draw".into()),
                layout: vec![draw_layout],
                vertex: VertexState {
                    shader: crate::LENS_SHADER,
                    entry_point: Some("lens_vertex".into()),
                    ..default()
                },
                fragment: Some(FragmentState {
                    shader: crate::LENS_SHADER,
                    entry_point: Some("lens_fragment".into()),
                    targets: vec![target],
                    ..default()
                }),
                ..default()
            });
            [copy, lens]
        });
        let params = LensParams {
            clip_from_view: view.clip_from_view,
            near: view.clip_from_view.w_axis.z,
            vertices: lens.vertices.len() as u32,
            steps: MARCH_STEPS,
            edge: EDGE,
            colours: if lens.chromatic { 3 } else { 1 },
        };
        let retraced = buffers.as_ref().is_none_or(|b| b.traced != lens.vertices);
        if retraced {
            let mut vertices = StorageBuffer::from(lens.vertices.clone());
            vertices.write_buffer(&render_device, &render_queue);
            let coords = render_device.create_buffer(&BufferDescriptor {
                label: Some("optica_spectacles_lens_coords"),
                // A coordinate per vertex and colour (green, red, blue).
                size: 3 * 16 * lens.vertices.len() as u64,
                usage: BufferUsages::STORAGE,
                mapped_at_creation: false,
            });
            let indices = render_device.create_buffer_with_data(
                &bevy::render::render_resource::BufferInitDescriptor {
                    label: Some("optica_spectacles_lens_indices"),
                    contents: &lens
                        .indices
                        .iter()
                        .flat_map(|i| i.to_le_bytes())
                        .collect::<Vec<u8>>(),
                    usage: BufferUsages::INDEX,
                },
            );
            let mut p = UniformBuffer::from(params);
            p.write_buffer(&render_device, &render_queue);
            commands.entity(entity).insert(RefractionBuffers {
                params: p,
                vertices,
                coords,
                indices,
                index_count: lens.indices.len() as u32,
                traced: lens.vertices.clone(),
                colours: params.colours,
            });
        } else if let Some(mut b) = buffers {
            b.params.set(params);
            b.params.write_buffer(&render_device, &render_queue);
        }
        commands.entity(entity).insert(RefractionPipelines {
            march,
            multisampled,
            copy,
            lens: lens_pipeline,
        });
    }
}

fn refraction_pass(
    view: ViewQuery<(
        &ViewTarget,
        &RefractionBuffers,
        &RefractionPipelines,
        Option<&ViewDepthTexture>,
    )>,
    shared: Res<RefractionShared>,
    pipeline_cache: Res<PipelineCache>,
    mut ctx: RenderContext,
) {
    let (target, buffers, pipelines, depth) = view.into_inner();
    let (Some(march), Some(copy), Some(lens)) = (
        pipeline_cache.get_compute_pipeline(pipelines.march),
        pipeline_cache.get_render_pipeline(pipelines.copy),
        pipeline_cache.get_render_pipeline(pipelines.lens),
    ) else {
        return;
    };
    // The depth is bindable a frame after `make_depth_readable` asks.
    let Some(depth) = depth.filter(|d| d.texture.usage().contains(TextureUsages::TEXTURE_BINDING))
    else {
        return;
    };
    let (Some(params), Some(vertices)) = (buffers.params.binding(), buffers.vertices.binding())
    else {
        return;
    };
    let device = ctx.render_device().clone();
    let march_group = device.create_bind_group(
        "optica_spectacles_lens_march",
        &pipeline_cache
            .get_bind_group_layout(&shared.march_layouts[usize::from(pipelines.multisampled)]),
        &BindGroupEntries::sequential((
            params.clone(),
            vertices.clone(),
            buffers.coords.as_entire_binding(),
            depth.view(),
        )),
    );
    let post = target.post_process_write();
    let draw_group = device.create_bind_group(
        "optica_spectacles_lens_draw",
        &pipeline_cache.get_bind_group_layout(&shared.draw_layout),
        &BindGroupEntries::sequential((
            params,
            vertices,
            buffers.coords.as_entire_binding(),
            post.source,
            &shared.sampler,
        )),
    );
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let span = diagnostics.time_span(ctx.command_encoder(), "optica/spectacles/refraction");
    {
        let mut pass = ctx
            .command_encoder()
            .begin_compute_pass(&ComputePassDescriptor {
                label: Some("optica_spectacles_lens_march"),
                timestamp_writes: None,
            });
        pass.set_pipeline(march);
        pass.set_bind_group(0, &march_group, &[]);
        pass.dispatch_workgroups((buffers.colours * buffers.traced.len() as u32).div_ceil(64), 1, 1);
    }
    {
        let mut pass = ctx
            .command_encoder()
            .begin_render_pass(&RenderPassDescriptor {
                label: Some("optica_spectacles_lens_draw"),
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
        pass.set_bind_group(0, &draw_group, &[]);
        pass.set_pipeline(copy);
        pass.draw(0..3, 0..1);
        pass.set_pipeline(lens);
        // The raw pass takes wgpu's own buffer slice.
        pass.set_index_buffer(
            std::ops::Deref::deref(&buffers.indices).slice(..),
            bevy::render::render_resource::IndexFormat::Uint32,
        );
        pass.draw_indexed(0..buffers.index_count, 0, 0..1);
    }
    span.end(ctx.command_encoder());
}
