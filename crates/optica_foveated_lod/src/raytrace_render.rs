//! The GPU side of the ray tracer: the scene's buffers (uploaded when
//! [`TracedScene`] changes), per view a parameter block and two ray
//! buffers, and the passes of `raytrace.wgsl` (coarse periphery, full
//! image, copy into the view) before Bevy's post-processing. Nothing is
//! queued or run for a scene without a [`GazeRayTracer`] camera.
//! Span: `optica/foveated_lod/trace`.

use bevy::core_pipeline::{Core3d, Core3dSystems, FullscreenShader};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use bevy::render::diagnostic::RecordDiagnostics;
use bevy::render::extract_component::ExtractComponentPlugin;
use bevy::render::extract_resource::ExtractResourcePlugin;
use bevy::render::render_resource::binding_types::{
    storage_buffer, storage_buffer_read_only, uniform_buffer,
};
use bevy::render::render_resource::{
    BindGroupEntries, BindGroupLayoutDescriptor, BindGroupLayoutEntries, Buffer, BufferDescriptor,
    BufferUsages, CachedComputePipelineId, CachedRenderPipelineId, ColorTargetState, ColorWrites,
    ComputePassDescriptor, ComputePipelineDescriptor, FragmentState, Operations, PipelineCache,
    RenderPassColorAttachment, RenderPassDescriptor, RenderPipelineDescriptor, ShaderStages,
    ShaderType, StorageBuffer, TextureFormat, UniformBuffer,
};
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy::render::view::{ExtractedView, ViewTarget};
use bevy::render::{Render, RenderApp, RenderStartup, RenderSystems};
use optica_optics::foveated_lod::{FlatScene, VisualField};

use crate::raytrace::{TracedScene, TracerView, eye_model_code};

/// `@workgroup_size` of the tracing passes (`LANES` invocations in
/// `raytrace.wgsl`).
const GROUP: UVec2 = UVec2::new(8, 4);

/// `Params` in `raytrace.wgsl`.
#[derive(Clone, Copy, Debug, Default, ShaderType)]
struct Params {
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
struct GpuNode {
    min: Vec3,
    a: u32,
    max: Vec3,
    b: u32,
}

#[derive(Clone, Copy, Debug, Default, ShaderType)]
struct GpuVertex {
    position: Vec3,
    normal: Vec3,
}

#[derive(Clone, Copy, Debug, Default, ShaderType)]
struct GpuMesh {
    root: u32,
    triangles: u32,
}

#[derive(Clone, Copy, Debug, Default, ShaderType)]
struct GpuObject {
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
struct GpuLight {
    position: Vec3,
    intensity: Vec3,
}

pub(crate) fn build(app: &mut App) {
    app.add_plugins((
        ExtractComponentPlugin::<TracerView>::default(),
        ExtractResourcePlugin::<TracedScene>::default(),
    ));
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
        return;
    };
    render_app
        .add_systems(RenderStartup, init_tracer)
        .add_systems(
            Render,
            (prepare_scene, prepare_views)
                .chain()
                .in_set(RenderSystems::PrepareBindGroups),
        )
        .add_systems(Core3d, trace_pass.in_set(Core3dSystems::EarlyPostProcess));
}

#[derive(Resource)]
struct TracerShared {
    trace_layout: BindGroupLayoutDescriptor,
    blit_layout: BindGroupLayoutDescriptor,
    /// `trace_mid`, `trace_outer` and `trace_full`, queued with the first view.
    trace: Option<[CachedComputePipelineId; 3]>,
    /// Per target format.
    blits: HashMap<TextureFormat, CachedRenderPipelineId>,
}

fn init_tracer(mut commands: Commands) {
    let trace_layout = BindGroupLayoutDescriptor::new(
        "optica_foveated_lod_trace",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                uniform_buffer::<Params>(false),
                storage_buffer_read_only::<Vec<GpuNode>>(false),
                storage_buffer_read_only::<Vec<UVec4>>(false),
                storage_buffer_read_only::<Vec<GpuVertex>>(false),
                storage_buffer_read_only::<Vec<GpuMesh>>(false),
                storage_buffer_read_only::<Vec<GpuObject>>(false),
                storage_buffer_read_only::<Vec<GpuLight>>(false),
                storage_buffer::<Vec<Vec4>>(false),
                storage_buffer::<Vec<Vec4>>(false),
            ),
        ),
    );
    let blit_layout = BindGroupLayoutDescriptor::new(
        "optica_foveated_lod_blit",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::FRAGMENT,
            (
                uniform_buffer::<Params>(false),
                storage_buffer_read_only::<Vec<Vec4>>(false),
            ),
        ),
    );
    commands.insert_resource(TracerShared {
        trace_layout,
        blit_layout,
        trace: None,
        blits: HashMap::default(),
    });
}

/// The scene on the GPU.
#[derive(Resource)]
struct GpuScene {
    generation: u64,
    nodes: StorageBuffer<Vec<GpuNode>>,
    triangles: StorageBuffer<Vec<UVec4>>,
    vertices: StorageBuffer<Vec<GpuVertex>>,
    meshes: StorageBuffer<Vec<GpuMesh>>,
    objects: StorageBuffer<Vec<GpuObject>>,
    lights: StorageBuffer<Vec<GpuLight>>,
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
fn prepare_scene(
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
struct ViewBuffers {
    params: UniformBuffer<Params>,
    image: Buffer,
    /// The middle layer's texels, then the outer layer's.
    low: Buffer,
    /// Texels `low` holds.
    layer_capacity: u64,
    size: UVec2,
    low_size: UVec2,
    outer_size: UVec2,
    /// The outer layer is traced.
    has_outer: bool,
    origin: UVec2,
    pipelines: [CachedComputePipelineId; 3],
    blit: CachedRenderPipelineId,
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

#[allow(clippy::too_many_arguments)]
fn prepare_views(
    mut commands: Commands,
    mut views: Query<(
        Entity,
        &ExtractedView,
        &TracerView,
        Option<&mut ViewBuffers>,
    )>,
    gpu: Option<Res<GpuScene>>,
    mut shared: ResMut<TracerShared>,
    pipeline_cache: Res<PipelineCache>,
    fullscreen: Res<FullscreenShader>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
) {
    let Some(gpu) = gpu else {
        return;
    };
    for (entity, view, tv, buffers) in &mut views {
        let layout = shared.trace_layout.clone();
        let pipelines = *shared.trace.get_or_insert_with(|| {
            ["trace_mid", "trace_outer", "trace_full"].map(|entry| {
                pipeline_cache.queue_compute_pipeline(ComputePipelineDescriptor {
                    label: Some(format!("optica_foveated_lod_{entry}").into()),
                    layout: vec![layout.clone()],
                    immediate_size: 0,
                    shader: crate::RAYTRACE_SHADER,
                    shader_defs: vec!["TRACE".into()],
                    entry_point: Some(entry.into()),
                    zero_initialize_workgroup_memory: false,
                })
            })
        });
        let blit_layout = shared.blit_layout.clone();
        let blit = *shared.blits.entry(view.target_format).or_insert_with(|| {
            pipeline_cache.queue_render_pipeline(RenderPipelineDescriptor {
                label: Some("optica_foveated_lod_blit".into()),
                layout: vec![blit_layout],
                vertex: fullscreen.to_vertex_state(),
                fragment: Some(FragmentState {
                    shader: crate::RAYTRACE_SHADER,
                    entry_point: Some("blit_fragment".into()),
                    targets: vec![Some(ColorTargetState {
                        format: view.target_format,
                        blend: None,
                        write_mask: ColorWrites::ALL,
                    })],
                    ..default()
                }),
                ..default()
            })
        });
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
                b.pipelines = pipelines;
                b.blit = blit;
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
                    pipelines,
                    blit,
                });
            }
        }
    }
}

fn trace_pass(
    view: ViewQuery<(&ViewTarget, &ViewBuffers, &TracerView)>,
    gpu: Option<Res<GpuScene>>,
    shared: Res<TracerShared>,
    pipeline_cache: Res<PipelineCache>,
    mut ctx: RenderContext,
) {
    let (target, buffers, tv) = view.into_inner();
    let Some(gpu) = gpu else {
        return;
    };
    let (Some(mid), Some(outer), Some(full), Some(blit)) = (
        pipeline_cache.get_compute_pipeline(buffers.pipelines[0]),
        pipeline_cache.get_compute_pipeline(buffers.pipelines[1]),
        pipeline_cache.get_compute_pipeline(buffers.pipelines[2]),
        pipeline_cache.get_render_pipeline(buffers.blit),
    ) else {
        return;
    };
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
        return;
    };
    let device = ctx.render_device().clone();
    let trace_group = device.create_bind_group(
        "optica_foveated_lod_trace",
        &pipeline_cache.get_bind_group_layout(&shared.trace_layout),
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
        &pipeline_cache.get_bind_group_layout(&shared.blit_layout),
        &BindGroupEntries::sequential((params, buffers.image.as_entire_binding())),
    );
    let post = target.post_process_write();
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    // The whole tracer, and within it the trace (compute) and the blit
    // (render): `optica/foveated_lod`, `.../trace`, `.../blit`.
    let span = diagnostics.time_span(ctx.command_encoder(), "optica/foveated_lod");
    {
        let mut pass = ctx
            .command_encoder()
            .begin_compute_pass(&ComputePassDescriptor {
                label: Some("optica_foveated_lod_trace"),
                timestamp_writes: None,
            });
        let pass_span = diagnostics.pass_span(&mut pass, "trace");
        pass.set_bind_group(0, &trace_group, &[]);
        if !tv.full_quality && tv.scale > 1 {
            pass.set_pipeline(mid);
            pass.dispatch_workgroups(
                buffers.low_size.x.div_ceil(GROUP.x),
                buffers.low_size.y.div_ceil(GROUP.y),
                1,
            );
            if buffers.has_outer {
                pass.set_pipeline(outer);
                pass.dispatch_workgroups(
                    buffers.outer_size.x.div_ceil(GROUP.x),
                    buffers.outer_size.y.div_ceil(GROUP.y),
                    1,
                );
            }
        }
        pass.set_pipeline(full);
        pass.dispatch_workgroups(
            buffers.size.x.div_ceil(GROUP.x),
            buffers.size.y.div_ceil(GROUP.y),
            1,
        );
        pass_span.end(&mut pass);
    }
    {
        let mut pass = ctx
            .command_encoder()
            .begin_render_pass(&RenderPassDescriptor {
                label: Some("optica_foveated_lod_blit"),
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
        // Cameras that share a target draw into their own viewport.
        let pass_span = diagnostics.pass_span(&mut pass, "blit");
        let (origin, size) = (buffers.origin.as_vec2(), buffers.size.as_vec2());
        pass.set_viewport(origin.x, origin.y, size.x, size.y, 0.0, 1.0);
        pass.set_bind_group(0, &blit_group, &[]);
        pass.set_pipeline(blit);
        pass.draw(0..3, 0..1);
        pass_span.end(&mut pass);
    }
    span.end(ctx.command_encoder());
}
