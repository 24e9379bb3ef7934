//! Dome: a planetarium domemaster — a starry sky turning about the pole
//! with constellation lines, an altitude–azimuth graticule, and a landscape
//! with large buildings near the horizon (big triangles at the rim), seen by
//! a slowly turning fisheye dome camera. In the vertex mode every straight
//! edge is refined until it lies within the camera's pixel tolerance of its
//! true curved image: the stars once (the paper's pre-subdivided class, they
//! only turn about the viewer), the lines and the landscape whenever they
//! move relative to the camera. The cube mode resamples four to six
//! ordinary cameras instead.
//!
//! ```sh
//! cargo run --example dome --features dome,egui,window -- [--fov 180] [--tilt 0] [--tolerance 0.5] [--lens equisolid] [--cube FACE_PX] [--out DIR]
//! # A render farm's job: frames 0..240 of the show, 4K, to ./show
//! cargo run --release --example dome --features dome -- --export show --frames 0..240 --size 4096
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
//! own range.

use bevy::prelude::*;
use optica::dome::lines::{self, Graticule};
use optica::dome::{
    DomeApparentSize, DomeCamera, DomeExport, DomeExportPlugin, DomeLens, DomeMode, DomePlugin,
    DomeRefineStats, DomeShowClock, parse_frame_range,
};

/// The domemaster's side in pixels (window and snapshots).
const SIZE: u32 = 1024;
/// Turn rate of the camera about the zenith, radians per second of show.
const TURN: f32 = 0.1;
/// Turn rate of the sky about the celestial pole, radians per second of
/// show (a day in two minutes).
const SKY_TURN: f32 = std::f32::consts::TAU / 120.0;
/// Show frames (at 30 fps) between the headless snapshots.
const SNAPSHOT_FRAMES: u32 = 60;
/// The largest export size.
const MAX_EXPORT_PX: u32 = 8192;

/// What the command line asks for.
struct Args {
    dome: DomeCamera,
    out: Option<String>,
    export: Option<(DomeExport, u32)>,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args().skip(1);
    let mut dome = DomeCamera::default();
    let (mut out, mut export_dir, mut frames, mut size, mut fps) =
        (None, None, None, 2048u32, 30.0f32);
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
            "--frames" => frames = Some(parse_frame_range(&value()?)?),
            "--size" => {
                let v = value()?;
                size = v
                    .parse()
                    .map_err(|_| format!("--size: `{v}` is not a size"))?;
            }
            "--fps" => fps = number(value()?)?,
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    dome.validate()?;
    let export = match export_dir {
        Some(dir) => {
            if !(16..=MAX_EXPORT_PX).contains(&size) {
                return Err(format!("--size {size} is outside 16..={MAX_EXPORT_PX}"));
            }
            let export = DomeExport::new(dir, frames.unwrap_or(0..1), fps);
            export.validate()?;
            Some((export, size))
        }
        None if frames.is_some() => return Err("--frames needs --export DIR".into()),
        None => None,
    };
    Ok(Args { dome, out, export })
}

fn main() {
    let Args { dome, out, export } = parse_args().unwrap_or_else(|e| {
        eprintln!("dome: {e}");
        std::process::exit(2);
    });
    if let Some((export, size)) = export {
        export_sequence(dome, export, size);
        return;
    }
    let has_display = std::env::var_os("DISPLAY").is_some();
    if cfg!(feature = "window") && has_display && out.is_none() {
        let mut app = App::new();
        app.add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "optica dome".into(),
                resolution: target_size(&dome, SIZE).into(),
                ..default()
            }),
            ..default()
        }));
        setup_app(&mut app, dome);
        app.add_systems(First, run_show_clock)
            .add_systems(Update, fit_window);
        #[cfg(feature = "egui")]
        app.add_plugins(bevy_egui::EguiPlugin::default())
            .add_systems(bevy_egui::EguiPrimaryContextPass, panel);
        app.run();
    } else {
        let dir = out.unwrap_or_else(|| "target/optica".into());
        let _ = std::fs::create_dir_all(&dir);
        for k in 0..4 {
            let (w, h) = target_size(&dome, SIZE);
            let frame = optica_harness::Headless::new(w, h)
                .adapter(optica_harness::Adapter::Auto)
                .render(|app| {
                    setup_app(app, dome);
                    app.insert_resource(DomeShowClock {
                        frame: k * SNAPSHOT_FRAMES,
                        ..default()
                    });
                })
                .unwrap_or_else(|e| {
                    eprintln!("dome: headless render failed: {e}");
                    std::process::exit(1);
                });
            let path = format!("{dir}/dome_{k}.png");
            frame.to_rgba8().save(&path).unwrap_or_else(|e| {
                eprintln!("dome: cannot write {path}: {e}");
                std::process::exit(1);
            });
            println!("rendered on {} -> {path}", frame.adapter);
        }
    }
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
    app.run();
    println!(
        "dome: frames {frames:?} at {size} px across in {:.1} s",
        start.elapsed().as_secs_f64()
    );
}

/// The image for `dome` at `size` px across: square for a fisheye, 2:1 for
/// the panorama.
fn target_size(dome: &DomeCamera, size: u32) -> (u32, u32) {
    match dome.lens {
        DomeLens::Equirectangular => (size, size / 2),
        _ => (size, size),
    }
}

/// How the camera is mounted: a fisheye looks at the zenith, the audience
/// facing −Z; the panorama looks at the horizon (−Z) with +Y up.
fn mount(dome: &DomeCamera) -> Quat {
    match dome.lens {
        DomeLens::Equirectangular => Transform::IDENTITY.looking_to(Vec3::NEG_Z, Vec3::Y),
        _ => Transform::IDENTITY.looking_to(Vec3::Y, Vec3::Z),
    }
    .rotation
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

/// In a window, the show clock follows real time.
fn run_show_clock(time: Res<Time>, mut clock: ResMut<DomeShowClock>) {
    clock.frame = (time.elapsed_secs() * clock.fps) as u32;
}

fn setup_app(app: &mut App, dome: DomeCamera) {
    app.add_plugins(DomePlugin)
        .insert_resource(GlobalAmbientLight {
            color: Color::srgb(0.5, 0.6, 0.9),
            brightness: 120.0,
            ..default()
        })
        .add_systems(
            Startup,
            move |commands: Commands,
                  meshes: ResMut<Assets<Mesh>>,
                  materials: ResMut<Assets<StandardMaterial>>| {
                spawn_planetarium(commands, meshes, materials, dome)
            },
        )
        .add_systems(Update, (turn, turn_sky));
}

/// A small deterministic generator, so the sky is the same on every run.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// A direction at altitude `alt` and azimuth `az` (radians; azimuth 0 is
/// −Z, the audience front).
fn sky_dir(alt: f32, az: f32) -> Vec3 {
    Vec3::new(alt.cos() * az.sin(), alt.sin(), -alt.cos() * az.cos())
}

/// The sky: stars and constellation lines, turning about the celestial
/// pole with the show clock (diurnal motion) around the viewer.
#[derive(Component)]
struct Sky;

/// The celestial pole seen from latitude 35° north, the audience facing
/// south (−Z): 35° above the northern horizon (+Z).
fn pole() -> Vec3 {
    let lat = 35f32.to_radians();
    Vec3::new(0.0, lat.sin(), lat.cos())
}

fn spawn_planetarium(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    dome: DomeCamera,
) {
    let mut glow = |c: Color| {
        materials.add(StandardMaterial {
            base_color: c,
            unlit: true,
            ..default()
        })
    };
    let (star, line, grid) = (
        glow(Color::srgb(1.0, 0.97, 0.9)),
        glow(Color::srgb(0.35, 0.55, 1.0)),
        glow(Color::srgb(0.6, 0.25, 0.25)),
    );
    let sky = commands
        .spawn((Sky, Transform::IDENTITY, Visibility::default()))
        .id();
    // Stars: small cubes 300 units out over the whole sphere (the ground
    // hides those below the horizon), one mesh. Their apparent size never
    // changes (they keep their distance and only turn about the viewer):
    // the paper's pre-subdivided class, split once and never again.
    const R: f32 = 300.0;
    let mut rng = Lcg(0x5EED);
    let mut stars = Vec::new();
    let mut field: Option<Mesh> = None;
    for _ in 0..1200 {
        let alt = (2.0 * rng.next() - 1.0).asin();
        let az = rng.next() * std::f32::consts::TAU;
        let size = 0.4 + 1.6 * rng.next().powi(4);
        let p = R * sky_dir(alt, az);
        stars.push(p);
        let cube = Mesh::from(Cuboid::from_length(size)).translated_by(p);
        match field.as_mut() {
            Some(f) => f.merge(&cube).expect("cubes share their attributes"),
            None => field = Some(cube),
        }
    }
    if let Some(field) = field {
        commands.spawn((
            Mesh3d(meshes.add(field)),
            MeshMaterial3d(star),
            DomeApparentSize::NearlyConstant,
            ChildOf(sky),
        ));
    }
    // Constellation lines: chains of nearby stars, one line mesh. A
    // segment between two stars on the sphere is seen along the great
    // circle through them; the dome refines it into that exact arc.
    let mut pairs = Vec::new();
    for k in 0..80 {
        let (a, b, c) = (stars[k * 7], stars[k * 7 + 1], stars[k * 7 + 2]);
        pairs.extend(
            [[a, b], [b, c]]
                .into_iter()
                .filter(|[p, q]| p.distance(*q) < 0.6 * R),
        );
    }
    commands.spawn((
        Mesh3d(meshes.add(lines::segments(&pairs))),
        MeshMaterial3d(line),
        ChildOf(sky),
    ));
    // The altitude–azimuth graticule, fixed to the horizon.
    commands.spawn((
        Mesh3d(
            meshes.add(
                Graticule {
                    radius: 0.9 * R,
                    altitude_step_deg: 30.0,
                    azimuth_step_deg: 45.0,
                    ..default()
                }
                .mesh(),
            ),
        ),
        MeshMaterial3d(grid),
    ));
    // The landscape: a ground plane and large buildings near the horizon.
    commands.spawn((
        Mesh3d(meshes.add(Plane3d::default().mesh().size(2000.0, 2000.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.12, 0.16, 0.1),
            perceptual_roughness: 0.9,
            ..default()
        })),
        Transform::from_xyz(0.0, -1.6, 0.0),
    ));
    let building = materials.add(StandardMaterial {
        base_color: Color::srgb(0.35, 0.33, 0.3),
        perceptual_roughness: 0.8,
        ..default()
    });
    for (i, (w, h)) in [
        (30.0, 25.0),
        (18.0, 45.0),
        (40.0, 15.0),
        (22.0, 30.0),
        (15.0, 60.0),
    ]
    .into_iter()
    .enumerate()
    {
        let az = (i as f32 * 72.0 + 20.0).to_radians();
        let p = 120.0 * sky_dir(0.0, az);
        commands.spawn((
            Mesh3d(meshes.add(Cuboid::new(w, h, w))),
            MeshMaterial3d(building.clone()),
            Transform::from_xyz(p.x, h / 2.0 - 1.6, p.z),
        ));
    }
    commands.spawn((
        DirectionalLight {
            illuminance: 1_500.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(-1.0, 2.0, 0.5).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    // The dome: a fisheye at the zenith, the audience facing −Z (or the
    // panorama looking at the horizon).
    commands.spawn((
        dome,
        Camera {
            clear_color: ClearColorConfig::Custom(Color::srgb(0.01, 0.015, 0.04)),
            ..default()
        },
        Transform::from_rotation(mount(&dome)),
    ));
}

/// Turns the dome camera about the zenith with the show clock (the twins
/// follow: refined again as the scene moves relative to the camera).
fn turn(clock: Res<DomeShowClock>, mut cameras: Query<(&mut Transform, &DomeCamera)>) {
    for (mut transform, dome) in &mut cameras {
        transform.rotation = Quat::from_rotation_y(TURN * clock.seconds()) * mount(dome);
    }
}

/// Turns the sky about the celestial pole with the show clock: the stars
/// (pre-subdivided) keep their twin, the constellation lines are refined
/// again.
fn turn_sky(clock: Res<DomeShowClock>, mut skies: Query<&mut Transform, With<Sky>>) {
    for mut transform in &mut skies {
        transform.rotation = Quat::from_axis_angle(pole(), SKY_TURN * clock.seconds());
    }
}

/// The dome camera's mode, field of view, tilt and tolerance.
#[cfg(feature = "egui")]
fn panel(
    mut contexts: bevy_egui::EguiContexts,
    mut cameras: Query<&mut DomeCamera>,
    stats: Res<DomeRefineStats>,
) -> Result {
    use bevy_egui::egui;
    let Ok(mut dome) = cameras.single_mut() else {
        return Ok(());
    };
    let mut edit = *dome;
    egui::Window::new("Dome").show(contexts.ctx_mut()?, |ui| {
        let mut cube = matches!(edit.mode, DomeMode::CubeMap { .. });
        ui.horizontal(|ui| {
            ui.radio_value(&mut cube, false, "vertex projection");
            ui.radio_value(&mut cube, true, "cube map");
        });
        edit.mode = match (cube, edit.mode) {
            (false, _) => DomeMode::Vertex,
            (true, DomeMode::CubeMap { face_px }) => {
                let mut face_px = face_px;
                ui.add(
                    egui::Slider::new(&mut face_px, 64..=4096)
                        .logarithmic(true)
                        .text("face size (px)"),
                );
                DomeMode::CubeMap { face_px }
            }
            (true, DomeMode::Vertex) => DomeMode::CubeMap { face_px: 768 },
        };
        egui::ComboBox::from_label("projection")
            .selected_text(edit.lens.name())
            .show_ui(ui, |ui| {
                for lens in DomeLens::ALL {
                    let chosen =
                        std::mem::discriminant(&edit.lens) == std::mem::discriminant(&lens);
                    if ui.selectable_label(chosen, lens.name()).clicked() && !chosen {
                        edit.lens = lens;
                    }
                }
            });
        if let DomeLens::Polynomial { k } = &mut edit.lens {
            ui.horizontal(|ui| {
                for (i, c) in k.iter_mut().enumerate() {
                    ui.label(format!("k{}", i + 1));
                    ui.add(egui::DragValue::new(c).speed(0.001).max_decimals(5));
                }
            });
        }
        // The panorama sees the whole sphere: no field of view to set.
        if edit.lens != DomeLens::Equirectangular {
            ui.add(egui::Slider::new(&mut edit.fov_deg, 60.0..=350.0).text("field of view (°)"));
        }
        ui.add(egui::Slider::new(&mut edit.tilt_deg, -30.0..=90.0).text("tilt (°)"));
        ui.add(
            egui::Slider::new(&mut edit.tolerance_px, 0.1..=40.0)
                .logarithmic(true)
                .text("tolerance (px)"),
        );
        if let Err(e) = edit.validate() {
            ui.colored_label(egui::Color32::from_rgb(230, 120, 60), e);
        }
        if edit.mode == DomeMode::Vertex {
            ui.label(format!(
                "refinement: {} meshes split again ({} vertices), {} kept, {:.1} ms",
                stats.rebuilt, stats.vertices, stats.kept, stats.cpu_ms
            ));
        }
    });
    if edit != *dome {
        *dome = edit;
    }
    Ok(())
}
