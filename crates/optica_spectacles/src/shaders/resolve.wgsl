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
// Nearest, clamped: gathers the four texels round a point.
@group(0) @binding(5) var gather_sampler: sampler;
#endif

#ifndef FULL
// The sharp depths of the bilinear footprint round `p` (pixels), in
// `textureGather` order.
fn footprint_depths(p: vec2<f32>, view: vec2<f32>) -> vec4<f32> {
#ifdef MULTISAMPLED
    // No gather from a multisampled texture: sample 0 of each pixel.
    let b = vec2<i32>(floor(p - 0.5));
    let hi = vec2<i32>(view) - 1;
    return vec4<f32>(
        textureLoad(sharp_depth, clamp(b + vec2<i32>(0, 1), vec2<i32>(0), hi), 0),
        textureLoad(sharp_depth, clamp(b + vec2<i32>(1, 1), vec2<i32>(0), hi), 0),
        textureLoad(sharp_depth, clamp(b + vec2<i32>(1, 0), vec2<i32>(0), hi), 0),
        textureLoad(sharp_depth, clamp(b, vec2<i32>(0), hi), 0),
    );
#else
    return textureGather(sharp_depth, gather_sampler, p / view);
#endif
}
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
        if any(from_px < vec2<f32>(0.0)) || any(from_px > view) {
            // The point lies outside the sharp view (a clone brings in what
            // lies just past the view's edge): the edge pixel nearest it
            // stands in for it, as a clamped texture would.
            let edge = clamp(vec2<i32>(from_px), vec2<i32>(0), vec2<i32>(view) - 1);
            sum += textureLoad(sharp, edge, 0).rgb;
            weight += 1.0;
            continue;
        }
        // The sharp pixels round that point (its bilinear footprint): the
        // ones that show the same surface, weighted bilinearly. (A point
        // near a silhouette may lie past the centres of the pixels the
        // sharp view drew the surface in, so the nearest pixel alone
        // would lose it.) Gathered: the footprint's four depths in one
        // fetch, its colours in three.
        let f = fract(from_px - 0.5);
        // Gather order: (u0, v1), (u1, v1), (u1, v0), (u0, v0).
        let bilinear = vec4<f32>((1.0 - f.x) * f.y, f.x * f.y, f.x * (1.0 - f.y), (1.0 - f.x) * (1.0 - f.y));
        let depths = footprint_depths(from_px, view);
        let same = abs(depths - vec4<f32>(g.z)) <= vec4<f32>(params.depth_tolerance * g.z);
        let w = select(vec4<f32>(0.0), max(bilinear, vec4<f32>(1e-4)), same);
        let wsum = dot(w, vec4<f32>(1.0));
        if wsum > 0.0 {
            let uv = from_px / view;
            let c = vec3<f32>(
                dot(w, textureGather(0, sharp, gather_sampler, uv)),
                dot(w, textureGather(1, sharp, gather_sampler, uv)),
                dot(w, textureGather(2, sharp, gather_sampler, uv)),
            );
            sum += c / wsum;
            weight += 1.0;
        }
    }
    if weight == 0.0 {
        return vec4<f32>(textureLoad(sharp, vec2<i32>(px), 0).rgb, 1.0);
    }
    return vec4<f32>(sum / weight, 1.0);
#endif
}
