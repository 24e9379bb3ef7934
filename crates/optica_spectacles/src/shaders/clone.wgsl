// A clone of a StandardMaterial mesh (paper §4.2), drawn by the clone
// camera into its tile of the clone atlas: Bevy's mesh vertex shader with
// every vertex moved by the clone's displacement vector (the paper's
// future work: the displacement in the vertex shader), then mapped into
// the clone's tile; StandardMaterial's own fragment shading, discarded
// outside the tile.
//
// Assembled by the plugin after `displacement.wgsl` (imported) and
// `field_lookup.wgsl` (pasted below the bindings).

//ENABLE_CLIP_DISTANCES

#import bevy_pbr::{
    mesh_bindings::mesh,
    mesh_functions,
    skinning,
    morph::{morph_position, morph_normal, morph_tangent},
    forward_io::{Vertex, VertexOutput, FragmentOutput},
    view_transformations::position_world_to_clip,
    mesh_view_bindings::view,
    pbr_fragment::pbr_input_from_standard_material,
    pbr_functions::{alpha_discard, apply_pbr_lighting, main_pass_post_lighting_processing},
    pbr_types::STANDARD_MATERIAL_FLAGS_UNLIT_BIT,
}
#import optica::spectacles::{CloneParams, naked_displacement, box_exit, pupil_sample}

@group(#{MATERIAL_BIND_GROUP}) @binding(100) var<uniform> clone: CloneParams;
@group(#{MATERIAL_BIND_GROUP}) @binding(101) var<storage, read> field: array<f32>;

//FIELD_LOOKUP

// Bevy's view space (camera at the origin looking down −z) to the eye's
// frame (+z forward, +x to the wearer's left, cornea at z = 0): a half
// turn about y and the camera's depth behind the cornea.
fn eye_of_view(v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(-v.x, v.y, clone.camera_z - v.z);
}

// The clone's displacement of the world-space point `world`, in world space.
fn displace(world: vec3<f32>, k: u32) -> vec3<f32> {
    if clone.mode == 0u {
        return vec3<f32>(0.0);
    }
    let v = (view.view_from_world * vec4<f32>(world, 1.0)).xyz;
    let p = eye_of_view(v);
    var d = vec3<f32>(0.0);
    if clone.mode == 1u {
        d = naked_displacement(p, k, clone);
    } else {
        d = field_displacement(p, vec3<f32>(0.0, 0.0, clone.camera_z), k, clone);
    }
    // Back to view space (the half turn), then to world space.
    let dv = vec3<f32>(-d.x, d.y, -d.z);
    return (view.world_from_view * vec4<f32>(dv, 0.0)).xyz;
}

// Clip space of the whole view squeezed into tile `k` of the atlas
// (tiles row by row from the top left).
fn into_tile(clip: vec4<f32>, k: u32) -> vec4<f32> {
    let cols = f32(clone.tile_cols);
    let rows = f32(clone.tile_rows);
    let col = f32(k % clone.tile_cols);
    let row = f32(k / clone.tile_cols);
    var out = clip;
    out.x = (clip.x + clip.w * (1.0 + 2.0 * col)) / cols - clip.w;
    out.y = (clip.y - clip.w * (1.0 + 2.0 * row)) / rows + clip.w;
    return out;
}

#ifdef MORPH_TARGETS
fn morph_vertex(vertex_in: Vertex, instance_index: u32) -> Vertex {
    var vertex = vertex_in;
    let first_vertex = mesh[instance_index].first_vertex_index;
    let vertex_index = vertex.index - first_vertex;
    let weight_count = bevy_pbr::morph::layer_count(instance_index);
    for (var i: u32 = 0u; i < weight_count; i++) {
        let weight = bevy_pbr::morph::weight_at(i, instance_index);
        if weight == 0.0 {
            continue;
        }
        vertex.position += weight * morph_position(vertex_index, i, instance_index);
#ifdef VERTEX_NORMALS
        vertex.normal += weight * morph_normal(vertex_index, i, instance_index);
#endif
#ifdef VERTEX_TANGENTS
        vertex.tangent += vec4(weight * morph_tangent(vertex_index, i, instance_index), 0.0);
#endif
    }
    return vertex;
}
#endif

#ifdef CLIP_DISTANCES
// Bevy's `VertexOutput` with the four planes of the clone's tile as clip
// distances: the rasteriser cuts each clone at its tile, so the fragment
// shader needs no discard (which would cost early depth testing).
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
#else
@vertex
fn vertex(vertex_no_morph: Vertex) -> VertexOutput {
    var out = clone_vertex(vertex_no_morph);
    out.position = into_tile(out.position, mesh_functions::get_tag(vertex_no_morph.instance_index));
    return out;
}
#endif

// Bevy's mesh vertex shader with the displacement; `position` is the
// view's clip position, not yet in the tile.
fn clone_vertex(vertex_no_morph: Vertex) -> VertexOutput {
    var out: VertexOutput;
#ifdef MORPH_TARGETS
    var vertex = morph_vertex(vertex_no_morph, vertex_no_morph.instance_index);
#else
    var vertex = vertex_no_morph;
#endif
    let mesh_world_from_local = mesh_functions::get_world_from_local(vertex_no_morph.instance_index);
#ifdef SKINNED
    var world_from_local = skinning::skin_model(
        vertex.joint_indices,
        vertex.joint_weights,
        vertex_no_morph.instance_index
    );
#else
    var world_from_local = mesh_world_from_local;
#endif
#ifdef VERTEX_NORMALS
#ifdef SKINNED
    out.world_normal = skinning::skin_normals(world_from_local, vertex.normal);
#else
    out.world_normal = mesh_functions::mesh_normal_local_to_world(
        vertex.normal,
        vertex_no_morph.instance_index
    );
#endif
#endif
    // The clone number is the mesh's tag.
    let k = mesh_functions::get_tag(vertex_no_morph.instance_index);
    let world = mesh_functions::mesh_position_local_to_world(world_from_local, vec4<f32>(vertex.position, 1.0));
    // Shaded where the original is (its lights and shadows), drawn where
    // the clone is.
    out.world_position = world;
    out.position = position_world_to_clip(world.xyz + displace(world.xyz, k));
#ifdef VERTEX_UVS_A
    out.uv = vertex.uv;
#endif
#ifdef VERTEX_UVS_B
    out.uv_b = vertex.uv_b;
#endif
#ifdef VERTEX_TANGENTS
    out.world_tangent = mesh_functions::mesh_tangent_local_to_world(
        world_from_local,
        vertex.tangent,
        vertex_no_morph.instance_index
    );
#endif
#ifdef VERTEX_COLORS
    out.color = vertex.color;
#endif
#ifdef VERTEX_OUTPUT_INSTANCE_INDEX
    out.instance_index = vertex_no_morph.instance_index;
#endif
#ifdef VISIBILITY_RANGE_DITHER
    out.visibility_range_dither = mesh_functions::get_visibility_range_dither_level(
        vertex_no_morph.instance_index, mesh_world_from_local[3]);
#endif
    return out;
}

@fragment
fn fragment(in: VertexOutput, @builtin(front_facing) is_front: bool) -> FragmentOutput {
    // A triangle that reaches past its tile (off the view's edge) would
    // draw into the neighbouring clone's tile: cut it at the tile.
    let k = mesh_functions::get_tag(in.instance_index);
    let tile = view.viewport.zw / vec2<f32>(f32(clone.tile_cols), f32(clone.tile_rows));
    let at = floor((in.position.xy - view.viewport.xy) / tile);
#ifndef CLIP_DISTANCES
    if at.x != f32(k % clone.tile_cols) || at.y != f32(k / clone.tile_cols) {
        discard;
    }
#endif
    var out: FragmentOutput;
#ifdef REPROJECTED
    {
        // Reprojected: where the clone's (undisplaced) surface point lies
        // in the sharp view, as an offset in pixels from this pixel, and
        // its depth there; the resolve takes the sharp view's colour.
        let src = view.clip_from_world * vec4<f32>(in.world_position.xyz, 1.0);
        let ndc = src.xyz / src.w;
        let from_px = (vec2<f32>(ndc.x, -ndc.y) * 0.5 + 0.5) * tile;
        let here = in.position.xy - view.viewport.xy - at * tile;
        out.color = vec4<f32>(from_px - here, ndc.z, 1.0);
        return out;
    }
#else
    var pbr_input = pbr_input_from_standard_material(in, is_front);
    pbr_input.material.base_color = alpha_discard(pbr_input.material, pbr_input.material.base_color);
    if (pbr_input.material.flags & STANDARD_MATERIAL_FLAGS_UNLIT_BIT) == 0u {
        out.color = apply_pbr_lighting(pbr_input);
    } else {
        out.color = pbr_input.material.base_color;
    }
    out.color = main_pass_post_lighting_processing(pbr_input, out.color);
    return out;
#endif
}
