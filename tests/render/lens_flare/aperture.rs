//! The aperture test (`aperture.wgsl`) against its CPU twin,
//! `Aperture::contains`, by readback: a 101² grid of stop-plane points over
//! round, six- and nine-bladed irises of several roundnesses and
//! rotations. Every point more than 1e-4 of the radius from the outline
//! gets the same answer (f32 against f64 decides the points on it).

use optica_harness::Headless;
use optica_lens_flare::twins::{APERTURE_WGSL, aperture_params};
use optica_optics::glam::DVec2;
use optica_optics::lens_flare::Aperture;

fn kernel() -> String {
    format!(
        "{}
@group(0) @binding(0) var<storage, read> input: array<f32>;
@group(0) @binding(1) var<storage, read_write> output: array<f32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
    let i = id.x;
    if i >= arrayLength(&output) {{ return; }}
    let p = vec2<f32>(input[4u + 2u * i], input[5u + 2u * i]);
    output[i] = select(0.0, 1.0, aperture_contains(p, u32(input[0]), input[1], input[2], input[3]));
}}",
        super::pasted(APERTURE_WGSL)
    )
}

#[test]
fn the_shader_tests_the_iris_like_its_cpu_twin() {
    let r = 12.5;
    let irises = [
        Aperture::circle(r).unwrap(),
        Aperture::blades(6, 0.0, 0.0, r).unwrap(),
        Aperture::blades(6, 0.3, 0.5, r).unwrap(),
        Aperture::blades(9, -1.0, 1.0, r).unwrap(),
        Aperture::blades(5, 2.0, 0.2, r).unwrap(),
    ];
    let n = 101;
    let points: Vec<DVec2> = (0..n * n)
        .map(|k| {
            let (i, j) = ((k % n) as f64, (k / n) as f64);
            DVec2::new(
                -1.2 * r + 2.4 * r * i / (n - 1) as f64,
                -1.2 * r + 2.4 * r * j / (n - 1) as f64,
            )
        })
        .collect();
    for iris in irises {
        let (blades, rotation, radius, w) = aperture_params(&iris);
        let mut input = vec![blades as f32, rotation, radius, w];
        input.extend(points.iter().flat_map(|p| [p.x as f32, p.y as f32]));
        let out = Headless::new(1, 1)
            .run_kernel(&kernel(), "main", &input, points.len())
            .expect("kernel");
        let (mut inside, mut differ) = (0, 0);
        for (k, p) in points.iter().enumerate() {
            let cpu = iris.contains(*p);
            inside += usize::from(cpu);
            if cpu != (out[k] == 1.0) {
                // Only on the outline: a nudge of 1e-4·r either way flips
                // the CPU's answer.
                let e = 1e-4 * r;
                let near = [DVec2::X, DVec2::Y, -DVec2::X, -DVec2::Y]
                    .iter()
                    .any(|d| iris.contains(*p + *d * e) != cpu);
                assert!(near, "{iris:?}: {p} CPU {cpu}, GPU {}", out[k]);
                differ += 1;
            }
        }
        eprintln!(
            "{iris:?}: {inside} of {} inside, {differ} on the outline differ",
            points.len()
        );
        assert!(inside > 3000, "{iris:?}: {inside}");
    }
}
