// The ghosts, added up at a reduced resolution (`LensFlare::ghost_resolution`),
// scaled up bilinearly onto the view and added to it. The texels hold
// irradiance (light per area), so interpolating them keeps each ghost's
// light.

#import bevy_core_pipeline::fullscreen_vertex_shader::FullscreenVertexOutput

@group(0) @binding(0) var ghosts: texture_2d<f32>;
@group(0) @binding(1) var ghosts_sampler: sampler;

@fragment
fn upsample(in: FullscreenVertexOutput) -> @location(0) vec4<f32> {
    return vec4<f32>(textureSampleLevel(ghosts, ghosts_sampler, in.uv, 0.0).rgb, 0.0);
}
