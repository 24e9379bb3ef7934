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

use bevy::asset::embedded_asset;
use bevy::core_pipeline::tonemapping::tonemapping;
use bevy::core_pipeline::{Core3d, Core3dSystems, FullscreenShader};
use bevy::diagnostic::FrameCount;
use bevy::platform::collections::HashMap;
use bevy::post_process::bloom::bloom;
use bevy::prelude::*;
use bevy::render::camera::TemporalJitter;
use bevy::render::diagnostic::RecordDiagnostics;
use bevy::render::extract_component::ExtractComponentPlugin;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::binding_types::{
    sampler, storage_buffer, storage_buffer_read_only, texture_2d, texture_depth_2d,
    texture_depth_2d_multisampled, uniform_buffer,
};
use bevy::render::render_resource::{
    BindGroup, BindGroupEntries, BindGroupLayoutDescriptor, BindGroupLayoutEntries, BlendComponent,
    BlendFactor, BlendOperation, BlendState, Buffer, BufferDescriptor, BufferUsages,
    CachedComputePipelineId, CachedRenderPipelineId, ColorTargetState, ColorWrites, CommandEncoder,
    ComputePassDescriptor, ComputePipeline, ComputePipelineDescriptor, FragmentState, IndexFormat,
    PipelineCache, RenderPassDescriptor, RenderPipelineDescriptor, ShaderStages, StorageBuffer,
    TextureFormat, TextureSampleType, TextureUsages, UniformBuffer, VertexState,
};
use bevy::render::render_resource::{
    Extent3d, FilterMode, LoadOp, Operations, RenderPassColorAttachment, Sampler,
    SamplerBindingType, SamplerDescriptor, StoreOp, Texture, TextureDescriptor, TextureDimension,
    TextureView, TextureViewDescriptor,
};
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy::render::texture::{FallbackImage, GpuImage};
use bevy::render::view::{ExtractedView, Msaa, ViewDepthTexture, ViewTarget};
use bevy::render::{Render, RenderApp, RenderStartup, RenderSystems};
use bevy::shader::Shader;
use bevy::shader::load_shader_library;

use crate::draws::{FlareDraws, FlareParams, GridJob, LightProbe};
use crate::gpu_lens::GpuSurface;

/// Where `embedded_asset!` puts the passes' shaders; they import the
/// libraries `optica_lens_flare::{types, lens_trace, aperture}`.
const TRACE_SHADER: &str = "embedded://optica_lens_flare/shaders/ghost_trace.wgsl";
const DRAW_SHADER: &str = "embedded://optica_lens_flare/shaders/ghost_draw.wgsl";
const CELLS_SHADER: &str = "embedded://optica_lens_flare/shaders/ghost_cells.wgsl";
const UPSAMPLE_SHADER: &str = "embedded://optica_lens_flare/shaders/upsample.wgsl";
const OCCLUSION_SHADER: &str = "embedded://optica_lens_flare/shaders/visibility.wgsl";

/// The passes' shaders, loaded once.
struct FlareShaders {
    trace: Handle<Shader>,
    draw: Handle<Shader>,
    cells: Handle<Shader>,
    upsample: Handle<Shader>,
    occlusion: Handle<Shader>,
}

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
        load_shader_library!(app, "shaders/flare_types.wgsl");
        load_shader_library!(app, "shaders/lens_trace.wgsl");
        load_shader_library!(app, "shaders/aperture.wgsl");
        embedded_asset!(app, "shaders/ghost_trace.wgsl");
        embedded_asset!(app, "shaders/ghost_cells.wgsl");
        embedded_asset!(app, "shaders/ghost_draw.wgsl");
        embedded_asset!(app, "shaders/upsample.wgsl");
        embedded_asset!(app, "shaders/visibility.wgsl");
        app.add_plugins(ExtractComponentPlugin::<FlareDraws>::default());
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        render_app
            .add_systems(RenderStartup, init_flare)
            .add_systems(
                Render,
                prepare_flare.in_set(RenderSystems::PrepareBindGroups),
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

/// Layouts and the pipelines, queued on first use.
#[derive(Resource)]
struct FlareShared {
    shaders: FlareShaders,
    trace_layout: BindGroupLayoutDescriptor,
    cells_layout: BindGroupLayoutDescriptor,
    draw_layout: BindGroupLayoutDescriptor,
    /// The occlusion pass's layouts: single-sampled depth, then MSAA.
    occlusion_layouts: [BindGroupLayoutDescriptor; 2],
    trace: Option<CachedComputePipelineId>,
    fill: Option<CachedComputePipelineId>,
    cells: Option<CachedComputePipelineId>,
    /// The draw and starburst pipelines per target format and whether
    /// the iris has blades (`BLADED_IRIS`).
    draws: HashMap<(TextureFormat, bool), [CachedRenderPipelineId; 2]>,
    /// Reduced-resolution ghosts: the layout, the bilinear sampler and,
    /// per view format, the pipeline that adds them to the view.
    upsample_layout: BindGroupLayoutDescriptor,
    upsample_sampler: Sampler,
    upsamples: HashMap<TextureFormat, CachedRenderPipelineId>,
    occlusion: [Option<CachedComputePipelineId>; 2],
}

/// The flare's additive draw pipeline for `format`, at the draw shader's
/// `entry` (`vertex` / `fragment` with the prefix).
fn draw_pipeline(
    pipeline_cache: &PipelineCache,
    shader: &Handle<Shader>,
    layout: BindGroupLayoutDescriptor,
    (format, bladed): (TextureFormat, bool),
    label: &'static str,
    prefix: &str,
) -> CachedRenderPipelineId {
    let shader_defs: Vec<bevy::shader::ShaderDefVal> = if bladed {
        vec!["BLADED_IRIS".into()]
    } else {
        vec![]
    };
    additive_pipeline(
        pipeline_cache,
        layout,
        format,
        label,
        VertexState {
            shader: shader.clone(),
            shader_defs: shader_defs.clone(),
            entry_point: Some(format!("{prefix}vertex").into()),
            ..default()
        },
        (shader.clone(), format!("{prefix}fragment"), shader_defs),
    )
}

/// A pipeline that adds what `fragment` (shader, entry) returns to a
/// `format` target.
fn additive_pipeline(
    pipeline_cache: &PipelineCache,
    layout: BindGroupLayoutDescriptor,
    format: TextureFormat,
    label: &'static str,
    vertex: VertexState,
    fragment: (Handle<Shader>, String, Vec<bevy::shader::ShaderDefVal>),
) -> CachedRenderPipelineId {
    pipeline_cache.queue_render_pipeline(RenderPipelineDescriptor {
        label: Some(label.into()),
        layout: vec![layout],
        vertex,
        fragment: Some(FragmentState {
            shader: fragment.0,
            shader_defs: fragment.2,
            entry_point: Some(fragment.1.into()),
            targets: vec![Some(ColorTargetState {
                format,
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
    })
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

fn init_flare(
    mut commands: Commands,
    render_device: Res<RenderDevice>,
    asset_server: Res<AssetServer>,
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
                storage_buffer_read_only::<Vec<f32>>(false),
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
    commands.insert_resource(FlareShared {
        shaders: FlareShaders {
            trace: asset_server.load(TRACE_SHADER),
            draw: asset_server.load(DRAW_SHADER),
            cells: asset_server.load(CELLS_SHADER),
            upsample: asset_server.load(UPSAMPLE_SHADER),
            occlusion: asset_server.load(OCCLUSION_SHADER),
        },
        upsample_layout,
        upsample_sampler,
        upsamples: HashMap::default(),
        trace_layout,
        cells_layout,
        draw_layout,
        occlusion_layouts: [occlusion_layout(false), occlusion_layout(true)],
        trace: None,
        fill: None,
        cells: None,
        draws: HashMap::default(),
        occlusion: [None, None],
    });
}

/// One view's buffers, bind groups and pipelines for this frame.
#[derive(Component)]
struct FlareBinding {
    /// Whether the rays are traced this frame (else last frame's stand).
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

/// One view's GPU buffers, kept between frames: rewritten in place, and
/// reallocated only when a frame needs more room than they have.
#[derive(Component, Default)]
struct FlareBuffers {
    uniform: UniformBuffer<FlareParams>,
    surfaces: StorageBuffer<Vec<GpuSurface>>,
    jobs: StorageBuffer<Vec<GridJob>>,
    probes: StorageBuffer<Vec<LightProbe>>,
    rays: Option<Buffer>,
    /// Per ray, the colour of the cell it is the first corner of.
    cell_colors: Option<Buffer>,
    /// The cells' triangles, written by the cell pass (empty where a cell
    /// adds no light).
    indices: Option<Buffer>,
    /// Each light's visibility, kept between frames for its history.
    visibility: Option<Buffer>,
    /// The reduced-resolution ghosts' target.
    reduced: Option<GhostTarget>,
    /// The large ghosts' target, at half the ghosts' resolution.
    coarse: Option<GhostTarget>,
    /// The lights whose visibility `visibility` holds.
    lights: Vec<Entity>,
    /// Whether the occlusion pass ran last frame (else the buffer holds
    /// ones, not a history to blend with).
    history_holds: bool,
    /// Whether the rays have been over the device's limit (warned once).
    warned_over_limit: bool,
    /// What the rays in `rays` were traced from; while a frame's grids,
    /// lens and settings are the same (a still camera and lights), they
    /// are not traced again.
    traced: Option<TraceKey>,
    /// The raw visibilities per light `visibility` holds (0: no TAA).
    jitter_cycle: u32,
}

/// A texture the ghosts are added up in before it is scaled up.
struct GhostTarget {
    size: UVec2,
    /// Kept with its view, which is what the passes use.
    _texture: Texture,
    view: TextureView,
}

impl GhostTarget {
    fn new(render_device: &RenderDevice, size: UVec2) -> Self {
        let texture = render_device.create_texture(&TextureDescriptor {
            label: Some("optica_lens_flare_ghosts"),
            size: Extent3d {
                width: size.x,
                height: size.y,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: TextureDimension::D2,
            format: GHOST_FORMAT,
            usage: TextureUsages::RENDER_ATTACHMENT | TextureUsages::TEXTURE_BINDING,
            view_formats: &[],
        });
        let view = texture.create_view(&TextureViewDescriptor::default());
        Self {
            size,
            _texture: texture,
            view,
        }
    }
}

/// Everything the trace's result depends on: the grids, the lens at each
/// wavelength and what the trace reads of the uniform (not, say, the
/// ringing's texture arriving, which changes only the draw).
#[derive(PartialEq)]
struct TraceKey {
    jobs: Vec<GridJob>,
    surfaces: Vec<GpuSurface>,
    params: [u32; 4],
}

/// Frames in Bevy's TAA jitter sequence (eight Halton (2, 3) offsets, the
/// one of frame n at n mod 8): the occlusion pass averages its last eight
/// raw visibilities, one per offset.
const JITTER_CYCLE: u32 = 8;

/// A view with flare draws: its buffers once made, its depth and MSAA.
type FlareView = (
    Entity,
    &'static ExtractedView,
    &'static FlareDraws,
    Option<&'static mut FlareBuffers>,
    Option<&'static ViewDepthTexture>,
    &'static Msaa,
    Option<&'static TemporalJitter>,
);

#[allow(clippy::too_many_arguments)]
fn prepare_flare(
    mut commands: Commands,
    mut views: Query<FlareView>,
    shared: ResMut<FlareShared>,
    pipeline_cache: Res<PipelineCache>,
    render_device: Res<RenderDevice>,
    render_queue: Res<RenderQueue>,
    images: Res<RenderAssets<GpuImage>>,
    fallback: Res<FallbackImage>,
    frame: Res<FrameCount>,
    fullscreen: Res<FullscreenShader>,
) {
    // Borrowed as a plain reference, so that its fields borrow apart.
    let shared = shared.into_inner();
    for (entity, view, draws, buffers, depth, msaa, jitter) in &mut views {
        let mut params = draws.params;
        if let Some(jitter) = jitter {
            // Where the jitter moves the image of a point this frame (with
            // a perspective projection, the same for every point).
            let mut jittered = view.clip_from_view;
            jitter.jitter_projection(&mut jittered, view.viewport.zw().as_vec2());
            let ndc = |m: Mat4| {
                let c = m * Vec4::new(0.0, 0.0, -1.0, 1.0);
                c.xy() / c.w
            };
            params.jitter_ndc = ndc(jittered) - ndc(view.clip_from_view);
            params.jitter_cycle = JITTER_CYCLE;
            params.jitter_slot = frame.0 % JITTER_CYCLE;
        }
        if params.jobs == 0 || params.rays == 0 {
            commands.entity(entity).remove::<FlareBinding>();
            continue;
        }
        let trace_layout = shared.trace_layout.clone();
        let trace = *shared.trace.get_or_insert_with(|| {
            pipeline_cache.queue_compute_pipeline(ComputePipelineDescriptor {
                label: Some("optica_lens_flare_trace".into()),
                layout: vec![trace_layout],
                immediate_size: 0,
                shader: shared.shaders.trace.clone(),
                shader_defs: vec![],
                entry_point: Some("trace".into()),
                zero_initialize_workgroup_memory: false,
            })
        });
        let fill_layout = shared.trace_layout.clone();
        let fill = *shared.fill.get_or_insert_with(|| {
            pipeline_cache.queue_compute_pipeline(ComputePipelineDescriptor {
                label: Some("optica_lens_flare_fill".into()),
                layout: vec![fill_layout],
                immediate_size: 0,
                shader: shared.shaders.trace.clone(),
                shader_defs: vec![],
                entry_point: Some("fill".into()),
                zero_initialize_workgroup_memory: false,
            })
        });
        let cells_layout = shared.cells_layout.clone();
        let cells_pipeline = *shared.cells.get_or_insert_with(|| {
            pipeline_cache.queue_compute_pipeline(ComputePipelineDescriptor {
                label: Some("optica_lens_flare_cells".into()),
                layout: vec![cells_layout],
                immediate_size: 0,
                shader: shared.shaders.cells.clone(),
                shader_defs: vec![],
                entry_point: Some("cells".into()),
                zero_initialize_workgroup_memory: false,
            })
        });
        let format = view.target_format;
        let divisor = draws.ghost_divisor.max(1);
        let bladed = params.blades != 0;
        let draw_shader = shared.shaders.draw.clone();
        let mut pipelines_for = |format: TextureFormat| {
            let draw_layout = shared.draw_layout.clone();
            let key = (format, bladed);
            *shared.draws.entry(key).or_insert_with(|| {
                [
                    draw_pipeline(
                        &pipeline_cache,
                        &draw_shader,
                        draw_layout.clone(),
                        key,
                        "optica_lens_flare_draw",
                        "",
                    ),
                    draw_pipeline(
                        &pipeline_cache,
                        &draw_shader,
                        draw_layout,
                        key,
                        "optica_lens_flare_starburst",
                        "starburst_",
                    ),
                ]
            })
        };
        let [_, starburst] = pipelines_for(format);
        let [draw, _] = pipelines_for(if divisor > 1 { GHOST_FORMAT } else { format });
        let [coarse_draw, _] = pipelines_for(GHOST_FORMAT);
        // The diffraction textures, once uploaded; until then (and when
        // off) the fallback, and the pass leaves them out.
        let texture = |id: Option<AssetId<Image>>| id.and_then(|id| images.get(id));
        let ringing = texture(draws.ringing);
        let burst = texture(draws.starburst);
        if ringing.is_none() {
            params.ringing = 0;
        }
        if burst.is_none() {
            params.starburst_scale = 0.0;
        }
        let fallback_view = &fallback.d2.texture_view;
        let ringing_view = ringing.map_or(fallback_view, |i| &i.texture_view);
        let burst_view = burst.map_or(fallback_view, |i| &i.texture_view);
        let mut created = None;
        let buffers = match buffers {
            Some(b) => b.into_inner(),
            None => created.insert(FlareBuffers::default()),
        };
        // More rays than one storage binding holds (128 MiB on many
        // devices: 2.8 M rays, e.g. 83 ghosts × 3 wavelengths at 128²): the
        // grids past it (the dimmest of the last light) are left out, with
        // one warning, instead of failing to bind.
        let limits = render_device.limits();
        let max_bytes = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size);
        let max_rays = u32::try_from(max_bytes / RAY_BYTES).unwrap_or(u32::MAX);
        if params.rays > max_rays {
            let kept = draws
                .jobs
                .iter()
                .take_while(|j| j.ray_end() <= max_rays)
                .count();
            if !buffers.warned_over_limit {
                warn!(
                    "optica_lens_flare: {} rays exceed the device's storage binding ({} rays); \
                     drawing {kept} of {} grids (lower LensFlare::grid, wavelengths or ghost_budget)",
                    params.rays,
                    max_rays,
                    draws.jobs.len()
                );
                buffers.warned_over_limit = true;
            }
            let last = kept.checked_sub(1).map(|k| draws.jobs[k]);
            params.jobs = kept as u32;
            params.rays = last.map_or(0, |j| j.ray_end());
            params.threads = last.map_or(0, |j| j.thread_end());
            params.cells = last.map_or(0, |j| j.cell_end());
            params.spans = last.map_or(0, |j| j.span_end());
            if kept == 0 {
                commands.entity(entity).remove::<FlareBinding>();
                continue;
            }
        }
        let rays = u64::from(params.rays);
        let cells = u64::from(params.cells).max(1);
        for (buffer, label, size, usage) in [
            (
                &mut buffers.rays,
                "optica_lens_flare_rays",
                rays * RAY_BYTES,
                BufferUsages::STORAGE,
            ),
            (
                &mut buffers.cell_colors,
                "optica_lens_flare_cell_colors",
                rays * CELL_COLOR_BYTES,
                BufferUsages::STORAGE,
            ),
            (
                &mut buffers.indices,
                "optica_lens_flare_indices",
                cells * CELL_INDEX_BYTES,
                BufferUsages::STORAGE | BufferUsages::INDEX,
            ),
        ] {
            if buffer.as_ref().is_none_or(|b| b.size() < size) {
                buffers.traced = None;
                *buffer = Some(render_device.create_buffer(&BufferDescriptor {
                    label: Some(label),
                    size,
                    usage,
                    mapped_at_creation: false,
                }));
            }
        }
        // The depth is read when occlusion is on and the view's depth can
        // be bound (`make_depth_readable` asks for it); otherwise, and until
        // the occlusion pipeline is compiled, every light is fully visible.
        let readable_depth = depth.filter(|d| {
            params.occlusion_radius_px > 0.0
                && params.lights > 0
                && d.texture.usage().contains(TextureUsages::TEXTURE_BINDING)
        });
        let multisampled = msaa.samples() > 1;
        let occlusion_layout = shared.occlusion_layouts[usize::from(multisampled)].clone();
        let occlusion_pipeline = readable_depth.map(|_| {
            *shared.occlusion[usize::from(multisampled)].get_or_insert_with(|| {
                pipeline_cache.queue_compute_pipeline(ComputePipelineDescriptor {
                    label: Some("optica_lens_flare_occlusion".into()),
                    layout: vec![occlusion_layout.clone()],
                    immediate_size: 0,
                    shader: shared.shaders.occlusion.clone(),
                    shader_defs: if multisampled {
                        vec!["MULTISAMPLED".into()]
                    } else {
                        vec![]
                    },
                    entry_point: Some("occlusion".into()),
                    zero_initialize_workgroup_memory: false,
                })
            })
        });
        let occlusion_ready =
            occlusion_pipeline.is_some_and(|id| pipeline_cache.get_compute_pipeline(id).is_some());
        // Each light's visibility. Its history holds while the pass ran
        // last frame for the same lights.
        let light_bytes = u64::from(params.lights.max(1)) * 4 * u64::from(1 + params.jitter_cycle);
        let fresh = buffers
            .visibility
            .as_ref()
            .is_none_or(|b| b.size() < light_bytes);
        if fresh {
            buffers.visibility = Some(render_device.create_buffer(&BufferDescriptor {
                label: Some("optica_lens_flare_visibility"),
                size: light_bytes,
                usage: BufferUsages::STORAGE | BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        params.reset_history = u32::from(
            fresh
                || !buffers.history_holds
                || buffers.lights != draws.light_entities
                || buffers.jitter_cycle != params.jitter_cycle,
        );
        buffers.jitter_cycle = params.jitter_cycle;
        buffers.history_holds = occlusion_ready;
        buffers.lights.clone_from(&draws.light_entities);
        let Some(visibility) = buffers.visibility.clone() else {
            continue;
        };
        if !occlusion_ready {
            let ones = vec![1f32; params.lights.max(1) as usize];
            render_queue.write_buffer(&visibility, 0, &f32_bytes(&ones));
        }
        buffers.uniform.set(params);
        buffers.uniform.write_buffer(&render_device, &render_queue);
        buffers.probes.get_mut().clone_from(&draws.lights);
        if buffers.probes.get().is_empty() {
            buffers.probes.get_mut().push(LightProbe::default());
        }
        buffers.probes.write_buffer(&render_device, &render_queue);
        buffers.surfaces.get_mut().clone_from(&draws.surfaces);
        buffers.surfaces.write_buffer(&render_device, &render_queue);
        buffers.jobs.get_mut().clone_from(&draws.jobs);
        buffers.jobs.write_buffer(&render_device, &render_queue);
        let (
            Some(u),
            Some(s),
            Some(j),
            Some(probes),
            Some(ray_buffer),
            Some(cell_colors),
            Some(indices),
        ) = (
            buffers.uniform.binding(),
            buffers.surfaces.binding(),
            buffers.jobs.binding(),
            buffers.probes.binding(),
            buffers.rays.as_ref(),
            buffers.cell_colors.as_ref(),
            buffers.indices.as_ref(),
        )
        else {
            continue;
        };
        let trace_group = render_device.create_bind_group(
            "optica_lens_flare_trace",
            &pipeline_cache.get_bind_group_layout(&shared.trace_layout),
            &BindGroupEntries::sequential((
                u.clone(),
                s,
                j.clone(),
                ray_buffer.as_entire_binding(),
            )),
        );
        let cells_group = render_device.create_bind_group(
            "optica_lens_flare_cells",
            &pipeline_cache.get_bind_group_layout(&shared.cells_layout),
            &BindGroupEntries::sequential((
                u.clone(),
                j,
                ray_buffer.as_entire_binding(),
                visibility.as_entire_binding(),
                cell_colors.as_entire_binding(),
                indices.as_entire_binding(),
            )),
        );
        let draw_group = render_device.create_bind_group(
            "optica_lens_flare_draw",
            &pipeline_cache.get_bind_group_layout(&shared.draw_layout),
            &BindGroupEntries::sequential((
                u.clone(),
                cell_colors.as_entire_binding(),
                ray_buffer.as_entire_binding(),
                visibility.as_entire_binding(),
                probes.clone(),
                ringing_view,
                burst_view,
            )),
        );
        let occlusion = match (readable_depth, occlusion_pipeline) {
            (Some(depth), Some(pipeline)) if occlusion_ready => {
                let group = render_device.create_bind_group(
                    "optica_lens_flare_occlusion",
                    &pipeline_cache.get_bind_group_layout(&occlusion_layout),
                    &BindGroupEntries::sequential((
                        u,
                        probes,
                        depth.view(),
                        visibility.as_entire_binding(),
                    )),
                );
                Some((group, pipeline))
            }
            _ => None,
        };
        // Reduced-resolution ghosts: their target, made again only when
        // the view's size or the divisor changes; and the large ghosts'
        // target at half that resolution, when there are any.
        let view_size = view.viewport.zw().max(UVec2::ONE);
        let ghost_size = view_size.map(|side| side.div_ceil(divisor));
        let mut upsampled_into = |target: &mut Option<GhostTarget>, size: UVec2, to| {
            let kept = target.take().filter(|kept| kept.size == size);
            let kept = kept.unwrap_or_else(|| GhostTarget::new(&render_device, size));
            let texture_view = kept.view.clone();
            *target = Some(kept);
            let layout = shared.upsample_layout.clone();
            let pipeline = *shared.upsamples.entry(to).or_insert_with(|| {
                additive_pipeline(
                    &pipeline_cache,
                    layout,
                    to,
                    "optica_lens_flare_upsample",
                    fullscreen.to_vertex_state(),
                    (shared.shaders.upsample.clone(), "upsample".into(), vec![]),
                )
            });
            let group = render_device.create_bind_group(
                "optica_lens_flare_upsample",
                &pipeline_cache.get_bind_group_layout(&shared.upsample_layout),
                &BindGroupEntries::sequential((&texture_view, &shared.upsample_sampler)),
            );
            (texture_view, group, pipeline)
        };
        let reduced =
            (divisor > 1).then(|| upsampled_into(&mut buffers.reduced, ghost_size, format));
        if divisor == 1 {
            buffers.reduced = None;
        }
        // The cells before `fine_cells` are added up at the ghosts'
        // resolution, the rest (the large ghosts') at half of it.
        let fine_cells = draws
            .jobs
            .get(draws.coarse_from)
            .map_or(params.cells, GridJob::cell_start)
            .min(params.cells);
        let ghost_format = if divisor > 1 { GHOST_FORMAT } else { format };
        let coarse = (fine_cells < params.cells).then(|| {
            let size = ghost_size.map(|side| side.div_ceil(2));
            upsampled_into(&mut buffers.coarse, size, ghost_format)
        });
        if coarse.is_none() {
            buffers.coarse = None;
        }
        // Trace only when what the rays depend on changed, or they have
        // not been traced into this buffer yet (the passes run only once
        // every pipeline is compiled).
        let key = TraceKey {
            jobs: draws.jobs[..params.jobs as usize].to_vec(),
            surfaces: draws.surfaces.clone(),
            params: params.trace_inputs(),
        };
        let retrace = buffers.traced.as_ref() != Some(&key);
        let ready = [trace, fill, cells_pipeline]
            .into_iter()
            .all(|id| pipeline_cache.get_compute_pipeline(id).is_some())
            && [
                Some(draw),
                reduced.as_ref().map(|r| r.2),
                coarse.as_ref().map(|c| c.2),
                coarse.as_ref().map(|_| coarse_draw),
            ]
            .into_iter()
            .flatten()
            .all(|id| pipeline_cache.get_render_pipeline(id).is_some());
        if !ready {
            // The passes wait for every pipeline as this system saw them
            // (the cache may finish one before the passes run), so that
            // the rays traced are the ones `traced` records.
            commands.entity(entity).remove::<FlareBinding>();
            if let Some(new) = created {
                commands.entity(entity).insert(new);
            }
            continue;
        }
        buffers.traced = Some(key);
        commands.entity(entity).insert(FlareBinding {
            retrace,
            reduced,
            coarse: coarse.map(|(view, group, upsample)| (view, group, upsample, coarse_draw)),
            fine_cells,
            trace_group,
            cells_group,
            draw_group,
            trace,
            fill,
            cells: cells_pipeline,
            draw,
            starburst: (params.starburst_scale > 0.0 && params.starburst_half_ndc > 0.0)
                .then_some(starburst),
            occlusion,
            threads: params.threads,
            rays: params.rays,
            cell_count: params.cells,
            spans: params.spans,
            indices: indices.clone(),
            lights: params.lights,
        });
        if let Some(new) = created {
            commands.entity(entity).insert(new);
        }
    }
}

/// Traces the grids, then draws their cells into the view target.
fn flare_passes(
    view: ViewQuery<(&ViewTarget, &FlareBinding)>,
    pipeline_cache: Res<PipelineCache>,
    mut ctx: RenderContext,
) {
    let (target, binding) = view.into_inner();
    let (Some(trace), Some(fill), Some(cells), Some(draw)) = (
        pipeline_cache.get_compute_pipeline(binding.trace),
        pipeline_cache.get_compute_pipeline(binding.fill),
        pipeline_cache.get_compute_pipeline(binding.cells),
        pipeline_cache.get_render_pipeline(binding.draw),
    ) else {
        return;
    };
    let starburst = binding
        .starburst
        .and_then(|id| pipeline_cache.get_render_pipeline(id));
    let reduced = match &binding.reduced {
        Some((texture, group, id)) => match pipeline_cache.get_render_pipeline(*id) {
            Some(pipeline) => Some((texture, group, pipeline)),
            None => return,
        },
        None => None,
    };
    let coarse = match &binding.coarse {
        Some((texture, group, upsample, draw)) => match (
            pipeline_cache.get_render_pipeline(*upsample),
            pipeline_cache.get_render_pipeline(*draw),
        ) {
            (Some(upsample), Some(draw)) => Some((texture, group, upsample, draw)),
            _ => return,
        },
        None => None,
    };
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let occlusion = binding.occlusion.as_ref().and_then(|(group, id)| {
        pipeline_cache
            .get_compute_pipeline(*id)
            .map(|pipeline| (group, pipeline))
    });
    let span = diagnostics.time_span(ctx.command_encoder(), "optica/flare");
    let encoder = ctx.command_encoder();
    if let Some((group, pipeline)) = occlusion {
        let groups = (binding.lights, 1);
        compute_pass(encoder, &diagnostics, "occlusion", pipeline, group, groups);
    }
    if binding.retrace {
        let groups = groups_for(binding.threads);
        compute_pass(
            encoder,
            &diagnostics,
            "trace",
            trace,
            &binding.trace_group,
            groups,
        );
        let groups = groups_for(binding.rays);
        compute_pass(
            encoder,
            &diagnostics,
            "fill",
            fill,
            &binding.trace_group,
            groups,
        );
    }
    let groups = groups_for(binding.spans);
    compute_pass(
        encoder,
        &diagnostics,
        "cells",
        cells,
        &binding.cells_group,
        groups,
    );
    // The ghosts: onto the view, or into their reduced-resolution target
    // (cleared), which is then scaled up onto the view with the
    // starburst.
    let view_attachment = target.get_unsampled_color_attachment();
    let ghost_attachment = match &reduced {
        Some((texture, ..)) => RenderPassColorAttachment {
            view: texture,
            depth_slice: None,
            resolve_target: None,
            ops: Operations {
                load: LoadOp::Clear(Default::default()),
                store: StoreOp::Store,
            },
        },
        None => view_attachment.clone(),
    };
    // The large ghosts first, into their own target at half the
    // resolution, which the ghosts' pass then scales up into its own.
    if let Some((texture, _, _, coarse_draw)) = &coarse {
        let mut pass = ctx
            .command_encoder()
            .begin_render_pass(&RenderPassDescriptor {
                label: Some("optica_lens_flare_coarse"),
                color_attachments: &[Some(RenderPassColorAttachment {
                    view: texture,
                    depth_slice: None,
                    resolve_target: None,
                    ops: Operations {
                        load: LoadOp::Clear(Default::default()),
                        store: StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
        let pass_span = diagnostics.pass_span(&mut pass, "coarse");
        pass.set_pipeline(coarse_draw);
        pass.set_bind_group(0, &binding.draw_group, &[]);
        pass.set_index_buffer((*binding.indices).slice(..), IndexFormat::Uint32);
        pass.draw_indexed(6 * binding.fine_cells..6 * binding.cell_count, 0, 0..1);
        pass_span.end(&mut pass);
    }
    {
        let mut pass = ctx
            .command_encoder()
            .begin_render_pass(&RenderPassDescriptor {
                label: Some("optica_lens_flare_draw"),
                color_attachments: &[Some(ghost_attachment)],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
        let pass_span = diagnostics.pass_span(&mut pass, "draw");
        pass.set_pipeline(draw);
        pass.set_bind_group(0, &binding.draw_group, &[]);
        pass.set_index_buffer((*binding.indices).slice(..), IndexFormat::Uint32);
        pass.draw_indexed(0..6 * binding.fine_cells, 0, 0..1);
        if let Some((_, group, upsample, _)) = coarse {
            pass.set_pipeline(upsample);
            pass.set_bind_group(0, group, &[]);
            pass.draw(0..3, 0..1);
            pass.set_bind_group(0, &binding.draw_group, &[]);
        }
        if let (None, Some(starburst)) = (&reduced, starburst) {
            pass.set_pipeline(starburst);
            pass.draw(0..6, 0..binding.lights);
        }
        pass_span.end(&mut pass);
    }
    if let Some((_, group, upsample)) = reduced {
        let mut pass = ctx
            .command_encoder()
            .begin_render_pass(&RenderPassDescriptor {
                label: Some("optica_lens_flare_composite"),
                color_attachments: &[Some(view_attachment)],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
        let pass_span = diagnostics.pass_span(&mut pass, "composite");
        pass.set_pipeline(upsample);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..3, 0..1);
        if let Some(starburst) = starburst {
            pass.set_pipeline(starburst);
            pass.set_bind_group(0, &binding.draw_group, &[]);
            pass.draw(0..6, 0..binding.lights);
        }
        pass_span.end(&mut pass);
    }
    span.end(ctx.command_encoder());
}

/// Dispatches `groups` (x, y) workgroups of `pipeline` with `group` in a
/// compute pass of its own, timed as `optica/flare/{span}`.
fn compute_pass(
    encoder: &mut CommandEncoder,
    diagnostics: &impl RecordDiagnostics,
    span: &'static str,
    pipeline: &ComputePipeline,
    group: &BindGroup,
    (x, y): (u32, u32),
) {
    let label = format!("optica_lens_flare_{span}");
    let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
        label: Some(&label),
        timestamp_writes: None,
    });
    let pass_span = diagnostics.pass_span(&mut pass, span);
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, group, &[]);
    pass.dispatch_workgroups(x, y, 1);
    pass_span.end(&mut pass);
}

/// Workgroups of 64 for `threads` threads, as (x, y) within the 65535 a
/// dimension allows (the shaders rebuild the index from both).
fn groups_for(threads: u32) -> (u32, u32) {
    let groups = threads.div_ceil(64);
    (groups.min(65535), groups.div_ceil(65535))
}

/// The bytes of `values` as the GPU reads them (little-endian `f32`s).
fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}
