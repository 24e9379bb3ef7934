//! Leave out what a scene does not need: with the plugin added but no
//! compound-eye material in the scene, no extra pipeline is built.

use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_compound_eye::CompoundEye;
use optica_harness::{Adapter, Headless, PipelineReport};

use super::{base, ortho, scene};

fn pipelines(setup: impl FnOnce(&mut App)) -> PipelineReport {
    Headless::new(32, 32)
        .adapter(Adapter::Noop)
        .frames(2)
        .check_pipelines(setup)
        .expect("pipelines compile")
}

fn camera() -> Transform {
    Transform::from_xyz(0.0, 0.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y)
}

fn sphere() -> Mesh {
    Sphere::new(0.5).mesh().uv(32, 16)
}

/// The same scene as `scene(.., None, ..)`, without the plugin.
fn without_plugin(app: &mut App) {
    app.add_systems(
        Startup,
        |mut commands: Commands,
         mut meshes: ResMut<Assets<Mesh>>,
         mut plain: ResMut<Assets<StandardMaterial>>| {
            commands.spawn((
                Mesh3d(meshes.add(sphere())),
                MeshMaterial3d(plain.add(base())),
            ));
            commands.spawn((
                DirectionalLight {
                    illuminance: 6_000.0,
                    shadow_maps_enabled: false,
                    ..default()
                },
                Transform::from_xyz(1.0, 2.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
            ));
            commands.spawn((Camera3d::default(), Msaa::Off, ortho(2.0), camera()));
        },
    );
}

#[test]
fn no_material_no_pipeline_and_the_material_compiles_on_noop() {
    let plain = pipelines(without_plugin);
    let plugin_no_material = pipelines(scene(
        sphere(),
        Transform::IDENTITY,
        None,
        camera(),
        ortho(2.0),
    ));
    // The same plain sphere, and a compound-eye sphere beside it.
    let with_material = pipelines(|app| {
        scene(
            sphere(),
            Transform::from_xyz(0.6, 0.0, 0.0),
            Some(CompoundEye::default()),
            camera(),
            ortho(2.0),
        )(app);
        app.add_systems(
            Startup,
            |mut commands: Commands,
             mut meshes: ResMut<Assets<Mesh>>,
             mut plain: ResMut<Assets<StandardMaterial>>| {
                commands.spawn((
                    Mesh3d(meshes.add(sphere())),
                    MeshMaterial3d(plain.add(base())),
                ));
            },
        );
    });
    eprintln!(
        "pipelines: without the plugin {}, plugin without material {}, with material {}",
        plain.ok, plugin_no_material.ok, with_material.ok
    );
    assert_eq!(
        plugin_no_material.ok, plain.ok,
        "{:?}\n{:?}",
        plugin_no_material.labels, plain.labels
    );
    assert!(
        with_material.ok > plugin_no_material.ok,
        "the material built no pipeline of its own: {:?}",
        with_material.labels
    );
}
