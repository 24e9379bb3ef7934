//! The tracer's buffers: the scene uploaded when it changes, each view's
//! parameters and ray buffers (`PrepareResources`), and each view's bind
//! groups (`PrepareBindGroups`).

use bevy::prelude::*;
use bevy::render::render_resource::{
    BindGroupEntries, Buffer, BufferDescriptor, BufferUsages, PipelineCache, ShaderType,
    StorageBuffer, UniformBuffer,
};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::view::ExtractedView;
use optica_optics::foveated_lod::{FlatScene, VisualField};

use super::TracerBinding;
use super::pipelines::TracerPipelines;
use crate::raytrace::{TracedScene, TracerView, eye_model_code};

/// `Params` in `raytrace.wgsl`.
#[derive(Clone, Copy, Debug, Default, ShaderType)]
pub(super) struct Params {
    world_from_clip: Mat4,
    eye: Vec3,
    width: u32,
    gaze_forward: Vec3,
    height: u32,
    gaze_right: Vec3,
    low_width: u32,
    gaze_up: Vec3,
    low_height: u32,
    background: Vec3,
    scale: u32,
    ambient: Vec3,
    reflect_max: u32,
    central: f32,
    ear: f32,
    nose: f32,
    upper: f32,
    lower: f32,
    eye_model: u32,
    boundary: u32,
    steps: u32,
    full_quality: u32,
    object_count: u32,
    light_count: u32,
    outer_level: f32,
    origin: UVec2,
    outer_width: u32,
    outer_height: u32,
}

#[derive(Clone, Copy, Debug, Default, ShaderType)]
pub(super) struct GpuNode {
    min: Vec3,
    a: u32,
    max: Vec3,
    b: u32,
}

#[derive(Clone, Copy, Debug, Default, ShaderType)]
pub(super) struct GpuVertex {
    position: Vec3,
    normal: Vec3,
}

#[derive(Clone, Copy, Debug, Default, ShaderType)]
pub(super) struct GpuMesh {
    root: u32,
    triangles: u32,
}

#[derive(Clone, Copy, Debug, Default, ShaderType)]
pub(super) struct GpuObject {
    min: Vec3,
    first_mesh: u32,
    max: Vec3,
    mesh_count: u32,
    color: Vec3,
    diffuse: f32,
    specular: f32,
    shininess: f32,
    reflectance: f32,
    transmittance: f32,
    ior: f32,
}

#[derive(Clone, Copy, Debug, Default, ShaderType)]
pub(super) struct GpuLight {
    position: Vec3,
    intensity: Vec3,
}

/// The scene on the GPU.
#[derive(Resource)]
pub(super) struct GpuScene {
    generation: u64,
    pub(super) nodes: StorageBuffer<Vec<GpuNode>>,
    pub(super) triangles: StorageBuffer<Vec<UVec4>>,
    pub(super) vertices: StorageBuffer<Vec<GpuVertex>>,
    pub(super) meshes: StorageBuffer<Vec<GpuMesh>>,
    pub(super) objects: StorageBuffer<Vec<GpuObject>>,
    pub(super) lights: StorageBuffer<Vec<GpuLight>>,
    object_count: u32,
    light_count: u32,
}

/// A storage buffer of `items`, or of one default item where there are
/// none (wgpu refuses empty bindings).
fn upload<T: ShaderType + Default + bevy::render::render_resource::encase::internal::WriteInto>(
    mut items: Vec<T>,
    device: &RenderDevice,
    queue: &RenderQueue,
) -> StorageBuffer<Vec<T>>
where
    Vec<T>: ShaderType + bevy::render::render_resource::encase::internal::WriteInto,
{
    if items.is_empty() {
        items.push(T::default());
    }
    let mut b = StorageBuffer::from(items);
    b.write_buffer(device, queue);
    b
}

fn gpu_scene(flat: &FlatScene, generation: u64, d: &RenderDevice, q: &RenderQueue) -> GpuScene {
    let v = |a: [f32; 3]| Vec3::from_array(a);
    GpuScene {
        generation,
        nodes: upload(
            flat.nodes
                .iter()
                .map(|n| GpuNode {
                    min: v(n.min),
                    a: n.a,
                    max: v(n.max),
                    b: n.b,
                })
                .collect(),
            d,
            q,
        ),
        triangles: upload(
            flat.triangles
                .iter()
                .map(|t| UVec4::new(t[0], t[1], t[2], 0))
                .collect(),
            d,
            q,
        ),
        vertices: upload(
            flat.vertices
                .iter()
                .map(|x| GpuVertex {
                    position: v(x.position),
                    normal: v(x.normal),
                })
                .collect(),
            d,
            q,
        ),
        meshes: upload(
            flat.meshes
                .iter()
                .map(|m| GpuMesh {
                    root: m.root,
                    triangles: m.triangles,
                })
                .collect(),
            d,
            q,
        ),
        objects: upload(
            flat.objects
                .iter()
                .map(|o| GpuObject {
                    min: v(o.min),
                    first_mesh: o.first_mesh,
                    max: v(o.max),
                    mesh_count: o.mesh_count,
                    color: v(o.color),
                    diffuse: o.diffuse,
                    specular: o.specular,
                    shininess: o.shininess,
                    reflectance: o.reflectance,
                    transmittance: o.transmittance,
                    ior: o.ior,
                })
                .collect(),
            d,
            q,
        ),
        lights: upload(
            flat.lights
                .iter()
                .map(|l| GpuLight {
                    position: l.position.as_vec3(),
                    intensity: l.intensity.as_vec3(),
                })
                .collect(),
            d,
            q,
        ),
        object_count: flat.objects.len() as u32,
        light_count: flat.lights.len() as u32,
    }
}

/// Uploads the scene when it was rebuilt, and only while a tracer view exists.
pub(super) fn prepare_scene(
    mut commands: Commands,
    views: Query<(), With<TracerView>>,
    traced: Option<Res<TracedScene>>,
    gpu: Option<Res<GpuScene>>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
) {
    let Some(traced) = traced else {
        return;
    };
    if views.is_empty() || gpu.is_some_and(|g| g.generation == traced.generation) {
        return;
    }
    commands.insert_resource(gpu_scene(&traced.flat, traced.generation, &device, &queue));
}

/// A view's buffers, kept while its size stays.
#[derive(Component)]
pub(super) struct ViewBuffers {
    pub(super) params: UniformBuffer<Params>,
    pub(super) image: Buffer,
    /// The middle layer's texels, then the outer layer's.
    pub(super) low: Buffer,
    /// Texels `low` holds.
    layer_capacity: u64,
    pub(super) size: UVec2,
    pub(super) low_size: UVec2,
    pub(super) outer_size: UVec2,
    /// The outer layer is traced.
    pub(super) has_outer: bool,
    pub(super) origin: UVec2,
}

fn field_params(field: &VisualField) -> (f32, f32, f32, f32, f32, u32) {
    let e = field.extents();
    (
        e.central as f32,
        e.ear as f32,
        e.nose as f32,
        e.upper as f32,
        e.lower as f32,
        match field.boundary_shape() {
            optica_optics::foveated_lod::BoundaryShape::PaperEq7 => 0,
            optica_optics::foveated_lod::BoundaryShape::TrueEllipse => 1,
        },
    )
}

pub(super) fn prepare_views(
    mut commands: Commands,
    mut views: Query<(
        Entity,
        &ExtractedView,
        &TracerView,
        Option<&mut ViewBuffers>,
    )>,
    gpu: Option<Res<GpuScene>>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
) {
    let Some(gpu) = gpu else {
        return;
    };
    for (entity, view, tv, buffers) in &mut views {
        let size = view.viewport.zw().max(UVec2::ONE);
        let scale = if tv.full_quality { 1 } else { tv.scale.max(1) };
        let low_size = UVec2::new(size.x.div_ceil(scale), size.y.div_ceil(scale));
        let outer_size = UVec2::new(size.x.div_ceil(2 * scale), size.y.div_ceil(2 * scale));
        let outer_level = if scale > 1 { tv.outer_level } else { 0.0 };
        // The layers' texels: none when every pixel is traced.
        let texels = |n: UVec2| n.x as u64 * n.y as u64;
        let layer_texels = if scale > 1 {
            texels(low_size)
                + if outer_level > 0.0 {
                    texels(outer_size)
                } else {
                    0
                }
        } else {
            0
        };
        let (central, ear, nose, upper, lower, boundary) = field_params(&tv.field);
        let params = Params {
            world_from_clip: Mat4::from_quat(view.world_from_view.rotation())
                * view.clip_from_view.inverse(),
            eye: view.world_from_view.translation(),
            width: size.x,
            gaze_forward: tv.gaze_forward,
            height: size.y,
            gaze_right: tv.gaze_right,
            low_width: low_size.x,
            gaze_up: tv.gaze_up,
            low_height: low_size.y,
            background: tv.background,
            scale,
            ambient: tv.ambient,
            reflect_max: tv.reflect_max,
            central,
            ear,
            nose,
            upper,
            lower,
            eye_model: eye_model_code(&tv.field),
            boundary,
            steps: tv.steps,
            full_quality: u32::from(tv.full_quality),
            object_count: gpu.object_count,
            light_count: gpu.light_count,
            outer_level,
            origin: view.viewport.xy(),
            outer_width: outer_size.x,
            outer_height: outer_size.y,
        };
        match buffers {
            Some(mut b) if b.size == size && b.layer_capacity >= layer_texels => {
                b.low_size = low_size;
                b.outer_size = outer_size;
                b.has_outer = outer_level > 0.0;
                b.params.set(params);
                b.params.write_buffer(&device, &queue);
                b.origin = view.viewport.xy();
            }
            _ => {
                let buffer = |label: &'static str, texels: u64| {
                    device.create_buffer(&BufferDescriptor {
                        label: Some(label),
                        size: 16 * texels.max(1),
                        usage: BufferUsages::STORAGE,
                        mapped_at_creation: false,
                    })
                };
                let mut p = UniformBuffer::from(params);
                p.write_buffer(&device, &queue);
                commands.entity(entity).insert(ViewBuffers {
                    params: p,
                    image: buffer("optica_foveated_lod_image", size.x as u64 * size.y as u64),
                    low: buffer("optica_foveated_lod_layers", layer_texels),
                    layer_capacity: layer_texels,
                    size,
                    low_size,
                    outer_size,
                    has_outer: outer_level > 0.0,
                    origin: view.viewport.xy(),
                });
            }
        }
    }
}

/// Each tracer view's bind groups, once the scene is on the GPU.
pub(super) fn prepare_tracer_bind_groups(
    mut commands: Commands,
    views: Query<(Entity, &ViewBuffers)>,
    gpu: Option<Res<GpuScene>>,
    pipelines: Res<TracerPipelines>,
    pipeline_cache: Res<PipelineCache>,
    device: Res<RenderDevice>,
) {
    let Some(gpu) = gpu else {
        return;
    };
    for (entity, buffers) in &views {
        let (
            Some(params),
            Some(nodes),
            Some(triangles),
            Some(vertices),
            Some(meshes),
            Some(objects),
            Some(lights),
        ) = (
            buffers.params.binding(),
            gpu.nodes.binding(),
            gpu.triangles.binding(),
            gpu.vertices.binding(),
            gpu.meshes.binding(),
            gpu.objects.binding(),
            gpu.lights.binding(),
        )
        else {
            commands.entity(entity).remove::<TracerBinding>();
            continue;
        };
        let trace_group = device.create_bind_group(
            "optica_foveated_lod_trace",
            &pipeline_cache.get_bind_group_layout(&pipelines.trace_layout),
            &BindGroupEntries::sequential((
                params.clone(),
                nodes,
                triangles,
                vertices,
                meshes,
                objects,
                lights,
                buffers.image.as_entire_binding(),
                buffers.low.as_entire_binding(),
            )),
        );
        let blit_group = device.create_bind_group(
            "optica_foveated_lod_blit",
            &pipeline_cache.get_bind_group_layout(&pipelines.blit_layout),
            &BindGroupEntries::sequential((params, buffers.image.as_entire_binding())),
        );
        commands.entity(entity).insert(TracerBinding {
            trace_group,
            blit_group,
        });
    }
}
