//! The paper's classification (§3.1) in the plugin: a mesh marked
//! `DomeApparentSize::NearlyConstant` is split once with the
//! rotation-invariant step, drawn unclipped (the vertex shader drops what
//! lies near the antipode), and not split again while the camera turns;
//! a mesh of changing size is refined again every frame it moves relative
//! to the camera.

use std::sync::{Arc, Mutex};

use bevy::prelude::*;
use optica_dome::{DomeApparentSize, DomeCamera, DomeRefineStats, DomeTwin, DomeTwins};
use optica_harness::Headless;
use optica_optics::dome::Treatment;

use super::scene::{SIZE, faces_shown, room_seen_by};

/// The room of `scene.rs` (one quad a face, the floor behind the viewer)
/// with `size` on every face, the camera turning 0.05 rad about the zenith
/// and back, moving 1 cm and back, then resting; the fraction of pixels
/// showing their face, and the refinement stats (of the frame before) and
/// the twins' treatments at the start of each frame.
fn turning_room(size: DomeApparentSize) -> (f64, Vec<(DomeRefineStats, Vec<Treatment>)>) {
    let seen = Arc::new(Mutex::new(Vec::new()));
    let log = seen.clone();
    let camera = DomeCamera::default();
    let frame = Headless::new(SIZE, SIZE)
        .frames(6)
        .render(move |app: &mut App| {
            room_seen_by(1, camera)(app);
            app.add_systems(
                PostStartup,
                move |mut commands: Commands, faces: Query<Entity, With<Mesh3d>>| {
                    for face in &faces {
                        commands.entity(face).insert(size);
                    }
                },
            );
            app.add_systems(
                Update,
                move |mut cameras: Query<&mut Transform, With<DomeCamera>>,
                      stats: Res<DomeRefineStats>,
                      twins: Query<&DomeTwins>| {
                    let mut log = log.lock().expect("log");
                    let treatments = twins.iter().flat_map(|t| &t.0).map(DomeTwin::treatment);
                    log.push((*stats, treatments.collect()));
                    // Frame 1 turns, frame 2 turns back and moves (the
                    // viewer's place in the room changes), frame 3 moves
                    // back; then the camera rests where it started.
                    let (turn, step) = match log.len() {
                        2 => (0.05, 0.0),
                        3 => (-0.05, 0.01),
                        4 => (0.0, -0.01),
                        _ => (0.0, 0.0),
                    };
                    for mut t in &mut cameras {
                        t.rotate_y(turn);
                        t.translation.x += step;
                    }
                },
            );
        })
        .expect("render");
    let shown = faces_shown(&frame, camera);
    let seen = seen.lock().expect("log").clone();
    (shown, seen)
}

#[test]
fn sky_objects_are_split_once_and_kept_while_the_camera_turns() {
    let (shown, seen) = turning_room(DomeApparentSize::NearlyConstant);
    for (k, (stats, _)) in seen.iter().enumerate() {
        eprintln!("nearly constant, frame {k}: {stats:?}");
    }
    // Built on frame 0, kept when the camera turns (frame 1), split again
    // when it moves (2, 3), kept while it rests.
    assert_eq!(seen[1].1, vec![Treatment::PreSubdivided; 6]);
    let passes: Vec<(usize, usize)> = seen.iter().map(|(s, _)| (s.rebuilt, s.kept)).collect();
    assert_eq!(
        passes[1..6],
        [(6, 0), (0, 6), (6, 0), (6, 0), (0, 6)],
        "{seen:?}"
    );
    // Unclipped, the floor behind the viewer stays out of the circle (no
    // streak across it from pieces near the antipode) and every pixel
    // shows its face.
    assert!(shown > 0.99, "{shown:.4} of the pixels show their face");
}

#[test]
fn scenery_is_refined_again_every_frame_the_camera_turns() {
    let (shown, seen) = turning_room(DomeApparentSize::Changing);
    assert_eq!(seen[1].1, vec![Treatment::Dynamic; 6]);
    // Built on frame 0, split again whenever the camera turns or moves
    // (frames 1–3), kept while it rests.
    let passes: Vec<(usize, usize)> = seen.iter().map(|(s, _)| (s.rebuilt, s.kept)).collect();
    assert_eq!(
        passes[1..6],
        [(6, 0), (6, 0), (6, 0), (6, 0), (0, 6)],
        "{seen:?}"
    );
    assert!(shown > 0.99, "{shown:.4} of the pixels show their face");
}

/// A moving camera in a scene of small, distant meshes: each mesh's
/// triangles are all their own refinement, so its twin draws the mesh
/// itself (the same asset: nothing built, nothing uploaded) and the stats
/// count it as unsplit; the sphere still shows at the zenith.
#[test]
fn small_distant_meshes_are_drawn_as_they_are() {
    let seen = Arc::new(Mutex::new(Vec::new()));
    let log = seen.clone();
    let frame = Headless::new(SIZE, SIZE)
        .frames(4)
        .render(move |app: &mut App| {
            app.add_plugins(optica_dome::DomePlugin);
            app.add_systems(
                Startup,
                |mut commands: Commands,
                 mut meshes: ResMut<Assets<Mesh>>,
                 mut materials: ResMut<Assets<StandardMaterial>>| {
                    commands.spawn((
                        Mesh3d(meshes.add(Sphere::new(0.5).mesh().uv(16, 8))),
                        super::flat(&mut materials, Color::srgb(1.0, 0.0, 0.0)),
                        Transform::from_xyz(0.0, 10.0, 0.0),
                    ));
                    commands.spawn(super::dome_camera(DomeCamera::default(), super::zenith()));
                },
            );
            app.add_systems(
                Update,
                move |mut cameras: Query<&mut Transform, With<DomeCamera>>,
                      stats: Res<DomeRefineStats>,
                      originals: Query<(&Mesh3d, &DomeTwins)>,
                      drawn: Query<&Mesh3d, Without<DomeTwins>>| {
                    let same = originals.iter().all(|(mesh, twins)| {
                        twins
                            .0
                            .iter()
                            .all(|t| drawn.get(t.twin).is_ok_and(|d| d.0 == mesh.0))
                    });
                    log.lock()
                        .expect("log")
                        .push((*stats, same, originals.iter().count()));
                    for mut t in &mut cameras {
                        t.translation.x += 0.01;
                    }
                },
            );
        })
        .expect("render");
    let seen = seen.lock().expect("log").clone();
    eprintln!("{seen:?}");
    // From the second frame on the twin exists, is rebuilt every frame
    // (the camera moves) and draws the sphere's own mesh.
    for (stats, same, originals) in &seen[2..] {
        assert_eq!(*originals, 1);
        assert_eq!((stats.rebuilt, stats.unsplit, stats.vertices), (1, 1, 0));
        assert!(same, "the twin draws a mesh of its own");
    }
    let centre = frame.to_rgba8().get_pixel(SIZE / 2, SIZE / 2).0;
    assert!(centre[0] > 200 && centre[1] < 50, "zenith shows {centre:?}");
}
