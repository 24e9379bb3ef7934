// The flare's cell pass, between the trace and the draw: one invocation per
// cell of every traced grid. A cell that can add light (its four rays
// alive, not every corner blocked by a rim, its light not hidden) gets its
// colour written at its first corner: the irradiance from its change of
// area with the bounded gain (`optica_optics::lens_flare::cell_intensity`)
// times the grid's colour, the flare's intensity and the light's
// visibility. Its two triangles go to its six places in the index buffer;
// any other cell gets two empty triangles there (every index its first
// corner), which the rasteriser drops before shading a pixel. The draw
// then shades each ray once (shared vertices) instead of six times per
// cell, and adds the cells in the same order every frame (an order that
// changed would change the sum's rounding, and the flare would shimmer).
// Appended by the plugin to `flare_types.wgsl`.

@group(0) @binding(0) var<uniform> params: FlareParams;
@group(0) @binding(1) var<storage, read> jobs: array<GridJob>;
@group(0) @binding(2) var<storage, read> rays: array<RayOut>;
// Each light's visibility through the scene's depth (`visibility.wgsl`).
@group(0) @binding(3) var<storage, read> visibility: array<f32>;
// Per ray: the colour (rgb) and wavelength (w) of the cell whose first
// corner it is; the draw's provoking vertex reads it flat.
@group(0) @binding(4) var<storage, read_write> cell_colors: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> indices: array<u32>;

// The grid that cell `i` belongs to (grids lie in order).
fn job_of_cell(i: u32) -> u32 {
    var lo = 0u;
    var hi = params.jobs - 1u;
    while lo < hi {
        let mid = (lo + hi + 1u) / 2u;
        if jobs[mid].cell_base <= i {
            lo = mid;
        } else {
            hi = mid - 1u;
        }
    }
    return lo;
}

// Twice the signed area of the triangle a, b, c.
fn triangle_area2(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>) -> f32 {
    return (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
}

@compute @workgroup_size(64)
fn cells(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = id.x + id.y * groups.x * 64u;
    if i >= params.cells {
        return;
    }
    let job = jobs[job_of_cell(i)];
    let m = job.n - 1u;
    let k = i - job.cell_base;
    let first = job.ray_base + (k / m) * job.n + k % m;
    // Corners in the draw's order: the first, its right, below right, below.
    let ids = vec4<u32>(first, first + 1u, first + job.n + 1u, first + job.n);
    // Empty until the cell proves it adds light.
    for (var v = 0u; v < 6u; v += 1u) {
        indices[6u * i + v] = first;
    }
    let c0 = rays[ids.x];
    let c1 = rays[ids.y];
    let c2 = rays[ids.z];
    let c3 = rays[ids.w];
    if c0.alive * c1.alive * c2.alive * c3.alive < 0.5 {
        return;
    }
    // r_rel is interpolated over the cell: with every corner blocked (> 1)
    // every pixel would be.
    if min(min(c0.r_rel, c1.r_rel), min(c2.r_rel, c3.r_rel)) > 1.0 {
        return;
    }
    let seen = clamp(visibility[job.light], 0.0, 1.0);
    // The area the two triangles cover, |s1| + |s2| (`cell_intensity`): a
    // cell folded across a caustic crosses itself, and the signed quad
    // area would cancel there and overstate its irradiance.
    let a_p = job.cell_pupil_mm2;
    let a_s = 0.5 * (abs(triangle_area2(c0.sensor, c1.sensor, c2.sensor))
        + abs(triangle_area2(c0.sensor, c2.sensor, c3.sensor)));
    let mean_t = 0.25 * (c0.throughput + c1.throughput + c2.throughput + c3.throughput);
    let irradiance = mean_t * a_p / max(a_s, a_p / params.max_gain);
    let color = job.color.rgb * irradiance * params.intensity * seen;
    if seen <= 0.0 {
        return;
    }
    cell_colors[first] = vec4<f32>(color, job.color.w);
    let at = 6u * i;
    indices[at] = ids.x;
    indices[at + 1u] = ids.y;
    indices[at + 2u] = ids.z;
    indices[at + 3u] = ids.x;
    indices[at + 4u] = ids.z;
    indices[at + 5u] = ids.w;
}
