//! Golden image on lavapipe: a lit room through a tilted 180° dome — walls,
//! a sphere and a box, a shadow-casting sun through the (absent) ceiling's
//! light and a point light: Bevy's lights and shadows on the refined twins.

use bevy::prelude::*;
use optica_dome::{DomeCamera, DomeLens, DomeMode, DomePlugin};
use optica_harness::{Golden, Headless, Tolerance, assert_golden, golden_name};

use super::dome_camera;

fn lit_room(app: &mut App) {
    lit_room_drawn_by(DomeMode::Vertex)(app);
}

/// The lit room through a tilted dome camera in `mode`.
fn lit_room_drawn_by(mode: DomeMode) -> impl FnOnce(&mut App) {
    lit_room_through(mode, DomeLens::Equidistant, 180.0)
}

/// The lit room through a tilted dome camera in `mode` with `lens` and a
/// field of view of `fov_deg`.
fn lit_room_through(mode: DomeMode, lens: DomeLens, fov_deg: f32) -> impl FnOnce(&mut App) {
    move |app: &mut App| {
        app.add_plugins(DomePlugin);
        app.add_systems(
            Startup,
            move |mut commands: Commands,
                  mut meshes: ResMut<Assets<Mesh>>,
                  mut materials: ResMut<Assets<StandardMaterial>>| {
                let mut paint = |c: Color| {
                    MeshMaterial3d(materials.add(StandardMaterial {
                        base_color: c,
                        perceptual_roughness: 0.6,
                        ..default()
                    }))
                };
                let wall = meshes.add(Plane3d::default().mesh().size(8.0, 4.0));
                let floor = meshes.add(Plane3d::default().mesh().size(8.0, 8.0));
                commands.spawn((Mesh3d(floor), paint(Color::srgb(0.6, 0.6, 0.55))));
                for (i, colour) in [
                    Color::srgb(0.8, 0.3, 0.2),
                    Color::srgb(0.2, 0.5, 0.8),
                    Color::srgb(0.3, 0.7, 0.3),
                    Color::srgb(0.8, 0.7, 0.3),
                ]
                .into_iter()
                .enumerate()
                {
                    let turn = Quat::from_rotation_y(i as f32 * std::f32::consts::FRAC_PI_2);
                    // A wall 4 units from the centre, facing in.
                    let place = Transform::from_rotation(turn)
                        * Transform::from_xyz(0.0, 2.0, -4.0)
                            .with_rotation(Quat::from_rotation_x(std::f32::consts::FRAC_PI_2));
                    commands.spawn((Mesh3d(wall.clone()), paint(colour), place));
                }
                commands.spawn((
                    Mesh3d(meshes.add(Sphere::new(0.6).mesh().uv(24, 12))),
                    paint(Color::srgb(0.9, 0.9, 0.9)),
                    Transform::from_xyz(-1.2, 0.6, -1.5),
                ));
                commands.spawn((
                    Mesh3d(meshes.add(Cuboid::new(1.0, 2.0, 1.0))),
                    paint(Color::srgb(0.5, 0.4, 0.7)),
                    Transform::from_xyz(1.5, 1.0, -0.5),
                ));
                commands.spawn((
                    DirectionalLight {
                        illuminance: 4_000.0,
                        shadow_maps_enabled: true,
                        ..default()
                    },
                    Transform::from_xyz(2.0, 6.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
                ));
                commands.spawn((
                    PointLight {
                        intensity: 300_000.0,
                        range: 20.0,
                        ..default()
                    },
                    Transform::from_xyz(-2.0, 3.0, 2.0),
                ));
                commands.spawn(dome_camera(
                    DomeCamera {
                        tilt_deg: 20.0,
                        mode,
                        lens,
                        fov_deg,
                        ..default()
                    },
                    Transform::from_xyz(0.0, 1.2, 1.0).looking_to(Vec3::Y, Vec3::Z),
                ));
            },
        );
    }
}

#[test]
fn lit_room_through_a_tilted_dome() {
    let frame = Headless::new(128, 128).render(lit_room).expect("render");
    assert_golden!(&frame);
}

/// The lit room through every other lens (the equidistant one is the
/// golden above), each at a field of view it is made for: a golden each.
#[test]
fn lit_room_through_every_lens() {
    let goldens = Golden::new(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden"));
    for (lens, fov) in [
        (DomeLens::Equisolid, 200.0),
        (DomeLens::Stereographic, 180.0),
        (DomeLens::Orthographic, 180.0),
        (DomeLens::ALL[4], 220.0),
    ] {
        let frame = Headless::new(128, 128)
            .render(lit_room_through(DomeMode::Vertex, lens, fov))
            .expect("render");
        let name = format!("{}__{}", golden_name!(), lens.name());
        goldens.assert_matches(&name, &frame, Tolerance::default());
    }
}

/// The same room in the cube-map mode (4 faces of 96 px for a 128 px
/// domemaster), its golden, and its agreement with the vertex mode: lights,
/// shadows and shading match but for the edges' anti-aliasing and the
/// cube's texel filtering (PSNR above 24 dB).
#[test]
fn lit_room_through_a_tilted_dome_cube_mode() {
    let cube = Headless::new(128, 128)
        .render(lit_room_drawn_by(DomeMode::CubeMap { face_px: 96 }))
        .expect("render");
    let vertex = Headless::new(128, 128).render(lit_room).expect("render");
    let psnr =
        optica_harness::metrics::psnr(&vertex.to_rgba8(), &cube.to_rgba8()).expect("same size");
    eprintln!("lit room, cube against vertex mode: PSNR {psnr:.1} dB");
    assert!(psnr > 24.0, "the modes differ: PSNR {psnr:.1} dB");
    assert_golden!(&cube);
}

/// Shadow cascades fit what the dome sees (in front of its view plane):
/// a sun shining upwards past a small box casts the box's shadow onto a
/// ceiling right above the camera.
#[test]
fn shadows_fall_where_the_dome_looks() {
    let frame = Headless::new(96, 96)
        .render(|app: &mut App| {
            app.add_plugins(DomePlugin);
            app.add_systems(
                Startup,
                |mut commands: Commands,
                 mut meshes: ResMut<Assets<Mesh>>,
                 mut materials: ResMut<Assets<StandardMaterial>>| {
                    let white = materials.add(StandardMaterial {
                        base_color: Color::WHITE,
                        cull_mode: None,
                        ..default()
                    });
                    // The ceiling, 6 up, facing down.
                    commands.spawn((
                        Mesh3d(meshes.add(Plane3d::new(Vec3::NEG_Y, Vec2::splat(10.0)).mesh())),
                        MeshMaterial3d(white.clone()),
                        Transform::from_xyz(0.0, 6.0, 0.0),
                    ));
                    // A box to one side, 3 up: with the sun going up and
                    // towards +x (1 across for 2 up), its shadow lands on
                    // the ceiling straight above the camera.
                    commands.spawn((
                        Mesh3d(meshes.add(Cuboid::from_length(1.0))),
                        MeshMaterial3d(white),
                        Transform::from_xyz(-1.5, 3.0, 0.0),
                    ));
                    commands.spawn((
                        DirectionalLight {
                            illuminance: 10_000.0,
                            shadow_maps_enabled: true,
                            ..default()
                        },
                        Transform::IDENTITY.looking_to(Vec3::new(0.5, 1.0, 0.0), Vec3::Z),
                    ));
                    commands.spawn(dome_camera(DomeCamera::default(), super::zenith()));
                },
            );
        })
        .expect("render");
    let img = frame.to_rgba8();
    let luma = |x: u32, y: u32| {
        img.get_pixel(x, y).0[..3]
            .iter()
            .map(|&v| v as f32)
            .sum::<f32>()
    };
    // The zenith (image centre) is in the box's shadow; the ceiling towards
    // the audience's front (below the centre in the image) is lit.
    let (shadowed, lit) = (luma(48, 48), luma(48, 70));
    assert!(shadowed < 0.5 * lit, "zenith {shadowed}, lit ceiling {lit}");
}
