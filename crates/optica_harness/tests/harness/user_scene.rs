//! A golden-image test of a small animated scene, as a user of the harness
//! writes one.

use bevy::prelude::*;
use optica_harness::{Headless, assert_golden};

/// Marks what turns.
#[derive(Component)]
pub struct Spin;

/// The scene: an orange cube lit by a directional light, seen from above a
/// corner. No shadows: they cost most of a lavapipe frame.
pub fn scene(
    mut commands: Commands,
    mut meshes: ResMut<Assets<Mesh>>,
    mut materials: ResMut<Assets<StandardMaterial>>,
) {
    commands.spawn((
        Spin,
        Mesh3d(meshes.add(Cuboid::new(1.0, 1.0, 1.0))),
        MeshMaterial3d(materials.add(StandardMaterial {
            base_color: Color::srgb(0.8, 0.45, 0.2),
            perceptual_roughness: 0.6,
            ..default()
        })),
    ));
    commands.spawn((
        DirectionalLight {
            illuminance: 8_000.0,
            shadow_maps_enabled: false,
            ..default()
        },
        Transform::from_xyz(2.0, 4.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    commands.spawn((
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::srgb(0.1, 0.12, 0.16)),
            ..default()
        },
        Transform::from_xyz(1.8, 1.5, 2.4).looking_at(Vec3::ZERO, Vec3::Y),
    ));
}

/// Turns the cube at 1 rad per second of Bevy time.
pub fn spin(time: Res<Time>, mut cubes: Query<&mut Transform, With<Spin>>) {
    for mut transform in &mut cubes {
        transform.rotation = Quat::from_rotation_y(time.elapsed_secs());
    }
}

#[test]
fn lit_cube_matches_its_golden() {
    // The harness steps time by 1/60 s per frame, so after 30 frames the
    // cube has turned by the same angle on every machine, however slow.
    let frame = Headless::new(128, 128)
        .frames(30)
        .render(|app| {
            app.add_systems(Startup, scene).add_systems(Update, spin);
        })
        .expect("headless render");
    // Compared with tests/golden/user_scene__lit_cube_matches_its_golden.png,
    // the golden of lavapipe; other adapters have goldens of their own.
    assert_golden!(&frame);
}
