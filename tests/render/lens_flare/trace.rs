//! The trace shader (`lens_trace.wgsl`) against its CPU twin,
//! `optica_optics::lens::PreparedLens::trace_to`, by compute readback: a
//! grid of rays through several ghosts of the coated Tessar and double
//! Gauss, on and off axis, at three wavelengths, both sides tracing the
//! same (f32) rays. f32 against f64, for rays landing within 50 mm of the
//! axis (a 24 × 36 mm frame and its surroundings): sensor positions within
//! 2e-3 mm, throughput within 1e-3 relative (plus 1e-9 absolute); for
//! every ray: positions within 2e-3 of their distance from the axis (the
//! rear ghosts of both lenses leave at steep angles and land up to 800 mm
//! out, where f32's relative round-off is amplified ~10³), r_rel within
//! 1e-3, stop crossings within 2e-3 mm. Rays alive on one side and dead
//! on the other only where the CPU ray passes within 0.05 mm of a
//! surface's edge of existence (a miss or total internal reflection).

use optica_harness::Headless;
use optica_lens_flare::twins::{LENS_TRACE_WGSL, SURFACE_FLOATS, pack_surfaces};
use optica_optics::lens::{self, Coating, LensPrescription, PreparedLens, TracePath, builtin};
use optica_optics::lens_flare::{Beam, coat_air_interfaces, light_from_field};

/// Rays landing this close to the axis, mm, are held to absolute bounds.
const IN_FRAME_MM: f64 = 50.0;

/// Floats the kernel writes per ray.
const OUT: usize = 11;

/// The library and a kernel that traces each input ray. Input: surface
/// count, first, second, sensor z, wavelength, ray count, the surface
/// records, then origin and direction per ray.
fn kernel() -> String {
    format!(
        "{}
@group(0) @binding(0) var<storage, read> input: array<f32>;
@group(0) @binding(1) var<storage, read_write> output: array<f32>;
const HEADER: u32 = 6u;
fn surface_count() -> u32 {{ return u32(input[0]); }}
fn surface_at(k: u32) -> LensSurface {{
    let b = HEADER + {SURFACE_FLOATS}u * k;
    return LensSurface(input[b], input[b + 1u], input[b + 2u], input[b + 3u],
        input[b + 4u], input[b + 5u], input[b + 6u], input[b + 7u]);
}}
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
    let i = id.x;
    let rays = u32(input[5]);
    if i >= rays {{ return; }}
    let base = HEADER + {SURFACE_FLOATS}u * surface_count() + 6u * i;
    let o = vec3<f32>(input[base], input[base + 1u], input[base + 2u]);
    let d = vec3<f32>(input[base + 3u], input[base + 4u], input[base + 5u]);
    let r = trace_ray(o, d, u32(input[1]), u32(input[2]), input[3], input[4]);
    let w = {OUT}u * i;
    output[w] = select(0.0, 1.0, r.alive);
    output[w + 1u] = r.sensor.x;
    output[w + 2u] = r.sensor.y;
    output[w + 3u] = r.r_rel;
    output[w + 4u] = r.throughput;
    output[w + 5u] = r.stop_first.x;
    output[w + 6u] = r.stop_first.y;
    output[w + 7u] = r.stop_second.x;
    output[w + 8u] = r.stop_second.y;
    output[w + 9u] = r.stop_third.x;
    output[w + 10u] = r.stop_third.y;
}}",
        super::pasted(LENS_TRACE_WGSL)
    )
}

/// How far the worst ray of a case was off, and how many rays disagreed
/// on being alive.
#[derive(Default, Debug)]
struct Worst {
    /// Rays landing within `IN_FRAME_MM` of the axis.
    sensor_mm: f64,
    /// Every ray: |Δ| / max(|p|, 1 mm).
    sensor_rel: f64,
    r_rel: f64,
    /// Rays landing within `IN_FRAME_MM` of the axis.
    throughput_rel: f64,
    stop_mm: f64,
    compared: usize,
    alive_mismatch: usize,
}

/// Traces a 24 × 24 grid of `beam` through `path` on the GPU and on the
/// CPU, and compares them.
fn compare(prescription: &LensPrescription, path: TracePath, field_deg: f64, wl: f64) -> Worst {
    let lens = PreparedLens::new(prescription, wl).expect("prepared");
    let light = light_from_field(field_deg, 30.0);
    let beam = Beam::for_path(prescription, path, light, wl).expect("beam");
    let n = 24;
    // The rays as the GPU gets them (rounded to f32), so that both sides
    // trace the same rays.
    let f32_rounded = |v: optica_optics::glam::DVec3| v.as_vec3().as_dvec3();
    let rays: Vec<_> = (0..n * n)
        .map(|k| {
            let (u, v) = (
                (k % n) as f64 / (n - 1) as f64,
                (k / n) as f64 / (n - 1) as f64,
            );
            let r = beam.ray_at(u, v).expect("ray");
            lens::Ray::new(f32_rounded(r.origin()), f32_rounded(r.dir())).expect("ray")
        })
        .collect();
    let TracePath::Ghost { first, second } = path else {
        panic!("ghost paths only")
    };
    let sensor_z = lens.table_sensor_z();
    let surfaces = pack_surfaces(&lens);
    let mut input = vec![
        surfaces.len() as f32,
        first as f32,
        second as f32,
        sensor_z as f32,
        wl as f32,
        rays.len() as f32,
    ];
    input.extend(surfaces.iter().flatten());
    for r in &rays {
        let (o, d) = (r.origin(), r.dir());
        input.extend([o.x, o.y, o.z, d.x, d.y, d.z].map(|v| v as f32));
    }
    let out = Headless::new(1, 1)
        .run_kernel(&kernel(), "main", &input, OUT * rays.len())
        .expect("kernel");
    let mut w = Worst::default();
    for (k, ray) in rays.iter().enumerate() {
        let g = &out[OUT * k..OUT * (k + 1)];
        let cpu = lens.trace_to(*ray, path, sensor_z);
        let gpu_alive = g[0] == 1.0;
        match cpu {
            Ok(c) if gpu_alive => {
                w.compared += 1;
                let ds = (c.position.x - f64::from(g[1])).hypot(c.position.y - f64::from(g[2]));
                let reach = c.position.truncate().length();
                w.sensor_rel = w.sensor_rel.max(ds / reach.max(1.0));
                w.r_rel = w.r_rel.max((c.r_rel - f64::from(g[3])).abs());
                if reach <= IN_FRAME_MM {
                    w.sensor_mm = w.sensor_mm.max(ds);
                    // Relative, with an absolute floor of 1e-9 (1e-6 · 1e-3).
                    let dt = (c.throughput - f64::from(g[4])).abs() / (c.throughput + 1e-6);
                    w.throughput_rel = w.throughput_rel.max(dt);
                }
                for s in 0..3 {
                    let (x, y) = (f64::from(g[5 + 2 * s]), f64::from(g[6 + 2 * s]));
                    let want = c.stop_xy_all[s];
                    w.stop_mm = w.stop_mm.max((want.x - x).hypot(want.y - y));
                }
            }
            Err(_) if !gpu_alive => {}
            _ => {
                // One side alive, the other dead: allowed only at the edge
                // of a miss (a ray nudged 0.05 mm changes its fate).
                let near_edge = [-0.05, 0.05].iter().any(|&dx| {
                    let nudged = lens::Ray::new(
                        ray.origin() + optica_optics::glam::DVec3::new(dx, dx, 0.0),
                        ray.dir(),
                    )
                    .expect("ray");
                    lens.trace_to(nudged, path, sensor_z).is_ok() != cpu.is_ok()
                });
                assert!(
                    near_edge,
                    "{path:?} at {field_deg}°, {wl} nm, ray {k}: CPU {:?}, GPU alive {gpu_alive}",
                    cpu.map(|c| c.position)
                );
                w.alive_mismatch += 1;
            }
        }
    }
    w
}

#[test]
fn the_shader_traces_ghosts_like_its_cpu_twin() {
    let coat = Coating::quarter_wave(1.38, 550.0).expect("coating");
    let lenses = [
        (
            "Tessar",
            coat_air_interfaces(&builtin::tessar(), coat).expect("coated"),
        ),
        (
            "double Gauss",
            coat_air_interfaces(&builtin::double_gauss(), coat).expect("coated"),
        ),
    ];
    let mut all = Worst::default();
    for (name, p) in &lenses {
        let paths = lens::ghosts(p);
        // The first, a middle and the last ghost of each lens: paths in
        // front of, straddling and behind the stop.
        for &(i, j) in [paths[0], paths[paths.len() / 2], paths[paths.len() - 1]].iter() {
            for field in [0.0, 12.0] {
                for wl in [440.0, 550.0, 650.0] {
                    let w = compare(p, TracePath::ghost(i, j), field, wl);
                    eprintln!("{name} ({i}, {j}) at {field}°, {wl} nm: {w:?}");
                    all.sensor_mm = all.sensor_mm.max(w.sensor_mm);
                    all.sensor_rel = all.sensor_rel.max(w.sensor_rel);
                    all.r_rel = all.r_rel.max(w.r_rel);
                    all.throughput_rel = all.throughput_rel.max(w.throughput_rel);
                    all.stop_mm = all.stop_mm.max(w.stop_mm);
                    all.compared += w.compared;
                    all.alive_mismatch += w.alive_mismatch;
                }
            }
        }
    }
    eprintln!("all: {all:?}");
    assert!(all.compared > 2_000, "{all:?}");
    assert!(all.sensor_mm < 2e-3, "{all:?}");
    assert!(all.sensor_rel < 2e-3, "{all:?}");
    assert!(all.r_rel < 1e-3, "{all:?}");
    assert!(all.throughput_rel < 1e-3, "{all:?}");
    assert!(all.stop_mm < 2e-3, "{all:?}");
    assert!(all.alive_mismatch * 1000 < all.compared, "{all:?}");
}
