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
                // A fisheye looks up; the panorama looks at the horizon.
                let mount = if lens == DomeLens::Equirectangular {
                    Transform::from_xyz(0.0, 1.2, 1.0).looking_to(Vec3::NEG_Z, Vec3::Y)
                } else {
                    Transform::from_xyz(0.0, 1.2, 1.0).looking_to(Vec3::Y, Vec3::Z)
                };
                commands.spawn(dome_camera(
                    DomeCamera {
                        tilt_deg: 20.0,
                        mode,
                        lens,
                        fov_deg,
                        ..default()
                    },
                    mount,
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

/// The lit room as a 256 × 128 equirectangular panorama (tilted 20°, so
/// the floor crosses the seam and the open ceiling's pole shows black): its
/// golden, and the cube mode (6 faces of 96 px) against it, as for the
/// fisheye above.
#[test]
fn lit_room_as_an_equirectangular_panorama() {
    let through = |mode| lit_room_through(mode, DomeLens::Equirectangular, 180.0);
    let vertex = Headless::new(256, 128)
        .render(through(DomeMode::Vertex))
        .expect("render");
    let cube = Headless::new(256, 128)
        .render(through(DomeMode::CubeMap { face_px: 96 }))
        .expect("render");
    let psnr =
        optica_harness::metrics::psnr(&vertex.to_rgba8(), &cube.to_rgba8()).expect("same size");
    eprintln!("lit room panorama, cube against vertex mode: PSNR {psnr:.1} dB");
    assert!(psnr > 24.0, "the modes differ: PSNR {psnr:.1} dB");
    // The seam's two columns show the wall behind the camera and the
    // floor, down to the bottom row (the nadir's row), not the clear
    // colour a gap would leave.
    let img = vertex.to_rgba8();
    for y in 55..128 {
        for x in [0, 255] {
            let p = img.get_pixel(x, y).0;
            assert!(
                p[0] as u32 + p[1] as u32 + p[2] as u32 > 30,
                "({x}, {y}) is {p:?}"
            );
        }
    }
    assert_golden!(&vertex);
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
