//! Foveated LOD: the paper's setting. A 3 m CAVE with front, right and floor
//! screens seen from a tracked eye, eight models of 5,780 triangles (mirror-
//! like and diffuse) over the walls, each drawn at the level of detail its
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

use bevy::camera::{RenderTarget, Viewport};
use bevy::prelude::*;
use bevy::render::render_resource::TextureFormat;
use optica::foveated_lod::{
    CaveView, Eye, FoveatedLodPlugin, GazeLod, GazeLodState, GazeRayTracer, HeadSource, RayTraced,
    SimulatedGaze, WallRect,
};

/// The side of one wall's image in the window (px).
const WALL_PX: u32 = 400;
/// The side of one wall's image headless (the paper's 256²).
const HEADLESS_WALL_PX: u32 = 256;
const CAVE_M: f32 = 3.0;
const EYE: Vec3 = Vec3::new(0.0, 1.5, 0.0);

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

/// How the walls are laid out in the target: side by side, `px` square each.
#[derive(Resource, Clone, Copy)]
struct Layout {
    px: u32,
    stereo: bool,
    /// Ray traced by the GPU tracer rather than rasterised.
    raytrace: bool,
}

fn main() {
    let args = parse_args().unwrap_or_else(|e| {
        eprintln!("foveated_lod: {e}");
        std::process::exit(2);
    });
    let has_display = std::env::var_os("DISPLAY").is_some();
    if cfg!(feature = "window") && has_display && args.out.is_none() {
        let mut app = App::new();
        app.add_plugins(DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: "optica foveated LOD — front, right, floor".into(),
                resolution: (3 * WALL_PX, WALL_PX).into(),
                ..default()
            }),
            ..default()
        }));
        setup_app(
            &mut app,
            Layout {
                px: WALL_PX,
                stereo: args.stereo,
                raytrace: args.raytrace,
            },
            SimulatedGaze {
                position: EYE,
                ..default()
            },
        );
        #[cfg(feature = "egui")]
        app.add_plugins((
            bevy_egui::EguiPlugin::default(),
            optica::foveated_lod::FoveatedLodPanelPlugin,
        ));
        app.run();
    } else {
        let dir = args.out.unwrap_or_else(|| "target/optica".into());
        let _ = std::fs::create_dir_all(&dir);
        let px = HEADLESS_WALL_PX;
        for (name, yaw, pitch) in [
            ("front", 0.0, 0.0),
            ("floor", 0.0, -60.0),
            ("right", 70.0, 0.0),
        ] {
            let gaze = SimulatedGaze {
                position: EYE,
                gaze_yaw_deg: yaw,
                gaze_pitch_deg: pitch,
                speed: 0.0,
                ..default()
            };
            let frame = optica_harness::Headless::new(3 * px, px)
                .adapter(optica_harness::Adapter::Auto)
                .frames(4)
                .render(|app| {
                    setup_app(
                        app,
                        Layout {
                            px,
                            stereo: args.stereo,
                            raytrace: args.raytrace,
                        },
                        gaze.clone(),
                    );
                    app.add_systems(Last, report_levels);
                })
                .unwrap_or_else(|e| {
                    eprintln!("foveated_lod: headless render failed: {e}");
                    std::process::exit(1);
                });
            let kind = if args.raytrace { "rt_" } else { "" };
            let path = format!("{dir}/foveated_lod_{kind}{name}.png");
            frame.to_rgba8().save(&path).unwrap_or_else(|e| {
                eprintln!("foveated_lod: cannot write {path}: {e}");
                std::process::exit(1);
            });
            println!("gaze {name}: rendered on {} -> {path}", frame.adapter);
        }
    }
}

fn setup_app(app: &mut App, layout: Layout, gaze: SimulatedGaze) {
    app.add_plugins(FoveatedLodPlugin)
        .insert_resource(HeadSource::Simulated(gaze))
        .insert_resource(layout)
        .insert_resource(GlobalAmbientLight {
            color: Color::srgb(0.6, 0.65, 0.75),
            brightness: 250.0,
            ..default()
        })
        .add_systems(Startup, spawn_cave);
}

/// The walls' cameras, the models spread over the three walls (as the
/// paper's scenes A and B), a light, and the CAVE's screens drawn faintly
/// so that the walls' edges show.
fn spawn_cave(
    mut commands: Commands,
    layout: Res<Layout>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut images: ResMut<Assets<Image>>,
) {
    let model = meshes.add(Sphere::new(0.15).mesh().ico(16).expect("an ico sphere"));
    let mirror = materials.add(StandardMaterial {
        base_color: Color::srgb(0.92, 0.92, 0.96),
        metallic: 1.0,
        perceptual_roughness: 0.06,
        ..default()
    });
    let diffuse = materials.add(StandardMaterial {
        base_color: Color::srgb(0.85, 0.5, 0.28),
        perceptual_roughness: 0.8,
        ..default()
    });
    let places = [
        Vec3::new(-0.8, 1.4, -1.0),
        Vec3::new(0.0, 1.6, -1.1),
        Vec3::new(0.7, 1.3, -0.9),
        Vec3::new(1.0, 1.2, -0.4),
        Vec3::new(1.0, 1.6, 0.4),
        Vec3::new(-0.6, 0.25, -0.5),
        Vec3::new(0.2, 0.25, -0.2),
        Vec3::new(0.6, 0.25, 0.5),
    ];
    for (i, p) in places.into_iter().enumerate() {
        let (kind, material) = if i % 2 == 0 {
            ("mirror", &mirror)
        } else {
            ("diffuse", &diffuse)
        };
        let mut model = commands.spawn((
            Name::new(format!("{kind} {}", i + 1)),
            Mesh3d(model.clone()),
            Transform::from_translation(p),
            GazeLod::default(),
        ));
        if layout.raytrace {
            // Traced, never rasterised: no material.
            model.insert(if i % 2 == 0 {
                RayTraced::mirror(LinearRgba::rgb(0.85, 0.85, 0.9), 0.6)
            } else {
                RayTraced::diffuse(LinearRgba::rgb(0.7, 0.25, 0.08))
            });
        } else {
            model.insert(MeshMaterial3d(material.clone()));
        }
    }
    commands.spawn((
        PointLight {
            intensity: 3.0e5,
            range: 20.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_xyz(0.4, 2.8, 0.6),
    ));
    // The room behind the screens: a floor and back walls to give the
    // mirror-like models something to reflect and the eye depth cues.
    let room = materials.add(StandardMaterial {
        base_color: Color::srgb(0.35, 0.38, 0.42),
        perceptual_roughness: 0.9,
        ..default()
    });
    let mut floor = commands.spawn((
        Mesh3d(meshes.add(Plane3d::new(Vec3::Y, Vec2::splat(CAVE_M / 2.0)))),
        Transform::from_xyz(0.0, 0.001, 0.0),
    ));
    if layout.raytrace {
        floor.insert(RayTraced::diffuse(LinearRgba::rgb(0.3, 0.32, 0.35)));
    } else {
        floor.insert(MeshMaterial3d(room));
    }
    let walls = WallRect::front_right_floor(CAVE_M).expect("a 3 m CAVE");
    let eyes: &[Eye] = if layout.stereo {
        &[Eye::Left, Eye::Right]
    } else {
        &[Eye::Cyclopean]
    };
    for (i, wall) in walls.into_iter().enumerate() {
        for (k, &eye) in eyes.iter().enumerate() {
            let mut camera = Camera {
                order: (i * eyes.len() + k) as isize,
                clear_color: ClearColorConfig::Custom(Color::srgb(0.08, 0.08, 0.1)),
                ..default()
            };
            let name = Name::new(format!("wall {i}, {eye:?} eye"));
            let tracer = layout.raytrace.then(GazeRayTracer::default);
            if k == 0 {
                camera.viewport = Some(Viewport {
                    physical_position: UVec2::new(i as u32 * layout.px, 0),
                    physical_size: UVec2::splat(layout.px),
                    ..default()
                });
                let mut c = commands.spawn((name, CaveView::new(wall, eye), camera));
                if let Some(t) = tracer {
                    c.insert(t);
                }
            } else {
                // The right eye's images would go to their own projectors;
                // here each goes to an image of its own, not shown.
                let target = Image::new_target_texture(
                    layout.px,
                    layout.px,
                    TextureFormat::Rgba8UnormSrgb,
                    None,
                );
                let target = RenderTarget::Image(images.add(target).into());
                let mut c = commands.spawn((name, CaveView::new(wall, eye), camera, target));
                if let Some(t) = tracer {
                    c.insert(t);
                }
            }
        }
    }
}

/// Prints each model's level once it settled (headless runs).
fn report_levels(
    frames: Res<bevy::diagnostic::FrameCount>,
    objects: Query<(&Name, &GazeLodState)>,
) {
    if frames.0 != 3 {
        return;
    }
    let mut rows: Vec<_> = objects.iter().collect();
    rows.sort_by_key(|(n, _)| n.to_string());
    for (name, s) in rows {
        println!(
            "  {name}: level {:.2}, step {}, {} triangles",
            s.level, s.step, s.triangles
        );
    }
}
