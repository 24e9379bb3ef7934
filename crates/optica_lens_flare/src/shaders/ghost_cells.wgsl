// The flare's cell pass, between the trace and the draw, run when the rays
// are traced again (the draw scales the colours by the flare's intensity
// and each light's visibility, so a still view's cells hold from frame to
// frame): every cell of every traced grid, a few cells of a row per
// invocation. A cell that can add light (its four rays alive, not every
// corner blocked by a rim) gets its colour written at its first corner:
// the irradiance from its change of area with the bounded gain
// (`optica_optics::lens_flare::cell_intensity`) times the grid's colour,
// with its wavelength. Its two triangles go to its
// six places in the index buffer; any other cell gets two empty triangles
// there (every index the same ray, `EMPTY`), which the rasteriser drops
// before shading a pixel. The draw then shades each ray once (shared vertices)
// instead of six times per cell, and adds the cells in the same order
// every frame (an order that changed would change the sum's rounding, and
// the flare would shimmer). A grid with `merge` set draws each smooth
// 2 × 2 block of its cells as one cell (`merged_block`): a large ghost's
// cells are smaller than its coarse pixels, and the draw's cost grows
// with their number.

#import optica_lens_flare::types::{FlareParams, GridJob, RayOut}
#import optica_lens_flare::aperture::aperture_contains_all

@group(0) @binding(0) var<uniform> params: FlareParams;
@group(0) @binding(1) var<storage, read> jobs: array<GridJob>;
@group(0) @binding(2) var<storage, read> rays: array<RayOut>;
// Per ray: the colour (rgb) and wavelength (w) of the cell whose first
// corner it is; the draw's provoking vertex reads it flat.
@group(0) @binding(3) var<storage, read_write> cell_colors: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> indices: array<u32>;

// Cells one invocation colours: a span of a row, whose shared corners are
// read once (lavapipe pays for every invocation, however small).
const SPAN_CELLS: u32 = 4u;

// The one ray every empty triangle is made of: the draw shades it once,
// not the first corner of every cell left out.
const EMPTY: u32 = 0u;

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
    // A merging grid's rows go in pairs, both coloured by the even row's
    // invocations (a last, unpaired row by its own, cell by cell).
    if job.merge > 0.0 {
        if (row & 1u) == 1u {
            return;
        }
        if row + 1u < m {
            for (var col = col0; col < min(col0 + SPAN_CELLS, m); col += 2u) {
                block(job, row, col);
            }
            return;
        }
    }
    let row_first = job.ray_base + row * job.n;
    // The span's left corners; each cell's right ones become the next's left.
    var left_top = rays[row_first + col0];
    var left_bottom = rays[row_first + col0 + job.n];
    for (var col = col0; col < min(col0 + SPAN_CELLS, m); col += 1u) {
        let first = row_first + col;
        let right_top = rays[first + 1u];
        let right_bottom = rays[first + job.n + 1u];
        cell(job, job.cell_base + row * m + col, first, left_top, right_top, right_bottom, left_bottom);
        left_top = right_top;
        left_bottom = right_bottom;
    }
}

// Colours cell `index` (among all grids' cells) with first corner `first`
// and corners c0..c3 in the draw's order (the first, its right, below
// right, below), and writes its triangles.
fn cell(job: GridJob, index: u32, first: u32, c0: RayOut, c1: RayOut, c2: RayOut, c3: RayOut) {
    let at = 6u * index;
    // (alive: 1 traced, 0.5 continued by the trace's fill, 0 dead.)
    if min(min(c0.alive, c1.alive), min(c2.alive, c3.alive)) <= 0.0
        // r_rel is interpolated over the cell: with every corner blocked
        // (> 1) every pixel would be.
        || min(min(c0.r_rel, c1.r_rel), min(c2.r_rel, c3.r_rel)) > 1.0 {
        for (var v = 0u; v < 6u; v += 1u) {
            indices[at + v] = EMPTY;
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
    cell_colors[first] = vec4<f32>(job.color.rgb * irradiance, job.color.w);
    let n = job.n;
    indices[at] = first;
    indices[at + 1u] = first + 1u;
    indices[at + 2u] = first + n + 1u;
    indices[at + 3u] = first;
    indices[at + 4u] = first + n + 1u;
    indices[at + 5u] = first + n;
}

// The 2 × 2 cells from row `row`, column `col` of `job` (one column when
// `col` is the last): drawn as one cell where they are smooth
// (`merged_block`), else cell by cell.
fn block(job: GridJob, row: u32, col: u32) {
    let n = job.n;
    let m = n - 1u;
    let f = job.ray_base + row * n + col;
    let index = job.cell_base + row * m + col;
    let r00 = rays[f];
    let r01 = rays[f + 1u];
    let r10 = rays[f + n];
    let r11 = rays[f + n + 1u];
    let r20 = rays[f + 2u * n];
    let r21 = rays[f + 2u * n + 1u];
    if col + 1u >= m {
        cell(job, index, f, r00, r01, r11, r10);
        cell(job, index + m, f + n, r10, r11, r21, r20);
        return;
    }
    let r02 = rays[f + 2u];
    let r12 = rays[f + n + 2u];
    let r22 = rays[f + 2u * n + 2u];
    // Every ray traced (not continued by the fill), inside every rim and
    // through the iris's blades: no pixel of the block is clipped, cell by
    // cell or as one.
    var merged = -1.0;
    if min(min(min(r00.alive, r01.alive), min(r02.alive, r10.alive)),
            min(min(r11.alive, r12.alive), min(min(r20.alive, r21.alive), r22.alive))) >= 1.0
        && max(max(max(r00.r_rel, r01.r_rel), max(r02.r_rel, r10.r_rel)),
            max(max(r11.r_rel, r12.r_rel), max(max(r20.r_rel, r21.r_rel), r22.r_rel))) <= 1.0
        && through_blades(r00) && through_blades(r01) && through_blades(r02)
        && through_blades(r10) && through_blades(r11) && through_blades(r12)
        && through_blades(r20) && through_blades(r21) && through_blades(r22) {
        merged = merged_block(job,
            r00.sensor, r01.sensor, r02.sensor, r10.sensor, r11.sensor, r12.sensor,
            r20.sensor, r21.sensor, r22.sensor,
            0.25 * vec4<f32>(r00.throughput + r01.throughput + r11.throughput + r10.throughput,
                r01.throughput + r02.throughput + r12.throughput + r11.throughput,
                r10.throughput + r11.throughput + r21.throughput + r20.throughput,
                r11.throughput + r12.throughput + r22.throughput + r21.throughput));
    }
    if merged < 0.0 {
        cell(job, index, f, r00, r01, r11, r10);
        cell(job, index + 1u, f + 1u, r01, r02, r12, r11);
        cell(job, index + m, f + n, r10, r11, r21, r20);
        cell(job, index + m + 1u, f + n + 1u, r11, r12, r22, r21);
        return;
    }
    cell_colors[f] = vec4<f32>(job.color.rgb * merged, job.color.w);
    let at = 6u * index;
    indices[at] = f;
    indices[at + 1u] = f + 2u;
    indices[at + 2u] = f + 2u * n + 2u;
    indices[at + 3u] = f;
    indices[at + 4u] = f + 2u * n + 2u;
    indices[at + 5u] = f + 2u * n;
    // The other three cells' triangles empty, so that the rays inside
    // the block are not shaded for them.
    for (var v = 0u; v < 6u; v += 1u) {
        indices[at + 6u + v] = EMPTY;
        indices[6u * (index + m) + v] = EMPTY;
        indices[6u * (index + m + 1u) + v] = EMPTY;
    }
}

// Whether ray `r` passes the iris's blades at every crossing of the stop
// plane (a round iris: always; its rim is in `r_rel`).
fn through_blades(r: RayOut) -> bool {
    return params.blades == 0u || aperture_contains_all(r.stop_first, r.stop_second, r.stop_third,
        params.blades, params.rotation, params.radius, params.arc_w);
}

// The doubled signed areas of the cell a, b, c, d's two triangles (a, b, c)
// and (a, c, d).
fn halves(a: vec2<f32>, b: vec2<f32>, c: vec2<f32>, d: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(triangle_area2(a, b, c), triangle_area2(a, c, d));
}

// The irradiance of the 2 × 2 cells on sensor points p00..p22 (row by
// row; `t` the four cells' mean throughputs) drawn as one cell, their
// power over the area the one cell covers (at most the brightest cell's
// irradiance); −1 where they are not smooth
// enough: a triangle of a cell or of the one cell turned against the
// others, a cell at the gain bound, irradiances apart by more than
// `job.merge` (the largest over the smallest, less 1), or the one cell's
// area off the four's by more than a tenth of that. The CPU twin is
// `optica_optics::lens_flare::merged_block`.
fn merged_block(job: GridJob, p00: vec2<f32>, p01: vec2<f32>, p02: vec2<f32>, p10: vec2<f32>,
        p11: vec2<f32>, p12: vec2<f32>, p20: vec2<f32>, p21: vec2<f32>, p22: vec2<f32>,
        t: vec4<f32>) -> f32 {
    let h0 = halves(p00, p01, p11, p10);
    let h1 = halves(p01, p02, p12, p11);
    let h2 = halves(p10, p11, p21, p20);
    let h3 = halves(p11, p12, p22, p21);
    let hb = halves(p00, p02, p22, p20);
    // With the orientation taken out every doubled area must be positive.
    let o = sign(h0.x);
    let lo = min(min(min(h0 * o, h1 * o), min(h2 * o, h3 * o)), hb * o);
    let a = 0.5 * o * vec4<f32>(h0.x + h0.y, h1.x + h1.y, h2.x + h2.y, h3.x + h3.y);
    let big = 0.5 * o * (hb.x + hb.y);
    let a_p = job.cell_pupil_area;
    if min(lo.x, lo.y) <= 0.0 || min(min(a.x, a.y), min(a.z, a.w)) < a_p / params.max_gain {
        return -1.0;
    }
    let e = t / a;
    let area = a.x + a.y + a.z + a.w;
    let e_lo = min(min(e.x, e.y), min(e.z, e.w));
    let e_hi = max(max(e.x, e.y), max(e.z, e.w));
    if e_hi > e_lo * (1.0 + job.merge) || abs(big - area) > 0.1 * job.merge * area {
        return -1.0;
    }
    return min((t.x + t.y + t.z + t.w) * a_p / big, e_hi * a_p);
}
