//! Scenes that the report's sweeps and the render tests both draw, written
//! once: a test and a report row that hold the same plugin to numbers see
//! the same scene.

use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_compound_eye::{CompoundEye, CompoundEyeMaterial, CompoundEyePlugin};
use optica_harness::textures::coordinates_in;
use optica_spectacles::{Spectacles, SpectaclesPlugin};

/// The base material of every test eye: a dull red-brown.
pub fn eye_base() -> StandardMaterial {
    StandardMaterial {
        base_color: Color::srgb(0.55, 0.16, 0.1),
        perceptual_roughness: 0.45,
        ..default()
    }
}

/// A compound eye on `mesh` (or the plain [`eye_base`] when `eye` is
/// `None`), a directional light without shadows, and a camera at `camera`
/// with `projection` and `clear` (Bevy's when `None`), MSAA off so that
/// every pixel is one fragment at its centre.
pub fn compound_eye_scene(
    mesh: Mesh,
    mesh_transform: Transform,
    eye: Option<CompoundEye>,
    camera: Transform,
    projection: Projection,
    clear: Option<Color>,
) -> impl FnOnce(&mut App) {
    move |app: &mut App| {
        app.add_plugins(CompoundEyePlugin);
        app.add_systems(
            Startup,
            move |mut commands: Commands,
                  mut meshes: ResMut<Assets<Mesh>>,
                  mut eyes: ResMut<Assets<CompoundEyeMaterial>>,
                  mut plain: ResMut<Assets<StandardMaterial>>| {
                let mesh = Mesh3d(meshes.add(mesh.clone()));
                match eye.clone() {
                    Some(extension) => commands.spawn((
                        mesh,
                        MeshMaterial3d(eyes.add(CompoundEyeMaterial {
                            base: eye_base(),
                            extension,
                        })),
                        mesh_transform,
                    )),
                    None => commands.spawn((
                        mesh,
                        MeshMaterial3d(plain.add(eye_base())),
                        mesh_transform,
                    )),
                };
                commands.spawn((
                    DirectionalLight {
                        illuminance: 6_000.0,
                        shadow_maps_enabled: false,
                        ..default()
                    },
                    Transform::from_xyz(1.0, 2.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
                ));
                let mut camera_entity =
                    commands.spawn((Camera3d::default(), Msaa::Off, projection.clone(), camera));
                if let Some(colour) = clear {
                    camera_entity.insert(Camera {
                        clear_color: ClearColorConfig::Custom(colour),
                        ..default()
                    });
                }
            },
        );
    }
}

/// A plane `plane_z` m ahead, `2·half` m wide, whose unlit texture holds
/// its own coordinates in `channels` (see
/// [`coordinates_in`]), seen by a
/// camera of vertical field `fov` (rad) through `spectacles` when given,
/// the background `clear`.
pub fn coordinate_plane(
    spectacles: Option<Spectacles>,
    fov: f32,
    plane_z: f32,
    half: f32,
    channels: [usize; 3],
    clear: Color,
) -> impl FnOnce(&mut App) {
    move |app: &mut App| {
        app.add_plugins(SpectaclesPlugin);
        app.add_systems(
            Startup,
            move |mut commands: Commands,
                  mut meshes: ResMut<Assets<Mesh>>,
                  mut images: ResMut<Assets<Image>>,
                  mut materials: ResMut<Assets<StandardMaterial>>| {
                commands.spawn((
                    Mesh3d(
                        meshes.add(
                            Plane3d::new(Vec3::Z, Vec2::splat(half))
                                .mesh()
                                .subdivisions(7),
                        ),
                    ),
                    MeshMaterial3d(materials.add(StandardMaterial {
                        base_color_texture: Some(images.add(coordinates_in(256, half, channels))),
                        unlit: true,
                        ..default()
                    })),
                    Transform::from_xyz(0.0, 0.0, -plane_z),
                ));
                let mut camera = commands.spawn((
                    Camera3d::default(),
                    Camera {
                        clear_color: ClearColorConfig::Custom(clear),
                        ..default()
                    },
                    Msaa::Off,
                    Projection::Perspective(PerspectiveProjection {
                        fov,
                        near: 0.05,
                        ..default()
                    }),
                ));
                if let Some(s) = spectacles.clone() {
                    camera.insert(s);
                }
            },
        );
    }
}
