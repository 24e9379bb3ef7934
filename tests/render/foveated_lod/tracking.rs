//! The tracked head: recorded traces (CSV), the OpenXR mapping, dropouts
//! and NaN, and no per-frame work without a consumer.

use bevy::prelude::*;
use optica_foveated_lod::{
    Eye, FoveationWork, GazeLod, GazeLodState, GazeState, HeadReplay, HeadSource, HeadTrace,
    TraceError, TrackedHead,
};
use optica_optics::foveated_lod::GazeEstimate;

use super::{FPS, cpu_app, set_gaze_yaw};

const HEADER: &str = "t,head_x,head_y,head_z,qx,qy,qz,qw,gaze_x,gaze_y,gaze_z\n";

#[test]
fn traces_round_trip_and_bad_files_are_errors() {
    let mut a = TrackedHead::looking(
        Vec3::new(0.1, 1.5, 0.2),
        Quat::from_rotation_y(0.3),
        Some(Vec3::new(0.2, -0.1, -1.0)),
        0.06,
    );
    a.timestamp_s = 0.0;
    let mut b = a.clone();
    b.timestamp_s = 0.25;
    b.eye_gaze = Some([Vec3::new(0.1, 0.0, -1.0), Vec3::new(-0.1, 0.0, -1.0)]);
    b.valid = false;
    let trace = HeadTrace::new(vec![a.clone(), b.clone()]).unwrap();
    let mut csv = Vec::new();
    trace.to_csv(&mut csv).unwrap();
    let back = HeadTrace::from_csv(csv.as_slice()).unwrap();
    assert_eq!(back.len(), 2);
    for (x, y) in back.samples().iter().zip(trace.samples()) {
        assert!(x.eyes[0].distance(y.eyes[0]) < 1e-6 && x.eyes[1].distance(y.eyes[1]) < 1e-6);
        assert!(x.orientation.angle_between(y.orientation) < 1e-5);
        assert_eq!(
            (x.gaze, x.eye_gaze, x.valid, x.timestamp_s),
            (y.gaze, y.eye_gaze, y.valid, y.timestamp_s)
        );
    }
    // Playback: the last sample at or before the time, looping.
    assert_eq!(back.at(0.1, false).unwrap().timestamp_s, 0.0);
    assert_eq!(back.at(9.0, false).unwrap().timestamp_s, 0.25);
    // Looping: the last sample plays for one interval, then the first.
    assert_eq!(back.at(0.3, true).unwrap().timestamp_s, 0.25);
    assert_eq!(back.at(0.55, true).unwrap().timestamp_s, 0.0);
    assert!(back.at(-1.0, false).is_none());

    // Malformed files are errors that say where, never panics.
    let missing_column = "t,head_x,head_y,qx,qy,qz,qw\n0,0,1.6,0,0,0,1\n";
    let text = format!("{HEADER}0,0,1.6,0,0,0,0,one,0,0,-1\n");
    let unknown = "t,head_x,head_y,head_z,qx,qy,qz,qw,pupil\n0,0,1.6,0,0,0,0,1,3\n";
    for bad in [missing_column, text.as_str(), unknown, "", HEADER] {
        let e = HeadTrace::from_csv(bad.as_bytes()).unwrap_err();
        eprintln!("{e}");
        assert!(matches!(e, TraceError::Csv(_) | TraceError::Empty), "{e}");
    }
    let backwards = format!("{HEADER}1,0,1.6,0,0,0,0,1,0,0,-1\n0.5,0,1.6,0,0,0,0,1,0,0,-1\n");
    assert!(matches!(
        HeadTrace::from_csv(backwards.as_bytes()),
        Err(TraceError::Time { row: 2, .. })
    ));
    // A NaN recorded by the tracker is kept: that sample is a dropout.
    let nan = format!("{HEADER}0,0,1.6,0,0,0,0,1,NaN,0,-1\n");
    let t = HeadTrace::from_csv(nan.as_bytes()).unwrap();
    assert!(t.samples()[0].sample(Eye::Cyclopean).frame().is_err());
}

/// The head is plain data: one process can send it (here as JSON) to one
/// app per CAVE wall.
#[test]
fn the_head_serialises_for_a_cave_of_several_machines() {
    let mut head = TrackedHead::looking(
        Vec3::new(0.2, 1.7, -0.1),
        Quat::from_rotation_y(0.4),
        Some(Vec3::new(0.1, -0.2, -1.0)),
        0.062,
    );
    head.eye_gaze = Some([Vec3::new(0.05, -0.2, -1.0), Vec3::new(0.15, -0.2, -1.0)]);
    head.timestamp_s = 12.5;
    let wire = serde_json::to_string(&head).unwrap();
    let back: TrackedHead = serde_json::from_str(&wire).unwrap();
    assert_eq!(back, head);
}

#[test]
fn openxr_without_eye_tracking_falls_back_to_the_head() {
    let head_pose = ([0.0, 1.7, 0.0], Quat::from_rotation_y(0.5).to_array());
    let gaze_pose = ([0.0, 1.7, 0.0], Quat::from_rotation_x(0.2).to_array());
    let tracked = TrackedHead::from_openxr(gaze_pose, head_pose, 2_500_000_000, 0.064, true);
    let untracked = TrackedHead::from_openxr(gaze_pose, head_pose, 2_500_000_000, 0.064, false);
    assert!((tracked.gaze.unwrap() - Quat::from_rotation_x(0.2) * Vec3::NEG_Z).length() < 1e-6);
    assert_eq!(untracked.gaze, None);
    let forward = untracked.gaze_of(Eye::Cyclopean);
    assert!((forward - Quat::from_rotation_y(0.5) * Vec3::NEG_Z).length() < 1e-6);
    assert!((untracked.eyes[0].distance(untracked.eyes[1]) - 0.064).abs() < 1e-6);
    let nan = TrackedHead::from_openxr(gaze_pose, ([0.0; 3], [f32::NAN; 4]), 0, 0.064, true);
    assert!(!nan.valid);
}

/// An object 3 m ahead; the gaze 60° to the side gives it a level near 0.6.
fn spawn_object(app: &mut App) -> Entity {
    let mesh = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Sphere::new(0.5).mesh().ico(3).unwrap());
    app.world_mut()
        .spawn((
            Mesh3d(mesh),
            Transform::from_xyz(0.0, 1.6, -3.0).with_scale(Vec3::splat(0.1)),
            GazeLod::default(),
        ))
        .id()
}

fn step(app: &App, e: Entity) -> u32 {
    app.world().get::<GazeLodState>(e).unwrap().step
}

/// Dropout, NaN and a zero gaze keep the last valid gaze for the hold
/// timeout (0.2 s), then the object is drawn at full quality; a valid sample
/// brings foveation back.
#[test]
fn dropouts_hold_then_fall_back_to_full_quality() {
    let mut app = cpu_app();
    let e = spawn_object(&mut app);
    set_gaze_yaw(&mut app, 60.0);
    for _ in 0..30 {
        app.update();
    }
    let foveated = step(&app, e);
    assert!(foveated < 8, "step {foveated}");
    for (what, spoil) in [
        (
            "dropout",
            Box::new(|h: &mut TrackedHead| h.valid = false) as Box<dyn Fn(&mut TrackedHead)>,
        ),
        (
            "NaN gaze",
            Box::new(|h: &mut TrackedHead| h.gaze = Some(Vec3::NAN)),
        ),
        (
            "zero gaze",
            Box::new(|h: &mut TrackedHead| h.gaze = Some(Vec3::ZERO)),
        ),
        (
            "NaN eyes",
            Box::new(|h: &mut TrackedHead| h.eyes = [Vec3::NAN; 2]),
        ),
    ] {
        // The app writes the head itself from now on.
        let good = app.world().resource::<TrackedHead>().clone();
        app.insert_resource(HeadSource::External);
        let mut bad = good.clone();
        spoil(&mut bad);
        app.insert_resource(bad);
        app.update();
        eprintln!(
            "{what}: {:?}",
            app.world().resource::<GazeState>().estimate(Eye::Cyclopean)
        );
        let frames_held = 1
            + (0..60)
                .take_while(|_| {
                    app.update();
                    matches!(
                        app.world().resource::<GazeState>().estimate(Eye::Cyclopean),
                        GazeEstimate::Held { .. }
                    )
                })
                .count();
        // 0.2 s at 60 fps: 12 frames (±1 for the clock's rounding).
        assert!(
            (11..=13).contains(&frames_held),
            "{what}: held {frames_held} frames"
        );
        assert!(app.world().resource::<GazeState>().full_quality(), "{what}");
        app.update();
        assert_eq!(step(&app, e), 8, "{what}: full quality after the timeout");
        let level = app.world().get::<GazeLodState>(e).unwrap().level;
        assert!(level == 1.0, "{what}: level {level}");
        app.insert_resource(good);
        for _ in 0..30 {
            app.update();
        }
        assert_eq!(step(&app, e), foveated, "{what}: foveated again");
    }
}

/// Without a `GazeLod` or a `CaveView` nothing runs, however the head moves.
#[test]
fn no_consumer_no_work() {
    let mut app = cpu_app();
    for i in 0..20 {
        set_gaze_yaw(&mut app, i as f32);
        app.update();
    }
    assert_ne!(
        app.world().resource::<TrackedHead>().gaze,
        None,
        "the source ran"
    );
    assert_eq!(
        *app.world().resource::<FoveationWork>(),
        FoveationWork::default()
    );
    assert_eq!(*app.world().resource::<GazeState>(), GazeState::default());
}

/// A replayed trace drives the levels like a live tracker.
#[test]
fn a_replayed_trace_drives_the_levels() {
    let mut app = cpu_app();
    let e = spawn_object(&mut app);
    let sample = |t: f64, yaw_deg: f32| {
        let mut h = TrackedHead::looking(
            Vec3::new(0.0, 1.6, 0.0),
            Quat::IDENTITY,
            Some(Quat::from_rotation_y(-yaw_deg.to_radians()) * Vec3::NEG_Z),
            0.063,
        );
        h.timestamp_s = t;
        h
    };
    let trace = HeadTrace::new(vec![sample(0.0, 0.0), sample(0.5, 70.0)]).unwrap();
    app.insert_resource(HeadSource::Replay(HeadReplay {
        trace,
        start_s: 0.0,
        looping: false,
    }));
    let mut steps = Vec::new();
    for _ in 0..(FPS as usize) {
        app.update();
        steps.push(step(&app, e));
    }
    assert_eq!(steps[5], 8);
    assert!(*steps.last().unwrap() < 8, "{steps:?}");
}

/// A 100 Hz recording (times as a tracker writes them, starting at an
/// arbitrary clock reading) replayed in 10 ms frames plays every sample on
/// its own frame, once, in order, whatever the rounding of the times; looped,
/// it plays the last sample too before the first comes again.
#[test]
fn a_trace_replays_each_sample_on_its_frame() {
    use std::time::Duration;
    let n = 50;
    let mut csv = String::from(HEADER);
    for i in 0..n {
        // 1.27, 1.28, ...: differences of such decimals are not exact in
        // binary (1.30 − 1.27 = 0.030000000000000027).
        csv.push_str(&format!(
            "{:.2},0,1.6,0,0,0,0,1,{},0,-1\n",
            1.27 + 0.01 * i as f64,
            i
        ));
    }
    let trace = HeadTrace::from_csv(csv.as_bytes()).unwrap();
    assert!(
        (trace.period_s() - 0.5).abs() < 1e-9,
        "{}",
        trace.period_s()
    );
    for looping in [false, true] {
        let mut app = cpu_app();
        app.insert_resource(bevy::time::TimeUpdateStrategy::ManualDuration(
            Duration::from_millis(10),
        ))
        .insert_resource(HeadSource::Replay(HeadReplay {
            trace: trace.clone(),
            start_s: 0.0,
            looping,
        }));
        let mut played = Vec::new();
        for _ in 0..(2 * n + 1) {
            app.update();
            let elapsed = app.world().resource::<Time>().elapsed_secs_f64();
            let gaze_x = app.world().resource::<TrackedHead>().gaze.unwrap().x;
            played.push((elapsed, gaze_x as usize));
        }
        for (elapsed, sample) in &played {
            let frame = (elapsed * 100.0).round() as usize;
            let expected = if looping { frame % n } else { frame.min(n - 1) };
            assert_eq!(
                *sample, expected,
                "looping {looping}: at {elapsed} s sample {sample} played, not {expected}: {played:?}"
            );
        }
        let last_played = played.iter().filter(|p| p.1 == n - 1).count();
        assert_eq!(last_played, if looping { 2 } else { n + 2 }, "{played:?}");
    }
}

/// A gaze pose that is zero or not finite while OpenXR says the gaze is
/// tracked falls back to the head's forward, the sample staying valid.
#[test]
fn openxr_broken_gaze_falls_back_to_the_head() {
    let head_pose = ([0.0, 1.7, 0.0], Quat::from_rotation_y(0.5).to_array());
    for q in [[0.0; 4], [f32::NAN; 4], [0.0, f32::INFINITY, 0.0, 1.0]] {
        let head = TrackedHead::from_openxr(([0.0, 1.7, 0.0], q), head_pose, 0, 0.064, true);
        assert!(head.valid, "{q:?}");
        assert_eq!(head.gaze, None, "{q:?}");
        let g = head.gaze_of(Eye::Cyclopean);
        assert!(
            (g - Quat::from_rotation_y(0.5) * Vec3::NEG_Z).length() < 1e-6,
            "{q:?}: {g:?}"
        );
    }
}

/// A datagram in DTrack's documented shape parses to its frame, time and body (mm,
/// the rotation column by column); malformed datagrams are refused with
/// the line named, never a panic, and a count of 10⁹ bodies is refused
/// before anything is allocated for it.
#[test]
fn dtrack_datagrams_parse_and_bad_ones_are_refused() {
    use optica_foveated_lod::dtrack::{DTrackError, DTrackFrame};
    let good = b"fr 21753\nts 39596.024\n6dcal 1\n6d 1 [0 1.000][326.848 -187.216 -7.977 0.0000 0.0000 30.0000][0.866025 0.500000 0.000000 -0.500000 0.866025 0.000000 0.000000 0.000000 1.000000]\n";
    let f = DTrackFrame::parse(good).unwrap();
    assert_eq!(f.frame, Some(21753));
    assert_eq!(f.timestamp_s, Some(39596.024));
    assert_eq!(f.bodies.len(), 1);
    let b = &f.bodies[0];
    assert_eq!((b.id, b.quality), (0, 1.0));
    assert!(b.position_mm.distance(Vec3::new(326.848, -187.216, -7.977)) < 1e-3);
    // Column by column: the body's X axis turned 30° about the room's Z.
    assert!(b.rotation.x_axis.distance(Vec3::new(0.866025, 0.5, 0.0)) < 1e-6);
    assert!((b.rotation.determinant() - 1.0).abs() < 1e-4);
    // No body tracked: an empty list.
    assert!(
        DTrackFrame::parse(b"fr 1\n6d 0\n")
            .unwrap()
            .bodies
            .is_empty()
    );
    let bad: [(&[u8], usize); 9] = [
        (b"fr x\n", 1),
        (b"fr 1\nts inf\n", 2),
        (b"6d 1000000000 [0 1][0 0 0 0 0 0][1 0 0 0 1 0 0 0 1]\n", 1),
        (b"6d 2 [0 1][0 0 0 0 0 0][1 0 0 0 1 0 0 0 1]\n", 1),
        (b"6d 1 [0 1][0 0 0 0 0][1 0 0 0 1 0 0 0 1]\n", 1),
        (b"6d 1 [0 1][0 0 NaN 0 0 0][1 0 0 0 1 0 0 0 1]\n", 1),
        (b"6d 1 [0 1][0 0 0 0 0 0][1 0 0 0 1 0 0 0 1\n", 1),
        (b"6d 1 [0 1][0 0 0 0 0 0][1 0 0 0 1 0 0 0 1][9 9]\n", 1),
        (b"fr 2\n6d 1 [-1 1][0 0 0 0 0 0][1 0 0 0 1 0 0 0 1]\n", 2),
    ];
    for (datagram, line) in bad {
        let e = DTrackFrame::parse(datagram).unwrap_err();
        eprintln!("{e}");
        assert!(
            matches!(e, DTrackError::Line { line: l, .. } if l == line),
            "{e}"
        );
    }
    assert_eq!(
        DTrackFrame::parse(&[0xff, 0xfe]).unwrap_err(),
        DTrackError::NotText
    );
    // Every prefix of the good datagram, and bytes at random: no panic.
    for n in 0..good.len() {
        let _ = DTrackFrame::parse(&good[..n]);
    }
    let mut x = 0x2545F4914F6CDD1Du64;
    for _ in 0..2000 {
        let mut bytes = good.to_vec();
        for _ in 0..4 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let i = (x % bytes.len() as u64) as usize;
            bytes[i] = b"[] 0123456789.-e\n6dfrNaN"[(x >> 32) as usize % 24];
        }
        let _ = DTrackFrame::parse(&bytes);
    }
}

/// A DTrack stream on the loopback drives the head: the body's position
/// (mm) and rotation through the calibration (the default turns DTrack's
/// Z-up room Y-up); a malformed datagram is counted and changes nothing; a
/// frame without the body reports the head lost.
#[test]
fn a_dtrack_stream_on_the_loopback_drives_the_head() {
    use optica_foveated_lod::dtrack::{DTrackError, DTrackSettings, DTrackStats};
    use std::net::UdpSocket;
    let mut app = cpu_app();
    app.insert_resource(HeadSource::DTrack(DTrackSettings {
        bind: "127.0.0.1:0".parse().unwrap(),
        body: 2,
        ..default()
    }));
    app.update();
    let addr = app
        .world()
        .resource::<DTrackStats>()
        .local_addr
        .expect("bound");
    let sender = UdpSocket::bind("127.0.0.1:0").unwrap();
    let send_until = |app: &mut App, datagram: &str, done: &dyn Fn(&App) -> bool| {
        sender.send_to(datagram.as_bytes(), addr).unwrap();
        for _ in 0..200 {
            app.update();
            if done(app) {
                return;
            }
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        panic!("the datagram never arrived: {datagram}");
    };
    // Body 2 at (1, 2, 1.5) m in the room, turned 90° about the room's Z
    // (up): in the scene, at (1, 1.5, −2), turned 90° about +Y.
    let frame = "fr 7\nts 12.5\n6d 2 [0 1.000][0 0 0 0 0 0][1 0 0 0 1 0 0 0 1] \
                 [2 0.900][1000 2000 1500 0 0 90][0 1 0 -1 0 0 0 0 1]\n";
    send_until(&mut app, frame, &|app| {
        app.world().resource::<DTrackStats>().frames >= 1
    });
    let head = app.world().resource::<TrackedHead>().clone();
    eprintln!("{head:?}");
    assert!(head.valid);
    assert!(
        head.centre().distance(Vec3::new(1.0, 1.5, -2.0)) < 1e-5,
        "{head:?}"
    );
    assert_eq!(head.timestamp_s, 12.5);
    let expected = Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2)
        * Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    assert!(
        head.orientation.dot(expected).abs() > 1.0 - 1e-6,
        "{expected:?}"
    );
    send_until(&mut app, "6d 1 [2 1][1 2 3][oops]\n", &|app| {
        app.world().resource::<DTrackStats>().malformed >= 1
    });
    assert_eq!(*app.world().resource::<TrackedHead>(), head);
    assert!(
        matches!(
            &app.world().resource::<DTrackStats>().last_error,
            Some(DTrackError::Line { line: 1, kind, .. }) if kind == "6d"
        ),
        "{:?}",
        app.world().resource::<DTrackStats>().last_error
    );
    send_until(
        &mut app,
        "fr 8\n6d 1 [0 1.000][0 0 0 0 0 0][1 0 0 0 1 0 0 0 1]\n",
        &|app| app.world().resource::<DTrackStats>().missing_body >= 1,
    );
    assert!(!app.world().resource::<TrackedHead>().valid);
}
