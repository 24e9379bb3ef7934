//! Foveated LOD: the paper's setting. A 3 m CAVE with front, right and floor
//! screens seen from a tracked eye, eight Stanford bunnies of 3,674
//! triangles (mirror-like and diffuse) over the walls, each drawn at the level of detail its
//! place in the visual field asks for; the gaze is simulated (arrow keys).
//!
//! ```sh
//! cargo run --example foveated_lod --features foveated_lod,egui,window -- [--stereo] [--raytrace] [--out DIR]
//! ```
//!
//! With the `window` feature and a display it opens a window showing the
//! three walls side by side (front, right, floor), with an egui panel (the
//! field's settings, the gaze, each model's level and triangles, the visual
//! field with the models in it) when the `egui` feature is on; otherwise
//! (or with `--out`) it renders headlessly and writes
//! `foveated_lod_front.png`, `_floor.png` and `_right.png` (the gaze at the
//! front wall, 60° down at the floor, 70° to the right) to `DIR`, by
//! default `target/optica/`. `--stereo` gives each wall two cameras, one
//! per eye, as the paper's CAVE did; the window then shows the left eye's.
//! `--raytrace` draws the walls with the paper's own method, the GPU ray
//! tracer (`GazeRayTracer`): mirrors reflect the other models and the
//! floor, each ray at the level of its direction in the visual field; the
//! PNGs are then `foveated_lod_rt_*.png`.

#[path = "scenes/common.rs"]
mod common;
#[path = "scenes/foveated_lod.rs"]
mod scene;

use bevy::prelude::*;
use optica::foveated_lod::SimulatedGaze;
use optica_harness::Headless;
use scene::Layout;

/// The side of one wall's image headless (the paper's 256²).
const HEADLESS_WALL_PX: u32 = 256;

struct Args {
    stereo: bool,
    raytrace: bool,
    out: Option<String>,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args().skip(1);
    let (mut stereo, mut raytrace, mut out) = (false, false, None);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--stereo" => stereo = true,
            "--raytrace" => raytrace = true,
            "--out" => out = Some(args.next().ok_or("--out needs a directory")?),
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    Ok(Args {
        stereo,
        raytrace,
        out,
    })
}

fn main() {
    let args = parse_args().unwrap_or_else(|e| {
        eprintln!("foveated_lod: {e}");
        std::process::exit(2);
    });
    if common::can_open_window() && args.out.is_none() {
        let px = scene::WALL_PX;
        let mut app = common::window_app("optica foveated LOD — front, right, floor", (3 * px, px));
        scene::build(&mut app);
        app.insert_resource(Layout {
            px,
            stereo: args.stereo,
            raytrace: args.raytrace,
            ..default()
        })
        .add_systems(Startup, scene::spawn);
        #[cfg(feature = "egui")]
        app.add_plugins((
            bevy_egui::EguiPlugin::default(),
            optica::foveated_lod::FoveatedLodPanelPlugin,
        ));
        app.run();
    } else {
        let dir = common::out_dir(args.out);
        let px = HEADLESS_WALL_PX;
        for (name, yaw, pitch) in [
            ("front", 0.0, 0.0),
            ("floor", 0.0, -60.0),
            ("right", 70.0, 0.0),
        ] {
            let layout = Layout {
                px,
                stereo: args.stereo,
                raytrace: args.raytrace,
                gaze: SimulatedGaze {
                    position: scene::EYE,
                    gaze_yaw_deg: yaw,
                    gaze_pitch_deg: pitch,
                    speed: 0.0,
                    ..default()
                },
            };
            let kind = if args.raytrace { "rt_" } else { "" };
            let path = format!("{dir}/foveated_lod_{kind}{name}.png");
            let headless = Headless::new(3 * px, px).frames(4);
            println!("gaze {name}:");
            common::render_png("foveated_lod", headless, &path, |app| {
                scene::build(app);
                app.insert_resource(layout)
                    .add_systems(Startup, scene::spawn)
                    .add_systems(Last, scene::report_levels);
            });
        }
    }
}
