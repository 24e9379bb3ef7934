//! Headless runs: HDR readback, deterministic time, the plugin hook, the
//! pipeline check on wgpu's noop backend, and the errors a run reports.

use bevy::prelude::*;
use optica_harness::{Adapter, HarnessError, Headless, Pixels};

use crate::user_scene::{scene, spin};

/// The golden test's scene: a cube turning at 1 rad per second of Bevy time.
fn spinning_cube(app: &mut App) {
    app.add_systems(Startup, scene).add_systems(Update, spin);
}

#[test]
fn hdr_readback_is_linear_and_finite() {
    let frame = Headless::new(64, 64)
        .hdr(true)
        .render(spinning_cube)
        .expect("headless HDR render");
    let Pixels::Hdr(px) = &frame.pixels else {
        panic!("asked for HDR, got 8-bit")
    };
    assert_eq!((px.width(), px.height()), (64, 64));
    assert!(px.as_raw().iter().all(|v| v.is_finite()));
    // The clear colour sRGB 0.1 is 0.010 linear: the HDR buffer holds linear light.
    let corner = px.get_pixel(0, 0).0;
    assert!(
        (corner[0] - 0.010).abs() < 0.002,
        "corner {corner:?} is not linear 0.010"
    );
    let brightest = px.pixels().map(|p| p.0[0]).fold(0.0f32, f32::max);
    assert!(
        brightest > 0.1,
        "the lit cube is missing from the HDR frame"
    );
    // Encoding to 8 bits goes through sRGB: linear 0.010 is about 25/255.
    let srgb = frame.to_rgba8().get_pixel(0, 0).0;
    assert!((24..=27).contains(&srgb[0]), "corner encodes as {srgb:?}");
}

#[test]
fn time_is_deterministic_and_advances_per_frame() {
    let render = |frames: u32| {
        Headless::new(64, 64)
            .frames(frames)
            .render(spinning_cube)
            .expect("render")
            .to_rgba8()
    };
    // Same frame count, same pixels, whatever the machine's speed.
    assert_eq!(
        render(12),
        render(12),
        "two runs of the same animated scene differ"
    );
    // One more frame: the cube has turned by another 1/60 rad.
    assert_ne!(
        render(12),
        render(13),
        "time did not advance between frames"
    );
}

#[test]
fn the_plugins_hook_reaches_default_plugins() {
    Headless::new(16, 16)
        .adapter(Adapter::Noop)
        .default_plugins(|plugins| plugins.set(ImagePlugin::default_nearest()))
        .check_pipelines(|app| {
            let image = app.get_added_plugins::<ImagePlugin>();
            let filter = image[0].default_sampler.mag_filter;
            assert_eq!(
                filter,
                bevy::image::ImageFilterMode::Nearest,
                "the hook's ImagePlugin was not used"
            );
        })
        .expect("pipeline check");
}

#[test]
fn pipelines_compile_on_the_noop_backend() {
    let report = Headless::new(64, 64)
        .adapter(Adapter::Noop)
        .frames(2)
        .check_pipelines(spinning_cube)
        .unwrap_or_else(|e| panic!("pipeline check failed: {e}"));
    assert_eq!(report.adapter.backend, "Noop", "{:?}", report.adapter);
    // The mesh, the tonemapping and the upscaling pipelines at least.
    assert!(report.ok >= 3, "{report:?}");
    assert_eq!(report.pending, 0, "{report:?}");
    assert_eq!(report.labels.len(), report.ok);
}

#[test]
fn a_missing_adapter_is_an_error_not_a_fallback() {
    // Bevy falls back to lavapipe when the named adapter is missing; the
    // harness must refuse, or a "GPU" timing would come from the CPU.
    match Headless::new(16, 16)
        .adapter(Adapter::Named("no-such-gpu-9000".into()))
        .render(|_| {})
    {
        Err(HarnessError::WrongAdapter { wanted, got }) => {
            assert!(
                wanted.contains("no-such-gpu-9000") && got.contains("llvmpipe"),
                "{wanted} / {got}"
            )
        }
        other => panic!("expected WrongAdapter, got {other:?}"),
    }
}

#[test]
fn bad_requests_are_errors() {
    assert!(matches!(
        Headless::new(0, 10).render(|_| {}),
        Err(HarnessError::BadSize(0, 10))
    ));
    assert!(matches!(
        Headless::new(10, 9000).render(|_| {}),
        Err(HarnessError::BadSize(10, 9000))
    ));
    assert!(matches!(
        Headless::new(8, 8).adapter(Adapter::Noop).render(|_| {}),
        Err(HarnessError::NoPixelsOnNoop)
    ));
    assert!(matches!(
        Headless::new(8, 8).time_frames(0, 0, |_| {}),
        Err(HarnessError::NoFrames)
    ));
}
