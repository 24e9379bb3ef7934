// The flare's compute pass: traces every ray of every ghost grid (one grid
// per ghost, wavelength and light) through the lens. Appended by the plugin
// to `lens_trace.wgsl` (whose `surface_count` and `surface_at` it
// supplies) and `flare_types.wgsl`. A grid's ray at pupil (u, v) starts at
// origin + u·du + v·dv and travels along dir; `lens_base` is where its
// wavelength's lens starts in `lens`; color.w is the wavelength, nm.

@group(0) @binding(0) var<uniform> params: FlareParams;
@group(0) @binding(1) var<storage, read> lens: array<LensSurface>;
@group(0) @binding(2) var<storage, read> jobs: array<GridJob>;
@group(0) @binding(3) var<storage, read_write> rays: array<RayOut>;

var<private> lens_base: u32;

fn surface_count() -> u32 {
    return params.surfaces;
}

fn surface_at(k: u32) -> LensSurface {
    return lens[lens_base + k];
}

// The grid that thread `i` traces for (grids lie in order).
fn job_of(i: u32) -> u32 {
    var lo = 0u;
    var hi = params.jobs - 1u;
    while lo < hi {
        let mid = (lo + hi + 1u) / 2u;
        if jobs[mid].thread_base <= i {
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
    let job = jobs[job_of(i)];
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
        turn(r.stop0, job.rotation), turn(r.stop1, job.rotation), turn(r.stop2, job.rotation),
        alive, 0.0,
    );
    // With symmetry the mirror row lands at (x, −y) before the turn.
    let mirror = n - 1u - row;
    if job.rows < n && mirror != row {
        let m = vec2<f32>(1.0, -1.0);
        rays[job.ray_base + mirror * n + col] = RayOut(
            turn(r.sensor * m, job.rotation), r.r_rel, r.throughput,
            turn(r.stop0 * m, job.rotation), turn(r.stop1 * m, job.rotation), turn(r.stop2 * m, job.rotation),
            alive, 0.0,
        );
    }
}

// `p` turned by the angle whose (cos, sin) is `cs`.
fn turn(p: vec2<f32>, cs: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(cs.x * p.x - cs.y * p.y, cs.y * p.x + cs.x * p.y);
}
