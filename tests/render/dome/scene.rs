//! A room seen through the dome: an inside-out box of six unlit,
//! differently coloured faces around a zenith-looking 180° dome camera.
//! Every pixel inside the image circle must show the face that the CPU
//! twin's inverse projection of its centre hits; outside it, the rim mask.

use bevy::prelude::*;
use optica_dome::{DomeCamera, DomePlugin};
use optica_harness::{Headless, RenderedFrame};
use optica_report::fixtures::{ROOM_AXES, dome_room};

use super::{dome_camera, flat, zenith};
use optica_optics::dome::cube_face_axis;
use optica_optics::glam::{DVec2, DVec3};

pub(super) const SIZE: u32 = 128;

/// The colour of each face of the room (`fixtures::ROOM_AXES`). The floor
/// lies behind a 180° dome: dropped, it must not show.
const FACES: [[f32; 3]; 6] = [
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 1.0, 0.0],
    [1.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
];

/// The room, each face `quads`×`quads` quads, seen by a dome camera with
/// `tolerance_px`.
fn room(quads: u32, tolerance_px: f32) -> impl FnOnce(&mut App) {
    room_seen_by(
        quads,
        DomeCamera {
            tolerance_px,
            ..default()
        },
    )
}

/// The room, each face `quads`×`quads` quads, seen by `dome`.
pub(super) fn room_seen_by(quads: u32, dome: DomeCamera) -> impl FnOnce(&mut App) {
    let colours = FACES.map(|[r, g, b]| Color::srgb(r, g, b));
    dome_room(colours, quads, move |commands| {
        commands.spawn(dome_camera(dome, zenith()));
    })
}

/// The face the ray from the room's centre along `dir` meets.
fn face_of(dir: DVec3) -> usize {
    let axis = cube_face_axis(dir).as_vec3();
    ROOM_AXES.iter().position(|f| *f == axis).unwrap_or(usize::MAX)
}

/// The fraction of pixels inside the image circle that show the face the
/// CPU twin's inverse projection of their centre meets; asserts that the
/// square's corners are black.
fn faces_right(quads: u32, tolerance_px: f32) -> f64 {
    let camera = DomeCamera {
        tolerance_px,
        ..default()
    };
    let frame = Headless::new(SIZE, SIZE)
        .render(room_seen_by(quads, camera))
        .expect("render");
    let fraction = faces_shown(&frame, camera);
    eprintln!("{quads}×{quads} quads a face, tolerance {tolerance_px} px");
    fraction
}

/// The face colour (or black, `FACES.len()`) nearest to a pixel's: exact
/// for the vertex mode, the 50 % line between two faces for a resampled
/// (bilinear) image.
pub(super) fn nearest_face(p: [u8; 4]) -> usize {
    let colours = FACES
        .iter()
        .map(|c| c.map(|v| v * 255.0))
        .chain([[0.0; 3]]);
    let distance = |c: [f32; 3]| {
        (0..3)
            .map(|k| (c[k] - f32::from(p[k])).powi(2))
            .sum::<f32>()
    };
    colours
        .enumerate()
        .min_by(|a, b| distance(a.1).total_cmp(&distance(b.1)))
        .map_or(FACES.len(), |(k, _)| k)
}

/// Of the room seen by `camera` (at `SIZE`), the fraction of pixels inside
/// the image circle whose nearest colour is the face the CPU twin's
/// inverse projection of their centre meets; asserts that the square's
/// corners are black.
pub(super) fn faces_shown(frame: &RenderedFrame, dome_settings: DomeCamera) -> f64 {
    let img = frame.to_rgba8();
    let (width, height) = img.dimensions();
    let dome = dome_settings
        .projection_of_target(width, height)
        .expect("a valid dome");
    let rotation = zenith().rotation.as_dquat();
    let (mut inside, mut matching, mut outside) = (0usize, 0usize, 0usize);
    let mut misses = Vec::new();
    for y in 0..height {
        for x in 0..width {
            let pixel = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
            let r = (pixel - dome.centre_px()).length();
            // Outside the circle the rim mask paints black (the walls
            // reach a little past the rim, to the guard cone).
            if r > dome.rim_radius_px() + 1.0 {
                let got = img.get_pixel(x, y).0;
                assert_eq!(
                    [got[0], got[1], got[2]],
                    [0, 0, 0],
                    "pixel ({x}, {y}) outside the circle"
                );
                outside += 1;
                continue;
            }
            // The anti-aliased rim itself is neither.
            if r > dome.rim_radius_px() - 1.0 {
                continue;
            }
            let view = dome.unproject(pixel).expect("inside the circle");
            let want = face_of(rotation * view);
            let got = img.get_pixel(x, y).0;
            inside += 1;
            if nearest_face(got) == want {
                matching += 1;
            } else if misses.len() < 8 {
                misses.push((x, y, want, got));
            }
        }
    }
    assert!(outside > 3000, "only {outside} pixels outside the circle");
    let fraction = matching as f64 / inside as f64;
    eprintln!(
        "{dome_settings:?}: {matching} of {inside} pixels show their face ({:.2} %); first misses {misses:?}",
        100.0 * fraction
    );
    fraction
}

/// One quad a face: the walls' edges span up to 90°, so only the
/// refinement (and the clipping of the floor, behind the viewer) puts them
/// where they belong.
#[test]
fn every_pixel_shows_the_face_its_direction_meets() {
    let refined = faces_right(1, 0.5);
    assert!(refined > 0.99, "{refined:.4} of the pixels match at 0.5 px");
    // Already subdivided faces come out the same.
    let fine = faces_right(16, 0.5);
    assert!(
        fine > 0.99,
        "{fine:.4} of the pixels match with 16×16 quads"
    );
    // A loose tolerance lets the chords sag: more pixels are wrong.
    let loose = faces_right(1, 40.0);
    assert!(
        loose < refined - 0.005,
        "40 px: {loose:.4}, 0.5 px: {refined:.4}"
    );
}

/// Culling fit for a fisheye: a small cube 85° from the zenith, outside any
/// perspective frustum narrower than 170° (the 90° one Bevy would build from
/// the dome's matrix included), is drawn where the CPU twin projects it.
#[test]
fn a_cube_near_the_rim_is_drawn_where_the_cpu_twin_puts_it() {
    let theta = 85f32.to_radians();
    // Towards the audience's right (+X), 85° down from the zenith (+Y).
    let centre = 3.0 * Vec3::new(theta.sin(), theta.cos(), 0.0);
    let frame = Headless::new(SIZE, SIZE)
        .render(move |app: &mut App| {
            app.add_plugins(DomePlugin);
            app.add_systems(
                Startup,
                move |mut commands: Commands,
                      mut meshes: ResMut<Assets<Mesh>>,
                      mut materials: ResMut<Assets<StandardMaterial>>| {
                    commands.spawn((
                        Mesh3d(meshes.add(Cuboid::from_length(0.5))),
                        flat(&mut materials, Color::WHITE),
                        Transform::from_translation(centre),
                    ));
                    commands.spawn(dome_camera(DomeCamera::default(), zenith()));
                },
            );
        })
        .expect("render");
    let img = frame.to_rgba8();
    let dome = DomeCamera::default()
        .projection(SIZE)
        .expect("a valid dome");
    let view = zenith().rotation.inverse() * centre;
    let expected = dome
        .project(view.as_dvec3())
        .visible_pixel()
        .expect("inside the circle");
    let lit: Vec<DVec2> = img
        .enumerate_pixels()
        .filter(|(_, _, p)| p.0[0] > 128)
        .map(|(x, y, _)| DVec2::new(x as f64 + 0.5, y as f64 + 0.5))
        .collect();
    assert!(
        !lit.is_empty(),
        "the cube near the rim was culled or not drawn"
    );
    let mean = lit.iter().copied().sum::<DVec2>() / lit.len() as f64;
    eprintln!(
        "cube near the rim: {} px, centroid {mean}, CPU twin {expected}",
        lit.len()
    );
    assert!(
        (mean - expected).length() < 2.0,
        "drawn at {mean}, the CPU twin puts it at {expected}"
    );
}

/// A moving camera: the twins are refined again every frame (in place, so
/// that Bevy keeps drawing them) and the room still fills the circle.
#[test]
fn a_turning_dome_camera_keeps_drawing_the_room() {
    let frame = Headless::new(SIZE, SIZE)
        .frames(6)
        .render(|app: &mut App| {
            room(1, 0.5)(app);
            app.add_systems(
                Update,
                |mut cameras: Query<&mut Transform, With<DomeCamera>>| {
                    for mut t in &mut cameras {
                        t.rotate_y(0.05);
                    }
                },
            );
        })
        .expect("render");
    let img = frame.to_rgba8();
    let dome = DomeCamera::default()
        .projection(SIZE)
        .expect("a valid dome");
    let (mut inside, mut coloured) = (0usize, 0usize);
    for (x, y, p) in img.enumerate_pixels() {
        let c = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
        if (c - dome.centre_px()).length() < dome.rim_radius_px() - 2.0 {
            inside += 1;
            coloured += usize::from(
                FACES
                    .iter()
                    .any(|f| f.map(|v| (v * 255.0) as u8) == [p.0[0], p.0[1], p.0[2]]),
            );
        }
    }
    assert!(
        coloured as f64 > 0.99 * inside as f64,
        "{coloured} of {inside} pixels show a face"
    );
}
