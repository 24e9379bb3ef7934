//! Leave out what a scene does not need: with the plugin added but no
//! compound-eye material in the scene, no extra pipeline is built.

use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_compound_eye::CompoundEye;
use optica_harness::{Headless, PipelineReport};

use super::{base, deferred, ortho, scene};

fn pipelines(setup: impl FnOnce(&mut App)) -> PipelineReport {
    crate::noop_pipelines(2, setup)
}

fn camera() -> Transform {
    Transform::from_xyz(0.0, 0.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y)
}

fn sphere() -> Mesh {
    Sphere::new(0.5).mesh().uv(32, 16)
}

/// Adds a plain sphere (the base material) at the origin.
fn with_plain_sphere(app: &mut App) {
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
}

/// The plain sphere of `without_plugin`, and a compound-eye sphere beside
/// it.
fn eye_beside_plain_sphere(app: &mut App) {
    scene(
        sphere(),
        Transform::from_xyz(0.6, 0.0, 0.0),
        Some(CompoundEye::default()),
        camera(),
        ortho(2.0),
    )(app);
    with_plain_sphere(app);
}

/// The same scene as `scene(.., None, ..)`, without the plugin.
fn without_plugin(app: &mut App) {
    with_plain_sphere(app);
    app.add_systems(Startup, |mut commands: Commands| {
        commands.spawn(optica_report::fixtures::eye_light());
        commands.spawn((Camera3d::default(), Msaa::Off, ortho(2.0), camera()));
    });
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
    let with_material = pipelines(eye_beside_plain_sphere);
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

/// The material in Bevy's other passes: it casts a shadow onto a plain
/// ground, and a camera with depth and normal prepasses draws it (the
/// prepass and shadow pipelines compile; the harness fails on any that
/// does not).
#[test]
fn the_material_casts_shadows_and_works_with_prepasses() {
    use bevy::core_pipeline::prepass::{DepthPrepass, NormalPrepass};
    const SIZE: u32 = 64;
    const SPAN: f32 = 2.4;
    let frame = Headless::new(SIZE, SIZE)
        .render(|app: &mut App| {
            app.add_plugins(optica_compound_eye::CompoundEyePlugin);
            app.add_systems(
                Startup,
                |mut commands: Commands,
                 mut meshes: ResMut<Assets<Mesh>>,
                 mut eyes: ResMut<Assets<optica_compound_eye::CompoundEyeMaterial>>,
                 mut plain: ResMut<Assets<StandardMaterial>>| {
                    let eye = optica_compound_eye::CompoundEyeMaterial {
                        base: base(),
                        extension: CompoundEye::default(),
                    };
                    commands.spawn((Mesh3d(meshes.add(sphere())), MeshMaterial3d(eyes.add(eye))));
                    commands.spawn((
                        Mesh3d(meshes.add(Plane3d::default().mesh().size(4.0, 4.0))),
                        MeshMaterial3d(plain.add(StandardMaterial::from_color(Color::WHITE))),
                        Transform::from_xyz(0.0, -0.6, 0.0),
                    ));
                    // From +x, 45° up: the shadow falls towards −x.
                    commands.spawn((
                        DirectionalLight {
                            illuminance: 8_000.0,
                            shadow_maps_enabled: true,
                            ..default()
                        },
                        Transform::from_xyz(1.0, 1.0, 0.0).looking_at(Vec3::ZERO, Vec3::Y),
                    ));
                    // Straight down, screen right = +x.
                    commands.spawn((
                        Camera3d::default(),
                        Msaa::Off,
                        DepthPrepass,
                        NormalPrepass,
                        ortho(SPAN),
                        Transform::from_xyz(0.0, 5.0, 0.0).looking_at(Vec3::ZERO, Vec3::NEG_Z),
                    ));
                },
            );
        })
        .expect("render");
    let img = frame.to_rgba8();
    let px = |x: f32| ((0.5 + x / SPAN) * SIZE as f32) as u32;
    let luma = |x: f32| {
        let p = img.get_pixel(px(x), SIZE / 2).0;
        p[0] as f32 + p[1] as f32 + p[2] as f32
    };
    let (shadowed, lit) = (luma(-0.85), luma(0.85));
    assert!(
        shadowed < 0.6 * lit,
        "ground in the eye's shadow {shadowed}, in the light {lit}"
    );
}

/// The deferred renderer: the material's G-buffer variant (the same
/// shader under `PREPASS_PIPELINE`) compiles and is built for a deferred
/// camera. Its pixels are compared with forward in `render_paths.rs`.
#[test]
fn the_material_builds_its_deferred_pipeline_on_noop() {
    let plain = pipelines(|app| {
        scene(sphere(), Transform::IDENTITY, None, camera(), ortho(2.0))(app);
        deferred(app);
    });
    // The G-buffer pass runs the material's own shader, not the base's.
    let shader = <CompoundEye as bevy::pbr::MaterialExtension>::deferred_fragment_shader();
    assert!(
        matches!(&shader, bevy::shader::ShaderRef::Path(p) if p.to_string().ends_with("compound_eye.wgsl")),
        "the deferred pass would run the base material's shader"
    );
    let eye = pipelines(|app| {
        eye_beside_plain_sphere(app);
        deferred(app);
    });
    eprintln!(
        "deferred pipelines: plain {}, with the eye {}",
        plain.ok, eye.ok
    );
    assert!(
        eye.ok > plain.ok,
        "no pipeline of the material's own: {:?}",
        eye.labels
    );
}
