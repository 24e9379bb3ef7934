//! Compound eye: an insect head with two compound eyes, the camera and the
//! light orbiting it; the dark patch on each eye (the pseudopupil) follows
//! the camera over the facets. The scene is `scenes/compound_eye.rs`,
//! shared with the showcase.
//!
//! ```sh
//! cargo run --example compound_eye --features compound_eye,egui,window -- [--preset honeybee] [--out DIR]
//! ```
//!
//! With the `window` feature and a display it opens a window, with an egui
//! panel for every setting and the species presets when the `egui` feature
//! is on; otherwise (or with `--out`) it renders headlessly and writes
//! `compound_eye_0.png` … `_3.png` (four points of the orbit) to `DIR`, by
//! default `target/optica/`.

#[path = "scenes/common.rs"]
mod common;
#[path = "scenes/compound_eye.rs"]
mod scene;

use bevy::prelude::*;
use optica::compound_eye::{EyePreset, presets};
use optica_harness::Headless;
use scene::CompoundScene;

/// Seconds of orbit between the headless snapshots: a quarter orbit.
const SNAPSHOT_SECONDS: f32 = 1.25;

struct Args {
    preset: EyePreset,
    out: Option<String>,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args().skip(1);
    let (mut preset, mut out) = (presets::HOUSEFLY, None);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--preset" => {
                let name = value()?;
                preset = presets::PRESETS
                    .into_iter()
                    .find(|p| p.name.to_lowercase().contains(&name.to_lowercase()))
                    .ok_or(format!(
                        "unknown preset `{name}`: drosophila, honeybee, housefly, dragonfly"
                    ))?;
            }
            "--out" => out = Some(value()?),
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    Ok(Args { preset, out })
}

fn main() {
    let args = parse_args().unwrap_or_else(|e| {
        eprintln!("compound_eye: {e}");
        std::process::exit(2);
    });
    let eye = scene::eye_of(&args.preset);
    println!(
        "{}: {} ommatidia ({})",
        args.preset.name, args.preset.ommatidia, args.preset.source
    );
    let (width, height) = scene::SIZE;
    if common::can_open_window() && args.out.is_none() {
        let mut app = common::window_app(
            format!("optica compound eye — {}", args.preset.name),
            (width, height),
        );
        scene::build(&mut app);
        scene::run_clock(&mut app);
        app.insert_resource(CompoundScene { eye, clock: 0.0 })
            .add_systems(Startup, scene::spawn);
        #[cfg(feature = "egui")]
        app.add_plugins((
            bevy_egui::EguiPlugin::default(),
            optica::compound_eye::CompoundEyePanelPlugin,
        ))
        .add_systems(PostStartup, scene::edit_both_eyes);
        app.run();
    } else {
        let dir = common::out_dir(args.out);
        for k in 0..4 {
            let path = format!("{dir}/compound_eye_{k}.png");
            let eye = eye.clone();
            common::render_png(
                "compound_eye",
                Headless::new(width, height).frames(2),
                &path,
                |app| {
                    scene::build(app);
                    app.insert_resource(CompoundScene {
                        eye,
                        clock: k as f32 * SNAPSHOT_SECONDS,
                    })
                    .add_systems(Startup, scene::spawn);
                },
            );
        }
    }
}
