//! What the example scenes share: the marker the showcase takes a scene
//! away by, and the headless output.

// Each example uses part of this file; the showcase uses all of it.
#![allow(dead_code)]

use std::time::Instant;

use bevy::prelude::*;

/// On every entity a scene spawns (children go with their parent), so the
/// showcase can despawn one scene before it spawns the next.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct SceneEntity;

/// An app with Bevy's default plugins and one window of `size` px titled
/// `title`.
pub fn window_app(title: impl Into<String>, size: (u32, u32)) -> App {
    let mut app = App::new();
    app.add_plugins(DefaultPlugins.set(WindowPlugin {
        primary_window: Some(Window {
            title: title.into(),
            resolution: size.into(),
            ..default()
        }),
        ..default()
    }));
    app
}

/// True where a window can open: the `window` feature is on and a display
/// is set.
pub fn can_open_window() -> bool {
    cfg!(feature = "window")
        && (std::env::var_os("DISPLAY").is_some() || std::env::var_os("WAYLAND_DISPLAY").is_some())
}

/// The folder headless PNGs go to: `out`, else `target/optica/`, created.
pub fn out_dir(out: Option<String>) -> String {
    let dir = out.unwrap_or_else(|| "target/optica".into());
    if let Err(e) = std::fs::create_dir_all(&dir) {
        eprintln!("cannot create {dir}: {e}");
        std::process::exit(1);
    }
    dir
}

/// Renders one headless picture with `headless` on the best adapter there
/// is, writes it to `path` and prints the adapter and the time it took;
/// exits the process with a message on failure.
pub fn render_png(
    example: &str,
    headless: optica_harness::Headless,
    path: &str,
    setup: impl FnOnce(&mut App),
) -> f64 {
    let start = Instant::now();
    let frame = headless
        .adapter(optica_harness::Adapter::Auto)
        .render(setup)
        .unwrap_or_else(|e| {
            eprintln!("{example}: headless render failed: {e}");
            std::process::exit(1);
        });
    frame.to_rgba8().save(path).unwrap_or_else(|e| {
        eprintln!("{example}: cannot write {path}: {e}");
        std::process::exit(1);
    });
    let seconds = start.elapsed().as_secs_f64();
    println!("{path}: rendered on {} in {seconds:.1} s", frame.adapter);
    seconds
}
