//! The cube-map mode: face cameras resampled into the domemaster. The room
//! of six coloured faces must come out as the CPU twin's inverse
//! projection says, with 4, 5 and 6 faces (by field of view), tilted, and
//! in agreement with the vertex mode on the same scene.

use bevy::prelude::*;
use optica_dome::{DomeCamera, DomeCubeFace, DomeLens, DomeMode, DomeTwinOf};
use optica_harness::Headless;

use super::scene::{SIZE, faces_shown, nearest_face, room_seen_by};

fn cube(fov_deg: f32, tilt_deg: f32) -> DomeCamera {
    DomeCamera {
        fov_deg,
        tilt_deg,
        mode: DomeMode::CubeMap { face_px: 96 },
        ..default()
    }
}

/// Every pixel's nearest colour is the face its direction meets: the cube
/// turned edge-on (4 faces) at 180°, face-on with 5 faces at 220°, and all
/// 6 at 300° (the floor shows); tilted by 30°.
#[test]
fn the_room_resampled_from_four_five_and_six_faces() {
    for camera in [
        cube(180.0, 0.0),
        cube(220.0, 0.0),
        cube(300.0, 0.0),
        cube(180.0, 30.0),
    ] {
        let frame = Headless::new(SIZE, SIZE)
            .render(room_seen_by(4, camera))
            .expect("render");
        let shown = faces_shown(&frame, camera);
        assert!(shown > 0.99, "{camera:?}: {shown:.4} of the pixels match");
    }
}

/// Every lens, in both modes, on a square and on a wide target: each
/// pixel shows the face its direction meets through the CPU twin's
/// inverse (one quad a face, so the vertex mode's refinement in each
/// lens's own image is what puts the walls' edges right). At 0.25 px: at
/// 0.5 px the orthographic lens, whose ceiling fills 82 % of the circle's
/// radius (61 % equidistant), has longer edges and 98.8 % of the wide
/// target's pixels right, most misses along an edge's sagging band.
#[test]
fn every_lens_in_both_modes_shows_each_pixel_its_face() {
    for lens in DomeLens::FISHEYES {
        for mode in [DomeMode::Vertex, DomeMode::CubeMap { face_px: 96 }] {
            for (w, h) in [(SIZE, SIZE), (160, 96)] {
                let camera = DomeCamera {
                    lens,
                    mode,
                    tolerance_px: 0.25,
                    ..default()
                };
                let frame = Headless::new(w, h)
                    .render(room_seen_by(1, camera))
                    .expect("render");
                let shown = faces_shown(&frame, camera);
                assert!(
                    shown > 0.99,
                    "{} {mode:?} {w}×{h}: {shown:.4} of the pixels match",
                    lens.name()
                );
            }
        }
    }
}

/// The two modes on the same room: the pixels' nearest colours agree but
/// for the edges' anti-aliasing (the cube mode filters, the vertex mode
/// does not) — at most 2 % of the pixels inside the circle.
#[test]
fn cube_and_vertex_modes_agree_on_the_room() {
    let vertex = DomeCamera::default();
    let cubed = cube(180.0, 0.0);
    let render = |camera| {
        Headless::new(SIZE, SIZE)
            .render(room_seen_by(1, camera))
            .expect("render")
            .to_rgba8()
    };
    let (a, b) = (render(vertex), render(cubed));
    let centre = SIZE as f32 / 2.0;
    let (mut inside, mut differ) = (0usize, 0usize);
    for (x, y, p) in a.enumerate_pixels() {
        let r = Vec2::new(x as f32 + 0.5 - centre, y as f32 + 0.5 - centre).length();
        if r > centre - 1.0 {
            continue;
        }
        inside += 1;
        differ += usize::from(nearest_face(p.0) != nearest_face(b.get_pixel(x, y).0));
    }
    let share = differ as f64 / inside as f64;
    eprintln!(
        "modes differ on {differ} of {inside} pixels ({:.2} %)",
        100.0 * share
    );
    assert!(share < 0.02, "{share:.4} of the pixels differ");
}

/// Switching modes at run time: the vertex mode's twins go when the camera
/// turns to the cube mode, the faces come (4 at 180°), and the room still
/// fills the circle; back to the vertex mode, the faces go.
#[test]
fn switching_modes_swaps_twins_for_faces() {
    use std::sync::{Arc, Mutex};
    // (twins, face cameras) at the start of each frame.
    let seen = Arc::new(Mutex::new(Vec::new()));
    let log = seen.clone();
    let frame = Headless::new(SIZE, SIZE)
        .frames(6)
        .render(move |app: &mut App| {
            room_seen_by(1, DomeCamera::default())(app);
            app.add_systems(
                Update,
                move |mut cameras: Query<&mut DomeCamera>,
                      twins: Query<(), With<DomeTwinOf>>,
                      faces: Query<(), With<DomeCubeFace>>| {
                    let mut log = log.lock().expect("log");
                    log.push((twins.iter().count(), faces.iter().count()));
                    let mode = match log.len() {
                        2 => DomeMode::CubeMap { face_px: 96 },
                        4 => DomeMode::Vertex,
                        5 => DomeMode::CubeMap { face_px: 96 },
                        _ => return,
                    };
                    for mut camera in &mut cameras {
                        camera.mode = mode;
                    }
                },
            );
        })
        .expect("render");
    let seen = seen.lock().expect("log").clone();
    eprintln!("(twins, faces) per frame: {seen:?}");
    // Frame 2 (vertex): six twins; 3 (cube): four faces, no twin; 5
    // (vertex again): twins back, faces gone; 6 on: the cube again.
    assert_eq!(seen[1], (6, 0), "{seen:?}");
    assert_eq!(seen[2], (0, 4), "{seen:?}");
    assert_eq!(seen[4], (6, 0), "{seen:?}");
    assert_eq!(seen.last(), Some(&(0, 4)), "{seen:?}");
    let shown = faces_shown(&frame, cube(180.0, 0.0));
    assert!(
        shown > 0.99,
        "{shown:.4} of the pixels match after switching"
    );
}

/// The resample pass records its time span, `optica/dome/cube_resample`
/// (GPU time where the adapter has timestamp queries).
#[test]
fn the_cube_resample_records_its_span() {
    let timed = Headless::new(64, 64)
        .time_frames(1, 2, room_seen_by(4, cube(180.0, 0.0)))
        .expect("render");
    let span = timed.span("optica/dome/cube_resample");
    eprintln!("{span:?}");
    assert!(span.is_some());
}
