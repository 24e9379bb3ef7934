// The flare's draw pass: every cell the cell pass kept as two triangles on
// the screen, in its colour (its irradiance, from `ghost_cells.wgsl`,
// scaled here by the flare's intensity and its light's visibility),
// clipped per pixel where r_rel > 1 or outside the iris, added to the HDR
// view before tonemapping.

#import optica_lens_flare::types::{FlareParams, LightProbe, RayOut}
#ifdef BLADED_IRIS
#import optica_lens_flare::aperture::aperture_contains_all
#endif

@group(0) @binding(0) var<uniform> params: FlareParams;
// Per ray: the colour and wavelength of the cell it is the first corner of.
@group(0) @binding(1) var<storage, read> cell_colors: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> rays: array<RayOut>;
// Each light's visibility through the scene's depth (`visibility.wgsl`).
@group(0) @binding(3) var<storage, read> visibility: array<f32>;
@group(0) @binding(4) var<storage, read> lights: array<LightProbe>;
// The iris's propagated intensity at 650, 550, 450 nm in r, g, b, over
// twice the iris's diameter (`optica_optics::lens_flare::ringing`).
@group(0) @binding(5) var ringing_texture: texture_2d<f32>;
// The starburst, RGB (`optica_optics::lens_flare::starburst`).
@group(0) @binding(6) var starburst_texture: texture_2d<f32>;

// `t` at the fractional texel `p`, bilinear, zero outside (the textures
// are 32-bit floats, which are not filterable everywhere).
fn bilinear(t: texture_2d<f32>, p: vec2<f32>) -> vec4<f32> {
    let size = vec2<i32>(textureDimensions(t));
    let q = p - 0.5;
    let i = vec2<i32>(floor(q));
    let f = q - floor(q);
    var acc = vec4<f32>(0.0);
    for (var k = 0; k < 4; k += 1) {
        let o = vec2<i32>(k & 1, k >> 1);
        let at = i + o;
        if all(at >= vec2<i32>(0)) && all(at < size) {
            let w = select(1.0 - f.x, f.x, o.x == 1) * select(1.0 - f.y, f.y, o.y == 1);
            acc += w * textureLoad(t, at, 0);
        }
    }
    return acc;
}

// The ringing at a stop-plane point (mm) for wavelength `wl` (nm), between
// the texture's three wavelengths.
fn ringing_at(stop: vec2<f32>, wl: f32) -> f32 {
    let size = vec2<f32>(textureDimensions(ringing_texture));
    let v = bilinear(ringing_texture, (stop / (4.0 * params.radius) + 0.5) * size);
    if wl >= 550.0 {
        return mix(v.g, v.r, clamp((wl - 550.0) / 100.0, 0.0, 1.0));
    }
    return mix(v.b, v.g, clamp((wl - 450.0) / 100.0, 0.0, 1.0));
}

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    // The cell's, from its first corner (the provoking vertex of both its
    // triangles, `ghost_cells.wgsl`).
    @location(0) @interpolate(flat) color: vec3<f32>,
    @location(1) r_rel: f32,
    // Where the ray crossed the stop plane (up to three times; with a
    // round iris r_rel already holds the stop's rim, so only the first is
    // kept, for the ringing).
    @location(2) stop_first: vec2<f32>,
#ifdef BLADED_IRIS
    @location(3) stop_second: vec2<f32>,
    @location(4) stop_third: vec2<f32>,
#endif
    @location(5) @interpolate(flat) wl: f32,
}

// One traced ray, shared by the (up to four) cells around it; indexed by
// the cell pass's index buffer, which holds only the cells that add light.
@vertex
fn vertex(@builtin(vertex_index) ray: u32) -> VertexOut {
    var out: VertexOut;
    let r = rays[ray];
    let cell = cell_colors[ray];
    let ndc = -r.sensor / vec2<f32>(params.half_height_mm * params.aspect, params.half_height_mm);
    out.position = vec4<f32>(ndc, 0.0, 1.0);
    // Every ray carries its grid's light: a hidden light's rays all land
    // on one point outside the view, so its triangles are empty and
    // culled before a pixel is shaded.
    let seen = clamp(visibility[u32(r.light)], 0.0, 1.0);
    out.color = cell.rgb * params.intensity * seen;
    if seen <= 0.0 {
        out.position = vec4<f32>(2.0, 2.0, 0.0, 1.0);
    }
    out.r_rel = r.r_rel;
    out.stop_first = r.stop_first;
#ifdef BLADED_IRIS
    out.stop_second = r.stop_second;
    out.stop_third = r.stop_third;
#endif
    out.wl = cell.w;
    return out;
}

@fragment
fn fragment(in: VertexOut) -> @location(0) vec4<f32> {
    // Blocked by a rim (the round stop included: a round iris is the
    // stop's rim, and its pixels need no more), or by the iris's blades at
    // any crossing of the stop plane (`aperture.wgsl`). Interpolating the
    // stop points and testing the iris cost a third of the draw.
    if in.r_rel > 1.0 {
        discard;
    }
#ifdef BLADED_IRIS
    if !aperture_contains_all(in.stop_first, in.stop_second, in.stop_third, params.blades, params.rotation, params.radius, params.arc_w) {
        discard;
    }
#endif
    var ring = 1.0;
    if params.ringing != 0u {
        ring = ringing_at(in.stop_first, in.wl);
    }
    return vec4<f32>(in.color * ring, 0.0);
}

// The most a starburst adds to a pixel: the light's own image is far
// brighter than any display, and the HDR target (16-bit floats, at most
// 65504) must not overflow where several lights' patterns meet.
const STARBURST_MAX: f32 = 4096.0;

struct StarburstOut {
    @builtin(position) position: vec4<f32>,
    // Texel coordinates in the starburst texture.
    @location(0) texel: vec2<f32>,
    @location(1) @interpolate(flat) color: vec3<f32>,
    // Where in the quad, −1..1 on each axis.
    @location(2) quad: vec2<f32>,
}

// One quad per light, centred on its image, `starburst_half_ndc` high.
@vertex
fn starburst_vertex(@builtin(vertex_index) vi: u32, @builtin(instance_index) light: u32) -> StarburstOut {
    var out: StarburstOut;
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, -1.0), vec2<f32>(1.0, 1.0),
        vec2<f32>(-1.0, -1.0), vec2<f32>(1.0, 1.0), vec2<f32>(-1.0, 1.0),
    );
    let c = corners[vi % 6u];
    let probe = lights[light];
    let seen = clamp(visibility[light], 0.0, 1.0);
    out.color = probe.color.rgb * seen * params.starburst_scale;
    let half = vec2<f32>(params.starburst_half_ndc / params.aspect, params.starburst_half_ndc);
    out.position = vec4<f32>(probe.ndc + c * half, 0.0, 1.0);
    // A light with no image (or fully hidden) draws nothing.
    if probe.read_depth == 0u || seen <= 0.0 {
        out.position = vec4<f32>(0.0, 0.0, -1.0, 1.0);
    }
    let size = vec2<f32>(textureDimensions(starburst_texture));
    out.texel = (c * vec2<f32>(1.0, -1.0) * 0.5 + 0.5) * size;
    out.quad = c;
    return out;
}

@fragment
fn starburst_fragment(in: StarburstOut) -> @location(0) vec4<f32> {
    let v = bilinear(starburst_texture, in.texel);
    // Faded out towards the quad's inscribed circle, so that the texture's
    // square edge does not show.
    let window = 1.0 - smoothstep(0.6, 1.0, length(in.quad));
    return vec4<f32>(min(in.color * max(v.rgb, vec3<f32>(0.0)) * window, vec3<f32>(STARBURST_MAX)), 0.0);
}
