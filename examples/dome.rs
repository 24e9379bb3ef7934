//! Dome: a planetarium domemaster — a starry sky with constellation lines
//! and an altitude graticule over a landscape with large buildings near the
//! horizon (big triangles at the rim), seen by a slowly turning fisheye dome
//! camera. Every straight edge is refined until it lies within the camera's
//! pixel tolerance of its true curved image.
//!
//! ```sh
//! cargo run --example dome --features dome,egui,window -- [--fov 180] [--tilt 0] [--tolerance 0.5] [--out DIR]
//! ```
//!
//! With the `window` feature and a display it opens a window (an egui panel
//! for field of view, tilt and tolerance with the `egui` feature); otherwise
//! (or with `--out`) it renders headlessly and writes `dome_0.png` …
//! `dome_3.png` (6° of turn apart) to `DIR`, by default `target/optica/`.

use bevy::prelude::*;
use optica::dome::{DomeCamera, DomePlugin};

/// The domemaster's side in pixels.
const SIZE: u32 = 1024;
/// Turn rate of the camera about the zenith, radians per second.
const TURN: f32 = 0.1;
/// Frames of 1/60 s between the headless snapshots.
const SNAPSHOT_FRAMES: u32 = 60;

fn parse_args() -> Result<(DomeCamera, Option<String>), String> {
    let mut args = std::env::args().skip(1);
    let (mut dome, mut out) = (DomeCamera::default(), None);
    while let Some(a) = args.next() {
        let mut number = || -> Result<f32, String> {
            let v = args.next().ok_or(format!("{a} needs a value"))?;
            v.parse().map_err(|_| format!("{a}: `{v}` is not a number"))
        };
        match a.as_str() {
            "--fov" => dome.fov_deg = number()?,
            "--tilt" => dome.tilt_deg = number()?,
            "--tolerance" => dome.tolerance_px = number()?,
            "--out" => out = Some(args.next().ok_or("--out needs a folder")?),
            _ => return Err(format!("unknown argument {a}")),
        }
    }
    dome.validate()?;
    Ok((dome, out))
}

fn main() {
    let (dome, out) = parse_args().unwrap_or_else(|e| {
        eprintln!("dome: {e}");
        std::process::exit(2);
    });
    let has_display = std::env::var_os("DISPLAY").is_some();
    if cfg!(feature = "window") && has_display && out.is_none() {
        let mut app = App::new();
        app.add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "optica dome".into(),
                resolution: (SIZE, SIZE).into(),
                ..default()
            }),
            ..default()
        }));
        setup_app(&mut app, dome);
        #[cfg(feature = "egui")]
        app.add_plugins(bevy_egui::EguiPlugin::default())
            .add_systems(bevy_egui::EguiPrimaryContextPass, panel);
        app.run();
    } else {
        let dir = out.unwrap_or_else(|| "target/optica".into());
        let _ = std::fs::create_dir_all(&dir);
        for k in 0..4 {
            let frame = optica_harness::Headless::new(SIZE, SIZE)
                .adapter(optica_harness::Adapter::Auto)
                .frames(1 + k * SNAPSHOT_FRAMES)
                .render(|app| setup_app(app, dome))
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
        .add_systems(Update, turn);
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
fn sky(alt: f32, az: f32) -> Vec3 {
    Vec3::new(alt.cos() * az.sin(), alt.sin(), -alt.cos() * az.cos())
}

/// A thin bar from `a` to `b`: a straight 3D segment the dome refines into
/// its curved image.
fn bar(a: Vec3, b: Vec3, width: f32) -> (Cuboid, Transform) {
    let d = b - a;
    (
        Cuboid::new(width, width, d.length()),
        Transform::from_translation((a + b) / 2.0).looking_to(d, Vec3::Y),
    )
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
    // Stars: small cubes 300 units out, uniform over the upper sky.
    const R: f32 = 300.0;
    let mut rng = Lcg(0x5EED);
    let star_mesh = meshes.add(Cuboid::from_length(1.0));
    let mut stars = Vec::new();
    for _ in 0..600 {
        let alt = rng.next().asin().max(0.03);
        let az = rng.next() * std::f32::consts::TAU;
        let size = 0.4 + 1.6 * rng.next().powi(4);
        let p = R * sky(alt, az);
        stars.push(p);
        commands.spawn((
            Mesh3d(star_mesh.clone()),
            MeshMaterial3d(star.clone()),
            Transform::from_translation(p).with_scale(Vec3::splat(size)),
        ));
    }
    // Constellation lines: chains of nearby stars.
    for k in 0..40 {
        let (a, b) = (stars[k * 7], stars[k * 7 + 1]);
        for (p, q) in [(a, b), (b, stars[k * 7 + 2])] {
            if p.distance(q) < 0.6 * R {
                let (shape, place) = bar(p, q, 0.5);
                commands.spawn((
                    Mesh3d(meshes.add(shape)),
                    MeshMaterial3d(line.clone()),
                    place,
                ));
            }
        }
    }
    // The graticule: altitude circles every 30° and eight meridians.
    let bars = |commands: &mut Commands, meshes: &mut Assets<Mesh>, points: Vec<Vec3>| {
        for w in points.windows(2) {
            let (shape, place) = bar(w[0], w[1], 0.4);
            commands.spawn((
                Mesh3d(meshes.add(shape)),
                MeshMaterial3d(grid.clone()),
                place,
            ));
        }
    };
    for alt in [30f32, 60.0] {
        let points = (0..=24)
            .map(|i| 0.9 * R * sky(alt.to_radians(), i as f32 * 15f32.to_radians()))
            .collect();
        bars(&mut commands, &mut meshes, points);
    }
    for m in 0..8 {
        let az = m as f32 * 45f32.to_radians();
        let points = (0..=6)
            .map(|i| 0.9 * R * sky((i as f32 * 15.0).to_radians(), az))
            .collect();
        bars(&mut commands, &mut meshes, points);
    }
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
        let p = 120.0 * sky(0.0, az);
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
    // The dome: a fisheye at the zenith, the audience facing −Z.
    commands.spawn((
        dome,
        Camera {
            clear_color: ClearColorConfig::Custom(Color::srgb(0.01, 0.015, 0.04)),
            ..default()
        },
        Transform::IDENTITY.looking_to(Vec3::Y, Vec3::Z),
    ));
}

/// Turns the dome camera about the zenith (the twins follow: refined again
/// as the scene moves relative to the camera).
fn turn(time: Res<Time>, mut cameras: Query<&mut Transform, With<DomeCamera>>) {
    for mut transform in &mut cameras {
        transform.rotate_y(TURN * time.delta_secs());
    }
}

/// The dome camera's field of view, tilt and tolerance.
#[cfg(feature = "egui")]
fn panel(mut contexts: bevy_egui::EguiContexts, mut cameras: Query<&mut DomeCamera>) -> Result {
    use bevy_egui::egui;
    let Ok(mut dome) = cameras.single_mut() else {
        return Ok(());
    };
    let mut edit = *dome;
    egui::Window::new("Dome").show(contexts.ctx_mut()?, |ui| {
        ui.add(egui::Slider::new(&mut edit.fov_deg, 60.0..=250.0).text("field of view (°)"));
        ui.add(egui::Slider::new(&mut edit.tilt_deg, -30.0..=90.0).text("tilt (°)"));
        ui.add(
            egui::Slider::new(&mut edit.tolerance_px, 0.1..=40.0)
                .logarithmic(true)
                .text("tolerance (px)"),
        );
        if let Err(e) = edit.validate() {
            ui.colored_label(egui::Color32::from_rgb(230, 120, 60), e);
        }
    });
    if edit != *dome {
        *dome = edit;
    }
    Ok(())
}
