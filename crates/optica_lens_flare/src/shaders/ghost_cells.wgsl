// The flare's cell pass, between the trace and the draw: every cell of
// every traced grid, a few cells of a row per invocation. A cell that can add light (its four rays
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

#import optica_lens_flare::types::{FlareParams, GridJob, RayOut}

@group(0) @binding(0) var<uniform> params: FlareParams;
@group(0) @binding(1) var<storage, read> jobs: array<GridJob>;
@group(0) @binding(2) var<storage, read> rays: array<RayOut>;
// Each light's visibility through the scene's depth (`visibility.wgsl`).
@group(0) @binding(3) var<storage, read> visibility: array<f32>;
// Per ray: the colour (rgb) and wavelength (w) of the cell whose first
// corner it is; the draw's provoking vertex reads it flat.
@group(0) @binding(4) var<storage, read_write> cell_colors: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> indices: array<u32>;

// Cells one invocation colours: a span of a row, whose shared corners are
// read once (lavapipe pays for every invocation, however small).
const SPAN_CELLS: u32 = 4u;

// The grid that span `i` belongs to (grids lie in order).
fn job_of_span(i: u32) -> u32 {
    var lo = 0u;
    var hi = params.jobs - 1u;
    while lo < hi {
        let mid = (lo + hi + 1u) / 2u;
        if jobs[mid].span_base <= i {
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
    if i >= params.spans {
        return;
    }
    let job = jobs[job_of_span(i)];
    let m = job.n - 1u;
    let spans_per_row = (m + SPAN_CELLS - 1u) / SPAN_CELLS;
    let k = i - job.span_base;
    let row = k / spans_per_row;
    let col0 = (k % spans_per_row) * SPAN_CELLS;
    let seen = clamp(visibility[job.light], 0.0, 1.0);
    let row_first = job.ray_base + row * job.n;
    // The span's left corners; each cell's right ones become the next's left.
    var left_top = rays[row_first + col0];
    var left_bottom = rays[row_first + col0 + job.n];
    for (var col = col0; col < min(col0 + SPAN_CELLS, m); col += 1u) {
        let first = row_first + col;
        let right_top = rays[first + 1u];
        let right_bottom = rays[first + job.n + 1u];
        cell(job, job.cell_base + row * m + col, first, seen, left_top, right_top, right_bottom, left_bottom);
        left_top = right_top;
        left_bottom = right_bottom;
    }
}

// Colours cell `index` (among all grids' cells) with first corner `first`
// and corners c0..c3 in the draw's order (the first, its right, below
// right, below), and writes its triangles.
fn cell(job: GridJob, index: u32, first: u32, seen: f32, c0: RayOut, c1: RayOut, c2: RayOut, c3: RayOut) {
    let at = 6u * index;
    // (alive: 1 traced, 0.5 continued by the trace's fill, 0 dead.)
    if min(min(c0.alive, c1.alive), min(c2.alive, c3.alive)) <= 0.0 || seen <= 0.0
        // r_rel is interpolated over the cell: with every corner blocked
        // (> 1) every pixel would be.
        || min(min(c0.r_rel, c1.r_rel), min(c2.r_rel, c3.r_rel)) > 1.0 {
        for (var v = 0u; v < 6u; v += 1u) {
            indices[at + v] = first;
        }
        return;
    }
    // The area the two triangles cover, |s1| + |s2| (`cell_intensity`): a
    // cell folded across a caustic crosses itself, and the signed quad
    // area would cancel there and overstate its irradiance.
    let a_p = job.cell_pupil_area;
    let a_s = 0.5 * (abs(triangle_area2(c0.sensor, c1.sensor, c2.sensor))
        + abs(triangle_area2(c0.sensor, c2.sensor, c3.sensor)));
    let mean_t = 0.25 * (c0.throughput + c1.throughput + c2.throughput + c3.throughput);
    let irradiance = mean_t * a_p / max(a_s, a_p / params.max_gain);
    cell_colors[first] = vec4<f32>(job.color.rgb * irradiance * params.intensity * seen, job.color.w);
    let n = job.n;
    indices[at] = first;
    indices[at + 1u] = first + 1u;
    indices[at + 2u] = first + n + 1u;
    indices[at + 3u] = first;
    indices[at + 4u] = first + n + 1u;
    indices[at + 5u] = first + n;
}
