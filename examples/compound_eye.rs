//! Compound eye: an insect head with two compound eyes, the camera and the
//! light orbiting it; the dark patch on each eye (the pseudopupil) follows
//! the camera over the facets.
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

use bevy::mesh::MeshBuilder;
use bevy::prelude::*;
use optica::compound_eye::{
    CompoundEye, CompoundEyeMaterial, CompoundEyePlugin, EyeCap, EyePreset, presets,
};

const WIDTH: u32 = 960;
const HEIGHT: u32 = 640;
/// Orbit speeds in radians per second.
const CAMERA_ORBIT: f32 = 0.35;
const LIGHT_ORBIT: f32 = -0.6;
/// Frames of 1/60 s between the headless snapshots: a quarter orbit apart.
const SNAPSHOT_FRAMES: u32 = 75;

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

/// The eye settings the scene starts with: the preset's facet count, made
/// coarser so that facets are visible at this scale (a real eye at this size
/// would have them far below a pixel; the prefilter then shows only the
/// pseudopupil).
#[derive(Resource, Clone)]
struct StartEye(CompoundEye);

fn main() {
    let args = parse_args().unwrap_or_else(|e| {
        eprintln!("compound_eye: {e}");
        std::process::exit(2);
    });
    let eye = CompoundEye {
        facets_per_uv: CompoundEye::from_preset(&args.preset)
            .facets_per_uv
            .min(70.0),
        // The caps' UVs are conformal: their tangents lose nothing and
        // leave no seams.
        tangent_axes: true,
        ..CompoundEye::from_preset(&args.preset)
    };
    println!(
        "{}: {} ommatidia ({})",
        args.preset.name, args.preset.ommatidia, args.preset.source
    );
    let has_display = std::env::var_os("DISPLAY").is_some();
    if cfg!(feature = "window") && has_display && args.out.is_none() {
        let mut app = App::new();
        app.add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: format!("optica compound eye — {}", args.preset.name),
                resolution: (WIDTH, HEIGHT).into(),
                ..default()
            }),
            ..default()
        }));
        setup_app(&mut app, eye);
        #[cfg(feature = "egui")]
        app.add_plugins((
            bevy_egui::EguiPlugin::default(),
            optica::compound_eye::CompoundEyePanelPlugin,
        ))
        .add_systems(PostStartup, edit_both_eyes);
        app.run();
    } else {
        let dir = args.out.unwrap_or_else(|| "target/optica".into());
        let _ = std::fs::create_dir_all(&dir);
        for k in 0..4 {
            let frame = optica_harness::Headless::new(WIDTH, HEIGHT)
                .adapter(optica_harness::Adapter::Auto)
                .frames(1 + k * SNAPSHOT_FRAMES)
                .render(|app| setup_app(app, eye.clone()))
                .unwrap_or_else(|e| {
                    eprintln!("compound_eye: headless render failed: {e}");
                    std::process::exit(1);
                });
            let path = format!("{dir}/compound_eye_{k}.png");
            frame.to_rgba8().save(&path).unwrap_or_else(|e| {
                eprintln!("compound_eye: cannot write {path}: {e}");
                std::process::exit(1);
            });
            println!("rendered on {} -> {path}", frame.adapter);
        }
    }
}

fn setup_app(app: &mut App, eye: CompoundEye) {
    app.add_plugins(CompoundEyePlugin)
        .insert_resource(StartEye(eye))
        .insert_resource(GlobalAmbientLight {
            color: Color::srgb(0.55, 0.65, 0.8),
            brightness: 350.0,
            ..default()
        })
        .add_systems(Startup, spawn_head)
        .add_systems(Update, orbit);
}

#[derive(Component)]
struct Eye;

#[derive(Component)]
struct Orbit {
    radius: f32,
    height: f32,
    speed: f32,
}

fn spawn_head(
    mut commands: Commands,
    start: Res<StartEye>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut plain: ResMut<Assets<StandardMaterial>>,
    mut eyes: ResMut<Assets<CompoundEyeMaterial>>,
) {
    let chitin = plain.add(StandardMaterial {
        base_color: Color::srgb(0.16, 0.1, 0.06),
        perceptual_roughness: 0.35,
        ..default()
    });
    let bristle = plain.add(StandardMaterial {
        base_color: Color::srgb(0.08, 0.06, 0.05),
        perceptual_roughness: 0.6,
        ..default()
    });
    // The head: a flattened ellipsoid looking along −Z; the thorax behind it.
    commands.spawn((
        Mesh3d(meshes.add(Sphere::new(1.0))),
        MeshMaterial3d(chitin.clone()),
        Transform::from_scale(Vec3::new(0.95, 0.8, 0.7)),
    ));
    commands.spawn((
        Mesh3d(meshes.add(Capsule3d::new(0.55, 0.9))),
        MeshMaterial3d(chitin.clone()),
        Transform::from_xyz(0.0, -0.15, 1.35)
            .with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2)),
    ));
    // Antennae and mouthparts.
    for side in [-1.0f32, 1.0] {
        commands.spawn((
            Mesh3d(meshes.add(Cylinder::new(0.03, 0.9))),
            MeshMaterial3d(bristle.clone()),
            Transform::from_xyz(0.22 * side, 0.55, -0.7).with_rotation(Quat::from_euler(
                EulerRot::XYZ,
                -0.9,
                0.0,
                -0.35 * side,
            )),
        ));
        commands.spawn((
            Mesh3d(meshes.add(Cone::new(0.09, 0.35))),
            MeshMaterial3d(bristle.clone()),
            Transform::from_xyz(0.12 * side, -0.62, -0.45)
                .with_rotation(Quat::from_rotation_x(3.0)),
        ));
    }
    // The compound eyes: large bulges on both sides. Each is an `EyeCap`,
    // whose UVs have no pole (a UV sphere would show one as rings of
    // shrinking facets), its axis pointing out of the head and its rim,
    // 130° from the axis, sunk into the head.
    let eye_mesh = meshes.add(
        EyeCap {
            half_angle: 130f32.to_radians(),
            ..default()
        }
        .build(),
    );
    for side in [-1.0f32, 1.0] {
        let material = eyes.add(CompoundEyeMaterial {
            base: StandardMaterial {
                base_color: Color::srgb(0.62, 0.14, 0.08),
                perceptual_roughness: 0.25,
                ..default()
            },
            extension: start.0.clone(),
        });
        commands.spawn((
            Eye,
            Mesh3d(eye_mesh.clone()),
            MeshMaterial3d(material),
            Transform::from_xyz(0.62 * side, 0.12, -0.18)
                .with_rotation(Quat::from_rotation_arc(Vec3::Z, side * Vec3::X))
                // The cap's own axes: across (world z), up, and out.
                .with_scale(Vec3::new(0.58, 0.62, 0.5)),
        ));
    }
    commands.spawn((
        DirectionalLight {
            illuminance: 9_000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::default(),
        Orbit {
            radius: 4.0,
            height: 3.0,
            speed: LIGHT_ORBIT,
        },
    ));
    commands.spawn((
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::srgb(0.62, 0.74, 0.88)),
            ..default()
        },
        Transform::default(),
        Orbit {
            radius: 3.6,
            height: 0.9,
            speed: CAMERA_ORBIT,
        },
    ));
}

/// Camera and light circle the head; the camera starts in front of the
/// right eye and swings round to the face.
fn orbit(time: Res<Time>, mut movers: Query<(&Orbit, &mut Transform)>) {
    for (o, mut t) in &mut movers {
        let a = -0.45 - o.speed * time.elapsed_secs();
        *t = Transform::from_xyz(o.radius * a.cos(), o.height, o.radius * a.sin())
            .looking_at(Vec3::new(0.0, 0.1, 0.0), Vec3::Y);
    }
}

/// The panel edits both eyes together.
#[cfg(feature = "egui")]
fn edit_both_eyes(
    mut commands: Commands,
    eyes: Query<&MeshMaterial3d<CompoundEyeMaterial>, With<Eye>>,
) {
    commands.insert_resource(optica::compound_eye::CompoundEyePanel {
        materials: eyes.iter().map(|m| m.id()).collect(),
    });
}
