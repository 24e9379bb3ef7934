//! Small scenes shared by the render tests.

use bevy::prelude::*;

/// A lit cube seen from above a corner, turned by `yaw` radians. No shadows:
/// they cost most of a lavapipe frame and this scene does not test them.
pub fn lit_cube(yaw: f32) -> impl Fn(Commands, ResMut<Assets<Mesh>>, ResMut<Assets<StandardMaterial>>) {
    move |mut commands, mut meshes, mut materials| {
        commands.spawn((
            Mesh3d(meshes.add(Cuboid::new(1.0, 1.0, 1.0))),
            MeshMaterial3d(materials.add(StandardMaterial {
                base_color: Color::srgb(0.8, 0.45, 0.2),
                perceptual_roughness: 0.6,
                ..default()
            })),
            Transform::from_rotation(Quat::from_rotation_y(yaw)),
        ));
        commands.spawn((
            DirectionalLight { illuminance: 8_000.0, shadow_maps_enabled: false, ..default() },
            Transform::from_xyz(2.0, 4.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
        ));
        commands.spawn((
            Camera3d::default(),
            Camera { clear_color: ClearColorConfig::Custom(Color::srgb(0.1, 0.12, 0.16)), ..default() },
            Transform::from_xyz(1.8, 1.5, 2.4).looking_at(Vec3::ZERO, Vec3::Y),
        ));
    }
}
