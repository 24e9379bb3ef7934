//! The lens flare scene: a low sun at dusk over a field of pillars and
//! three coloured lamps, seen through a real lens (the coated Brendel
//! Tessar by default); the camera pans slowly so the ghosts slide through
//! the picture along the line through the sun and the centre.

// Each example uses part of this file; the showcase uses all of it.
#![allow(dead_code)]

use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::prelude::*;
use optica::lens_flare::{FlareSource, LensFlare, LensFlarePlugin};

use super::common::SceneEntity;

/// The scene's name in file names and on the command line.
pub const NAME: &str = "lens_flare";
/// The picture's size in a window of its own.
pub const SIZE: (u32, u32) = (960, 540);
/// Pan rate of the camera, radians per second.
const PAN: f32 = 0.08;

/// The shipped lenses, embedded in the plugin: (name, asset path).
pub use optica::lens_flare::lenses::ALL as LENSES;

/// What the scene starts with: the lens (an index into [`LENSES`]) and
/// the pan's clock (s).
#[derive(Resource, Clone, Debug, Default)]
pub struct FlareScene {
    /// Index into [`LENSES`].
    pub lens: usize,
    /// The pan's clock, seconds (real time in a window, fixed for snapshots).
    pub clock: f32,
}

/// Adds the plugin and the pan (it moves only this scene's camera).
pub fn build(app: &mut App) {
    app.add_plugins(LensFlarePlugin)
        .init_resource::<FlareScene>()
        .add_systems(Update, pan);
}

/// Runs the pan's clock in real time (a window).
pub fn run_clock(app: &mut App) {
    app.add_systems(First, |time: Res<Time>, mut scene: ResMut<FlareScene>| {
        scene.clock = time.elapsed_secs();
    });
}

pub fn spawn(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
    assets: Res<AssetServer>,
    scene: Res<FlareScene>,
) {
    commands.insert_resource(ClearColor(Color::srgb(0.04, 0.06, 0.14)));
    commands.insert_resource(GlobalAmbientLight::default());
    commands.spawn((
        SceneEntity,
        Mesh3d(meshes.add(Plane3d::default().mesh().size(400.0, 400.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.25, 0.3, 0.2),
            perceptual_roughness: 0.9,
            ..default()
        })),
    ));
    let stone = materials.add(StandardMaterial {
        base_color: Color::srgb(0.6, 0.58, 0.55),
        ..default()
    });
    let pillar = meshes.add(Cuboid::new(2.0, 14.0, 2.0));
    for k in 0..9 {
        let a = -0.9 + 0.22 * k as f32;
        let d = 30.0 + 8.0 * (k % 3) as f32;
        commands.spawn((
            SceneEntity,
            Mesh3d(pillar.clone()),
            MeshMaterial3d(stone.clone()),
            Transform::from_xyz(d * a.sin(), 7.0, -d * a.cos()),
        ));
    }
    // A low sun ahead, a little to the right, and its disc on the sky.
    let travel = Vec3::new(-0.3, -0.13, 1.0).normalize();
    commands.spawn((
        SceneEntity,
        DirectionalLight {
            illuminance: 8_000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::IDENTITY.looking_to(travel, Vec3::Y),
        FlareSource::default(),
    ));
    commands.spawn((
        SceneEntity,
        Mesh3d(meshes.add(Sphere::new(3.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::BLACK,
            emissive: LinearRgba::rgb(400.0, 300.0, 200.0),
            ..default()
        })),
        Transform::from_translation(-travel * 300.0),
    ));
    // Three lamps: they flare too.
    for (k, colour) in [
        Color::srgb(1.0, 0.5, 0.2),
        Color::srgb(0.3, 1.0, 0.4),
        Color::srgb(0.4, 0.5, 1.0),
    ]
    .into_iter()
    .enumerate()
    {
        commands.spawn((
            SceneEntity,
            PointLight {
                intensity: 4.0e5,
                range: 60.0,
                color: colour,
                ..default()
            },
            Transform::from_xyz(-8.0 + 8.0 * k as f32, 3.0, -14.0),
            FlareSource::default(),
        ));
    }
    commands.spawn((
        SceneEntity,
        Camera3d::default(),
        Tonemapping::TonyMcMapface,
        Transform::from_xyz(0.0, 1.7, 6.0),
        LensFlare {
            // Dusk light is dim; the ghosts are scaled up to show.
            intensity: 150.0,
            ..LensFlare::new(assets.load(LENSES[scene.lens].1))
        },
    ));
}

/// Pans the camera left and right with the clock.
fn pan(scene: Res<FlareScene>, mut cameras: Query<&mut Transform, With<LensFlare>>) {
    for mut t in &mut cameras {
        let yaw = 0.25 * (PAN * scene.clock * 4.0).sin();
        t.rotation = Quat::from_rotation_y(yaw) * Quat::from_rotation_x(0.08);
    }
}

