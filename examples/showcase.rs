//! The showcase: all five plugins in one app, one scene at a time.
//!
//! ```sh
//! cargo run --release --features showcase --example showcase
//! cargo run --release --features showcase --example showcase -- --headless --out DIR [--size 512] [--scene dome]
//! ```
//!
//! In a window (the `window` feature and a display): the scene named by
//! `--scene` (default the lens flare) with its plugin's panel, and a panel
//! to switch scenes (or the keys 1–5), the frame time and each plugin pass's
//! GPU time (its `optica/…` span, where the adapter has timestamp queries).
//! Switching despawns the scene shown and spawns the next: the hidden
//! plugins then run no pass, no pipeline and no per-frame system.
//!
//! Headless (`--headless`, or no display): every scene (or the one
//! `--scene` names) rendered once, each in an app of its own, to
//! `DIR/<scene>.png` (default `target/optica/showcase/`), `--size` px wide
//! (default 512; each scene keeps its own shape). It prints the adapter
//! and the time per scene. These are the README's pictures.
//!
//! The scenes are in `scenes/`, shared with each plugin's own example.

#[path = "scenes/mod.rs"]
mod scenes;

use bevy::prelude::*;
use optica_harness::Headless;
use scenes::common;
use scenes::{Scene, Showcase, compound_eye, dome, lens_flare, switch_scene};

/// The window's size.
const WINDOW: (u32, u32) = (1280, 720);
/// The headless pictures' default width.
const HEADLESS_WIDTH: u32 = 512;

struct Args {
    headless: bool,
    out: Option<String>,
    width: u32,
    scene: Option<Scene>,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args().skip(1);
    let mut parsed = Args {
        headless: false,
        out: None,
        width: HEADLESS_WIDTH,
        scene: None,
    };
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--headless" => parsed.headless = true,
            "--out" => parsed.out = Some(value()?),
            "--size" => {
                let v = value()?;
                parsed.width = v
                    .parse()
                    .ok()
                    .filter(|w| (48..=4096).contains(w))
                    .ok_or(format!("--size: `{v}` is not a width in 48..=4096 px"))?;
            }
            "--scene" => {
                let name = value()?;
                let names: Vec<_> = Scene::ALL.iter().map(|s| s.name()).collect();
                parsed.scene = Some(
                    *Scene::ALL
                        .iter()
                        .find(|s| s.name() == name)
                        .ok_or(format!("--scene: `{name}` is none of {}", names.join(", ")))?,
                );
            }
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    Ok(parsed)
}

fn main() {
    let args = parse_args().unwrap_or_else(|e| {
        eprintln!("showcase: {e}");
        std::process::exit(2);
    });
    if !args.headless && args.out.is_none() && common::can_open_window() {
        windowed(args.scene.unwrap_or(Scene::LensFlare));
    } else {
        let dir = common::out_dir(Some(
            args.out.unwrap_or_else(|| "target/optica/showcase".into()),
        ));
        let scenes = match args.scene {
            Some(s) => vec![s],
            None => Scene::ALL.to_vec(),
        };
        let mut total = 0.0;
        for scene in scenes {
            let (w, h) = scene.size(args.width);
            let headless = Headless::new(w, h).frames(scene.frames());
            let path = format!("{dir}/{}.png", scene.name());
            total += common::render_png("showcase", headless, &path, |app| {
                scene.setup_alone(app, args.width)
            });
        }
        println!("showcase: {total:.1} s in all");
    }
}

fn windowed(first: Scene) {
    let mut app = common::window_app("optica showcase", WINDOW);
    for scene in Scene::ALL {
        scene.build(&mut app, WINDOW.0);
    }
    lens_flare::run_clock(&mut app);
    compound_eye::run_clock(&mut app);
    app.add_systems(First, dome::run_show_clock)
        .insert_resource(Showcase {
            shown: None,
            wanted: first,
        })
        .add_systems(PreUpdate, (switch_by_key, switch_scene).chain());
    #[cfg(feature = "egui")]
    app.add_plugins((
        bevy_egui::EguiPlugin::default(),
        bevy::diagnostic::FrameTimeDiagnosticsPlugin::default(),
        bevy::render::diagnostic::RenderDiagnosticsPlugin,
        optica::compound_eye::CompoundEyePanelPlugin,
        optica::foveated_lod::FoveatedLodPanelPlugin,
        optica::spectacles::SpectaclesPanelPlugin,
        optica::lens_flare::LensFlarePanelPlugin,
        optica::dome::DomePanelPlugin,
    ))
    .add_systems(bevy_egui::EguiPrimaryContextPass, showcase_panel);
    app.run();
}

/// Keys 1–5 pick a scene.
fn switch_by_key(keys: Option<Res<ButtonInput<KeyCode>>>, mut showcase: ResMut<Showcase>) {
    let Some(keys) = keys else { return };
    let digits = [
        KeyCode::Digit1,
        KeyCode::Digit2,
        KeyCode::Digit3,
        KeyCode::Digit4,
        KeyCode::Digit5,
    ];
    for (key, scene) in digits.into_iter().zip(Scene::ALL) {
        if keys.just_pressed(key) {
            showcase.wanted = scene;
        }
    }
}

/// The scene switcher, the frame time and the plugins' GPU passes.
#[cfg(feature = "egui")]
fn showcase_panel(
    mut contexts: bevy_egui::EguiContexts,
    mut showcase: ResMut<Showcase>,
    diagnostics: Res<bevy::diagnostic::DiagnosticsStore>,
) -> Result {
    use bevy::diagnostic::FrameTimeDiagnosticsPlugin;
    use bevy_egui::egui;
    egui::Window::new("optica")
        .anchor(egui::Align2::RIGHT_TOP, [-8.0, 8.0])
        .show(contexts.ctx_mut()?, |ui| {
            for (i, scene) in Scene::ALL.into_iter().enumerate() {
                let label = format!("{}  {}", i + 1, scene.title());
                if ui
                    .selectable_label(showcase.wanted == scene, label)
                    .clicked()
                {
                    showcase.wanted = scene;
                }
            }
            ui.separator();
            if let Some(ms) = diagnostics
                .get(&FrameTimeDiagnosticsPlugin::FRAME_TIME)
                .and_then(|d| d.smoothed())
            {
                ui.label(format!(
                    "frame {ms:.1} ms ({:.0} fps)",
                    1000.0 / ms.max(1e-3)
                ));
            }
            // Every optica pass that recorded a span this frame: GPU time where
            // the adapter has timestamp queries, else the CPU time to encode it.
            let mut passes: Vec<(String, f64, &str)> = diagnostics
                .iter()
                .filter_map(|d| {
                    let path = d.path().as_str();
                    let span = path.strip_prefix("render/optica/")?;
                    // A hidden scene's passes keep their last value: only those
                    // measured in the last half second are shown.
                    let fresh = d.measurement()?.time.elapsed().as_secs_f32() < 0.5;
                    if !fresh {
                        return None;
                    }
                    let (span, kind) = span
                        .strip_suffix("/elapsed_gpu")
                        .map(|s| (s, "GPU"))
                        .or_else(|| span.strip_suffix("/elapsed_cpu").map(|s| (s, "CPU")))?;
                    Some((span.to_string(), d.smoothed()?, kind))
                })
                .collect();
            passes.sort_by(|a, b| a.0.cmp(&b.0));
            if passes.is_empty() {
                ui.label("no optica pass this frame");
            }
            for (span, ms, kind) in passes {
                ui.label(format!("{span}: {ms:.2} ms {kind}"));
            }
        });
    Ok(())
}
