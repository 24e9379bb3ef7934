//! The compound eye scene: an insect head with two compound eyes, the
//! camera and the light orbiting it; the dark patch on each eye (the
//! pseudopupil) follows the camera over the facets.

// Each example uses part of this file; the showcase uses all of it.
#![allow(dead_code)]

use bevy::mesh::MeshBuilder;
use bevy::prelude::*;
use optica::compound_eye::{
    CompoundEye, CompoundEyeMaterial, CompoundEyePlugin, EyeCap, EyePreset,
};

use super::common::SceneEntity;

/// The scene's name in file names and on the command line.
pub const NAME: &str = "compound_eye";
/// The picture's size in a window of its own.
pub const SIZE: (u32, u32) = (960, 640);
/// Orbit speeds in radians per second.
const CAMERA_ORBIT: f32 = 0.35;
const LIGHT_ORBIT: f32 = -0.6;

/// What the scene starts with: the eyes' settings, and the orbit's clock
/// (s; real time in a window, fixed for snapshots).
#[derive(Resource, Clone, Debug)]
pub struct CompoundScene {
    /// Both eyes' settings.
    pub eye: CompoundEye,
    /// The orbit's clock (s).
    pub clock: f32,
}

impl Default for CompoundScene {
    fn default() -> Self {
        Self {
            eye: eye_of(&optica::compound_eye::presets::HOUSEFLY),
            clock: 0.0,
        }
    }
}

/// The eye settings for `preset`: its facet count made coarser so that
/// facets are visible at this scale (a real eye at this size would have
/// them far below a pixel; the prefilter then shows only the pseudopupil).
pub fn eye_of(preset: &EyePreset) -> CompoundEye {
    CompoundEye {
        facets_per_uv: CompoundEye::from_preset(preset).facets_per_uv.min(70.0),
        // The caps' UVs are conformal: their tangents lose nothing and
        // leave no seams.
        tangent_axes: true,
        ..CompoundEye::from_preset(preset)
    }
}

/// Adds the plugin and the orbit (it moves only this scene's camera and light).
pub fn build(app: &mut App) {
    app.add_plugins(CompoundEyePlugin)
        .init_resource::<CompoundScene>()
        .add_systems(Update, orbit);
}

/// Runs the orbit's clock in real time (a window).
pub fn run_clock(app: &mut App) {
    app.add_systems(
        First,
        |time: Res<Time>, mut scene: ResMut<CompoundScene>| {
            scene.clock = time.elapsed_secs();
        },
    );
}

/// One of the two compound eyes.
#[derive(Component)]
pub struct Eye;

#[derive(Component)]
struct Orbit {
    radius: f32,
    height: f32,
    speed: f32,
}

pub fn spawn(
    mut commands: Commands,
    start: Res<CompoundScene>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut plain: ResMut<Assets<StandardMaterial>>,
    mut eyes: ResMut<Assets<CompoundEyeMaterial>>,
) {
    commands.insert_resource(GlobalAmbientLight {
        color: Color::srgb(0.55, 0.65, 0.8),
        brightness: 350.0,
        ..default()
    });
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
        SceneEntity,
        Mesh3d(meshes.add(Sphere::new(1.0))),
        MeshMaterial3d(chitin.clone()),
        Transform::from_scale(Vec3::new(0.95, 0.8, 0.7)),
    ));
    commands.spawn((
        SceneEntity,
        Mesh3d(meshes.add(Capsule3d::new(0.55, 0.9))),
        MeshMaterial3d(chitin.clone()),
        Transform::from_xyz(0.0, -0.15, 1.35)
            .with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2)),
    ));
    // Antennae and mouthparts.
    for side in [-1.0f32, 1.0] {
        commands.spawn((
            SceneEntity,
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
            SceneEntity,
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
    let mut cap = EyeCap {
        half_angle: 130f32.to_radians(),
        ..default()
    }
    .build();
    // Its smooth axis field too, for the panel's "along the mesh's axis field".
    optica_compound_eye::insert_axis_field(&mut cap).expect("the cap is a triangle mesh with UVs");
    let eye_mesh = meshes.add(cap);
    for side in [-1.0f32, 1.0] {
        let material = eyes.add(CompoundEyeMaterial {
            base: StandardMaterial {
                base_color: Color::srgb(0.62, 0.14, 0.08),
                perceptual_roughness: 0.25,
                ..default()
            },
            extension: start.eye.clone(),
        });
        commands.spawn((
            SceneEntity,
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
        SceneEntity,
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
        SceneEntity,
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
fn orbit(scene: Res<CompoundScene>, mut movers: Query<(&Orbit, &mut Transform)>) {
    for (o, mut t) in &mut movers {
        let a = -0.45 - o.speed * scene.clock;
        *t = Transform::from_xyz(o.radius * a.cos(), o.height, o.radius * a.sin())
            .looking_at(Vec3::new(0.0, 0.1, 0.0), Vec3::Y);
    }
}

/// The panel edits both eyes together.
#[cfg(feature = "egui")]
pub fn edit_both_eyes(
    mut commands: Commands,
    eyes: Query<&MeshMaterial3d<CompoundEyeMaterial>, With<Eye>>,
) {
    commands.insert_resource(optica::compound_eye::CompoundEyePanel {
        materials: eyes.iter().map(|m| m.id()).collect(),
    });
}
