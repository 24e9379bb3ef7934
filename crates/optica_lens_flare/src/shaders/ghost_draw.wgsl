// The flare's draw pass: every cell of every traced grid as two triangles
// on the screen, its irradiance from its change of area with the bounded
// gain (`optica_optics::lens_flare::cell_intensity`), clipped per pixel
// where r_rel > 1 or outside the iris, scaled by its light's visibility,
// added to the HDR view before tonemapping. Appended by the plugin to
// `aperture.wgsl` and `flare_types.wgsl`.

@group(0) @binding(0) var<uniform> params: FlareParams;
@group(0) @binding(1) var<storage, read> jobs: array<GridJob>;
@group(0) @binding(2) var<storage, read> rays: array<RayOut>;
// Each light's visibility through the scene's depth (`visibility.wgsl`).
@group(0) @binding(3) var<storage, read> visibility: array<f32>;

struct VertexOut {
    @builtin(position) position: vec4<f32>,
    @location(0) color: vec3<f32>,
    @location(1) r_rel: f32,
    // Where the ray crossed the stop plane (up to three times).
    @location(2) stop0: vec2<f32>,
    @location(3) stop1: vec2<f32>,
    @location(4) stop2: vec2<f32>,
}

// Twice the signed area of the quad a, b, c, d (shoelace).
fn quad_area2(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, d: vec2<f32>) -> f32 {
    return (a.x * b.y - b.x * a.y) + (b.x * c.y - c.x * b.y) + (c.x * d.y - d.x * c.y) + (d.x * a.y - a.x * d.y);
}

@vertex
fn vertex(@builtin(vertex_index) vi: u32, @builtin(instance_index) job_index: u32) -> VertexOut {
    var out: VertexOut;
    // Outside the clip volume unless the cell is alive.
    out.position = vec4<f32>(0.0, 0.0, -1.0, 1.0);
    out.color = vec3<f32>(0.0);
    out.r_rel = 2.0;
    let n = params.n;
    let m = n - 1u;
    let cell = vi / 6u;
    let ci = cell % m;
    let cj = cell / m;
    let base = job_index * n * n;
    var corners = array<RayOut, 4>(
        rays[base + cj * n + ci],
        rays[base + cj * n + ci + 1u],
        rays[base + (cj + 1u) * n + ci + 1u],
        rays[base + (cj + 1u) * n + ci],
    );
    if corners[0].alive * corners[1].alive * corners[2].alive * corners[3].alive < 0.5 {
        return out;
    }
    let job = jobs[job_index];
    let seen = clamp(visibility[job.light], 0.0, 1.0);
    if seen <= 0.0 {
        return out;
    }
    let a_p = job.cell_pupil_mm2;
    let a_s = 0.5 * abs(quad_area2(corners[0].sensor, corners[1].sensor, corners[2].sensor, corners[3].sensor));
    let mean_t = 0.25 * (corners[0].throughput + corners[1].throughput + corners[2].throughput + corners[3].throughput);
    let irradiance = mean_t * a_p / max(a_s, a_p / params.max_gain);
    var order = array<u32, 6>(0u, 1u, 2u, 0u, 2u, 3u);
    let r = corners[order[vi % 6u]];
    let ndc = -r.sensor / vec2<f32>(params.half_height_mm * params.aspect, params.half_height_mm);
    out.position = vec4<f32>(ndc, 0.0, 1.0);
    out.color = job.color.rgb * irradiance * params.intensity * seen;
    out.r_rel = r.r_rel;
    out.stop0 = r.stop0;
    out.stop1 = r.stop1;
    out.stop2 = r.stop2;
    return out;
}

@fragment
fn fragment(in: VertexOut) -> @location(0) vec4<f32> {
    // Blocked by a rim (the round stop included), or by the iris's blades
    // at any crossing of the stop plane (`aperture.wgsl`).
    let inside = aperture_contains(in.stop0, params.blades, params.rotation, params.radius, params.arc_w)
        && aperture_contains(in.stop1, params.blades, params.rotation, params.radius, params.arc_w)
        && aperture_contains(in.stop2, params.blades, params.rotation, params.radius, params.arc_w);
    if in.r_rel > 1.0 || !inside {
        discard;
    }
    return vec4<f32>(in.color, 0.0);
}
