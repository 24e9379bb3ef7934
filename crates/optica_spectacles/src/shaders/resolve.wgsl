// The accumulation of the paper's §4.1 (Haeberli and Akeley's accumulation
// buffer): the eye camera's view becomes the mean of the S clone tiles of
// the atlas, in linear HDR, before Bevy's post-processing and tonemapping.
//
// `FULL`: each tile holds its clone's shaded colour.
// Otherwise each tile holds, per pixel, where that clone's (undisplaced)
// surface point lies in the sharp view (offset in pixels, xy) and its
// depth there (z, reverse-Z NDC), or alpha 0 where the clone has no
// geometry; the colour is the sharp view's where that point is visible in
// it, and a clone whose point the sharp view hides is left out of the
// mean at that pixel. `MULTISAMPLED` reads sample 0 of an MSAA depth.

#import bevy_core_pipeline::fullscreen_vertex_shader::FullscreenVertexOutput

struct ResolveParams {
    clones: u32,
    tile_cols: u32,
    tile_rows: u32,
    // Relative depth difference still taken as the same surface.
    depth_tolerance: f32,
    // What a clone shows where it has no geometry (linear RGBA).
    background: vec4<f32>,
}

@group(0) @binding(0) var atlas: texture_2d<f32>;
@group(0) @binding(1) var atlas_sampler: sampler;
@group(0) @binding(2) var<uniform> params: ResolveParams;
#ifndef FULL
@group(0) @binding(3) var sharp: texture_2d<f32>;
#ifdef MULTISAMPLED
@group(0) @binding(4) var sharp_depth: texture_depth_multisampled_2d;
#else
@group(0) @binding(4) var sharp_depth: texture_depth_2d;
#endif
#endif

fn tile_origin(k: u32, tile: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(f32(k % params.tile_cols), f32(k / params.tile_cols)) * tile;
}

@fragment
fn fragment(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    let size = vec2<f32>(textureDimensions(atlas));
    let tile = size / vec2<f32>(f32(params.tile_cols), f32(params.tile_rows));
#ifdef FULL
    // Kept half a texel inside the tile, so that filtering (when the view
    // and the tile differ in size) never reads a neighbouring clone.
    let inner = clamp(in.uv * tile, vec2<f32>(0.5), tile - vec2<f32>(0.5));
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < params.clones; k++) {
        sum += textureSampleLevel(atlas, atlas_sampler, (tile_origin(k, tile) + inner) / size, 0.0).rgb;
    }
    return vec4<f32>(sum / f32(params.clones), 1.0);
#else
    let view = vec2<f32>(textureDimensions(sharp));
    let px = floor(in.uv * view);
    let here = min(vec2<i32>(px * tile / view), vec2<i32>(tile) - 1);
    // What a clone without geometry here shows: the sharp view's sky (a
    // skybox, the clear colour) where the sharp view has none either,
    // else the clear colour.
    var background = params.background.rgb;
    if textureLoad(sharp_depth, vec2<i32>(px), 0) == 0.0 {
        background = textureLoad(sharp, vec2<i32>(px), 0).rgb;
    }
    var sum = vec3<f32>(0.0);
    var weight = 0.0;
    for (var k = 0u; k < params.clones; k++) {
        let g = textureLoad(atlas, vec2<i32>(tile_origin(k, tile)) + here, 0);
        if g.a == 0.0 {
            sum += background;
            weight += 1.0;
            continue;
        }
        let from_px = (vec2<f32>(here) + 0.5 + g.xy) * view / tile;
        // The sharp pixels round that point (its bilinear footprint): the
        // ones that show the same surface, weighted bilinearly. (A point
        // near a silhouette may lie past the centres of the pixels the
        // sharp view drew the surface in, so the nearest pixel alone
        // would lose it.)
        let base = floor(from_px - 0.5);
        let f = from_px - 0.5 - base;
        var c = vec3<f32>(0.0);
        var w = 0.0;
        for (var j = 0u; j < 4u; j++) {
            let o = vec2<f32>(f32(j & 1u), f32(j >> 1u));
            let ip = base + o;
            if any(ip < vec2<f32>(0.0)) || any(ip >= view) {
                continue;
            }
            let d = textureLoad(sharp_depth, vec2<i32>(ip), 0);
            if abs(d - g.z) <= params.depth_tolerance * g.z {
                let b = mix(1.0 - f, f, o);
                let wb = max(b.x * b.y, 1e-4);
                c += wb * textureLoad(sharp, vec2<i32>(ip), 0).rgb;
                w += wb;
            }
        }
        if w > 0.0 {
            sum += c / w;
            weight += 1.0;
        }
    }
    if weight == 0.0 {
        return vec4<f32>(textureLoad(sharp, vec2<i32>(px), 0).rgb, 1.0);
    }
    return vec4<f32>(sum / weight, 1.0);
#endif
}
