// The clone's vertex: Bevy's mesh vertex shader with every vertex moved
// by the clone's displacement vector (paper §4.2; the paper's future
// work: the displacement in the vertex shader), and the map of the view
// into the clone's tile of the atlas. The two entry files, `clone.wgsl`
// and `clone_clip.wgsl` (the same with clip distances, which need an
// `enable` directive at the top of the file), call it.

#define_import_path optica::spectacles::clone_vertex

#import bevy_pbr::{
    mesh_bindings::mesh,
    mesh_functions,
    skinning,
    morph::{morph_position, morph_normal, morph_tangent},
    forward_io::{Vertex, VertexOutput},
    view_transformations::position_world_to_clip,
    mesh_view_bindings::view,
}
#import optica::spectacles::{CloneParams, naked_displacement}
#import optica::spectacles::field::field_displacement

@group(#{MATERIAL_BIND_GROUP}) @binding(100) var<uniform> clone: CloneParams;

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

