//! The spectacles' buffers (`PrepareResources`): each eye camera's resolve
//! parameters, each lens camera's lens (rewritten only when it was
//! retraced) and each mirror environment camera's reflected rays; and the
//! bind groups that do not read the view's post-process textures
//! (`PrepareBindGroups`): the resolve of the clones' colours and both
//! marches.

use bevy::prelude::*;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::{
    BindGroupEntries, Buffer, BufferDescriptor, BufferInitDescriptor, BufferUsages, PipelineCache,
    ShaderType, StorageBuffer, TextureUsages, UniformBuffer,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::storage::GpuShaderBuffer;
use bevy::render::texture::GpuImage;
use bevy::render::view::{ExtractedView, ViewDepthTexture};

use super::pipelines::SpectaclesPipelines;
use super::{
    MirrorMarchBinding, RefractionMarchBinding, RefractionPipelineIds, ResolveFullBinding,
    ResolvePipelineIds, Variant,
};
use crate::clones::CloneResolve;
use crate::mirror::MirrorEnvironment;
use crate::refraction::{LensRefraction, LensVertex};

/// Relative depth difference a reprojected clone's surface point may have
/// from the sharp view's surface and still count as visible there: 1 %,
/// well above f16's 0.1 % (the atlas's precision) and the change of depth
/// across a pixel of a surface seen at up to ~80° from face-on at 1 px
/// per 0.1° (the offset's rounding to a pixel), well below the gap
/// between an object and what lies behind it in ordinary scenes.
const REPROJECTION_DEPTH_TOLERANCE: f32 = 0.01;

/// Geometric steps of an exit ray's march through the depth (2 cm to 2 km,
/// a factor of 1.2 apart), before 16 bisections.
pub const MARCH_STEPS: u32 = 64;

/// The lens's dark edge where its rays do not get through (linear).
const EDGE: f32 = 0.02;

/// The resolve's numbers (`ResolveParams` in `resolve.wgsl`).
#[derive(Clone, Copy, Debug, Default, ShaderType)]
pub(super) struct ResolveParams {
    clones: u32,
    tile_cols: u32,
    tile_rows: u32,
    depth_tolerance: f32,
    background: Vec4,
}

/// `LensParams` in `lens_refraction.wgsl`.
#[derive(Clone, Copy, Debug, Default, ShaderType)]
pub(super) struct LensParams {
    clip_from_view: Mat4,
    near: f32,
    vertices: u32,
    steps: u32,
    edge: f32,
    /// 3 when the lens parts the colours (a march per colour), else 1 (the
    /// green march stands for all three).
    colours: u32,
}

impl LensParams {
    fn of(view: &ExtractedView, vertices: usize, colours: u32) -> Self {
        Self {
            clip_from_view: view.clip_from_view,
            near: view.clip_from_view.w_axis.z,
            vertices: vertices as u32,
            steps: MARCH_STEPS,
            edge: EDGE,
            colours,
        }
    }
}

/// An eye camera's resolve parameters for this frame.
#[derive(Component)]
pub(super) struct ResolveBuffers {
    pub(super) atlas: AssetId<Image>,
    pub(super) params: UniformBuffer<ResolveParams>,
}

/// A view's lens on the GPU, kept between frames; the vertices are
/// rewritten only when the lens was retraced.
#[derive(Component)]
pub(super) struct RefractionBuffers {
    pub(super) params: UniformBuffer<LensParams>,
    pub(super) vertices: StorageBuffer<Vec<LensVertex>>,
    pub(super) coords: Buffer,
    pub(super) indices: Buffer,
    pub(super) index_count: u32,
    /// The trace the buffers hold (its vertices, compared to see a retrace).
    traced: Vec<LensVertex>,
    /// Marches per vertex (`LensParams::colours`).
    colours: u32,
}

impl RefractionBuffers {
    /// Threads of the march: a vertex and colour each.
    pub(super) fn march_threads(&self) -> u32 {
        self.colours * self.traced.len() as u32
    }
}

/// An environment camera's march inputs, kept between frames; the
/// vertices are rewritten only when the mirror was retraced.
#[derive(Component)]
pub(super) struct MirrorMarch {
    params: UniformBuffer<LensParams>,
    vertices: StorageBuffer<Vec<LensVertex>>,
    pub(super) count: u32,
    traced: Vec<LensVertex>,
}

/// Every view's buffers.
pub(super) fn prepare_spectacles_resources(
    mut commands: Commands,
    mut resolves: Query<(Entity, &CloneResolve, Option<&mut ResolveBuffers>)>,
    mut lenses: Query<(
        Entity,
        &ExtractedView,
        &LensRefraction,
        Option<&mut RefractionBuffers>,
    )>,
    mut mirrors: Query<(
        Entity,
        &ExtractedView,
        &MirrorEnvironment,
        Option<&mut MirrorMarch>,
    )>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
) {
    for (entity, resolve, buffers) in &mut resolves {
        let params = ResolveParams {
            clones: resolve.clones,
            tile_cols: resolve.tiles.x,
            tile_rows: resolve.tiles.y,
            depth_tolerance: REPROJECTION_DEPTH_TOLERANCE,
            background: resolve.background,
        };
        // The view's uniform is kept: rewritten in place each frame, not
        // made anew.
        match buffers {
            Some(mut b) => {
                b.atlas = resolve.atlas;
                b.params.set(params);
                b.params.write_buffer(&device, &queue);
            }
            None => {
                let mut uniform = UniformBuffer::from(params);
                uniform.write_buffer(&device, &queue);
                commands.entity(entity).insert(ResolveBuffers {
                    atlas: resolve.atlas,
                    params: uniform,
                });
            }
        }
    }
    for (entity, view, lens, buffers) in &mut lenses {
        if lens.vertices.is_empty() || lens.indices.is_empty() {
            continue;
        }
        let params = LensParams::of(view, lens.vertices.len(), if lens.chromatic { 3 } else { 1 });
        match buffers {
            Some(mut b) if b.traced == lens.vertices => {
                b.params.set(params);
                b.params.write_buffer(&device, &queue);
            }
            _ => {
                commands
                    .entity(entity)
                    .insert(lens_buffers(lens, params, &device, &queue));
            }
        }
    }
    for (entity, view, environment, march) in &mut mirrors {
        if environment.vertices.is_empty() {
            continue;
        }
        let params = LensParams::of(view, environment.vertices.len(), 1);
        match march {
            Some(mut m) if m.traced == environment.vertices => {
                m.params.set(params);
                m.params.write_buffer(&device, &queue);
            }
            _ => {
                let mut uniform = UniformBuffer::from(params);
                uniform.write_buffer(&device, &queue);
                let mut vertices = StorageBuffer::from(environment.vertices.clone());
                vertices.write_buffer(&device, &queue);
                commands.entity(entity).insert(MirrorMarch {
                    params: uniform,
                    vertices,
                    count: environment.vertices.len() as u32,
                    traced: environment.vertices.clone(),
                });
            }
        }
    }
}

/// A retraced lens's buffers.
fn lens_buffers(
    lens: &LensRefraction,
    params: LensParams,
    device: &RenderDevice,
    queue: &RenderQueue,
) -> RefractionBuffers {
    let mut vertices = StorageBuffer::from(lens.vertices.clone());
    vertices.write_buffer(device, queue);
    let coords = device.create_buffer(&BufferDescriptor {
        label: Some("optica_spectacles_lens_coords"),
        // A coordinate per vertex and colour (green, red, blue).
        size: 3 * 16 * lens.vertices.len() as u64,
        usage: BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let indices = device.create_buffer_with_data(&BufferInitDescriptor {
        label: Some("optica_spectacles_lens_indices"),
        contents: &lens
            .indices
            .iter()
            .flat_map(|i| i.to_le_bytes())
            .collect::<Vec<u8>>(),
        usage: BufferUsages::INDEX,
    });
    let mut p = UniformBuffer::from(params);
    p.write_buffer(device, queue);
    RefractionBuffers {
        params: p,
        vertices,
        coords,
        indices,
        index_count: lens.indices.len() as u32,
        traced: lens.vertices.clone(),
        colours: params.colours,
    }
}

/// The depth, once it is bindable (a frame after the plugin asks for it).
fn bindable(depth: Option<&ViewDepthTexture>) -> Option<&ViewDepthTexture> {
    depth.filter(|d| d.texture.usage().contains(TextureUsages::TEXTURE_BINDING))
}

/// The bind groups that do not read the view's post-process textures: the
/// resolve of the clones' own colours, the lens's march and a mirror's.
#[allow(clippy::type_complexity)]
pub(super) fn prepare_spectacles_bind_groups(
    mut commands: Commands,
    resolves: Query<(Entity, &ResolvePipelineIds, &ResolveBuffers)>,
    lenses: Query<(
        Entity,
        &RefractionPipelineIds,
        &RefractionBuffers,
        Option<&ViewDepthTexture>,
    )>,
    mirrors: Query<(
        Entity,
        &MirrorEnvironment,
        &MirrorMarch,
        Option<&ViewDepthTexture>,
    )>,
    pipelines: Res<SpectaclesPipelines>,
    pipeline_cache: Res<PipelineCache>,
    images: Res<RenderAssets<GpuImage>>,
    shader_buffers: Res<RenderAssets<GpuShaderBuffer>>,
    device: Res<RenderDevice>,
) {
    let layout = |l| pipeline_cache.get_bind_group_layout(l);
    for (entity, ids, buffers) in &resolves {
        let (Variant::Full, Some(atlas), Some(params)) =
            (ids.variant, images.get(buffers.atlas), buffers.params.binding())
        else {
            commands.entity(entity).remove::<ResolveFullBinding>();
            continue;
        };
        let group = device.create_bind_group(
            "optica_spectacles_resolve",
            &layout(pipelines.resolve_layout(Variant::Full)),
            &BindGroupEntries::sequential((&atlas.texture_view, &pipelines.linear, params)),
        );
        commands.entity(entity).insert(ResolveFullBinding(group));
    }
    for (entity, ids, buffers, depth) in &lenses {
        let (Some(depth), Some(params), Some(vertices)) = (
            bindable(depth),
            buffers.params.binding(),
            buffers.vertices.binding(),
        ) else {
            commands.entity(entity).remove::<RefractionMarchBinding>();
            continue;
        };
        let group = device.create_bind_group(
            "optica_spectacles_lens_march",
            &layout(pipelines.march_layout(ids.multisampled)),
            &BindGroupEntries::sequential((
                params,
                vertices,
                buffers.coords.as_entire_binding(),
                depth.view(),
            )),
        );
        commands.entity(entity).insert(RefractionMarchBinding(group));
    }
    for (entity, environment, march, depth) in &mirrors {
        let (Some(depth), Some(coords), Some(params), Some(vertices)) = (
            depth,
            shader_buffers.get(&environment.coords),
            march.params.binding(),
            march.vertices.binding(),
        ) else {
            commands.entity(entity).remove::<MirrorMarchBinding>();
            continue;
        };
        let group = device.create_bind_group(
            "optica_spectacles_mirror_march",
            &layout(pipelines.march_layout(false)),
            &BindGroupEntries::sequential((
                params,
                vertices,
                coords.buffer.as_entire_binding(),
                depth.view(),
            )),
        );
        commands.entity(entity).insert(MirrorMarchBinding(group));
    }
}
