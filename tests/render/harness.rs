//! The harness on a real scene: golden comparison, its failure, HDR readback
//! and the pipeline check on wgpu's noop backend.

use bevy::prelude::*;
use optica_harness::{Adapter, Golden, GoldenOutcome, Headless, Tolerance};

use crate::scenes::lit_cube;

const SIZE: u32 = 128;

fn golden() -> Golden {
    Golden::new(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden"))
}

fn render_cube(yaw: f32) -> optica_harness::RenderedFrame {
    Headless::new(SIZE, SIZE)
        .render(|app| {
            app.add_systems(Startup, lit_cube(yaw));
        })
        .unwrap_or_else(|e| panic!("headless render failed: {e}"))
}

#[test]
fn lit_cube_matches_its_golden() {
    let frame = render_cube(0.5);
    eprintln!("adapter: {}", frame.adapter);
    assert!(frame.adapter.contains("llvmpipe"), "the goldens are lavapipe renders, got {}", frame.adapter);
    let image = frame.to_rgba8();
    // A cube must be there at all: the centre pixel is lit, not the clear colour.
    let centre = image.get_pixel(SIZE / 2, SIZE / 2);
    assert!(centre[0] > 60 && centre[0] > centre[2], "centre pixel {centre:?} is not the orange cube");
    let outcome = golden().assert_matches("lit_cube", &image, Tolerance::default());
    eprintln!("lit cube against the golden: {outcome:?}");
}

#[test]
fn golden_comparison_fails_when_the_scene_changes() {
    // The same scene with the cube turned by 0.15 rad more: a small change a
    // golden test must catch. Compared without update mode, whatever the env says.
    let turned = render_cube(0.65).to_rgba8();
    match golden().updating(false).compare("lit_cube", &turned, Tolerance::default()) {
        Ok(GoldenOutcome::Differs { metrics, .. }) => {
            eprintln!("turned cube against the golden: {metrics:?}");
            assert!(metrics.differing_fraction > Tolerance::default().max_differing_fraction)
        }
        other => panic!("a turned cube must not match the golden: {other:?}"),
    }
}

#[test]
fn hdr_readback_is_linear_and_finite() {
    let frame = Headless::new(64, 64)
        .hdr(true)
        .render(|app| {
            app.add_systems(Startup, lit_cube(0.5));
        })
        .unwrap_or_else(|e| panic!("headless HDR render failed: {e}"));
    let px = frame.hdr.as_ref().expect("hdr pixels");
    assert_eq!(px.len(), 64 * 64);
    assert!(px.iter().all(|p| p.iter().all(|v| v.is_finite())));
    // The clear colour sRGB 0.1 is 0.01 linear: the HDR buffer holds linear light.
    let corner = px[0];
    assert!((corner[0] - 0.010).abs() < 0.002, "corner {corner:?} is not linear 0.010");
    let brightest = px.iter().map(|p| p[0]).fold(0.0f32, f32::max);
    assert!(brightest > 0.1, "the lit cube is missing from the HDR frame");
}

#[test]
fn pipelines_compile_on_the_noop_backend() {
    let report = Headless::new(64, 64)
        .adapter(Adapter::Noop)
        .frames(2)
        .check_pipelines(|app| {
            app.add_systems(Startup, lit_cube(0.5));
        })
        .unwrap_or_else(|e| panic!("pipeline check failed: {e}"));
    assert!(report.adapter.contains("Noop"), "{}", report.adapter);
    // The mesh, the tonemapping and the upscaling pipelines at least.
    assert!(report.ok >= 3, "{report:?}");
    assert_eq!(report.pending, 0, "{report:?}");
}
