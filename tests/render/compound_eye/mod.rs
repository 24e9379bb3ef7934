//! The compound-eye material on lavapipe: its optics against the CPU twin,
//! the moving pseudopupil, goldens, stability, and no pipeline for a scene
//! without it.

mod environment;
mod eye_cap;
mod goldens;
mod parity;
mod pipelines;
mod pseudopupil;
mod render_paths;
mod stability;
mod texture;

use bevy::camera::ScalingMode;
use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_compound_eye::{CompoundEye, CompoundEyeMaterial, CompoundEyePlugin};

/// The base material every test eye uses: a dull red-brown.
pub fn base() -> StandardMaterial {
    StandardMaterial {
        base_color: Color::srgb(0.55, 0.16, 0.1),
        perceptual_roughness: 0.45,
        ..default()
    }
}

/// A scene: `mesh` with `eye` (or the plain base material when `None`), a
/// directional light without shadows, and `camera` (a transform and a
/// projection), MSAA off so that every pixel is one fragment at its centre.
pub fn scene(
    mesh: Mesh,
    mesh_transform: Transform,
    eye: Option<CompoundEye>,
    camera: Transform,
    projection: Projection,
) -> impl FnOnce(&mut App) {
    move |app: &mut App| {
        app.add_plugins(CompoundEyePlugin);
        app.add_systems(
            Startup,
            move |mut commands: Commands,
                  mut meshes: ResMut<Assets<Mesh>>,
                  mut eyes: ResMut<Assets<CompoundEyeMaterial>>,
                  mut plain: ResMut<Assets<StandardMaterial>>| {
                let mesh = meshes.add(mesh.clone());
                match eye.clone() {
                    Some(extension) => {
                        let material = eyes.add(CompoundEyeMaterial {
                            base: base(),
                            extension,
                        });
                        commands.spawn((Mesh3d(mesh), MeshMaterial3d(material), mesh_transform));
                    }
                    None => {
                        commands.spawn((
                            Mesh3d(mesh),
                            MeshMaterial3d(plain.add(base())),
                            mesh_transform,
                        ));
                    }
                }
                commands.spawn((
                    DirectionalLight {
                        illuminance: 6_000.0,
                        shadow_maps_enabled: false,
                        ..default()
                    },
                    Transform::from_xyz(1.0, 2.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
                ));
                commands.spawn((
                    Camera3d::default(),
                    Camera {
                        clear_color: ClearColorConfig::Custom(Color::srgb(0.05, 0.06, 0.08)),
                        ..default()
                    },
                    Msaa::Off,
                    projection.clone(),
                    camera,
                ));
            },
        );
    }
}

/// An orthographic projection showing `size`×`size` world units.
pub fn ortho(size: f32) -> Projection {
    Projection::Orthographic(OrthographicProjection {
        scaling_mode: ScalingMode::Fixed {
            width: size,
            height: size,
        },
        ..OrthographicProjection::default_3d()
    })
}

/// Renders with the deferred renderer: the default opaque method and a
/// deferred prepass on every camera.
pub fn deferred(app: &mut App) {
    use bevy::core_pipeline::prepass::{DeferredPrepass, DepthPrepass};
    use bevy::pbr::DefaultOpaqueRendererMethod;
    app.insert_resource(DefaultOpaqueRendererMethod::deferred());
    app.add_systems(
        PostStartup,
        |cameras: Query<Entity, With<Camera3d>>, mut commands: Commands| {
            for camera in &cameras {
                commands
                    .entity(camera)
                    .insert((DepthPrepass, DeferredPrepass));
            }
        },
    );
}
