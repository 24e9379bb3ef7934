//! Bevy's own MSAA, error against run time: the rendering sweep every
//! plugin sweep is shaped after, and the frame-time baseline of the adapter.
//!
//! - Knob: MSAA samples per pixel (1, 2, 4, 8; counts the adapter cannot
//!   do are left out and said so in the report).
//! - Reference: the same scene rendered at [`SUPERSAMPLE`]× the size with
//!   MSAA off, box-filtered down in linear light.
//! - Error: PSNR (dB, higher is better), 1 − SSIM and mean ꟻLIP of the
//!   frame against the reference.
//! - Time: median frame time and the main opaque pass's GPU time
//!   (timestamp queries, [`optica_harness::Headless::time_frames`]), against
//!   the frame with MSAA off measured in the same run.

use bevy::prelude::*;
use bevy::render::view::Msaa;
use image::RgbaImage;
use optica_harness::{HarnessError, TimeSource};

use super::SweepError;
use crate::{Report, Row, SweepContext};

/// The reference is rendered at this many times the side and box-filtered
/// down: 16 samples per pixel on a regular grid, twice what the largest
/// MSAA setting takes, so it stays the better estimate of the pixel integral.
pub const SUPERSAMPLE: u32 = 4;

/// The span of Bevy's main opaque pass (`bevy_core_pipeline`).
pub const OPAQUE_PASS: &str = "main_opaque_pass_3d";

/// The sweep's scene: cubes and a sphere with many silhouette edges at all
/// angles, lit by a directional light without shadows (lavapipe spends most
/// of a shadowed frame on the shadow map, which MSAA does not touch).
pub fn scene(app: &mut App, samples: u32) {
    let msaa = match samples {
        1 => Msaa::Off,
        2 => Msaa::Sample2,
        4 => Msaa::Sample4,
        _ => Msaa::Sample8,
    };
    app.add_systems(
        Startup,
        move |mut commands: Commands,
              mut meshes: ResMut<Assets<Mesh>>,
              mut materials: ResMut<Assets<StandardMaterial>>| {
            let cube = meshes.add(Cuboid::new(0.6, 0.6, 0.6));
            for i in 0..9 {
                let (x, z) = ((i % 3) as f32 - 1.0, (i / 3) as f32 - 1.0);
                commands.spawn((
                    Mesh3d(cube.clone()),
                    MeshMaterial3d(materials.add(Color::hsl(40.0 * i as f32, 0.6, 0.55))),
                    Transform::from_xyz(x, 0.0, z).with_rotation(Quat::from_euler(
                        EulerRot::YXZ,
                        0.37 * i as f32,
                        0.21 * i as f32,
                        0.0,
                    )),
                ));
            }
            commands.spawn((
                Mesh3d(meshes.add(Sphere::new(0.35).mesh().uv(48, 24))),
                MeshMaterial3d(materials.add(Color::WHITE)),
                Transform::from_xyz(0.0, 0.65, 0.0),
            ));
            commands.spawn((
                DirectionalLight {
                    illuminance: 8_000.0,
                    shadow_maps_enabled: false,
                    ..default()
                },
                Transform::from_xyz(2.0, 4.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
            ));
            commands.spawn((
                Camera3d::default(),
                Camera {
                    clear_color: ClearColorConfig::Custom(Color::srgb(0.08, 0.09, 0.12)),
                    ..default()
                },
                msaa,
                Transform::from_xyz(2.2, 2.0, 2.6).looking_at(Vec3::new(0.0, 0.1, 0.0), Vec3::Y),
            ));
        },
    );
}

/// Box-filters `image` down by `factor` in linear light (sRGB decoded,
/// averaged, re-encoded with bevy_color).
pub fn downsample_linear(image: &RgbaImage, factor: u32) -> RgbaImage {
    let (w, h) = (image.width() / factor, image.height() / factor);
    RgbaImage::from_fn(w, h, |x, y| {
        let mut sum = LinearRgba::new(0.0, 0.0, 0.0, 0.0);
        for dy in 0..factor {
            for dx in 0..factor {
                let p = image.get_pixel(x * factor + dx, y * factor + dy).0;
                let c = LinearRgba::from(Srgba::rgba_u8(p[0], p[1], p[2], p[3]));
                sum = LinearRgba::new(
                    sum.red + c.red,
                    sum.green + c.green,
                    sum.blue + c.blue,
                    sum.alpha + c.alpha,
                );
            }
        }
        let n = (factor * factor) as f32;
        let mean = LinearRgba::new(sum.red / n, sum.green / n, sum.blue / n, sum.alpha / n);
        image::Rgba(Srgba::from(mean).to_u8_array())
    })
}

/// Runs the sweep.
pub fn run(ctx: &SweepContext) -> Result<Report, SweepError> {
    let size = ctx.pick(64, 256);
    let warmup = ctx.pick(1, 5);
    let knobs = [1u32, 2, 4, 8];

    ctx.progress(0, knobs.len() + 1, "reference");
    let reference = ctx
        .headless(size * SUPERSAMPLE, size * SUPERSAMPLE)
        .render(|app| scene(app, 1))?;
    let reference_image = downsample_linear(&reference.to_rgba8(), SUPERSAMPLE);
    let mut report = Report::rendered("render", "msaa_samples", reference.adapter.clone());
    report.reference = format!(
        "the same frame rendered at {SUPERSAMPLE}× the side ({0}², MSAA off) and box-filtered to {1}² in linear light",
        size * SUPERSAMPLE,
        size
    );
    report.baseline = format!(
        "the frame with MSAA off, {}; `opaque_gpu_ms` is the main opaque pass's GPU time",
        ctx.paired_words(warmup)
    );
    let (blocks, per_block) = ctx.blocks();
    let mut skipped = Vec::new();
    for (i, &samples) in knobs.iter().enumerate() {
        ctx.progress(i + 1, knobs.len() + 1, &format!("{samples} samples"));
        let headless = ctx.headless(size, size);
        let frame = match headless.render(|app| scene(app, samples)) {
            Ok(frame) => frame,
            // A sample count the adapter's formats do not support fails
            // validation; the row is left out, not faked.
            Err(HarnessError::Wgpu(e)) | Err(HarnessError::Exited(e)) if samples > 1 => {
                skipped.push(format!(
                    "{samples} ({})",
                    e.lines().next().unwrap_or_default()
                ));
                continue;
            }
            Err(e) => return Err(e.into()),
        };
        // Against MSAA off in alternating blocks (off against itself for
        // the first row: the interval noise alone gives).
        let paired = headless.time_paired(
            warmup,
            blocks,
            per_block,
            |app| scene(app, samples),
            |app| scene(app, 1),
        )?;
        let timings = &paired.effect;
        let m =
            optica_harness::metrics::compare(&reference_image, &frame.to_rgba8()).map_err(|e| {
                SweepError::Harness(HarnessError::Golden {
                    path: "reference".into(),
                    message: e.to_string(),
                })
            })?;
        let mut row = Row::paired(samples as f64, &paired)
            .err("psnr_db", m.psnr_db)
            .err("flip_mean", m.flip_mean)
            .err("one_minus_ssim", 1.0 - m.ssim)
            .timing("frame_iqr_ms", timings.frame_ms.iqr());
        if let Some(pass) = timings
            .pass(OPAQUE_PASS)
            .filter(|p| p.source == TimeSource::GpuTimestamps)
        {
            row = row.timing("opaque_gpu_ms", pass.ms.median);
        }
        report.rows.push(row);
    }
    if !skipped.is_empty() {
        report.reference.push_str(&format!(
            "; sample counts this adapter refused: {}",
            skipped.join(", ")
        ));
    }

    // Stability: the whole path on extreme inputs.
    let tiny = ctx.headless(1, 1).render(|app| scene(app, 1))?;
    let px = tiny.to_rgba8().get_pixel(0, 0).0;
    report.case(
        "1×1 target",
        px[3] == 255,
        format!("one pixel rendered: {px:?}"),
    );
    let hot = ctx.headless(32, 32).hdr(true).render(|app| {
        scene(app, 1);
        app.add_systems(PostStartup, |mut lights: Query<&mut DirectionalLight>| {
            for mut l in &mut lights {
                l.illuminance = 1e9;
            }
        });
    })?;
    let finite = hot
        .hdr()
        .is_some_and(|img| img.as_raw().iter().all(|v| v.is_finite()));
    let peak = hot.hdr().map_or(0.0, |img| {
        img.as_raw().iter().cloned().fold(0.0f32, f32::max)
    });
    report.case(
        "1e9 lux light, HDR",
        finite,
        format!("all pixels finite: {finite}, brightest {peak:.3e}"),
    );
    Ok(report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn downsampling_averages_in_linear_light() {
        // Black and white pixels average to linear 0.5, which is sRGB 188, not 128.
        let img = RgbaImage::from_fn(2, 2, |x, _| {
            if x == 0 {
                image::Rgba([0, 0, 0, 255])
            } else {
                image::Rgba([255; 4])
            }
        });
        let out = downsample_linear(&img, 2);
        assert_eq!(out.dimensions(), (1, 1));
        assert_eq!(out.get_pixel(0, 0).0, [188, 188, 188, 255]);
    }

    #[test]
    fn quick_sweep_renders_and_records_the_adapter() {
        let r = run(&SweepContext::new("render", true, true)).expect("render sweep on lavapipe");
        let adapter = r
            .adapter
            .as_ref()
            .expect("a rendering sweep records its adapter");
        assert!(adapter.name.contains("llvmpipe"), "{adapter:?}");
        assert!(r.problems().is_empty(), "{:#?}", r.problems());
        // MSAA off and 4× are Vulkan's required sample counts: always there.
        let knobs: Vec<f64> = r.rows.iter().map(|row| row.knob).collect();
        assert!(knobs.contains(&1.0) && knobs.contains(&4.0), "{knobs:?}");
        let flip = |k: f64| r.rows.iter().find(|row| row.knob == k).unwrap().error["flip_mean"];
        assert!(
            flip(4.0) < flip(1.0),
            "4× MSAA is not closer to the supersampled reference: {} vs {}",
            flip(4.0),
            flip(1.0)
        );
        // lavapipe has timestamp queries: the opaque pass has a GPU time.
        assert!(
            r.rows
                .iter()
                .all(|row| row.timings.contains_key("opaque_gpu_ms")),
            "{:?}",
            r.rows
        );
    }

    #[test]
    fn a_missing_adapter_fails_the_sweep() {
        let ctx = SweepContext::new("render", true, true)
            .with_adapter(optica_harness::Adapter::Named("no-such-gpu".into()));
        match run(&ctx) {
            Err(SweepError::Harness(HarnessError::WrongAdapter { .. })) => {}
            other => panic!("expected WrongAdapter, got {:?}", other.map(|r| r.adapter)),
        }
    }
}
