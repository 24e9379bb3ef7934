//! Scenes that the report's sweeps and the render tests both draw, written
//! once: a test and a report row that hold the same plugin to numbers see
//! the same scene.

use bevy::camera::Hdr;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_compound_eye::{CompoundEye, CompoundEyeMaterial, CompoundEyePlugin};
use optica_dome::DomePlugin;
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
                commands.spawn(eye_light());
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
                let mut camera = commands.spawn(clearing_camera(clear, fov, 0.05));
                if let Some(s) = spectacles.clone() {
                    camera.insert(s);
                }
            },
        );
    }
}

/// Radical inverse of `i` in `base` (the Halton sequence): the evenly
/// spread sample points of the spectacles' parity test and sweep.
pub fn halton(i: usize, base: usize) -> f64 {
    let (mut f, mut r, mut i) = (1.0, 0.0, i);
    while i > 0 {
        f /= base as f64;
        r += f * (i % base) as f64;
        i /= base;
    }
    r
}

/// A camera's look for measuring: clearing to black, untonemapped (values
/// come out as drawn), `msaa`.
pub fn black_untonemapped(msaa: Msaa) -> impl Bundle {
    (
        Camera {
            clear_color: ClearColorConfig::Custom(Color::BLACK),
            ..default()
        },
        Tonemapping::None,
        msaa,
    )
}

/// A camera at the origin looking along −Z, clearing to black, HDR,
/// untonemapped, one sample per pixel: its image is the lens flare's light.
pub fn black_hdr_camera() -> impl Bundle {
    (Camera3d::default(), black_untonemapped(Msaa::Off), Hdr)
}

/// A perspective camera of vertical field `fov` (rad) and near plane
/// `near` (m), clearing to `clear`, one sample per pixel.
pub fn clearing_camera(clear: Color, fov: f32, near: f32) -> impl Bundle {
    (
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(clear),
            ..default()
        },
        Msaa::Off,
        Projection::Perspective(PerspectiveProjection {
            fov,
            near,
            ..default()
        }),
    )
}

/// The compound-eye scenes' light: a directional light of 6,000 lux
/// without shadows, from (1, 2, 3) towards the origin.
pub fn eye_light() -> impl Bundle {
    (
        DirectionalLight {
            illuminance: 6_000.0,
            shadow_maps_enabled: false,
            ..default()
        },
        Transform::from_xyz(1.0, 2.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y),
    )
}

/// An unlit material drawn on both sides: its colour comes out as given
/// from whichever side a dome sees it.
pub fn unlit(colour: Color) -> StandardMaterial {
    StandardMaterial {
        base_color: colour,
        unlit: true,
        cull_mode: None,
        ..default()
    }
}

/// The dome scenes' view: from the origin to the zenith (+Y), the back of
/// the theatre towards +Z.
pub fn zenith() -> Transform {
    Transform::IDENTITY.looking_to(Vec3::Y, Vec3::Z)
}

/// Outward axis of each face of the dome room, the box [−1, 1]³: ceiling,
/// front, back, right, left, floor.
pub const ROOM_AXES: [Vec3; 6] = [Vec3::Y, Vec3::NEG_Z, Vec3::Z, Vec3::X, Vec3::NEG_X, Vec3::NEG_Y];

/// The dome room (faces in `colours`, `quads`×`quads` quads each, see
/// [`spawn_room`]) with the dome plugin, seen by what `view` spawns.
pub fn dome_room(
    colours: [Color; 6],
    quads: u32,
    view: impl Fn(&mut Commands) + Send + Sync + 'static,
) -> impl FnOnce(&mut App) {
    move |app: &mut App| {
        app.add_plugins(DomePlugin);
        app.add_systems(
            Startup,
            move |mut commands: Commands,
                  mut meshes: ResMut<Assets<Mesh>>,
                  mut materials: ResMut<Assets<StandardMaterial>>| {
                spawn_room(&mut commands, &mut meshes, &mut materials, colours, quads);
                view(&mut commands);
            },
        );
    }
}

/// Spawns the dome room: face `k` (of [`ROOM_AXES`]) `unlit` in
/// `colours[k]`, facing in, `quads`×`quads` quads.
pub fn spawn_room(
    commands: &mut Commands,
    meshes: &mut Assets<Mesh>,
    materials: &mut Assets<StandardMaterial>,
    colours: [Color; 6],
    quads: u32,
) {
    let plane = meshes.add(room_face_mesh(quads));
    for (axis, colour) in ROOM_AXES.into_iter().zip(colours) {
        commands.spawn((
            Mesh3d(plane.clone()),
            MeshMaterial3d(materials.add(unlit(colour))),
            room_face(axis),
        ));
    }
}

/// A face of the dome room: a 2 × 2 plane of `quads`×`quads` quads, its
/// normal +Y.
pub fn room_face_mesh(quads: u32) -> Mesh {
    Plane3d::default().mesh().size(2.0, 2.0).subdivisions(quads.max(1) - 1).build()
}

/// Where the room's face of outward `axis` lies, its normal turned to
/// point into the room.
pub fn room_face(axis: Vec3) -> Transform {
    Transform::from_translation(axis).with_rotation(Quat::from_rotation_arc(Vec3::Y, -axis))
}
