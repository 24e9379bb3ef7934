enable clip_distances;

// The clone's vertex stage where the device clips by distances the vertex
// shader writes: `clone.wgsl`'s vertex with the four planes of the
// clone's tile as clip distances, so the rasteriser cuts each clone at
// its tile and the fragment shader needs no discard (which would cost
// early depth testing). Its own file because the `enable` directive must
// open the file, before any shader def can act.

#import bevy_pbr::{mesh_functions, forward_io::Vertex}
#import optica::spectacles::clone_vertex::{clone_vertex, into_tile}

// Bevy's `VertexOutput` with the clip distances.
struct CloneVertexOutput {
    @builtin(position) position: vec4<f32>,
    @location(0) world_position: vec4<f32>,
    @location(1) world_normal: vec3<f32>,
#ifdef VERTEX_UVS_A
    @location(2) uv: vec2<f32>,
#endif
#ifdef VERTEX_UVS_B
    @location(3) uv_b: vec2<f32>,
#endif
#ifdef VERTEX_TANGENTS
    @location(4) world_tangent: vec4<f32>,
#endif
#ifdef VERTEX_COLORS
    @location(5) color: vec4<f32>,
#endif
#ifdef VERTEX_OUTPUT_INSTANCE_INDEX
    @location(6) @interpolate(flat) instance_index: u32,
#endif
#ifdef VISIBILITY_RANGE_DITHER
    @location(7) @interpolate(flat) visibility_range_dither: i32,
#endif
    @builtin(clip_distances) clip_distances: array<f32, 4>,
}

@vertex
fn vertex(vertex_no_morph: Vertex) -> CloneVertexOutput {
    let out = clone_vertex(vertex_no_morph);
    var o: CloneVertexOutput;
    o.position = into_tile(out.position, mesh_functions::get_tag(vertex_no_morph.instance_index));
    o.world_position = out.world_position;
    o.world_normal = out.world_normal;
#ifdef VERTEX_UVS_A
    o.uv = out.uv;
#endif
#ifdef VERTEX_UVS_B
    o.uv_b = out.uv_b;
#endif
#ifdef VERTEX_TANGENTS
    o.world_tangent = out.world_tangent;
#endif
#ifdef VERTEX_COLORS
    o.color = out.color;
#endif
#ifdef VERTEX_OUTPUT_INSTANCE_INDEX
    o.instance_index = out.instance_index;
#endif
#ifdef VISIBILITY_RANGE_DITHER
    o.visibility_range_dither = out.visibility_range_dither;
#endif
    // The view's own clip volume, before it is squeezed into the tile.
    let c = out.position;
    o.clip_distances = array<f32, 4>(c.w + c.x, c.w - c.x, c.w + c.y, c.w - c.y);
    return o;
}
