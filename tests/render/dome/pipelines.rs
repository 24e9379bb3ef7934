//! Leave out what a scene does not need: with the plugin but no dome
//! camera, no pipeline is built that the same scene without the plugin
//! does not build.

use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_dome::DomePlugin;
use optica_harness::PipelineReport;

fn pipelines(setup: impl FnOnce(&mut App)) -> PipelineReport {
    crate::noop_pipelines(2, setup)
}

fn scene(app: &mut App) {
    app.add_systems(
        Startup,
        |mut commands: Commands,
         mut meshes: ResMut<Assets<Mesh>>,
         mut materials: ResMut<Assets<StandardMaterial>>| {
            commands.spawn((
                Mesh3d(meshes.add(Cuboid::default())),
                MeshMaterial3d(materials.add(StandardMaterial::default())),
            ));
            commands.spawn((
                DirectionalLight::default(),
                Transform::from_xyz(1.0, 2.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
            ));
            commands.spawn((
                Camera3d::default(),
                Msaa::Off,
                Transform::from_xyz(0.0, 0.0, 4.0).looking_at(Vec3::ZERO, Vec3::Y),
            ));
        },
    );
}

#[test]
fn no_dome_camera_no_pipeline_and_a_dome_view_compiles_on_noop() {
    let plain = pipelines(scene);
    let plugin = pipelines(|app| {
        app.add_plugins(DomePlugin);
        scene(app);
    });
    assert_eq!(
        plugin.ok, plain.ok,
        "{:?}\n{:?}",
        plugin.labels, plain.labels
    );
    // A dome camera beside the perspective one: its view's pipelines (the
    // patched vertex path, VIEW_PROJECTION_NONSTANDARD) compile.
    let dome = pipelines(|app| {
        app.add_plugins(DomePlugin);
        scene(app);
        app.add_systems(Startup, |mut commands: Commands| {
            commands.spawn((
                optica_dome::DomeCamera::default(),
                Msaa::Off,
                super::zenith(),
            ));
        });
    });
    assert!(
        dome.ok > plain.ok,
        "the dome view built no pipeline of its own: {:?}",
        dome.labels
    );
    let resample = |r: &PipelineReport| r.labels.iter().any(|l| l.contains("cube_resample"));
    assert!(
        !resample(&dome),
        "a vertex-mode dome built the cube pass: {:?}",
        dome.labels
    );
    // A cube-mode dome camera: its resampling pass compiles, and only then
    // is it built.
    let cube = pipelines(|app| {
        app.add_plugins(DomePlugin);
        scene(app);
        app.add_systems(Startup, |mut commands: Commands| {
            commands.spawn((
                optica_dome::DomeCamera {
                    mode: optica_dome::DomeMode::CubeMap { face_px: 16 },
                    ..default()
                },
                Msaa::Off,
                super::zenith(),
            ));
        });
    });
    assert!(resample(&cube), "no cube pass: {:?}", cube.labels);
}
