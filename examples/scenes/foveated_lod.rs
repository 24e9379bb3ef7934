//! The foveated LOD scene: the paper's setting. A 3 m CAVE with front,
//! right and floor screens seen from a tracked eye, eight Stanford bunnies
//! (mirror-like and diffuse) over the walls, each drawn at the level of
//! detail its place in the visual field asks for; the gaze is simulated
//! (arrow keys).

// Each example uses part of this file; the showcase uses all of it.
#![allow(dead_code)]

use bevy::camera::{RenderTarget, Viewport};
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy::render::render_resource::TextureFormat;
use optica::foveated_lod::{
    CaveView, Eye, FoveatedLodPlugin, GazeLod, GazeLodState, GazeRayTracer, HeadSource, RayTraced,
    SimulatedGaze, WallRect,
};

use super::common::SceneEntity;

/// The scene's name in file names and on the command line.
pub const NAME: &str = "foveated_lod";
/// The side of one wall's image in a window of its own (px).
pub const WALL_PX: u32 = 400;
const CAVE_M: f32 = 3.0;
/// Where the simulated eye is.
pub const EYE: Vec3 = Vec3::new(0.0, 1.5, 0.0);
/// The bunny file is about 10 units tall; the models are about 0.35 m.
const BUNNY_SCALE: f32 = 0.035;

/// How the walls are laid out in the target and drawn: side by side, `px`
/// square each, from `gaze`.
#[derive(Resource, Clone, Debug)]
pub struct Layout {
    /// One wall's side (px).
    pub px: u32,
    /// Two cameras per wall, one per eye (the window shows the left's).
    pub stereo: bool,
    /// Ray traced by the GPU tracer rather than rasterised.
    pub raytrace: bool,
    /// The simulated head and gaze the scene starts with.
    pub gaze: SimulatedGaze,
}

impl Default for Layout {
    fn default() -> Self {
        Self {
            px: WALL_PX,
            stereo: false,
            raytrace: false,
            gaze: SimulatedGaze {
                position: EYE,
                ..default()
            },
        }
    }
}

/// Adds the plugin.
pub fn build(app: &mut App) {
    app.add_plugins(FoveatedLodPlugin).init_resource::<Layout>();
}

/// The Stanford bunny (the npm package `bunny`, public domain: 1,839
/// vertices, 3,674 triangles), read from `assets/meshes/bunny.obj` at build
/// time, with smooth normals.
pub fn bunny() -> Mesh {
    const OBJ: &str = include_str!("../../assets/meshes/bunny.obj");
    let (mut positions, mut indices) = (Vec::<[f32; 3]>::new(), Vec::<u32>::new());
    for line in OBJ.lines() {
        let mut words = line.split_whitespace();
        let numbers = |words: std::str::SplitWhitespace| -> Vec<f32> {
            words
                .map(|w| w.parse().expect("a number in bunny.obj"))
                .collect()
        };
        match words.next() {
            Some("v") => {
                let v = numbers(words);
                positions.push([v[0], v[1], v[2]]);
            }
            Some("f") => indices.extend(numbers(words).into_iter().map(|i| i as u32 - 1)),
            _ => {}
        }
    }
    let mut mesh = Mesh::new(PrimitiveTopology::TriangleList, default())
        .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions)
        .with_inserted_indices(Indices::U32(indices));
    mesh.compute_smooth_normals();
    mesh
}

/// The walls' cameras, the models spread over the three walls (as the
/// paper's scenes A and B), a light, and the CAVE's screens drawn faintly
/// so that the walls' edges show.
pub fn spawn(
    mut commands: Commands,
    layout: Res<Layout>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    mut images: ResMut<Assets<Image>>,
) {
    commands.insert_resource(HeadSource::Simulated(layout.gaze.clone()));
    commands.insert_resource(GlobalAmbientLight {
        color: Color::srgb(0.6, 0.65, 0.75),
        brightness: 250.0,
        ..default()
    });
    let model = meshes.add(bunny());
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
            SceneEntity,
            Name::new(format!("{kind} {}", i + 1)),
            Mesh3d(model.clone()),
            // About 0.35 m tall, standing on its base, turned this way and that.
            Transform::from_translation(p - Vec3::Y * 0.17)
                .with_rotation(Quat::from_rotation_y(0.9 * i as f32 - 0.5))
                .with_scale(Vec3::splat(BUNNY_SCALE)),
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
        SceneEntity,
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
        SceneEntity,
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
                let mut c = commands.spawn((SceneEntity, name, CaveView::new(wall, eye), camera));
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
                let mut c =
                    commands.spawn((SceneEntity, name, CaveView::new(wall, eye), camera, target));
                if let Some(t) = tracer {
                    c.insert(t);
                }
            }
        }
    }
}

/// Prints each model's level once it settled (headless runs).
pub fn report_levels(
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
