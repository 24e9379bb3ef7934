//! Dome: a planetarium domemaster — a starry sky turning about the pole
//! with constellation lines, an altitude–azimuth graticule, and a landscape
//! with large buildings near the horizon (big triangles at the rim), seen by
//! a slowly turning fisheye dome camera. In the vertex mode every straight
//! edge is refined until it lies within the camera's pixel tolerance of its
//! true curved image: the stars once (the paper's pre-subdivided class, they
//! only turn about the viewer), the lines and the landscape whenever they
//! move relative to the camera. The cube mode resamples four to six
//! ordinary cameras instead. The scene is `scenes/dome.rs`, shared with the
//! showcase.
//!
//! ```sh
//! cargo run --example dome --features dome,egui,window -- [--fov 180] [--tilt 0] [--tolerance 0.5] [--lens equisolid] [--cube FACE_PX] [--out DIR]
//! # A render farm's job: frames 0..240 of the show, 4K, to ./show
//! cargo run --release --example dome --features dome -- --export show --frames 0..240 --size 4096
//! # The farm's last step: which frames of 0..240 are missing (exit status 1 if any)
//! cargo run --release --example dome --features dome -- --export show --frames 0..240 --check
//! ```
//!
//! `--lens` picks the projection: the radial mappings `equidistant` (the
//! default and the domemaster standard), `equisolid`, `stereographic`,
//! `orthographic`, or `polynomial` with `--k k1,k2,k3,k4` (a calibrated
//! lens's Kannala–Brandt coefficients); or `equirectangular`, a 360° × 180°
//! panorama on a 2:1 image, the camera looking at the horizon.
//!
//! With the `window` feature and a display it opens a window (an egui panel
//! for mode, lens, field of view, tilt and tolerance with the `egui` feature);
//! otherwise (or with `--out`) it renders headlessly and writes
//! `dome_0.png` … `dome_3.png` (2 s of show apart) to `DIR`, by default
//! `target/optica/`. `--export DIR` writes the domemaster PNG sequence
//! `DIR/domemaster_NNNNNN.png` of `--frames A..B` (B excluded; `A..=B` and a
//! single `A` work too) at `--size` px (default 2048, up to 8192) and
//! `--fps` (default 30): every frame depends on its number alone, so a farm
//! manager (Flamenco, OpenCue, a Slurm array job) can give each machine its
//! own range. A task that cannot write its frames exits with status 1.
//! `--check` renders nothing: it lists the frames of the range with no PNG
//! and the `--frames` ranges that render them again (`scripts/farm/`
//! runs a show as a Slurm array job).

#[path = "scenes/common.rs"]
mod common;
#[path = "scenes/dome.rs"]
mod scene;

use bevy::prelude::*;
use optica::dome::{
    DomeCamera, DomeExport, DomeExportPlugin, DomeLens, DomeMode, DomeShowClock, parse_frame_range,
};
use optica_harness::Headless;
use scene::{DomeScene, SIZE, target_size};

/// Show frames (at 30 fps) between the headless snapshots.
const SNAPSHOT_FRAMES: u32 = 60;
/// The largest export size.
const MAX_EXPORT_PX: u32 = 8192;

/// What the command line asks for.
struct Args {
    dome: DomeCamera,
    out: Option<String>,
    export: Option<(DomeExport, u32)>,
    /// List the export's missing frames instead of rendering.
    check: bool,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args().skip(1);
    let mut dome = DomeCamera::default();
    let (mut out, mut export_dir, mut frames, mut size, mut fps) =
        (None, None, None, 2048u32, 30.0f32);
    let mut check = false;
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        let number = |v: String| -> Result<f32, String> {
            v.parse().map_err(|_| format!("`{v}` is not a number"))
        };
        match a.as_str() {
            "--fov" => dome.fov_deg = number(value()?)?,
            "--tilt" => dome.tilt_deg = number(value()?)?,
            "--tolerance" => dome.tolerance_px = number(value()?)?,
            "--lens" => {
                let name = value()?;
                let k = match dome.lens {
                    DomeLens::Polynomial { k } => k,
                    _ => [1.0, -0.04, 0.003, -0.0001],
                };
                dome.lens = match name.as_str() {
                    "polynomial" => DomeLens::Polynomial { k },
                    _ => *DomeLens::ALL
                        .iter()
                        .find(|l| l.name() == name)
                        .ok_or(format!("--lens: `{name}` is not a lens"))?,
                };
            }
            "--k" => {
                let v = value()?;
                let k: Vec<f32> = v
                    .split(',')
                    .map(|c| c.trim().parse())
                    .collect::<Result<_, _>>()
                    .map_err(|_| format!("--k: `{v}` is not four numbers"))?;
                let k: [f32; 4] = k
                    .try_into()
                    .map_err(|_| format!("--k: `{v}` is not four numbers"))?;
                dome.lens = DomeLens::Polynomial { k };
            }
            "--cube" => {
                let face_px = value()?;
                let face_px = face_px
                    .parse()
                    .map_err(|_| format!("--cube: `{face_px}` is not a size in px"))?;
                dome.mode = DomeMode::CubeMap { face_px };
            }
            "--out" => out = Some(value()?),
            "--export" => export_dir = Some(value()?),
            "--frames" => frames = Some(parse_frame_range(&value()?).map_err(|e| e.to_string())?),
            "--size" => {
                let v = value()?;
                size = v
                    .parse()
                    .map_err(|_| format!("--size: `{v}` is not a size"))?;
            }
            "--fps" => fps = number(value()?)?,
            "--check" => check = true,
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    dome.validate().map_err(|e| e.to_string())?;
    let export = match export_dir {
        Some(dir) => {
            if !(16..=MAX_EXPORT_PX).contains(&size) {
                return Err(format!("--size {size} is outside 16..={MAX_EXPORT_PX}"));
            }
            let export = DomeExport::new(dir, frames.unwrap_or(0..1), fps);
            export.validate().map_err(|e| e.to_string())?;
            Some((export, size))
        }
        None if frames.is_some() || check => {
            return Err("--frames and --check need --export DIR".into());
        }
        None => None,
    };
    Ok(Args {
        dome,
        out,
        export,
        check,
    })
}

fn main() {
    let Args {
        dome,
        out,
        export,
        check,
    } = parse_args().unwrap_or_else(|e| {
        eprintln!("dome: {e}");
        std::process::exit(2);
    });
    if let Some((export, size)) = export {
        if check {
            check_sequence(&export);
        }
        export_sequence(dome, export, size);
        return;
    }
    if common::can_open_window() && out.is_none() {
        let mut app = common::window_app("optica dome", target_size(&dome, SIZE));
        setup_app(&mut app, dome);
        app.add_systems(First, scene::run_show_clock)
            .add_systems(Update, fit_window);
        #[cfg(feature = "egui")]
        app.add_plugins((
            bevy_egui::EguiPlugin::default(),
            optica::dome::DomePanelPlugin,
        ));
        app.run();
    } else {
        let dir = common::out_dir(out);
        for k in 0..4 {
            let (w, h) = target_size(&dome, SIZE);
            common::render_png(
                "dome",
                Headless::new(w, h),
                &format!("{dir}/dome_{k}.png"),
                |app| {
                    setup_app(app, dome);
                    app.insert_resource(DomeShowClock {
                        frame: k * SNAPSHOT_FRAMES,
                        ..default()
                    });
                },
            );
        }
    }
}

fn setup_app(app: &mut App, dome: DomeCamera) {
    scene::build(app);
    app.insert_resource(DomeScene { dome })
        .add_systems(Startup, scene::spawn);
}

/// Writes the PNG sequence without a window: the dome camera draws into an
/// image of `size`², each frame is captured and saved, then the app exits.
fn export_sequence(dome: DomeCamera, export: DomeExport, size: u32) {
    use bevy::camera::RenderTarget;
    use bevy::render::RenderPlugin;
    use bevy::render::render_resource::TextureFormat;
    use bevy::window::ExitCondition;

    let frames = export.frames.clone();
    let plugins = DefaultPlugins
        .set(WindowPlugin {
            primary_window: None,
            exit_condition: ExitCondition::DontExit,
            ..default()
        })
        .set(RenderPlugin {
            // Every frame drawn complete: no frame waits on a pipeline.
            synchronous_pipeline_compilation: true,
            ..default()
        });
    // No event loop: the schedule runner drives the app.
    #[cfg(feature = "window")]
    let plugins = plugins.disable::<bevy::winit::WinitPlugin>();
    let mut app = App::new();
    app.add_plugins(plugins)
        .add_plugins(bevy::app::ScheduleRunnerPlugin::run_loop(
            std::time::Duration::ZERO,
        ));
    setup_app(&mut app, dome);
    app.add_plugins(DomeExportPlugin(export)).add_systems(
        PostStartup,
        move |mut commands: Commands,
              mut images: ResMut<Assets<Image>>,
              cameras: Query<Entity, With<DomeCamera>>| {
            let (w, h) = target_size(&dome, size);
            let mut image = Image::new_target_texture(w, h, TextureFormat::Rgba8UnormSrgb, None);
            image.texture_descriptor.usage |=
                bevy::render::render_resource::TextureUsages::COPY_SRC;
            let handle = images.add(image);
            for camera in &cameras {
                commands
                    .entity(camera)
                    .insert(RenderTarget::Image(handle.clone().into()));
            }
        },
    );
    let start = std::time::Instant::now();
    let exit = app.run();
    if exit.is_error() {
        eprintln!("dome: frames {frames:?} not all written");
        std::process::exit(1);
    }
    println!(
        "dome: frames {frames:?} at {size} px across in {:.1} s",
        start.elapsed().as_secs_f64()
    );
}

/// A farm's final step: says which frames of the export have no PNG and
/// the ranges that render them again; exits 0 when none is missing, else 1.
fn check_sequence(export: &DomeExport) -> ! {
    let missing = export.missing();
    let total = export.frames.len();
    if missing.is_empty() {
        println!(
            "dome: all {total} frames of {:?} are in {}",
            export.frames,
            export.dir.display()
        );
        std::process::exit(0);
    }
    let list: Vec<String> = missing.iter().map(u32::to_string).collect();
    let ranges: Vec<String> = optica::dome::frame_ranges(&missing)
        .iter()
        .map(|r| format!("{}..{}", r.start, r.end))
        .collect();
    println!(
        "dome: {} of {total} frames missing in {}: {}",
        missing.len(),
        export.dir.display(),
        list.join(" ")
    );
    println!("dome: rerun --frames {}", ranges.join(" --frames "));
    std::process::exit(1);
}

/// Keeps the window's shape that of the image (2:1 for the panorama) when
/// the panel changes the projection.
#[cfg(feature = "window")]
fn fit_window(cameras: Query<&DomeCamera, Changed<DomeCamera>>, mut windows: Query<&mut Window>) {
    let (Ok(dome), Ok(mut window)) = (cameras.single(), windows.single_mut()) else {
        return;
    };
    let (w, h) = target_size(dome, SIZE);
    if window.resolution.physical_height() * w != window.resolution.physical_width() * h {
        window.resolution.set(w as f32, h as f32);
    }
}

#[cfg(not(feature = "window"))]
fn fit_window() {}
