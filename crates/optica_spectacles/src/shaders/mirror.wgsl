// The per-vertex mirror's material (the paper's §3.2): each vertex carries
// its index in `uv.x`; the march on the mirror's environment camera wrote
// that vertex's texture coordinate into `coords` (where its reflected ray
// meets the scene, seen from the virtual viewpoint), and each fragment
// shows the environment image at the coordinate interpolated from its
// triangle's vertices, times the mirror's reflectance. Triangles with a
// vertex the viewer sees from behind are drawn as the mirror's dark edge.

#import bevy_pbr::{
    mesh_functions,
    view_transformations::position_world_to_clip,
}

@group(#{MATERIAL_BIND_GROUP}) @binding(0) var<uniform> tint: vec4<f32>;
@group(#{MATERIAL_BIND_GROUP}) @binding(1) var environment: texture_2d<f32>;
@group(#{MATERIAL_BIND_GROUP}) @binding(2) var environment_sampler: sampler;
@group(#{MATERIAL_BIND_GROUP}) @binding(3) var<storage, read> coords: array<vec4<f32>>;

struct Vertex {
    @builtin(instance_index) instance_index: u32,
    @location(0) position: vec3<f32>,
    @location(2) uv: vec2<f32>,
}

struct MirrorOut {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) front: f32,
}

@vertex
fn vertex(v: Vertex) -> MirrorOut {
    var out: MirrorOut;
    let world_from_local = mesh_functions::get_world_from_local(v.instance_index);
    let world = mesh_functions::mesh_position_local_to_world(world_from_local, vec4<f32>(v.position, 1.0));
    out.position = position_world_to_clip(world.xyz);
    let c = coords[u32(v.uv.x + 0.5)];
    out.uv = c.xy;
    out.front = c.w;
    return out;
}

@fragment
fn fragment(in: MirrorOut) -> @location(0) vec4<f32> {
    let seen = textureSampleLevel(environment, environment_sampler, clamp(in.uv, vec2<f32>(0.0), vec2<f32>(1.0)), 0.0).rgb;
    let front = step(0.999, in.front);
    return vec4<f32>(mix(vec3<f32>(0.02), seen * tint.rgb, front), 1.0);
}
