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
use optica_compound_eye::CompoundEye;

/// The base material every test eye uses: a dull red-brown.
pub use optica_report::fixtures::eye_base as base;

/// A scene: `mesh` with `eye` (or the plain base material when `None`), a
/// directional light without shadows, and `camera` (a transform and a
/// projection), MSAA off so that every pixel is one fragment at its centre
/// (the report's scene, `optica_report::fixtures::compound_eye_scene`).
pub fn scene(
    mesh: Mesh,
    mesh_transform: Transform,
    eye: Option<CompoundEye>,
    camera: Transform,
    projection: Projection,
) -> impl FnOnce(&mut App) {
    optica_report::fixtures::compound_eye_scene(
        mesh,
        mesh_transform,
        eye,
        camera,
        projection,
        Some(Color::srgb(0.05, 0.06, 0.08)),
    )
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
