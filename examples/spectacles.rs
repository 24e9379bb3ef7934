//! Spectacles: a room seen through an eye — a book at 30 cm on the table,
//! an eye chart of tumbling Es on the wall 5 m away — for the paper's
//! Fig. 8 cases and everyday eyes, with and without their glasses. The
//! scene is `scenes/spectacles.rs`, shared with the showcase.
//!
//! ```sh
//! cargo run --example spectacles --features spectacles,egui,window -- [--preset myope] [--out DIR]
//!     [--mirror per-vertex|cube-map]
//! ```
//!
//! `--mirror` hangs a convex safety mirror on the left wall (the paper's
//! §3.2) and draws it per vertex or as Bevy's cube map would; the view is
//! then drawn sharp (a mirror is not among the clones), and the PNG is
//! `spectacles_<preset>_mirror_<method>.png`.
//!
//! With the `window` feature and a display it opens a window (the `egui`
//! feature adds a panel for every setting and the presets); otherwise (or
//! with `--out`) it renders each preset headlessly to
//! `DIR/spectacles_<preset>.png` (default `target/optica/`). Either way it
//! prints, per preset, what its wearer sees: the blur disc at the chart and
//! at the book in arcminutes (a 20/20 letter is 5′ tall, its strokes 1′)
//! and the glasses' magnification.

#[path = "scenes/common.rs"]
mod common;
#[path = "scenes/spectacles.rs"]
mod scene;

use bevy::prelude::*;
use optica::spectacles::MirrorMethod;
use optica::spectacles::presets::{Preset, presets};
use optica_harness::Headless;
use scene::{BOOK, BOOK_M, CHART_M, SpectaclesScene, book_down_deg};

/// The command line: presets, output folder, a mirror.
struct Args {
    presets: Vec<Preset>,
    out: Option<String>,
    mirror: Option<MirrorMethod>,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args().skip(1);
    let (mut chosen, mut out, mut mirror) = (presets(), None, None);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--preset" => {
                let name = value()?;
                let p = presets()
                    .into_iter()
                    .find(|p| p.name == name)
                    .ok_or_else(|| {
                        let names: Vec<_> = presets().iter().map(|p| p.name).collect();
                        format!("unknown preset `{name}`: {}", names.join(", "))
                    })?;
                chosen = vec![p];
            }
            "--out" => out = Some(value()?),
            "--mirror" => {
                mirror = Some(match value()?.as_str() {
                    "per-vertex" => MirrorMethod::PerVertex,
                    "cube-map" => MirrorMethod::CubeMap,
                    m => return Err(format!("unknown mirror method `{m}`: per-vertex, cube-map")),
                })
            }
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    Ok(Args {
        presets: chosen,
        out,
        mirror,
    })
}

fn main() {
    let Args {
        presets: chosen,
        out,
        mirror,
    } = parse_args().unwrap_or_else(|e| {
        eprintln!("spectacles: {e}");
        std::process::exit(2);
    });
    for p in &chosen {
        describe(p);
    }
    let (width, height) = scene::SIZE;
    if common::can_open_window() && out.is_none() {
        let mut app = common::window_app("optica spectacles", (width, height));
        setup_app(&mut app, chosen[0].clone(), mirror.clone());
        #[cfg(feature = "egui")]
        app.add_plugins((
            bevy_egui::EguiPlugin::default(),
            optica::spectacles::SpectaclesPanelPlugin,
        ));
        app.run();
    } else {
        let dir = common::out_dir(out);
        for p in chosen {
            let name = match &mirror {
                None => p.name.to_string(),
                Some(MirrorMethod::PerVertex) => format!("{}_mirror_per-vertex", p.name),
                Some(_) => format!("{}_mirror_cube-map", p.name),
            };
            let m = mirror.clone();
            let path = format!("{dir}/spectacles_{name}.png");
            common::render_png(
                "spectacles",
                Headless::new(width, height).frames(6),
                &path,
                |app| setup_app(app, p, m),
            );
        }
    }
}

/// What a wearer of `p` sees, on the terminal.
fn describe(p: &Preset) {
    let at = |m: f64, down: f64| match p.sight_looking_down(m, down) {
        Ok((s, _)) => format!("{:.1}′", s.blur_arcmin),
        Err(e) => format!("({e})"),
    };
    let magnification = match p.sight(f64::from(CHART_M)) {
        Ok((_, m)) if p.spectacles.is_some() => format!(", things look {m:+.1} % in size"),
        _ => String::new(),
    };
    println!(
        "{}: {}\n    blur disc at the chart ({CHART_M} m) {}, at the book ({BOOK_M} m, {:.0}° down) {}{magnification}",
        p.name,
        p.description,
        at(f64::from(CHART_M), 0.0),
        book_down_deg(),
        at(f64::from(BOOK.length()), book_down_deg()),
    );
}

fn setup_app(app: &mut App, preset: Preset, mirror: Option<MirrorMethod>) {
    scene::build(app);
    app.insert_resource(SpectaclesScene { preset, mirror })
        .add_systems(Startup, scene::spawn);
}
