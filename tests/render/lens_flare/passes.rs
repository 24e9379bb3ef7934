//! The flare's passes on lavapipe: a sun 12° off the axis of a camera with
//! the coated Tessar draws ghosts (finite, bounded, along the line through
//! the sun's image and the centre); the sun behind the camera draws none;
//! and a scene without `LensFlare` builds no flare pipeline.

use bevy::prelude::*;
use optica_harness::{Adapter, Headless, PipelineReport, RenderedFrame};
use optica_lens_flare::{LensFlare, LensFlarePlugin};

const SIZE: u32 = 128;
const TESSAR: &str = "lenses/tessar-us2854889.lens";

/// A black scene, a camera with the Tessar's flare (or none) looking along
/// −Z, and a sun whose light travels along `travel`.
fn scene(travel: Vec3, flare: bool) -> impl FnOnce(&mut App) {
    scene_with(travel, flare, |_| {})
}

fn scene_with(
    travel: Vec3,
    flare: bool,
    edit: impl Fn(&mut LensFlare) + Send + Sync + 'static,
) -> impl FnOnce(&mut App) {
    move |app: &mut App| {
        app.add_plugins(LensFlarePlugin);
        app.add_systems(
            Startup,
            move |mut commands: Commands, assets: Res<AssetServer>| {
                commands.spawn(super::sun(travel, 100_000.0));
                let mut camera = commands.spawn((super::black_hdr_camera(), Transform::IDENTITY));
                if flare {
                    let mut settings = LensFlare {
                        grid: 24,
                        intensity: 1.0,
                        ..LensFlare::new(assets.load(TESSAR))
                    };
                    edit(&mut settings);
                    camera.insert(settings);
                }
            },
        );
    }
}

fn render(travel: Vec3) -> RenderedFrame {
    Headless::new(SIZE, SIZE)
        .hdr(true)
        .frames(12)
        .render(scene(travel, true))
        .expect("render")
}

/// The flare's total light (sum of all channels) with `edit` applied.
fn total(edit: impl Fn(&mut LensFlare) + Send + Sync + 'static) -> f64 {
    let frame = Headless::new(SIZE, SIZE)
        .hdr(true)
        .frames(12)
        .render(scene_with(
            Vec3::new(-0.15, -0.15, 1.0).normalize(),
            true,
            edit,
        ))
        .expect("render");
    let img = frame.hdr().expect("HDR");
    img.as_raw()
        .chunks(4)
        .map(|p| f64::from(p[0] + p[1] + p[2]))
        .sum()
}

/// The iris clips the ghosts per pixel: five straight blades let through
/// less than the round stop they are inscribed in (a pentagon has 76 % of
/// its circumcircle's area), but most of it.
#[test]
fn the_iris_blades_clip_the_ghosts() {
    let round = total(|f| f.aperture.blades = 0);
    let five = total(|f| {
        f.aperture.blades = 5;
        f.aperture.roundness = 0.0;
    });
    eprintln!("flare light: round iris {round:.1}, five blades {five:.1}");
    assert!(
        five < 0.97 * round && five > 0.5 * round,
        "{five} vs {round}"
    );
}

/// (pixels lit above `floor`, largest value, all finite).
fn lit(frame: &RenderedFrame, floor: f32) -> (usize, f32, bool) {
    let img = frame.hdr().expect("HDR frame");
    let finite = img.as_raw().iter().all(|v| v.is_finite());
    let mut n = 0;
    let mut max = 0f32;
    for p in img.pixels() {
        let v = p.0[0].max(p.0[1]).max(p.0[2]);
        max = max.max(v);
        n += usize::from(v > floor);
    }
    (n, max, finite)
}

#[test]
fn a_sun_off_axis_flares_and_a_sun_behind_does_not() {
    // Light from up and to the right, 12° off the axis, travelling into
    // the camera (+Z in view space, the camera looking along −Z).
    let off = Vec3::new(-0.15, -0.15, 1.0).normalize();
    let frame = render(off);
    let (n, max, finite) = lit(&frame, 1e-4);
    eprintln!("sun 12° off axis: {n} px lit, brightest {max}");
    if let Ok(dir) = std::env::var("OPTICA_FLARE_DEBUG") {
        let img = frame.hdr().expect("HDR");
        let png = image::RgbaImage::from_fn(SIZE, SIZE, |x, y| {
            let p = img.get_pixel(x, y).0;
            let t = |v: f32| ((v * 20.0).min(1.0).powf(1.0 / 2.2) * 255.0) as u8;
            image::Rgba([t(p[0]), t(p[1]), t(p[2]), 255])
        });
        png.save(format!("{dir}/flare.png")).expect("png");
    }
    assert!(finite, "a non-finite pixel");
    assert!(n > 200, "only {n} px of flare");
    assert!(max < 1e4, "unbounded: {max}");
    // Ghosts lie on the line from the sun's image (upper right) through the
    // centre; the brightest (a focused one) lies beyond it, lower left.
    let img = frame.hdr().expect("HDR");
    let (bx, by, _) = img
        .enumerate_pixels()
        .map(|(x, y, p)| (x, y, p.0[0] + p.0[1] + p.0[2]))
        .fold((0, 0, 0f32), |a, b| if b.2 > a.2 { b } else { a });
    eprintln!("brightest flare pixel ({bx}, {by}) of {SIZE}²");
    assert!(
        bx < SIZE / 2 && by > SIZE / 2,
        "brightest at ({bx}, {by}), not lower left"
    );
    assert!(bx.abs_diff(SIZE - by) < 12, "({bx}, {by}) off the diagonal");
    // Behind the camera: no light enters the lens.
    let (n, _, finite) = lit(&render(Vec3::new(0.1, 0.1, -1.0).normalize()), 1e-6);
    assert!(finite);
    assert_eq!(n, 0, "{n} px lit by a sun behind the camera");
}

fn pipelines(setup: impl FnOnce(&mut App)) -> PipelineReport {
    Headless::new(32, 32)
        .adapter(Adapter::Noop)
        .frames(6)
        .check_pipelines(setup)
        .expect("pipelines compile")
}

#[test]
fn no_flare_camera_no_flare_pipeline() {
    let travel = Vec3::new(-0.15, -0.15, 1.0).normalize();
    let without = pipelines(scene(travel, false));
    assert!(
        !without.labels.iter().any(|l| l.contains("lens_flare")),
        "{:?}",
        without.labels
    );
    let with = pipelines(scene(travel, true));
    eprintln!("{:?}", with.labels);
    for want in ["optica_lens_flare_trace", "optica_lens_flare_draw"] {
        assert!(
            with.labels.iter().any(|l| l == want),
            "{want}: {:?}",
            with.labels
        );
    }
}
