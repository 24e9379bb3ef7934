//! Lens flare: a low sun at dusk over a field of pillars and three
//! coloured lamps, seen through a real lens (the coated Brendel Tessar by
//! default); the camera pans slowly so the ghosts slide through the
//! picture along the line through the sun and the centre. The scene is
//! `scenes/lens_flare.rs`, shared with the showcase.
//!
//! ```sh
//! cargo run --example lens_flare --features lens_flare,egui,window -- [--lens tessar|double-gauss|heliar] [--out DIR]
//! ```
//!
//! With the `window` feature and a display it opens a window, with an egui
//! panel (lens, grid, wavelengths and where they merge, the ghosts'
//! resolution, blades, f-number, coating, ghost budget, intensity, and the
//! flare's share of the frame) when the `egui` feature is on; otherwise
//! (or with `--out`) it renders headlessly and writes `lens_flare_0.png` …
//! `_3.png` to `DIR`, by default `target/optica/`.

#[path = "scenes/common.rs"]
mod common;
#[path = "scenes/lens_flare.rs"]
mod scene;

use bevy::prelude::*;
use optica_harness::Headless;
use scene::{FlareScene, LENSES};

/// Seconds of pan between the headless snapshots.
const SNAPSHOT_SECONDS: f32 = 3.0;

struct Args {
    lens: usize,
    out: Option<String>,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args().skip(1);
    let (mut lens, mut out) = (0, None);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--lens" => {
                let name = value()?;
                lens = LENSES
                    .iter()
                    .position(|(_, path)| path.contains(name.as_str()))
                    .ok_or(format!(
                        "unknown lens `{name}`: tessar, double-gauss, heliar, zoom"
                    ))?;
            }
            "--out" => out = Some(value()?),
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    Ok(Args { lens, out })
}

fn main() {
    let args = parse_args().unwrap_or_else(|e| {
        eprintln!("lens_flare: {e}");
        std::process::exit(2);
    });
    let (width, height) = scene::SIZE;
    if common::can_open_window() && args.out.is_none() {
        let mut app = common::window_app("optica lens flare", (width, height));
        scene::build(&mut app);
        scene::run_clock(&mut app);
        app.insert_resource(FlareScene {
            lens: args.lens,
            ..default()
        })
        .add_systems(Startup, scene::spawn);
        #[cfg(feature = "egui")]
        app.add_plugins((
            bevy_egui::EguiPlugin::default(),
            // The flare's share of the frame, shown in the panel.
            bevy::diagnostic::FrameTimeDiagnosticsPlugin::default(),
            bevy::render::diagnostic::RenderDiagnosticsPlugin,
            optica::lens_flare::LensFlarePanelPlugin,
        ));
        app.run();
    } else {
        let dir = common::out_dir(args.out);
        for k in 0..4 {
            let headless = Headless::new(width, height).frames(12);
            common::render_png(
                "lens_flare",
                headless,
                &format!("{dir}/lens_flare_{k}.png"),
                |app| {
                    scene::build(app);
                    app.insert_resource(FlareScene {
                        lens: args.lens,
                        clock: k as f32 * SNAPSHOT_SECONDS,
                    })
                    .add_systems(Startup, scene::spawn);
                },
            );
        }
    }
}
