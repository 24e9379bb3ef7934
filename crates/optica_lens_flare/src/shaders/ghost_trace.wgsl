// The flare's compute passes: `trace` traces every ray of every ghost grid
// (one grid per ghost, wavelength and light) through the lens with
// `lens_trace.wgsl`, whose `surface_count` and `surface_at` it overrides to
// read the lens of the grid's wavelength. A grid's ray at pupil (u, v) starts at
// origin + u·du + v·dv and travels along dir; `lens_base` is where its
// wavelength's lens starts in `lens`; color.w is the wavelength, nm. Then
// `fill` continues the traced rays into the dead ones next to them.

#import optica_lens_flare::types::{FlareParams, GridJob, RayOut}
#import optica_lens_flare::lens_trace
#import optica_lens_flare::lens_trace::{LensSurface, trace_ray}

@group(0) @binding(0) var<uniform> params: FlareParams;
@group(0) @binding(1) var<storage, read> lens: array<LensSurface>;
@group(0) @binding(2) var<storage, read> jobs: array<GridJob>;
@group(0) @binding(3) var<storage, read_write> rays: array<RayOut>;

var<private> lens_base: u32;

override fn optica_lens_flare::lens_trace::surface_count() -> u32 {
    return params.surfaces;
}

override fn optica_lens_flare::lens_trace::surface_at(k: u32) -> LensSurface {
    return lens[lens_base + k];
}

// The grid that thread `i` traces for or, with `by_ray`, that ray `i`
// belongs to (grids lie in order).
fn job_of(i: u32, by_ray: bool) -> u32 {
    var lo = 0u;
    var hi = params.jobs - 1u;
    while lo < hi {
        let mid = (lo + hi + 1u) / 2u;
        if select(jobs[mid].thread_base, jobs[mid].ray_base, by_ray) <= i {
            lo = mid;
        } else {
            hi = mid - 1u;
        }
    }
    return lo;
}

@compute @workgroup_size(64)
fn trace(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = id.x + id.y * groups.x * 64u;
    if i >= params.threads {
        return;
    }
    let job = jobs[job_of(i, false)];
    let n = job.n;
    let k = i - job.thread_base;
    let step = 1.0 / f32(n - 1u);
    let col = k % n;
    let row = k / n;
    let u = f32(col) * step;
    let v = f32(row) * step;
    lens_base = job.lens_base;
    let o = job.origin + u * job.du + v * job.dv;
    let r = trace_ray(o, job.dir, job.first, job.second, params.sensor_z, job.color.w);
    let alive = select(0.0, 1.0, r.alive);
    rays[job.ray_base + row * n + col] = RayOut(
        turn(r.sensor, job.rotation), r.r_rel, r.throughput,
        turn(r.stop_first, job.rotation), turn(r.stop_second, job.rotation), turn(r.stop_third, job.rotation),
        alive, f32(job.light),
    );
    // With symmetry the mirror row lands at (x, −y) before the turn.
    let mirror = n - 1u - row;
    if job.rows < n && mirror != row {
        let m = vec2<f32>(1.0, -1.0);
        rays[job.ray_base + mirror * n + col] = RayOut(
            turn(r.sensor * m, job.rotation), r.r_rel, r.throughput,
            turn(r.stop_first * m, job.rotation), turn(r.stop_second * m, job.rotation), turn(r.stop_third * m, job.rotation),
            alive, f32(job.light),
        );
    }
}

// `p` turned by the angle whose (cos, sin) is `cs`.
fn turn(p: vec2<f32>, cs: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(cs.x * p.x - cs.y * p.y, cs.y * p.x + cs.x * p.y);
}

// Whether the ray at column `col`, row `row` of `job`'s grid was traced
// alive (alive 1; `fill` writes 0.5 into the rays it continues, and reads
// only traced ones, so the order it runs in does not matter).
fn traced(job: GridJob, col: i32, row: i32) -> bool {
    let n = i32(job.n);
    return col >= 0 && row >= 0 && col < n && row < n
        && rays[job.ray_base + u32(row * n + col)].alive == 1.0;
}

fn ray_at(job: GridJob, col: i32, row: i32) -> RayOut {
    return rays[job.ray_base + u32(row * i32(job.n) + col)];
}

// A dead ray next to traced ones gets their straight-line continuation:
// from each side whose next two rays a, b of its row or column were traced
// alive, 2a − b of their sensor and stop points and r_rel (the throughput
// of a), averaged over those sides. A ray that missed a sphere or met total
// internal reflection would
// otherwise leave every cell it is a corner of undrawn, though the part of
// the cell nearer the live rays passes; continued, its corner usually lands
// beyond a rim (r_rel > 1) and the draw's per-pixel clip cuts the cell
// where the light stops. The CPU twin is
// `optica_optics::lens_flare::RayGrid::extrapolated`.
@compute @workgroup_size(64)
fn fill(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let i = id.x + id.y * groups.x * 64u;
    if i >= params.rays || rays[i].alive != 0.0 {
        return;
    }
    let job = jobs[job_of(i, true)];
    let k = i - job.ray_base;
    let col = i32(k % job.n);
    let row = i32(k / job.n);
    var sides = array<vec2<i32>, 4>(vec2<i32>(1, 0), vec2<i32>(-1, 0), vec2<i32>(0, 1), vec2<i32>(0, -1));
    var sum = RayOut(vec2<f32>(0.0), 0.0, 0.0, vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0), 0.0, 0.0);
    var w = 0.0;
    for (var s = 0; s < 4; s += 1) {
        let d = sides[s];
        if !traced(job, col + d.x, row + d.y) || !traced(job, col + 2 * d.x, row + 2 * d.y) {
            continue;
        }
        let a = ray_at(job, col + d.x, row + d.y);
        let b = ray_at(job, col + 2 * d.x, row + 2 * d.y);
        sum.sensor += 2.0 * a.sensor - b.sensor;
        sum.r_rel += 2.0 * a.r_rel - b.r_rel;
        sum.throughput += a.throughput;
        sum.stop_first += 2.0 * a.stop_first - b.stop_first;
        sum.stop_second += 2.0 * a.stop_second - b.stop_second;
        sum.stop_third += 2.0 * a.stop_third - b.stop_third;
        w += 1.0;
    }
    if w > 0.0 {
        // A traced ray's r_rel holds the stop's rim (the draw skips the
        // test of a round iris for it); a straight-line r_rel can fall
        // below its stop points', so it is raised to theirs.
        let stop_first = sum.stop_first / w;
        let stop_second = sum.stop_second / w;
        let stop_third = sum.stop_third / w;
        let farthest = max(length(stop_first), max(length(stop_second), length(stop_third)));
        let at_stop = select(0.0, farthest / params.radius, params.radius > 0.0);
        rays[i] = RayOut(
            sum.sensor / w, max(sum.r_rel / w, at_stop), sum.throughput / w,
            stop_first, stop_second, stop_third,
            0.5, f32(job.light),
        );
    }
}
