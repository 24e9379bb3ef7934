//! A CAVE across processes: a head source and one process per wall (front,
//! right and floor, as in the paper's CAVE; per eye with `--stereo`), each
//! drawing its wall's off-axis view of the foveated LOD scene from the same
//! head sample, in lock step (`optica::foveated_lod::cluster`).
//!
//! ```sh
//! # Head source + three wall processes on this machine, 120 frames, PNGs and a report to DIR:
//! cargo run --example cave --features foveated_lod -- --launch --frames 120 --out DIR
//! # The same frames drawn by one process, each wall in an app of its own (the reference;
//! # --one-app: all walls in one app, as a single-process CAVE draws them):
//! cargo run --example cave --features foveated_lod -- --reference --frames 120 --out DIR
//! # One wall on its own (what --launch starts; on another machine, give the source's address):
//! cargo run --example cave --features foveated_lod -- --wall right --source 10.0.0.1:7700 --out DIR
//! ```
//!
//! `--launch` publishes a head that moves 1 cm a frame with a sweeping gaze
//! (sample `n` stamped `n`/60 s) to the walls it starts, writes each wall's
//! frame `n` as `DIR/<wall>_<n>.png` and `DIR/cave_report.json`: per wall
//! the frames drawn and the latency from a sample to its frame, the walls
//! dropped and joined. Also: `--px` (a wall's side, default 64),
//! `--timeout-ms` (how long a frame waits for a wall, default 1000),
//! `--kill WALL@N` (kill that wall's process before frame N: the others go
//! on after the timeout), `--late WALL@N` (start that wall after frame N:
//! it joins at the frame under way), `--port` (the source's UDP port,
//! default any free one). Every process sets the foveation's clock to the
//! head samples' own time, so the walls choose the same levels from the
//! same samples. The levels' hysteresis (dead band, dwell, the saving
//! gate) remembers earlier samples, which a wall that joins late has not
//! seen: its levels, and so its frames, may differ from the others' until
//! it has caught up. `--no-hysteresis` makes the levels a function of the
//! current sample alone, and a late wall's frames are the others' from its
//! first one.

#[path = "scenes/common.rs"]
mod common;
#[path = "scenes/foveated_lod.rs"]
mod scene;

use std::collections::BTreeMap;
use std::net::SocketAddr;
use std::process::{Child, Command};
use std::time::{Duration, Instant};

use bevy::camera::Viewport;
use bevy::core_pipeline::tonemapping::DebandDither;
use bevy::prelude::*;
use optica::foveated_lod::cluster::{HeadPublisher, HeadSubscriber};
use optica::foveated_lod::{CaveView, Eye, Foveation, FoveationClock, HeadSource, TrackedHead};
use optica_harness::{Headless, HeadlessRun};

/// The walls, in the scene's order.
const WALLS: [&str; 3] = ["front", "right", "floor"];

/// Head sample `n`: the eye 1 cm further right each frame, the gaze
/// sweeping left and right and up and down, stamped `n`/60 s.
fn head_at(n: u64) -> TrackedHead {
    let t = n as f32;
    let centre = scene::EYE + Vec3::new(0.01 * t - 0.2, 0.0, 0.0);
    let gaze = Quat::from_euler(
        EulerRot::YXZ,
        (-40.0 * (0.21 * t).sin()).to_radians(),
        (-25.0 * (0.13 * t).sin()).to_radians(),
        0.0,
    ) * Vec3::NEG_Z;
    let mut head = TrackedHead::looking(centre, Quat::IDENTITY, Some(gaze), 0.063);
    head.timestamp_s = n as f64 / 60.0;
    head
}

/// The foveation every process uses: levels on the head samples' clock,
/// and with `no_hysteresis` a function of the current sample alone.
fn foveation(no_hysteresis: bool) -> Foveation {
    let mut foveation = Foveation {
        clock: FoveationClock::HeadSample,
        ..default()
    };
    if no_hysteresis {
        foveation.dead_band = 0.0;
        foveation.min_dwell_s = 0.0;
        foveation.min_saving = 0.0;
    }
    foveation
}

/// The headless app of `walls` (indices into [`WALLS`], side by side,
/// `px` each) seen by `eye`, settled with the first head.
fn start(
    walls: &[usize],
    eye: Eye,
    px: u32,
    foveation: Foveation,
    first: &TrackedHead,
) -> HeadlessRun {
    let walls = walls.to_vec();
    let first = first.clone();
    let width = px * walls.len() as u32;
    let mut run = Headless::new(width, px)
        .start(move |app: &mut App| {
            scene::build(app);
            app.insert_resource(scene::Layout { px, ..default() })
                .insert_resource(foveation)
                .insert_resource(first)
                .add_systems(Startup, scene::spawn)
                .add_systems(PostStartup, move |commands: Commands, cameras: Query<(Entity, &mut Camera, &mut CaveView)>| {
                    keep_walls(commands, cameras, &walls, eye, px)
                });
        })
        .unwrap_or_else(|e| fail(&format!("cannot start the renderer: {e}")));
    // Pipelines compiled and levels chosen before the first sample counts.
    run.frame()
        .unwrap_or_else(|e| fail(&format!("first frame: {e}")));
    run
}

/// Keeps the cameras of `walls` (the first eye's), side by side from the
/// left, seen by `eye`; the head comes from outside.
fn keep_walls(
    mut commands: Commands,
    mut cameras: Query<(Entity, &mut Camera, &mut CaveView)>,
    walls: &[usize],
    eye: Eye,
    px: u32,
) {
    commands.insert_resource(HeadSource::External);
    for (entity, mut camera, mut view) in &mut cameras {
        let wall = camera.order as usize;
        match walls.iter().position(|&w| w == wall) {
            Some(slot) => {
                camera.viewport = Some(Viewport {
                    physical_position: UVec2::new(slot as u32 * px, 0),
                    physical_size: UVec2::splat(px),
                    ..default()
                });
                view.eye = eye;
                // Bevy's deband dither follows the pixel's place in the
                // target: off, so that a wall drawn at the left of its own
                // target and the same wall beside others in one target
                // (the reference) are the same pixels.
                commands.entity(entity).insert(DebandDither::Disabled);
            }
            None => commands.entity(entity).despawn(),
        }
    }
}

/// Draws `head` and writes each wall's part of the frame as
/// `dir/<wall>_<n>.png`.
fn draw(run: &mut HeadlessRun, head: TrackedHead, n: u64) -> image::RgbaImage {
    run.app().insert_resource(head);
    run.frame()
        .unwrap_or_else(|e| fail(&format!("frame {n}: {e}")))
        .to_rgba8()
}

fn save(image: &image::RgbaImage, slot: usize, px: u32, dir: &str, name: &str, n: u64) {
    let part = image::imageops::crop_imm(image, slot as u32 * px, 0, px, px).to_image();
    let path = format!("{dir}/{name}_{n:04}.png");
    part.save(&path)
        .unwrap_or_else(|e| fail(&format!("{path}: {e}")));
}

fn fail(why: &str) -> ! {
    eprintln!("cave: {why}");
    std::process::exit(1);
}

/// One wall's process: joins the source, draws every sample, answers.
fn wall(name: &str, eye: Eye, source: SocketAddr, px: u32, foveation: Foveation, dir: &str) {
    let index = WALLS
        .iter()
        .position(|w| name.starts_with(w))
        .unwrap_or_else(|| fail(&format!("no wall `{name}` (front, right, floor)")));
    // Ready to draw before joining, so that compiling holds nobody back.
    let mut run = start(&[index], eye, px, foveation, &head_at(0));
    let mut subscriber =
        HeadSubscriber::join(source, name).unwrap_or_else(|e| fail(&e.to_string()));
    let mut first = true;
    loop {
        match subscriber.next_sample(Duration::from_secs(30)) {
            Ok(Some((n, head))) => {
                // A wall's first sample is drawn twice: the update after a
                // jump from the warm-up head to a late sample does not yet
                // draw what the others draw for it (measured: a late
                // wall's first frame differed from one process's, every
                // later one was the same), the next update does.
                if first {
                    draw(&mut run, head.clone(), n);
                    first = false;
                }
                // The PNG stands for the projector: the frame is drawn
                // once it is written.
                let image = draw(&mut run, head, n);
                save(&image, 0, px, dir, name, n);
                if let Err(e) = subscriber.drawn(n) {
                    eprintln!("cave: wall {name}: {e}");
                }
            }
            Ok(None) => return,
            Err(e) => fail(&format!("wall {name}: {e}")),
        }
    }
}

/// The reference: every wall drawn by this one process from the same
/// samples, with no network. Each wall in an app of its own (as a wall
/// process draws it: the same pixels, bit for bit), or with `one_app` all
/// three side by side in one app, as a single-process CAVE draws them
/// (the same up to the rounding of the viewport's offset: a pixel or two
/// of a frame by 1/255).
fn reference(frames: u64, px: u32, foveation: Foveation, dir: &str, one_app: bool) {
    let groups: Vec<Vec<usize>> = if one_app {
        vec![(0..WALLS.len()).collect()]
    } else {
        (0..WALLS.len()).map(|w| vec![w]).collect()
    };
    for walls in groups {
        let mut run = start(&walls, Eye::Cyclopean, px, foveation.clone(), &head_at(0));
        for n in 0..frames {
            let image = draw(&mut run, head_at(n), n);
            for (slot, &w) in walls.iter().enumerate() {
                save(&image, slot, px, dir, WALLS[w], n);
            }
        }
    }
    println!(
        "cave: {frames} frames of {} walls in one process to {dir}",
        WALLS.len()
    );
}

/// A wall and the frame something happens to it.
fn wall_at(text: &str) -> Result<(String, u64), String> {
    let (wall, n) = text
        .split_once('@')
        .ok_or(format!("`{text}` is not WALL@FRAME"))?;
    let n = n.parse().map_err(|_| format!("`{n}` is not a frame"))?;
    Ok((wall.to_string(), n))
}

struct Launch {
    frames: u64,
    px: u32,
    dir: String,
    port: u16,
    timeout: Duration,
    stereo: bool,
    no_hysteresis: bool,
    kill: Option<(String, u64)>,
    late: Option<(String, u64)>,
}

/// The head source, with the wall processes it starts.
fn launch(l: Launch) {
    let mut source =
        HeadPublisher::bind(("127.0.0.1", l.port)).unwrap_or_else(|e| fail(&e.to_string()));
    source.wall_timeout = l.timeout;
    let addr = source.local_addr().unwrap_or_else(|e| fail(&e.to_string()));
    let names: Vec<String> = if l.stereo {
        WALLS
            .iter()
            .flat_map(|w| [format!("{w}/left"), format!("{w}/right")])
            .collect()
    } else {
        WALLS.iter().map(|w| w.to_string()).collect()
    };
    let spawn = |name: &str| -> Child {
        let eye = match name.split_once('/') {
            Some((_, eye)) => eye,
            None => "cyclopean",
        };
        let mut wall = Command::new(std::env::current_exe().expect("this binary"));
        wall.args(["--wall", name, "--eye", eye, "--source", &addr.to_string()])
            .args(["--px", &l.px.to_string(), "--out", &l.dir]);
        if l.no_hysteresis {
            wall.arg("--no-hysteresis");
        }
        wall.spawn()
            .unwrap_or_else(|e| fail(&format!("cannot start wall {name}: {e}")))
    };
    let is_late = |name: &str| l.late.as_ref().is_some_and(|(w, _)| w == name);
    let mut children: BTreeMap<String, Child> = names
        .iter()
        .filter(|n| !is_late(n))
        .map(|n| (n.clone(), spawn(n)))
        .collect();
    let expected = children.len();
    let joined = source.wait_for_walls(expected, Duration::from_secs(120));
    if joined < expected {
        fail(&format!("{joined} of {expected} walls joined within 120 s"));
    }
    println!("cave: {joined} walls joined {addr}");
    let mut latency: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    let mut events = Vec::new();
    let mut slowest = Duration::ZERO;
    for n in 0..l.frames {
        if let Some((wall, at)) = &l.kill
            && *at == n
            && let Some(mut child) = children.remove(wall)
        {
            let _ = child.kill();
            let _ = child.wait();
            events.push(format!("frame {n}: killed {wall}"));
        }
        let start = Instant::now();
        let report = source.publish(n, &head_at(n));
        slowest = slowest.max(start.elapsed());
        for (wall, took) in report.drawn {
            latency
                .entry(wall)
                .or_default()
                .push(took.as_secs_f64() * 1e3);
        }
        for wall in report.dropped {
            events.push(format!("frame {n}: dropped {wall}"));
        }
        for wall in report.joined {
            events.push(format!("frame {n}: joined {wall}"));
        }
        if let Some((wall, at)) = &l.late
            && *at == n
        {
            children.insert(wall.clone(), spawn(wall));
            events.push(format!("frame {n}: started {wall}"));
        }
    }
    source.end();
    for (name, mut child) in children {
        if !child.wait().is_ok_and(|s| s.success()) {
            events.push(format!("wall {name} exited with an error"));
        }
    }
    let walls: serde_json::Map<String, serde_json::Value> = latency
        .into_iter()
        .map(|(wall, mut ms)| {
            ms.sort_by(f64::total_cmp);
            let at = |q: f64| ms[((ms.len() - 1) as f64 * q).round() as usize];
            let figures = serde_json::json!({
                "frames_drawn": ms.len(),
                "latency_ms": { "min": ms[0], "median": at(0.5), "p95": at(0.95), "max": at(1.0) },
            });
            (wall, figures)
        })
        .collect();
    let report = serde_json::json!({
        "frames": l.frames,
        "px": l.px,
        "wall_timeout_ms": l.timeout.as_millis() as u64,
        "slowest_frame_ms": slowest.as_secs_f64() * 1e3,
        "walls": walls,
        "events": events,
        "refused_datagrams": source.refused,
    });
    let path = format!("{}/cave_report.json", l.dir);
    std::fs::write(&path, serde_json::to_string_pretty(&report).expect("json"))
        .unwrap_or_else(|e| fail(&format!("{path}: {e}")));
    println!("{}", serde_json::to_string_pretty(&report).expect("json"));
}

fn main() {
    let mut args = std::env::args().skip(1);
    let (mut mode, mut name, mut eye, mut source) = (None, None, Eye::Cyclopean, None);
    let mut one_app = false;
    let mut l = Launch {
        frames: 60,
        px: 64,
        dir: common::out_dir(None),
        port: 0,
        timeout: Duration::from_millis(1000),
        stereo: false,
        no_hysteresis: false,
        kill: None,
        late: None,
    };
    let parsed: Result<(), String> = (|| {
        while let Some(a) = args.next() {
            let mut value = || args.next().ok_or(format!("{a} needs a value"));
            match a.as_str() {
                "--launch" | "--reference" => mode = Some(a.clone()),
                "--wall" => {
                    mode = Some(a.clone());
                    name = Some(value()?);
                }
                "--eye" => {
                    eye = match value()?.as_str() {
                        "left" => Eye::Left,
                        "right" => Eye::Right,
                        "cyclopean" => Eye::Cyclopean,
                        other => {
                            return Err(format!(
                                "--eye: `{other}` is not left, right or cyclopean"
                            ));
                        }
                    }
                }
                "--source" => {
                    let v = value()?;
                    source = Some(
                        v.parse::<SocketAddr>()
                            .map_err(|_| format!("--source: `{v}` is not an address"))?,
                    );
                }
                "--frames" => l.frames = value()?.parse().map_err(|_| "--frames needs a count")?,
                "--px" => l.px = value()?.parse().map_err(|_| "--px needs a size")?,
                "--port" => l.port = value()?.parse().map_err(|_| "--port needs a port")?,
                "--timeout-ms" => {
                    l.timeout = Duration::from_millis(
                        value()?
                            .parse()
                            .map_err(|_| "--timeout-ms needs milliseconds")?,
                    )
                }
                "--out" => l.dir = value()?,
                "--stereo" => l.stereo = true,
                "--one-app" => one_app = true,
                "--no-hysteresis" => l.no_hysteresis = true,
                "--kill" => l.kill = Some(wall_at(&value()?)?),
                "--late" => l.late = Some(wall_at(&value()?)?),
                _ => return Err(format!("unknown argument {a}")),
            }
        }
        if !(16..=4096).contains(&l.px) {
            return Err(format!("--px {} is outside 16..=4096", l.px));
        }
        Ok(())
    })();
    if let Err(e) = parsed {
        eprintln!("cave: {e}");
        std::process::exit(2);
    }
    std::fs::create_dir_all(&l.dir).unwrap_or_else(|e| fail(&format!("{}: {e}", l.dir)));
    match mode.as_deref() {
        Some("--launch") => launch(l),
        Some("--reference") => {
            reference(l.frames, l.px, foveation(l.no_hysteresis), &l.dir, one_app)
        }
        Some("--wall") => {
            let source = source.unwrap_or_else(|| fail("--wall needs --source ADDRESS"));
            wall(
                name.as_deref().unwrap_or("front"),
                eye,
                source,
                l.px,
                foveation(l.no_hysteresis),
                &l.dir,
            );
        }
        _ => {
            eprintln!(
                "cave: give --launch, --reference or --wall NAME --source ADDRESS (see the docs at the top of examples/cave.rs)"
            );
            std::process::exit(2);
        }
    }
}
