//! The vertex shader's equidistant projection (`equidistant.wgsl`, reading
//! its parameters from the dome's `clip_from_view`) against
//! `optica_optics::dome::DomeProjection::project`, by compute readback.
//! Tolerance: 1e-4 of the image radius (NDC), as the plugin issue states;
//! depth (near/|p|) to 1e-5 relative.

use bevy::camera::CameraProjection;
use optica_dome::{DomeCamera, DomeClip};
use optica_harness::Headless;
use optica_optics::glam::DVec3;

/// The library under test, without its `#define_import_path` line, and a
/// kernel that projects each input point.
fn kernel() -> String {
    let library = include_str!("../../../crates/optica_dome/src/shaders/equidistant.wgsl")
        .lines()
        .filter(|l| !l.starts_with("#define_import_path"))
        .collect::<Vec<_>>()
        .join("\n");
    format!(
        "{library}
@group(0) @binding(0) var<storage, read> input: array<f32>;
@group(0) @binding(1) var<storage, read_write> output: array<f32>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {{
    let i = id.x;
    if 4u * i >= arrayLength(&output) {{ return; }}
    var m: mat4x4<f32>;
    for (var c = 0u; c < 4u; c++) {{
        m[c] = vec4<f32>(input[4u * c], input[4u * c + 1u], input[4u * c + 2u], input[4u * c + 3u]);
    }}
    let p = vec3<f32>(input[16u + 3u * i], input[17u + 3u * i], input[18u + 3u * i]);
    let clip = clip_of_view(p, m);
    output[4u * i] = clip.x / clip.w;
    output[4u * i + 1u] = clip.y / clip.w;
    output[4u * i + 2u] = clip.z / clip.w;
    output[4u * i + 3u] = select(0.0, 1.0, is_dome(m));
}}"
    )
}

/// Points all around the camera, up to 179.9° from the dome axis, at
/// distances from 0.3 to 300: a fixed spiral, so the test is reproducible.
fn points(dome: &optica_optics::dome::DomeProjection) -> Vec<DVec3> {
    let n = 500;
    (0..n)
        .map(|k| {
            let t = (k as f64 + 0.5) / n as f64;
            let theta = t * 179.9f64.to_radians();
            let phi = k as f64 * 2.399_963; // golden angle
            let distance = 0.3 * 1000f64.powf((k * 7 % n) as f64 / n as f64);
            let q = DVec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            dome.from_dome(q) * distance
        })
        .collect()
}

#[test]
fn the_shader_projects_like_its_cpu_twin() {
    let size = 4096;
    let half = size as f64 / 2.0;
    for (fov, tilt) in [
        (180.0, 0.0),
        (180.0, 25.0),
        (250.0, 0.0),
        (250.0, 90.0),
        (60.0, -10.0),
    ] {
        let camera = DomeCamera {
            fov_deg: fov,
            tilt_deg: tilt,
            ..Default::default()
        };
        let clip = DomeClip {
            theta_max: 0.5 * fov.to_radians(),
            tilt: tilt.to_radians(),
            near: camera.near,
            far: camera.far,
        };
        let cpu = camera.projection(size).expect("a valid dome");
        let points = points(&cpu);
        let mut input: Vec<f32> = clip.get_clip_from_view().to_cols_array().to_vec();
        input.extend(
            points
                .iter()
                .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32]),
        );
        let out = Headless::new(1, 1)
            .run_kernel(&kernel(), "main", &input, 4 * points.len())
            .expect("kernel");
        let (mut worst, mut beyond) = ((0.0f64, 0.0f64), 0);
        for (i, p) in points.iter().enumerate() {
            let got = &out[4 * i..4 * i + 4];
            assert_eq!(
                got[3], 1.0,
                "fov {fov}, tilt {tilt}: the matrix is not recognised as a dome's"
            );
            // Past the draw limit the vertex is dropped (depth < 0); next
            // to it f32 may round either way.
            let theta = cpu.theta(*p);
            let limit = cpu.theta_draw_limit();
            if theta > limit + 1e-4 {
                assert!(
                    got[2] < 0.0,
                    "fov {fov}, point {p} at θ = {theta}: not dropped"
                );
                beyond += 1;
                continue;
            }
            if theta > limit - 1e-4 {
                continue;
            }
            let image = cpu.project(*p).image_point().expect("not at the antipode");
            let want = ((image.pixel.x - half) / half, (half - image.pixel.y) / half);
            let d_ndc = (got[0] as f64 - want.0).hypot(got[1] as f64 - want.1);
            let depth = camera.near as f64 / image.distance;
            let d_depth = (got[2] as f64 - depth).abs() / depth;
            assert!(
                d_ndc < 1e-4 && d_depth < 1e-5,
                "fov {fov}, tilt {tilt}, point {p}: NDC ({}, {}) vs ({}, {}) (off {d_ndc:.2e}), depth {} vs {depth}",
                got[0],
                got[1],
                want.0,
                want.1,
                got[2]
            );
            worst = (worst.0.max(d_ndc), worst.1.max(d_depth));
        }
        assert!(beyond > 0, "fov {fov}: no point past the draw limit");
        eprintln!(
            "fov {fov}°, tilt {tilt}°: {} points ({beyond} dropped past the draw limit), worst NDC error {:.2e} of the image radius, depth {:.2e} relative",
            points.len(),
            worst.0,
            worst.1
        );
    }
}

#[test]
fn a_perspective_matrix_is_not_taken_for_a_dome() {
    let perspective = bevy::math::Mat4::perspective_infinite_reverse_rh(1.0, 1.0, 0.1);
    let mut input: Vec<f32> = perspective.to_cols_array().to_vec();
    input.extend([0.0, 0.0, -1.0]);
    let out = Headless::new(1, 1)
        .run_kernel(&kernel(), "main", &input, 4)
        .expect("kernel");
    assert_eq!(out[3], 0.0);
}
