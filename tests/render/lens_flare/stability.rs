//! Stiff cases of the flare: a light on the axis, 60° off it (outside the
//! view), the Heliar's plano surface, the double Gauss wide open at f/1.1,
//! the Tessar stopped to f/32 and the 33-interface zoom with every
//! unblocked ghost; an f-number faster than the lens and a malformed lens
//! file are refused with a reason, and a lens file broken on reload leaves
//! the last good lens in place. Each: no NaN or infinite pixel, no pixel
//! brighter than the CPU twins' bound (`bound.rs`), no panic.

use bevy::asset::AssetPlugin;
use bevy::prelude::*;
use optica_harness::Headless;
use optica_lens_flare::{Error, FlareGhosts, LensFlare, LensFlarePlugin};
use optica_optics::input::Expected;
use optica_optics::lens_flare::FlareError;
use std::sync::{Arc, Mutex};

const SIZE: u32 = 96;

/// What a stiff case drew: its largest channel value, whether every
/// pixel is finite, the flare's problem, the ghosts drawn, and the bound
/// on any pixel the CPU twins give (`super::bound`; 0 without a lens).
struct Case {
    max: f32,
    finite: bool,
    problem: Option<Error>,
    drawn: usize,
    bound: f32,
}

/// Renders a sun travelling along `travel` through `lens` (a path under
/// `root`) with `edit` applied.
fn case(
    root: &'static str,
    lens: &'static str,
    travel: Vec3,
    edit: impl Fn(&mut LensFlare) + Send + Sync + 'static,
) -> Case {
    let seen = Arc::new(Mutex::new(None));
    let log = seen.clone();
    let frame = headless_at(root, SIZE, 12)
        .render(move |app: &mut App| {
            app.add_plugins(LensFlarePlugin);
            app.add_systems(
                Startup,
                move |mut commands: Commands, assets: Res<AssetServer>| {
                    commands.spawn(super::sun(travel, LUX));
                    let mut flare = LensFlare {
                        grid: 16,
                        ..LensFlare::new(assets.load(lens))
                    };
                    edit(&mut flare);
                    commands.spawn((super::black_hdr_camera(), flare));
                },
            );
            app.add_systems(Last, move |flares: Query<(&LensFlare, &FlareGhosts)>| {
                if let Ok((f, g)) = flares.single() {
                    *log.lock().expect("log") = Some((f.clone(), g.clone()));
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
    let (flare, ghosts) = seen.lock().expect("log").clone().expect("the flare ran");
    let bound = if ghosts.lens.is_some() && ghosts.problem.is_none() {
        super::bound::brightest_pixel(&flare, &ghosts, travel, LUX, std::f32::consts::FRAC_PI_4, SIZE)
    } else {
        0.0
    };
    Case {
        max,
        finite,
        problem: ghosts.problem.clone(),
        drawn: ghosts.drawn().count(),
        bound,
    }
}

const LUX: f32 = 100_000.0;

const ASSETS: &str = "assets";

/// A `size`² HDR render of `frames` frames whose assets load from `root`.
fn headless_at(root: &'static str, size: u32, frames: u32) -> Headless {
    Headless::new(size, size)
        .hdr(true)
        .frames(frames)
        .default_plugins(move |g| {
            g.set(AssetPlugin {
                file_path: root.into(),
                ..default()
            })
        })
}
const TESSAR: &str = "lenses/tessar-us2854889.lens";

#[test]
fn stiff_cases_stay_finite_and_bounded() {
    let axis = Vec3::Z;
    let sixty = Vec3::new(-60f32.to_radians().sin(), 0.0, 60f32.to_radians().cos());
    /// (name, lens, travel, settings).
    type Stiff = (&'static str, &'static str, Vec3, fn(&mut LensFlare));
    let cases: [Stiff; 6] = [
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
        let Case { max, finite, problem, drawn, bound } = case(ASSETS, lens, travel.normalize(), edit);
        eprintln!("{name}: brightest {max} (the twins' bound {bound}), {drawn} ghosts drawn, problem {problem:?}");
        assert!(finite, "{name}: a non-finite pixel");
        assert!(max > 0.0 && max <= bound, "{name}: brightest {max}, bound {bound}");
        assert_eq!(problem, None, "{name}");
        assert!(drawn > 0, "{name}: no ghost drawn");
    }
}

#[test]
fn impossible_settings_and_malformed_files_are_refused() {
    // f/1 on an f/2.8 lens: refused, no flare, no panic.
    let Case { max, finite, problem, .. } =
        case(ASSETS, TESSAR, Vec3::new(0.1, 0.1, 1.0).normalize(), |f| {
            f.aperture.f_number = Some(1.0)
        });
    assert!(finite && max == 0.0, "{max}");
    // Refused by the optics: the f-number below the lens's own (f/2.8).
    match &problem {
        Some(Error::Optics(FlareError::Input(e))) => {
            assert_eq!(e.what, "f-number");
            assert_eq!(e.value, 1.0);
            assert!(
                matches!(e.expected, Expected::Range { min, .. } if (2.0..3.5).contains(&min)),
                "{e}"
            );
        }
        other => panic!("{other:?}"),
    }
    // A malformed file: the loader refuses it (Bevy logs the line and
    // field), the flare says the lens is not loaded and draws nothing.
    let Case { max, finite, problem, .. } = case(
        "tests/assets",
        "lenses/broken.lens",
        Vec3::new(0.1, 0.1, 1.0).normalize(),
        |_| {},
    );
    assert!(finite && max == 0.0, "{max}");
    assert_eq!(problem, Some(Error::LensNotLoaded));
}

/// Settings with no meaning are refused by name (the flare then draws
/// nothing and says why, as above), never drawn as NaN.
#[test]
fn bad_numbers_in_the_settings_are_named() {
    let flare = LensFlare::new(Handle::default());
    assert_eq!(flare.validate(), Ok(()));
    for bad in [f32::NAN, -1.0, f32::INFINITY] {
        let err = LensFlare {
            merge_wavelengths_px: bad,
            ..flare.clone()
        }
        .validate()
        .expect_err("refused");
        assert!(
            matches!(&err, Error::Setting(e) if e.what == "flare merge_wavelengths_px"
                && e.expected == Expected::NonNegative && (e.value.is_nan() || e.value == f64::from(bad))),
            "{err:?}"
        );
        let err = LensFlare {
            coarse_ghost_px: Some(bad),
            ..flare.clone()
        }
        .validate()
        .expect_err("refused");
        assert!(
            matches!(&err, Error::Setting(e) if e.what == "flare coarse_ghost_px"),
            "{err:?}"
        );
        let err = LensFlare {
            merge_cells: bad,
            ..flare.clone()
        }
        .validate()
        .expect_err("refused");
        assert!(
            matches!(&err, Error::Setting(e) if e.what == "flare merge_cells"),
            "{err:?}"
        );
    }
    let err = LensFlare {
        wavelengths: 0,
        ..flare.clone()
    }
    .validate()
    .expect_err("refused");
    assert!(
        matches!(&err, Error::Setting(e) if e.what == "flare wavelengths" && e.value == 0.0),
        "{err:?}"
    );
    assert_eq!(
        err.to_string(),
        "flare wavelengths = 0: expected a finite number in 1 ..= 16"
    );
    // The iris and the diffraction textures' integer settings have their own variants.
    let mut bad = flare.clone();
    bad.aperture.blades = 2;
    assert_eq!(bad.validate(), Err(Error::Blades(2)));
    let mut bad = flare.clone();
    bad.ringing
        .as_mut()
        .expect("ringing on by default")
        .resolution = 33;
    assert_eq!(
        bad.validate(),
        Err(Error::Resolution {
            what: "ringing",
            side: 33
        })
    );
}

/// Hot reload keeps the last good lens: a `.lens` file overwritten with
/// random bytes is refused on reload and the flare keeps drawing the
/// Tessar's ghosts; overwritten with the double Gauss, it reloads and the
/// ghosts are the double Gauss's.
#[test]
fn a_broken_reload_keeps_the_last_good_lens() {
    let dir = std::env::temp_dir().join(format!("optica-hot-lens-{}", std::process::id()));
    let lenses = dir.join("lenses");
    std::fs::create_dir_all(&lenses).expect("temp dir");
    let hot = lenses.join("hot.lens");
    let source = |name: &str| {
        std::fs::read(format!(
            "{}/assets/lenses/{name}",
            env!("CARGO_MANIFEST_DIR")
        ))
        .expect("shipped lens")
    };
    std::fs::write(&hot, source("tessar-us2854889.lens")).expect("write");
    // Ghost counts seen after each step: (tessar, after garbage, after double Gauss).
    let seen = Arc::new(Mutex::new(Vec::<(u32, usize, Option<Error>)>::new()));
    let log = seen.clone();
    let root: &'static str = Box::leak(dir.to_string_lossy().into_owned().into_boxed_str());
    let hot_path = hot.clone();
    let double_gauss = source("double-gauss-us2701982.lens");
    headless_at(root, 32, 60)
        .render(move |app: &mut App| {
            app.add_plugins(LensFlarePlugin);
            app.add_systems(
                Startup,
                |mut commands: Commands, assets: Res<AssetServer>| {
                    commands.spawn(super::sun(Vec3::new(0.1, 0.1, 1.0).normalize(), 100_000.0));
                    commands.spawn((
                        super::black_hdr_camera(),
                        LensFlare {
                            grid: 8,
                            ..LensFlare::new(assets.load("lenses/hot.lens"))
                        },
                    ));
                },
            );
            app.add_systems(
                Update,
                move |mut frame: Local<u32>,
                      assets: Res<AssetServer>,
                      ghosts: Query<&FlareGhosts>| {
                    *frame += 1;
                    let Ok(g) = ghosts.single() else { return };
                    log.lock()
                        .expect("log")
                        .push((*frame, g.ghosts.len(), g.problem.clone()));
                    let step = |bytes: &[u8]| {
                        std::fs::write(&hot_path, bytes).expect("overwrite");
                        assets.reload("lenses/hot.lens");
                    };
                    match *frame {
                        15 => {
                            // Random bytes (a fixed xorshift stream).
                            let mut x = 0x2545_f491_4f6c_dd1du64;
                            let junk: Vec<u8> = (0..512)
                                .map(|_| {
                                    x ^= x << 13;
                                    x ^= x >> 7;
                                    x ^= x << 17;
                                    x as u8
                                })
                                .collect();
                            step(&junk);
                        }
                        35 => step(&double_gauss),
                        _ => {}
                    }
                },
            );
        })
        .expect("render");
    let _ = std::fs::remove_dir_all(&dir);
    let seen = seen.lock().expect("log").clone();
    let at = |f: u32| seen.iter().find(|s| s.0 == f).cloned();
    eprintln!(
        "ghosts at frames 14, 34, 60: {:?} {:?} {:?}",
        at(14),
        at(34),
        at(60)
    );
    assert_eq!(at(14).map(|s| s.1), Some(21), "the Tessar first");
    // After the broken reload: the Tessar's ghosts are kept.
    assert!(
        seen.iter()
            .filter(|s| (16..=35).contains(&s.0))
            .all(|s| s.1 == 21),
        "{seen:?}"
    );
    assert_eq!(
        at(60).map(|s| s.1),
        Some(91),
        "the double Gauss after its reload"
    );
}

/// More rays than one storage binding holds (on lavapipe 128 MiB, 2.8 M
/// rays; here 83 ghosts × 3 wavelengths at 128², 4.1 M): the grids past the
/// limit are left out with a warning instead of failing to bind (which
/// panicked), and the frame stays finite with the rest of the flare drawn.
#[test]
fn more_rays_than_the_device_binds_are_left_out() {
    let frame = headless_at(ASSETS, 32, 4)
        .render(|app: &mut App| {
            app.add_plugins(LensFlarePlugin);
            app.add_systems(
                Startup,
                |mut commands: Commands, assets: Res<AssetServer>| {
                    commands.spawn(super::sun(Vec3::new(0.1, -0.1, 1.0).normalize(), 100_000.0));
                    commands.spawn((
                        super::black_hdr_camera(),
                        LensFlare {
                            grid: 128,
                            ghost_budget: 91,
                            min_relative: 0.0,
                            starburst: None,
                            ..LensFlare::new(assets.load("lenses/double-gauss-us2701982.lens"))
                        },
                    ));
                },
            );
        })
        .expect("render");
    let img = frame.hdr().expect("HDR");
    assert!(
        img.as_raw().iter().all(|v| v.is_finite()),
        "a non-finite pixel"
    );
    let lit = img
        .pixels()
        .filter(|p| p.0[0] + p.0[1] + p.0[2] > 0.0)
        .count();
    assert!(
        lit > 100,
        "only {lit} px lit: the kept ghosts were not drawn"
    );
}
