//! The PNG-sequence export: frames are written as numbered PNGs, each a
//! function of its frame number alone, so a range split across machines
//! gives the same images as one run.

use std::path::{Path, PathBuf};

use bevy::prelude::*;
use optica_dome::lines::Graticule;
use optica_dome::{
    DomeCamera, DomeExport, DomeExportPlugin, DomeShowClock, Error, frame_ranges, parse_frame_range,
};
use optica_harness::{HarnessError, Headless};

use super::scene::room_seen_by;
use super::zenith;

/// A fresh folder under the system's temporary one.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("optica_dome_{name}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Exports `frames` of the room at 10 fps, the camera turning 1 rad a
/// second.
fn export(dir: &Path, frames: std::ops::Range<u32>) {
    export_exiting(dir, frames, false).expect("render");
}

/// As [`export`], the plugin asking the app to exit when done (or on a
/// failure) if `exit_when_done`: the harness's error says how it exited.
fn export_exiting(
    dir: &Path,
    frames: std::ops::Range<u32>,
    exit_when_done: bool,
) -> Result<(), HarnessError> {
    let dir = dir.to_owned();
    Headless::new(64, 64)
        .frames(24)
        .render(move |app: &mut App| {
            room_seen_by(2, DomeCamera::default())(app);
            // A graticule around the camera: its horizon circle lies
            // exactly on the rim of the 180° dome, where the least change
            // of the refinement shows.
            app.add_systems(
                Startup,
                |mut commands: Commands,
                 mut meshes: ResMut<Assets<Mesh>>,
                 mut materials: ResMut<Assets<StandardMaterial>>| {
                    let grid = Graticule {
                        radius: 0.5,
                        ..default()
                    };
                    commands.spawn((
                        Mesh3d(meshes.add(grid.mesh())),
                        MeshMaterial3d(materials.add(StandardMaterial {
                            base_color: Color::WHITE,
                            unlit: true,
                            ..default()
                        })),
                    ));
                },
            );
            app.add_plugins(DomeExportPlugin(DomeExport {
                exit_when_done,
                ..DomeExport::new(dir, frames, 10.0)
            }))
            .add_systems(
                Update,
                |clock: Res<DomeShowClock>,
                 mut cameras: Query<&mut Transform, With<DomeCamera>>| {
                    for mut t in &mut cameras {
                        t.rotation = Quat::from_rotation_y(clock.seconds()) * zenith().rotation;
                    }
                },
            );
        })
        .map(|_| ())
}

fn load(path: PathBuf) -> image::RgbImage {
    image::open(&path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
}

#[test]
fn a_split_range_gives_the_same_frames() {
    let (whole, part) = (scratch("whole"), scratch("part"));
    export(&whole, 3..6);
    export(&part, 4..5);
    let name = |f: u32| format!("domemaster_{f:06}.png");
    for f in 3..6 {
        assert!(whole.join(name(f)).exists(), "frame {f} missing");
    }
    assert!(!whole.join(name(6)).exists() && !whole.join(name(2)).exists());
    let frames: Vec<_> = (3..6).map(|f| load(whole.join(name(f)))).collect();
    assert_eq!(frames[0].dimensions(), (64, 64));
    let differ = |a: &image::RgbImage, b: &image::RgbImage| {
        a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count()
    };
    // 0.1 rad between frames: the room's edges move by a few pixels.
    for k in 0..2 {
        let moved = differ(&frames[k], &frames[k + 1]);
        assert!(
            moved > 20,
            "frames {} and {} differ in {moved} px",
            k + 3,
            k + 4
        );
    }
    // Frame 4 rendered on its own is frame 4 of the range, bit for bit:
    // each frame is captured only once its twins have settled (before, a
    // frame showed the twins refined for the frame before it, and the
    // first frame of a range differed along the rim and the room's edges).
    let alone = load(part.join(name(4)));
    let changed = differ(&alone, &frames[1]);
    eprintln!("frame 4 on its own differs in {changed} px");
    assert_eq!(changed, 0, "frame 4 on its own differs in {changed} px");

    // A farm's final step: the frames of a show with no finished PNG, and
    // the ranges that render them again. No half-written file is left.
    let show = |frames| DomeExport::new(&whole, frames, 10.0);
    assert!(show(3..6).missing().is_empty());
    assert_eq!(show(0..8).missing(), vec![0, 1, 2, 6, 7]);
    assert_eq!(frame_ranges(&show(0..8).missing()), vec![0..3, 6..8]);
    let leftovers: Vec<_> = std::fs::read_dir(&whole)
        .expect("show folder")
        .filter_map(|e| e.ok())
        .filter(|e| !e.file_name().to_string_lossy().ends_with(".png"))
        .map(|e| e.file_name())
        .collect();
    assert!(leftovers.is_empty(), "left in the folder: {leftovers:?}");
    // A truncated file and an unfinished write count as missing.
    std::fs::write(whole.join(name(6)), b"\x89PN").expect("write");
    std::fs::write(whole.join(format!("{}.part", name(7))), b"").expect("write");
    assert_eq!(show(6..8).missing(), vec![6, 7]);
    assert_eq!(
        frame_ranges(&[2, 3, 4, 9, 11, 12]),
        vec![2..5, 9..10, 11..13]
    );
    let _ = std::fs::remove_dir_all(whole);
    let _ = std::fs::remove_dir_all(part);
}

/// A frame the export cannot write ends the run with an error (a farm
/// task's exit status), and the frame stays missing.
#[test]
fn a_frame_that_cannot_be_written_fails_the_export() {
    let dir = scratch("unwritable");
    // A folder where frame 4's PNG would go: the rename onto it fails.
    let blocked = dir.join("domemaster_000004.png");
    std::fs::create_dir_all(blocked.join("in_the_way")).expect("folder");
    let exit = export_exiting(&dir, 3..6, true);
    assert!(
        matches!(&exit, Err(HarnessError::Exited(how)) if how.contains("Error")),
        "{exit:?}"
    );
    assert_eq!(DomeExport::new(&dir, 3..6, 10.0).missing(), vec![4, 5]);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn frame_ranges_parse_as_farm_managers_write_them() {
    assert_eq!(parse_frame_range("0..240"), Ok(0..240));
    assert_eq!(parse_frame_range("10..=19"), Ok(10..20));
    assert_eq!(parse_frame_range("7"), Ok(7..8));
    assert_eq!(parse_frame_range("5..5"), Err(Error::EmptyFrames(5..5)));
    assert_eq!(
        parse_frame_range("a..3"),
        Err(Error::FrameNumber {
            part: "a".into(),
            text: "a..3".into()
        })
    );
    assert!(
        matches!(parse_frame_range("-1..3"), Err(Error::FrameNumber { part, .. }) if part == "-1")
    );
    let refused = DomeExport::new(std::env::temp_dir(), 0..1, 0.0).validate();
    assert!(
        matches!(&refused, Err(Error::Setting(e)) if e.what == "frame rate (1/s)" && e.value == 0.0),
        "{refused:?}"
    );
    assert_eq!(
        DomeExport::new(std::env::temp_dir(), 3..3, 24.0).validate(),
        Err(Error::EmptyFrames(3..3))
    );
}

/// An export app without rendering, writing into a scratch folder.
fn export_app(dir: &str) -> App {
    let mut app = App::new();
    app.add_plugins(DomeExportPlugin(DomeExport::new(scratch(dir), 5..7, 24.0)));
    app
}

/// The first capture waits until the render world has made every
/// pipeline, then warms up, then captures.
#[test]
fn the_first_capture_waits_until_every_pipeline_is_made() {
    use optica_dome::hooks::{ExportState, PendingPipelines};
    use std::sync::atomic::Ordering;
    let mut app = export_app("wait");
    let pending = app.world().resource::<PendingPipelines>().clone();
    pending.0.store(3, Ordering::Relaxed);
    for _ in 0..10 {
        app.update();
    }
    let state = app.world().resource::<ExportState>();
    assert_eq!((state.warmup, state.waited, state.next), (2, 10, 5));
    assert_eq!(app.world().resource::<DomeShowClock>().frame, 5);
    // Ready: the warm-up on the first frame runs, then the capture.
    pending.0.store(0, Ordering::Relaxed);
    app.update();
    assert_eq!(app.world().resource::<ExportState>().warmup, 1);
}

/// A pipeline that never comes ends the job with an error exit.
#[test]
fn a_pipeline_that_never_comes_ends_the_job_with_an_error() {
    use optica_dome::hooks::{MAX_PIPELINE_WAIT_UPDATES, PendingPipelines};
    use std::sync::atomic::Ordering;
    let mut app = export_app("never");
    let pending = app.world().resource::<PendingPipelines>().clone();
    pending.0.store(1, Ordering::Relaxed);
    for _ in 0..MAX_PIPELINE_WAIT_UPDATES {
        app.update();
    }
    assert!(matches!(app.should_exit(), Some(AppExit::Error(_))));
}
