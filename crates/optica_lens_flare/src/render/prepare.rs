//! Each flare view's GPU resources and bind groups for the frame, in two
//! systems as Bevy's own passes do: [`prepare_flare_resources`] grows and
//! writes its buffers (kept between frames) and its reduced-resolution
//! targets; [`prepare_flare_bind_groups`] binds them, as a
//! [`FlareBinding`](super::FlareBinding). Views whose pipelines are not
//! compiled yet get none and run no pass.

use bevy::diagnostic::FrameCount;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy::render::camera::TemporalJitter;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::{
    BindGroup, BindGroupEntries, Buffer, BufferDescriptor, BufferId, BufferUsages,
    CachedComputePipelineId, CachedRenderPipelineId, Extent3d, PipelineCache, StorageBuffer,
    Texture, TextureDescriptor, TextureDimension, TextureUsages, TextureView,
    TextureViewDescriptor, TextureViewId, UniformBuffer,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::texture::{FallbackImage, GpuImage};
use bevy::render::view::{ExtractedView, Msaa, ViewDepthTexture};

use super::pipelines::{FlarePipelineIds, FlarePipelines};
use super::{CELL_COLOR_BYTES, CELL_INDEX_BYTES, FlareBinding, GHOST_FORMAT, RAY_BYTES};
use crate::draws::{FlareDraws, FlareParams, GridJob, LightProbe};
use crate::gpu_lens::GpuSurface;

/// One view's GPU buffers, kept between frames: rewritten in place, and
/// reallocated only when a frame needs more room than they have.
#[derive(Component, Default)]
pub(super) struct FlareBuffers {
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
    /// The bind groups and what they were made from.
    groups: Option<(GroupSources, BindGroups)>,
    /// What the rays in `rays` were traced from; while a frame's grids,
    /// lens and settings are the same (a still camera and lights), they
    /// are not traced again.
    traced: Option<TraceKey>,
    /// The raw visibilities per light `visibility` holds (0: no TAA).
    jitter_cycle: u32,
    /// This frame's inputs to the bind groups, from the resources system.
    frame: Option<FrameInputs>,
}

/// A texture the ghosts are added up in before it is scaled up.
struct GhostTarget {
    size: UVec2,
    /// Kept with its view, which is what the passes use.
    _texture: Texture,
    view: TextureView,
    /// The bind group that reads it to scale it up, once made.
    upsample_group: Option<BindGroup>,
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
            upsample_group: None,
        }
    }
}

/// The buffers and texture views a view's bind groups bind.
#[derive(PartialEq)]
struct GroupSources {
    buffers: [Option<BufferId>; 8],
    views: [TextureViewId; 2],
    /// The depth the occlusion pass reads, when it runs.
    depth: Option<TextureViewId>,
}

/// A view's bind groups, kept while what they bind is the same.
#[derive(Clone)]
struct BindGroups {
    trace: BindGroup,
    cells: BindGroup,
    draw: BindGroup,
    occlusion: Option<BindGroup>,
}

/// Everything the trace's result depends on: the grids, the lens at each
/// wavelength and what the trace reads of the uniform (not, say, the
/// ringing's texture arriving, which changes only the draw).
#[derive(PartialEq)]
struct TraceKey {
    jobs: Vec<GridJob>,
    surfaces: Vec<GpuSurface>,
    params: [u32; 10],
}

/// Frames in Bevy's TAA jitter sequence (eight Halton (2, 3) offsets, the
/// one of frame n at n mod 8): the occlusion pass averages its last eight
/// raw visibilities, one per offset.
const JITTER_CYCLE: u32 = 8;

/// What the resources system worked out for a view this frame, for the
/// bind-group system; absent when the view runs no pass.
struct FrameInputs {
    params: FlareParams,
    /// The cells added up at the ghosts' resolution (the rest are the
    /// large ghosts').
    fine_cells: u32,
    /// The diffraction textures (the fallback until they arrive).
    ringing_view: TextureView,
    burst_view: TextureView,
    /// The depth the occlusion pass reads, its pipeline, and whether the
    /// depth is multisampled; absent when the pass does not run.
    occlusion: Option<(TextureView, CachedComputePipelineId, bool)>,
}

/// A view with flare draws: its buffers once made, its depth and MSAA.
type FlareView = (
    Entity,
    &'static ExtractedView,
    &'static FlareDraws,
    Option<&'static FlarePipelineIds>,
    Option<&'static mut FlareBuffers>,
    Option<&'static ViewDepthTexture>,
    &'static Msaa,
    Option<&'static TemporalJitter>,
);

/// The devices and assets the resources system reads.
#[derive(SystemParam)]
pub(super) struct ResourceInputs<'w> {
    pipeline_cache: Res<'w, PipelineCache>,
    render_device: Res<'w, RenderDevice>,
    render_queue: Res<'w, RenderQueue>,
    images: Res<'w, RenderAssets<GpuImage>>,
    fallback: Res<'w, FallbackImage>,
    frame: Res<'w, FrameCount>,
}

/// Per flare view, in `PrepareResources`: its buffers grown and written,
/// its reduced-resolution targets, and the [`FrameInputs`] the bind-group
/// system binds.
pub(super) fn prepare_flare_resources(
    mut commands: Commands,
    mut views: Query<FlareView>,
    inputs: ResourceInputs,
) {
    for (entity, view, draws, ids, buffers, depth, msaa, jitter) in &mut views {
        let mut created = None;
        let buffers = match buffers {
            Some(b) => b.into_inner(),
            None => created.insert(FlareBuffers::default()),
        };
        buffers.frame = ids.and_then(|ids| {
            let view = ViewInputs {
                view,
                draws,
                ids,
                depth,
                multisampled: msaa.samples() > 1,
                jitter,
            };
            prepare_view(buffers, &view, &inputs)
        });
        if let Some(new) = created {
            commands.entity(entity).insert(new);
        }
    }
}

/// What one view brings to [`prepare_view`].
struct ViewInputs<'a> {
    view: &'a ExtractedView,
    draws: &'a FlareDraws,
    ids: &'a FlarePipelineIds,
    depth: Option<&'a ViewDepthTexture>,
    multisampled: bool,
    jitter: Option<&'a TemporalJitter>,
}

/// The jitter's move of a point's image this frame (with a perspective
/// projection, the same for every point), for the ghosts to follow it.
fn jitter_params(
    params: &mut FlareParams,
    jitter: &TemporalJitter,
    view: &ExtractedView,
    frame: u32,
) {
    let clip_from_view = view.clip_from_view;
    let mut jittered = clip_from_view;
    jitter.jitter_projection(&mut jittered, view.viewport.zw().as_vec2());
    let ndc = |m: Mat4| {
        let c = m * Vec4::new(0.0, 0.0, -1.0, 1.0);
        c.xy() / c.w
    };
    params.jitter_ndc = ndc(jittered) - ndc(clip_from_view);
    params.jitter_cycle = JITTER_CYCLE;
    params.jitter_slot = frame % JITTER_CYCLE;
}

/// Leaves out the grids past what one storage binding holds; `None` when
/// not even the first fits.
fn fit_to_device(
    params: &mut FlareParams,
    draws: &FlareDraws,
    buffers: &mut FlareBuffers,
    render_device: &RenderDevice,
) -> Option<()> {
    // More rays than one storage binding holds (128 MiB on many devices:
    // 2.8 M rays, e.g. 83 ghosts × 3 wavelengths at 128²): the grids past
    // it (the dimmest of the last light) are left out, with one warning,
    // instead of failing to bind.
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
        let last = draws.jobs[..kept].last()?;
        params.jobs = kept as u32;
        params.rays = last.ray_end();
        params.threads = last.thread_end();
        params.cells = last.cell_end();
        params.spans = last.span_end();
    }
    Some(())
}

/// The rays', cell colours' and indices' buffers, made again (and the
/// rays marked for retracing) when they are too small.
fn grow_ray_buffers(
    buffers: &mut FlareBuffers,
    params: &FlareParams,
    render_device: &RenderDevice,
) {
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
}

/// One view's resources; `None` when it has nothing to draw.
fn prepare_view(
    buffers: &mut FlareBuffers,
    view: &ViewInputs,
    inputs: &ResourceInputs,
) -> Option<FrameInputs> {
    let ResourceInputs {
        pipeline_cache,
        render_device,
        render_queue,
        images,
        fallback,
        frame,
    } = inputs;
    let draws = view.draws;
    let mut params = draws.params;
    if let Some(jitter) = view.jitter {
        jitter_params(&mut params, jitter, view.view, frame.0);
    }
    if params.jobs == 0 || params.rays == 0 {
        return None;
    }
    // The diffraction textures, once uploaded; until then (and when off)
    // the fallback, and the pass leaves them out.
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
    let ringing_view = ringing.map_or(fallback_view, |i| &i.texture_view).clone();
    let burst_view = burst.map_or(fallback_view, |i| &i.texture_view).clone();
    fit_to_device(&mut params, draws, buffers, render_device)?;
    grow_ray_buffers(buffers, &params, render_device);
    // The depth is read when occlusion is on and the view's depth can be
    // bound (`make_depth_readable` asks for it); otherwise, and until the
    // occlusion pipeline is compiled, every light is fully visible.
    let occlusion = view
        .depth
        .filter(|d| {
            params.occlusion_radius_px > 0.0
                && params.lights > 0
                && d.texture.usage().contains(TextureUsages::TEXTURE_BINDING)
        })
        .zip(view.ids.occlusion)
        .filter(|(_, id)| pipeline_cache.get_compute_pipeline(*id).is_some())
        .map(|(depth, id)| (depth.view().clone(), id, view.multisampled));
    // Each light's visibility. Its history holds while the pass ran last
    // frame for the same lights.
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
    buffers.history_holds = occlusion.is_some();
    buffers.lights.clone_from(&draws.light_entities);
    if occlusion.is_none()
        && let Some(visibility) = &buffers.visibility
    {
        let ones = vec![1f32; params.lights.max(1) as usize];
        render_queue.write_buffer(visibility, 0, &f32_bytes(&ones));
    }
    buffers.uniform.set(params);
    buffers.uniform.write_buffer(render_device, render_queue);
    buffers.probes.get_mut().clone_from(&draws.lights);
    if buffers.probes.get().is_empty() {
        buffers.probes.get_mut().push(LightProbe::default());
    }
    buffers.probes.write_buffer(render_device, render_queue);
    buffers.surfaces.get_mut().clone_from(&draws.surfaces);
    buffers.surfaces.write_buffer(render_device, render_queue);
    buffers.jobs.get_mut().clone_from(&draws.jobs);
    buffers.jobs.write_buffer(render_device, render_queue);
    // Reduced-resolution ghosts: their target, made again only when the
    // view's size or the divisor changes; and the large ghosts' target at
    // half that resolution, when there are any. The cells before
    // `fine_cells` are added up at the ghosts' resolution, the rest at
    // half of it.
    let divisor = draws.ghost_divisor.max(1);
    let view_size = view.view.viewport.zw().max(UVec2::ONE);
    let ghost_size = view_size.map(|side| side.div_ceil(divisor));
    let fine_cells = draws
        .jobs
        .get(draws.coarse_from)
        .map_or(params.cells, GridJob::cell_start)
        .min(params.cells);
    let ids = view.ids;
    let reduced = (divisor > 1 && ids.upsample_view.is_some()).then_some(ghost_size);
    let coarse =
        (fine_cells < params.cells && ids.coarse.is_some() && ids.upsample_ghosts.is_some())
            .then(|| ghost_size.map(|side| side.div_ceil(2)));
    for (target, size) in [
        (&mut buffers.reduced, reduced),
        (&mut buffers.coarse, coarse),
    ] {
        *target = size.map(|size| match target.take() {
            Some(kept) if kept.size == size => kept,
            _ => GhostTarget::new(render_device, size),
        });
    }
    Some(FrameInputs {
        params,
        fine_cells,
        ringing_view,
        burst_view,
        occlusion,
    })
}

/// Per flare view, in `PrepareBindGroups`: its bind groups (kept while
/// what they bind is the same) and, once every pipeline it needs is
/// compiled, its [`FlareBinding`].
pub(super) fn prepare_flare_bind_groups(
    mut commands: Commands,
    mut views: Query<(
        Entity,
        &FlareDraws,
        Option<&FlarePipelineIds>,
        Option<&mut FlareBuffers>,
    )>,
    pipelines: Res<FlarePipelines>,
    pipeline_cache: Res<PipelineCache>,
    render_device: Res<RenderDevice>,
) {
    for (entity, draws, ids, buffers) in &mut views {
        let binding = ids.zip(buffers).and_then(|(ids, buffers)| {
            bind_view(
                buffers.into_inner(),
                draws,
                ids,
                &pipelines,
                &pipeline_cache,
                &render_device,
            )
        });
        match binding {
            Some(binding) => commands.entity(entity).insert(binding),
            None => commands.entity(entity).remove::<FlareBinding>(),
        };
    }
}

/// One view's binding; `None` until its resources and pipelines are ready.
fn bind_view(
    buffers: &mut FlareBuffers,
    draws: &FlareDraws,
    ids: &FlarePipelineIds,
    pipelines: &FlarePipelines,
    pipeline_cache: &PipelineCache,
    render_device: &RenderDevice,
) -> Option<FlareBinding> {
    let frame = buffers.frame.take()?;
    let params = frame.params;
    let ray_buffer = buffers.rays.as_ref()?;
    let cell_colors = buffers.cell_colors.as_ref()?;
    let indices = buffers.indices.as_ref()?;
    let visibility = buffers.visibility.as_ref()?;
    // The bind groups, made again only when a buffer or texture they bind
    // is new (grown, resized, or a texture arrived).
    let made_from = GroupSources {
        buffers: [
            buffers.uniform.buffer(),
            buffers.surfaces.buffer(),
            buffers.jobs.buffer(),
            buffers.probes.buffer(),
            Some(ray_buffer),
            Some(cell_colors),
            Some(indices),
            Some(visibility),
        ]
        .map(|b| b.map(Buffer::id)),
        views: [frame.ringing_view.id(), frame.burst_view.id()],
        depth: frame.occlusion.as_ref().map(|(depth, ..)| depth.id()),
    };
    let groups = match buffers.groups.take() {
        Some((kept_from, groups)) if kept_from == made_from => groups,
        _ => make_groups(buffers, &frame, pipelines, pipeline_cache, render_device)?,
    };
    buffers.groups = Some((made_from, groups.clone()));
    let occlusion = groups
        .occlusion
        .clone()
        .zip(frame.occlusion.map(|(_, id, _)| id));
    // The ghost targets' upsampling groups, made with their targets.
    let upsampled = |target: &mut Option<GhostTarget>, pipeline: Option<_>| {
        let target = target.as_mut()?;
        let group = target.upsample_group.get_or_insert_with(|| {
            render_device.create_bind_group(
                "optica_lens_flare_upsample",
                &pipeline_cache.get_bind_group_layout(&pipelines.upsample_layout),
                &BindGroupEntries::sequential((&target.view, &pipelines.upsample_sampler)),
            )
        });
        Some((target.view.clone(), group.clone(), pipeline?))
    };
    let reduced = upsampled(&mut buffers.reduced, ids.upsample_view);
    let coarse = upsampled(&mut buffers.coarse, ids.upsample_ghosts)
        .zip(ids.coarse)
        .map(|((view, group, upsample), draw)| (view, group, upsample, draw));
    // Trace only when what the rays depend on changed, or they have not
    // been traced into this buffer yet (the passes run only once every
    // pipeline is compiled).
    let key = TraceKey {
        jobs: draws.jobs[..params.jobs as usize].to_vec(),
        surfaces: draws.surfaces.clone(),
        params: params.trace_inputs(),
    };
    let retrace = buffers.traced.as_ref() != Some(&key);
    // The passes wait for every pipeline as this system saw them (the
    // cache may finish one before the passes run), so that the rays traced
    // are the ones `traced` records.
    let render_ids = [
        Some(ids.ghosts),
        reduced.as_ref().map(|r| r.2),
        coarse.as_ref().map(|c| c.2),
        coarse.as_ref().map(|c| c.3),
    ];
    if !pipelines_ready(pipeline_cache, ids, render_ids.into_iter().flatten()) {
        return None;
    }
    buffers.traced = Some(key);
    Some(FlareBinding {
        retrace,
        reduced,
        coarse,
        fine_cells: frame.fine_cells,
        trace_group: groups.trace,
        cells_group: groups.cells,
        draw_group: groups.draw,
        trace: ids.trace,
        fill: ids.fill,
        cells: ids.cells,
        draw: ids.ghosts,
        starburst: ids
            .starburst
            .filter(|_| params.starburst_scale > 0.0 && params.starburst_half_ndc > 0.0),
        occlusion,
        threads: params.threads,
        rays: params.rays,
        cell_count: params.cells,
        spans: params.spans,
        indices: indices.clone(),
        lights: params.lights,
    })
}

/// A view's bind groups over its buffers and this frame's textures.
fn make_groups(
    buffers: &FlareBuffers,
    frame: &FrameInputs,
    pipelines: &FlarePipelines,
    pipeline_cache: &PipelineCache,
    render_device: &RenderDevice,
) -> Option<BindGroups> {
    let u = buffers.uniform.binding()?;
    let s = buffers.surfaces.binding()?;
    let j = buffers.jobs.binding()?;
    let probes = buffers.probes.binding()?;
    let ray_buffer = buffers.rays.as_ref()?;
    let cell_colors = buffers.cell_colors.as_ref()?;
    let indices = buffers.indices.as_ref()?;
    let visibility = buffers.visibility.as_ref()?;
    let layout = |descriptor| pipeline_cache.get_bind_group_layout(descriptor);
    Some(BindGroups {
        trace: render_device.create_bind_group(
            "optica_lens_flare_trace",
            &layout(&pipelines.trace_layout),
            &BindGroupEntries::sequential((
                u.clone(),
                s,
                j.clone(),
                ray_buffer.as_entire_binding(),
            )),
        ),
        cells: render_device.create_bind_group(
            "optica_lens_flare_cells",
            &layout(&pipelines.cells_layout),
            &BindGroupEntries::sequential((
                u.clone(),
                j,
                ray_buffer.as_entire_binding(),
                cell_colors.as_entire_binding(),
                indices.as_entire_binding(),
            )),
        ),
        draw: render_device.create_bind_group(
            "optica_lens_flare_draw",
            &layout(&pipelines.draw_layout),
            &BindGroupEntries::sequential((
                u.clone(),
                cell_colors.as_entire_binding(),
                ray_buffer.as_entire_binding(),
                visibility.as_entire_binding(),
                probes.clone(),
                &frame.ringing_view,
                &frame.burst_view,
            )),
        ),
        occlusion: frame.occlusion.as_ref().map(|(depth, _, multisampled)| {
            render_device.create_bind_group(
                "optica_lens_flare_occlusion",
                &layout(&pipelines.occlusion_layouts[usize::from(*multisampled)]),
                &BindGroupEntries::sequential((u, probes, depth, visibility.as_entire_binding())),
            )
        }),
    })
}

/// Whether the compute pipelines and `render` pipelines of a view are
/// compiled.
fn pipelines_ready(
    cache: &PipelineCache,
    ids: &FlarePipelineIds,
    render: impl Iterator<Item = CachedRenderPipelineId>,
) -> bool {
    [ids.trace, ids.fill, ids.cells]
        .into_iter()
        .all(|id| cache.get_compute_pipeline(id).is_some())
        && render
            .into_iter()
            .all(|id| cache.get_render_pipeline(id).is_some())
}

/// The bytes of `values` as the GPU reads them (little-endian `f32`s).
fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}
