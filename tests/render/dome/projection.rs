//! The vertex shader's fisheye projection (`projection.wgsl`, reading
//! its parameters from the dome's `clip_from_view`) against
//! `optica_optics::dome::DomeProjection::project`, by compute readback.
//! Tolerance: 1e-4 of the image radius (NDC), as the plugin issue states;
//! depth (near/|p|) to 1e-5 relative.

use bevy::camera::CameraProjection;
use optica_dome::{DomeCamera, DomeLens};
use optica_dome::twins::DomeClip;
use optica_harness::Headless;
use optica_optics::glam::{DVec2, DVec3};

/// The library under test, without its `#define_import_path` line, and a
/// kernel that projects each input point.
fn kernel() -> String {
    let library = include_str!("../../../crates/optica_dome/src/shaders/projection.wgsl")
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
    spiral()
        .into_iter()
        .map(|(q, distance)| dome.from_dome(q) * distance)
        .collect()
}

/// The kernel's output for `points` under `camera`'s projection on a
/// `width` × `height` target: per point NDC x, y, depth and whether the
/// matrix was taken for a dome's.
fn project_on_gpu(camera: &DomeCamera, width: u32, height: u32, points: &[DVec3]) -> Vec<f32> {
    let mut clip = DomeClip::of(camera);
    clip.update(width as f32, height as f32);
    let mut input: Vec<f32> = clip.get_clip_from_view().to_cols_array().to_vec();
    input.extend(
        points
            .iter()
            .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32]),
    );
    Headless::new(1, 1)
        .run_kernel(&kernel(), "main", &input, 4 * points.len())
        .expect("kernel")
}

/// Projects `points` with the shader for `camera` on a `width` × `height`
/// target and holds every result to the CPU twin; returns the worst NDC
/// and relative depth errors and how many points lay past the draw limit.
fn check_against_twin(camera: &DomeCamera, width: u32, height: u32) -> (f64, f64, usize) {
    let (fov, tilt, lens) = (camera.fov_deg, camera.tilt_deg, camera.lens);
    let cpu = camera
        .projection_of_target(width, height)
        .expect("a valid dome");
    let points = points(&cpu);
    let out = project_on_gpu(camera, width, height, &points);
    let half = DVec2::new(f64::from(width), f64::from(height)) / 2.0;
    let (mut worst, mut beyond) = ((0.0f64, 0.0f64), 0);
    for (i, p) in points.iter().enumerate() {
        let got = &out[4 * i..4 * i + 4];
        assert_eq!(
            got[3], 1.0,
            "{lens:?} fov {fov}, tilt {tilt}: the matrix is not recognised as a dome's"
        );
        // Past the draw limit the vertex is dropped (depth < 0); next
        // to it f32 may round either way.
        let theta = cpu.theta(*p);
        let limit = cpu.theta_draw_limit();
        if theta > limit + 1e-4 {
            assert!(
                got[2] < 0.0,
                "{lens:?} fov {fov}, point {p} at θ = {theta}: not dropped"
            );
            beyond += 1;
            continue;
        }
        if theta > limit - 1e-4 {
            continue;
        }
        let image = cpu.project(*p).image_point().expect("not at the antipode");
        let want = (
            (image.pixel.x - half.x) / half.x,
            (half.y - image.pixel.y) / half.y,
        );
        // NDC error relative to the image circle's radius (the larger of
        // the two axes' NDC scales is 1), and to the point's own radius
        // outside the circle (a stereographic 250° dome puts θ = 170° at
        // 8 radii, where f32 keeps ~1e-5 of it).
        let radius = want.0.hypot(want.1).max(1.0);
        let d_ndc = (got[0] as f64 - want.0).hypot(got[1] as f64 - want.1) / radius;
        let depth = camera.near as f64 / image.distance;
        let d_depth = (got[2] as f64 - depth).abs() / depth;
        assert!(
            d_ndc < 1e-4 && d_depth < 1e-5,
            "{lens:?} fov {fov}, tilt {tilt}, {width}×{height}, point {p}: NDC ({}, {}) vs ({}, {}) (off {d_ndc:.2e}), depth {} vs {depth}",
            got[0],
            got[1],
            want.0,
            want.1,
            got[2]
        );
        worst = (worst.0.max(d_ndc), worst.1.max(d_depth));
    }
    (worst.0, worst.1, beyond)
}

#[test]
fn the_shader_projects_like_its_cpu_twin() {
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
        let (ndc, depth, beyond) = check_against_twin(&camera, 4096, 4096);
        assert!(beyond > 0, "fov {fov}: no point past the draw limit");
        eprintln!(
            "fov {fov}°, tilt {tilt}°: {beyond} points dropped past the draw limit, worst NDC error {ndc:.2e} of the image radius, depth {depth:.2e} relative",
        );
    }
}

#[test]
fn every_lens_projects_like_its_cpu_twin_on_square_and_wide_targets() {
    for lens in DomeLens::FISHEYES {
        for (fov, tilt) in [(180.0, 0.0), (250.0, 20.0), (90.0, -10.0)] {
            if lens == DomeLens::Orthographic && fov > 180.0 {
                continue;
            }
            let camera = DomeCamera {
                fov_deg: fov,
                tilt_deg: tilt,
                lens,
                ..Default::default()
            };
            for (w, h) in [(4096, 4096), (1920, 1080), (600, 1000)] {
                let (ndc, depth, _) = check_against_twin(&camera, w, h);
                eprintln!(
                    "{} fov {fov}° tilt {tilt}° {w}×{h}: worst NDC {ndc:.2e}, depth {depth:.2e}",
                    lens.name()
                );
            }
        }
    }
}

/// The equirectangular branch of the shader against
/// `EquirectProjection::project`, tilted or not, on a 2:1 and a square
/// target (the panorama fills both): points all around, at every distance,
/// up to 0.06° from a pole; points within 1e-3 rad of the seam, whose side
/// f32 cannot tell, are left out.
#[test]
fn the_equirectangular_panorama_projects_like_its_cpu_twin() {
    for tilt in [0.0, 30.0] {
        let camera = DomeCamera {
            lens: DomeLens::Equirectangular,
            tilt_deg: tilt,
            ..Default::default()
        };
        for (w, h) in [(4096, 2048), (1000, 1000)] {
            let Ok(optica_optics::dome::Panorama::Equirectangular(cpu)) = camera.panorama(w, h)
            else {
                panic!("an equirectangular panorama");
            };
            let points: Vec<DVec3> = spiral()
                .into_iter()
                .map(|(q, distance)| cpu.from_frame(q) * distance)
                .collect();
            let out = project_on_gpu(&camera, w, h, &points);
            let half = DVec2::new(f64::from(w), f64::from(h)) / 2.0;
            let (mut worst, mut checked) = (0.0f64, 0);
            for (i, p) in points.iter().enumerate() {
                let got = &out[4 * i..4 * i + 4];
                assert_eq!(
                    got[3], 1.0,
                    "tilt {tilt}: not recognised as a dome's matrix"
                );
                let q = cpu.to_frame(*p);
                if q.x.atan2(q.z).abs() > std::f64::consts::PI - 1e-3 {
                    continue;
                }
                let pixel = cpu.project(*p).visible_pixel().expect("not on a pole");
                let want = ((pixel.x - half.x) / half.x, (half.y - pixel.y) / half.y);
                let d_ndc = (got[0] as f64 - want.0).hypot(got[1] as f64 - want.1);
                let depth = camera.near as f64 / p.length();
                let d_depth = (got[2] as f64 - depth).abs() / depth;
                assert!(
                    d_ndc < 1e-4 && d_depth < 1e-5,
                    "tilt {tilt}, {w}×{h}, point {p}: NDC ({}, {}) vs {want:?}, depth {} vs {depth}",
                    got[0],
                    got[1],
                    got[2]
                );
                worst = worst.max(d_ndc);
                checked += 1;
            }
            assert!(checked > 450, "only {checked} points checked");
            eprintln!("equirectangular, tilt {tilt}°, {w}×{h}: worst NDC error {worst:.2e}");
        }
    }
}

/// A fixed spiral of unit directions (frame coordinates: the third is the
/// image centre's) up to 179.9° from the centre, with distances from 0.3
/// to 300.
fn spiral() -> Vec<(DVec3, f64)> {
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
            (q, distance)
        })
        .collect()
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
