// mask.rs `DomeRimMask`: the view outside the image circle in one colour.
#import bevy_core_pipeline::fullscreen_vertex_shader::FullscreenVertexOutput

@group(0) @binding(0) var screen_texture: texture_2d<f32>;
@group(0) @binding(1) var texture_sampler: sampler;

struct DomeRimMask {
    colour: vec4<f32>,
}

@group(0) @binding(2) var<uniform> mask: DomeRimMask;

@fragment
fn fragment(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    let size = vec2<f32>(textureDimensions(screen_texture));
    let seen = textureSampleLevel(screen_texture, texture_sampler, in.uv, 0.0);
    // Radius of the pixel centre in units of the image circle's, which
    // fits the shorter side; the rim is at 1. Coverage of the pixel by the
    // circle, linear over one pixel's width.
    let short = min(size.x, size.y);
    let ndc = (in.uv * 2.0 - 1.0) * size / short;
    let r = length(ndc);
    let pixel = 2.0 / short;
    let inside = clamp((1.0 - r) / pixel + 0.5, 0.0, 1.0);
    return mix(mask.colour, seen, inside);
}
