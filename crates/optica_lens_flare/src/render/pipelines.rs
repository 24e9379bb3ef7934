//! The flare's pipelines, specialised on first use through Bevy's
//! `Specialized*Pipelines` caches (a scene without a flare camera queues
//! none): the compute passes by kind, the additive draws by what they
//! draw and the target's format.

use bevy::core_pipeline::FullscreenShader;
use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    sampler, storage_buffer, storage_buffer_read_only, texture_2d, texture_depth_2d,
    texture_depth_2d_multisampled, uniform_buffer,
};
use bevy::render::render_resource::{
    BindGroupLayoutDescriptor, BindGroupLayoutEntries, BlendComponent, BlendFactor, BlendOperation,
    BlendState, CachedComputePipelineId, CachedRenderPipelineId, ColorTargetState, ColorWrites,
    ComputePipelineDescriptor, FilterMode, FragmentState, PipelineCache, RenderPipelineDescriptor,
    Sampler, SamplerBindingType, SamplerDescriptor, ShaderStages, SpecializedComputePipeline,
    SpecializedComputePipelines, SpecializedRenderPipeline, SpecializedRenderPipelines,
    TextureFormat, TextureSampleType, VertexState,
};
use bevy::render::renderer::RenderDevice;
use bevy::render::view::{ExtractedView, Msaa};
use bevy::shader::ShaderDefVal;

use super::GHOST_FORMAT;
use crate::draws::{FlareDraws, FlareParams, GridJob, LightProbe};
use crate::gpu_lens::GpuSurface;

/// Where `embedded_asset!` puts the passes' shaders (the plugin embeds
/// them); they import the libraries `optica_lens_flare::{types,
/// lens_trace, aperture}`.
const TRACE_SHADER: &str = "embedded://optica_lens_flare/shaders/ghost_trace.wgsl";
const DRAW_SHADER: &str = "embedded://optica_lens_flare/shaders/ghost_draw.wgsl";
const CELLS_SHADER: &str = "embedded://optica_lens_flare/shaders/ghost_cells.wgsl";
const UPSAMPLE_SHADER: &str = "embedded://optica_lens_flare/shaders/upsample.wgsl";
const OCCLUSION_SHADER: &str = "embedded://optica_lens_flare/shaders/visibility.wgsl";

/// The layouts, shaders and sampler of the flare's passes.
#[derive(Resource)]
pub(super) struct FlarePipelines {
    pub(super) trace_layout: BindGroupLayoutDescriptor,
    pub(super) cells_layout: BindGroupLayoutDescriptor,
    pub(super) draw_layout: BindGroupLayoutDescriptor,
    /// The occlusion pass's layouts: single-sampled depth, then MSAA.
    pub(super) occlusion_layouts: [BindGroupLayoutDescriptor; 2],
    /// A reduced-resolution target, read bilinearly to be scaled up.
    pub(super) upsample_layout: BindGroupLayoutDescriptor,
    pub(super) upsample_sampler: Sampler,
    fullscreen: FullscreenShader,
    trace_shader: Handle<Shader>,
    cells_shader: Handle<Shader>,
    draw_shader: Handle<Shader>,
    upsample_shader: Handle<Shader>,
    occlusion_shader: Handle<Shader>,
}

/// A compute pass.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub(super) enum ComputeKind {
    /// The rays of every grid.
    Trace,
    /// Dead rays continued from the live ones beside them.
    Fill,
    /// Each cell's colour and triangles.
    Cells,
    /// Each light's visibility from the view's depth (MSAA or not).
    Occlusion { multisampled: bool },
}

/// An additive draw into a target of `format`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub(super) struct DrawKey {
    pub(super) kind: DrawKind,
    pub(super) format: TextureFormat,
}

/// What an additive draw draws.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub(super) enum DrawKind {
    /// The cells of the ghosts, clipped by a round or a bladed iris.
    Ghosts { bladed: bool },
    /// Each light's starburst.
    Starburst,
    /// A reduced-resolution target scaled up.
    Upsample,
}

/// The pipelines one view's passes use this frame.
#[derive(Component)]
pub(super) struct FlarePipelineIds {
    pub(super) trace: CachedComputePipelineId,
    pub(super) fill: CachedComputePipelineId,
    pub(super) cells: CachedComputePipelineId,
    /// When the view's lights' depth is read.
    pub(super) occlusion: Option<CachedComputePipelineId>,
    /// The ghosts, into the ghosts' target.
    pub(super) ghosts: CachedRenderPipelineId,
    /// The large ghosts, into their half-resolution target, when there
    /// are any.
    pub(super) coarse: Option<CachedRenderPipelineId>,
    /// The starburst, onto the view, when it is on.
    pub(super) starburst: Option<CachedRenderPipelineId>,
    /// The ghosts' target scaled up onto the view, when it is reduced.
    pub(super) upsample_view: Option<CachedRenderPipelineId>,
    /// The large ghosts' target scaled up into the ghosts', when there
    /// are any.
    pub(super) upsample_ghosts: Option<CachedRenderPipelineId>,
}

pub(super) fn init_flare_pipelines(
    mut commands: Commands,
    render_device: Res<RenderDevice>,
    asset_server: Res<AssetServer>,
    fullscreen: Res<FullscreenShader>,
) {
    let trace_layout = BindGroupLayoutDescriptor::new(
        "optica_lens_flare_trace_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                uniform_buffer::<FlareParams>(false),
                storage_buffer_read_only::<Vec<GpuSurface>>(false),
                storage_buffer_read_only::<Vec<GridJob>>(false),
                storage_buffer::<Vec<[f32; 12]>>(false),
            ),
        ),
    );
    let cells_layout = BindGroupLayoutDescriptor::new(
        "optica_lens_flare_cells_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                uniform_buffer::<FlareParams>(false),
                storage_buffer_read_only::<Vec<GridJob>>(false),
                storage_buffer_read_only::<Vec<[f32; 12]>>(false),
                storage_buffer::<Vec<[f32; 4]>>(false),
                storage_buffer::<Vec<u32>>(false),
            ),
        ),
    );
    let draw_layout = BindGroupLayoutDescriptor::new(
        "optica_lens_flare_draw_layout",
        &BindGroupLayoutEntries::sequential(
            // The fragment stage reads the iris from the uniform.
            ShaderStages::VERTEX_FRAGMENT,
            (
                uniform_buffer::<FlareParams>(false),
                storage_buffer_read_only::<Vec<[f32; 4]>>(false),
                storage_buffer_read_only::<Vec<[f32; 12]>>(false),
                storage_buffer_read_only::<Vec<f32>>(false),
                storage_buffer_read_only::<Vec<LightProbe>>(false),
                texture_2d(TextureSampleType::Float { filterable: false }),
                texture_2d(TextureSampleType::Float { filterable: false }),
            ),
        ),
    );
    let upsample_layout = BindGroupLayoutDescriptor::new(
        "optica_lens_flare_upsample_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::FRAGMENT,
            (
                texture_2d(TextureSampleType::Float { filterable: true }),
                sampler(SamplerBindingType::Filtering),
            ),
        ),
    );
    let upsample_sampler = render_device.create_sampler(&SamplerDescriptor {
        label: Some("optica_lens_flare_upsample"),
        mag_filter: FilterMode::Linear,
        min_filter: FilterMode::Linear,
        ..default()
    });
    commands.insert_resource(FlarePipelines {
        trace_layout,
        cells_layout,
        draw_layout,
        occlusion_layouts: [occlusion_layout(false), occlusion_layout(true)],
        upsample_layout,
        upsample_sampler,
        fullscreen: fullscreen.clone(),
        trace_shader: asset_server.load(TRACE_SHADER),
        cells_shader: asset_server.load(CELLS_SHADER),
        draw_shader: asset_server.load(DRAW_SHADER),
        upsample_shader: asset_server.load(UPSAMPLE_SHADER),
        occlusion_shader: asset_server.load(OCCLUSION_SHADER),
    });
}

fn occlusion_layout(multisampled: bool) -> BindGroupLayoutDescriptor {
    BindGroupLayoutDescriptor::new(
        "optica_lens_flare_occlusion_layout",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                uniform_buffer::<FlareParams>(false),
                storage_buffer_read_only::<Vec<LightProbe>>(false),
                if multisampled {
                    texture_depth_2d_multisampled()
                } else {
                    texture_depth_2d()
                },
                storage_buffer::<Vec<f32>>(false),
            ),
        ),
    )
}

impl SpecializedComputePipeline for FlarePipelines {
    type Key = ComputeKind;

    fn specialize(&self, key: ComputeKind) -> ComputePipelineDescriptor {
        let (label, layout, shader, entry, shader_defs) = match key {
            ComputeKind::Trace => (
                "optica_lens_flare_trace",
                &self.trace_layout,
                &self.trace_shader,
                "trace",
                vec![],
            ),
            ComputeKind::Fill => (
                "optica_lens_flare_fill",
                &self.trace_layout,
                &self.trace_shader,
                "fill",
                vec![],
            ),
            ComputeKind::Cells => (
                "optica_lens_flare_cells",
                &self.cells_layout,
                &self.cells_shader,
                "cells",
                vec![],
            ),
            ComputeKind::Occlusion { multisampled } => (
                "optica_lens_flare_occlusion",
                &self.occlusion_layouts[usize::from(multisampled)],
                &self.occlusion_shader,
                "occlusion",
                if multisampled {
                    vec!["MULTISAMPLED".into()]
                } else {
                    vec![]
                },
            ),
        };
        ComputePipelineDescriptor {
            label: Some(label.into()),
            layout: vec![layout.clone()],
            immediate_size: 0,
            shader: shader.clone(),
            shader_defs,
            entry_point: Some(entry.into()),
            zero_initialize_workgroup_memory: false,
        }
    }
}

impl SpecializedRenderPipeline for FlarePipelines {
    type Key = DrawKey;

    fn specialize(&self, key: DrawKey) -> RenderPipelineDescriptor {
        let draw = |prefix: &str, shader_defs: Vec<ShaderDefVal>| {
            (
                vec![self.draw_layout.clone()],
                VertexState {
                    shader: self.draw_shader.clone(),
                    shader_defs: shader_defs.clone(),
                    entry_point: Some(format!("{prefix}vertex").into()),
                    ..default()
                },
                (
                    self.draw_shader.clone(),
                    format!("{prefix}fragment"),
                    shader_defs,
                ),
            )
        };
        let (label, (layout, vertex, (shader, entry, shader_defs))) = match key.kind {
            DrawKind::Ghosts { bladed } => (
                "optica_lens_flare_draw",
                draw(
                    "",
                    if bladed {
                        vec!["BLADED_IRIS".into()]
                    } else {
                        vec![]
                    },
                ),
            ),
            DrawKind::Starburst => ("optica_lens_flare_starburst", draw("starburst_", vec![])),
            DrawKind::Upsample => (
                "optica_lens_flare_upsample",
                (
                    vec![self.upsample_layout.clone()],
                    self.fullscreen.to_vertex_state(),
                    (self.upsample_shader.clone(), "upsample".into(), vec![]),
                ),
            ),
        };
        RenderPipelineDescriptor {
            label: Some(label.into()),
            layout,
            vertex,
            fragment: Some(FragmentState {
                shader,
                shader_defs,
                entry_point: Some(entry.into()),
                targets: vec![Some(ColorTargetState {
                    format: key.format,
                    // Added: the flare is light.
                    blend: Some(BlendState {
                        color: BlendComponent {
                            src_factor: BlendFactor::One,
                            dst_factor: BlendFactor::One,
                            operation: BlendOperation::Add,
                        },
                        alpha: BlendComponent {
                            src_factor: BlendFactor::Zero,
                            dst_factor: BlendFactor::One,
                            operation: BlendOperation::Add,
                        },
                    }),
                    write_mask: ColorWrites::ALL,
                })],
            }),
            ..default()
        }
    }
}

/// Specialises each flare view's pipelines (the cache queues a pipeline
/// the first time its key is asked for).
pub(super) fn prepare_flare_pipelines(
    mut commands: Commands,
    pipeline_cache: Res<PipelineCache>,
    pipelines: Res<FlarePipelines>,
    mut compute: ResMut<SpecializedComputePipelines<FlarePipelines>>,
    mut render: ResMut<SpecializedRenderPipelines<FlarePipelines>>,
    views: Query<(Entity, &ExtractedView, &FlareDraws, &Msaa)>,
) {
    for (entity, view, draws, msaa) in &views {
        let params = &draws.params;
        if params.jobs == 0 || params.rays == 0 {
            commands.entity(entity).remove::<FlarePipelineIds>();
            continue;
        }
        let mut compute = |kind| compute.specialize(&pipeline_cache, &pipelines, kind);
        let occlusion = (params.occlusion_radius_px > 0.0 && params.lights > 0).then(|| {
            compute(ComputeKind::Occlusion {
                multisampled: msaa.samples() > 1,
            })
        });
        let ids = (
            compute(ComputeKind::Trace),
            compute(ComputeKind::Fill),
            compute(ComputeKind::Cells),
        );
        let mut draw =
            |kind, format| render.specialize(&pipeline_cache, &pipelines, DrawKey { kind, format });
        let ghost_format = if draws.ghost_divisor > 1 {
            GHOST_FORMAT
        } else {
            view.target_format
        };
        let bladed = params.blades != 0;
        let reduced = draws.ghost_divisor > 1;
        let coarse = draws.coarse_from < draws.jobs.len();
        let starburst = params.starburst_half_ndc > 0.0 && params.starburst_scale > 0.0;
        commands.entity(entity).insert(FlarePipelineIds {
            trace: ids.0,
            fill: ids.1,
            cells: ids.2,
            occlusion,
            ghosts: draw(DrawKind::Ghosts { bladed }, ghost_format),
            coarse: coarse.then(|| draw(DrawKind::Ghosts { bladed }, GHOST_FORMAT)),
            starburst: starburst.then(|| draw(DrawKind::Starburst, view.target_format)),
            upsample_view: reduced.then(|| draw(DrawKind::Upsample, view.target_format)),
            upsample_ghosts: coarse.then(|| draw(DrawKind::Upsample, ghost_format)),
        });
    }
}
