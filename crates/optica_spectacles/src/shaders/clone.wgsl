// A clone of a StandardMaterial mesh (paper §4.2), drawn by the clone
// camera into its tile of the clone atlas: the displaced vertex of
// `clone_vertex.wgsl`, mapped into the clone's tile; StandardMaterial's
// own fragment shading, discarded outside the tile. Where the device has
// clip distances, `clone_clip.wgsl` is the vertex stage instead and the
// rasteriser does the cut.

#import bevy_pbr::{
    mesh_functions,
    forward_io::{Vertex, VertexOutput, FragmentOutput},
    mesh_view_bindings::view,
    pbr_fragment::pbr_input_from_standard_material,
    pbr_functions::{alpha_discard, apply_pbr_lighting, main_pass_post_lighting_processing},
    pbr_types::STANDARD_MATERIAL_FLAGS_UNLIT_BIT,
}
#import optica::spectacles::clone_vertex::{clone, clone_vertex, into_tile}

@vertex
fn vertex(vertex_no_morph: Vertex) -> VertexOutput {
    var out = clone_vertex(vertex_no_morph);
    out.position = into_tile(out.position, mesh_functions::get_tag(vertex_no_morph.instance_index));
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
