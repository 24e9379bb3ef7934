//! Stiff cases of the flare: a light on the axis, 60° off it (outside the
//! view), the Heliar's plano surface, the double Gauss wide open at f/1.1
//! and the Tessar stopped to f/32; an f-number faster than the lens and a
//! malformed lens file are refused with a reason. Each: no NaN or infinite
//! pixel, bounded values, no panic.

use bevy::asset::AssetPlugin;
use bevy::prelude::*;
use optica_harness::Headless;
use optica_lens_flare::{FlareGhosts, LensFlare, LensFlarePlugin};
use std::sync::{Arc, Mutex};

const SIZE: u32 = 96;

/// Renders a sun travelling along `travel` through `lens` (a path under
/// `root`) with `edit` applied; (largest channel value, all finite, the
/// flare's problem, drawn ghosts).
fn case(
    root: &'static str,
    lens: &'static str,
    travel: Vec3,
    edit: impl Fn(&mut LensFlare) + Send + Sync + 'static,
) -> (f32, bool, Option<String>, usize) {
    let seen = Arc::new(Mutex::new((None, 0)));
    let log = seen.clone();
    let frame = Headless::new(SIZE, SIZE)
        .hdr(true)
        .frames(12)
        .default_plugins(move |g| {
            g.set(AssetPlugin {
                file_path: root.into(),
                ..default()
            })
        })
        .render(move |app: &mut App| {
            app.add_plugins(LensFlarePlugin);
            app.add_systems(
                Startup,
                move |mut commands: Commands, assets: Res<AssetServer>| {
                    commands.spawn(super::sun(travel, 100_000.0));
                    let mut flare = LensFlare {
                        grid: 16,
                        ..LensFlare::new(assets.load(lens))
                    };
                    edit(&mut flare);
                    commands.spawn((super::black_hdr_camera(), flare));
                },
            );
            app.add_systems(Last, move |ghosts: Query<&FlareGhosts>| {
                if let Ok(g) = ghosts.single() {
                    *log.lock().expect("log") = (g.problem.clone(), g.drawn().count());
                }
            });
        })
        .expect("render");
    let img = frame.hdr().expect("HDR");
    let finite = img.as_raw().iter().all(|v| v.is_finite());
    // (Colour channels only: alpha is 1.)
    let max = img
        .as_raw()
        .chunks(4)
        .flat_map(|p| p[..3].to_vec())
        .fold(0f32, f32::max);
    let (problem, drawn) = seen.lock().expect("log").clone();
    (max, finite, problem, drawn)
}

const ASSETS: &str = "assets";
const TESSAR: &str = "lenses/tessar-us2854889.lens";

#[test]
fn stiff_cases_stay_finite_and_bounded() {
    let axis = Vec3::Z;
    let sixty = Vec3::new(-60f32.to_radians().sin(), 0.0, 60f32.to_radians().cos());
    /// (name, lens, travel, settings).
    type Case = (&'static str, &'static str, Vec3, fn(&mut LensFlare));
    let cases: [Case; 6] = [
        ("on axis", TESSAR, axis, |_| {}),
        ("60° off axis, outside the view", TESSAR, sixty, |_| {}),
        (
            "Heliar (plano surface)",
            "lenses/heliar-us2645156.lens",
            Vec3::new(0.1, 0.1, 1.0),
            |_| {},
        ),
        (
            "double Gauss at f/1.1",
            "lenses/double-gauss-us2701982.lens",
            Vec3::new(0.1, -0.1, 1.0),
            |_| {},
        ),
        ("Tessar at f/32", TESSAR, Vec3::new(0.1, 0.1, 1.0), |f| {
            f.aperture.f_number = Some(32.0)
        }),
        (
            "zoom (33 interfaces), every unblocked ghost, 25° off axis",
            "lenses/zoom-canon-us5537259.lens",
            Vec3::new(0.3, -0.3, 0.9),
            |f| {
                f.ghost_budget = 528;
                f.min_relative = 0.0;
                f.grid = 8;
            },
        ),
    ];
    for (name, lens, travel, edit) in cases {
        let (max, finite, problem, drawn) = case(ASSETS, lens, travel.normalize(), edit);
        eprintln!("{name}: brightest {max}, {drawn} ghosts drawn, problem {problem:?}");
        assert!(finite, "{name}: a non-finite pixel");
        assert!(max > 0.0 && max < 1e4, "{name}: {max}");
        assert_eq!(problem, None, "{name}");
        assert!(drawn > 0, "{name}: no ghost drawn");
    }
}

#[test]
fn impossible_settings_and_malformed_files_are_refused() {
    // f/1 on an f/2.8 lens: refused, no flare, no panic.
    let (max, finite, problem, _) =
        case(ASSETS, TESSAR, Vec3::new(0.1, 0.1, 1.0).normalize(), |f| {
            f.aperture.f_number = Some(1.0)
        });
    assert!(finite && max == 0.0, "{max}");
    assert!(
        problem.as_deref().is_some_and(|p| p.contains("f-number")),
        "{problem:?}"
    );
    // A malformed file: the loader refuses it (Bevy logs the line and
    // field), the flare says the lens is not loaded and draws nothing.
    let (max, finite, problem, _) = case(
        "tests/assets",
        "lenses/broken.lens",
        Vec3::new(0.1, 0.1, 1.0).normalize(),
        |_| {},
    );
    assert!(finite && max == 0.0, "{max}");
    assert!(
        problem.as_deref().is_some_and(|p| p.contains("not loaded")),
        "{problem:?}"
    );
}
