//! LOD chains (built once, eq. 10's budgets) and their switching under
//! gaze traces: hysteresis and dwell against thrash, a saccade's latency,
//! objects outside the field hidden, and no work while the head is still.

use std::sync::Arc;

use bevy::prelude::*;
use optica_foveated_lod::{
    Foveation, FoveationGate, FoveationWork, GazeLod, GazeLodState, LodChain,
};
use optica_optics::foveated_lod::{lod_for_level, polygon_budget};

use super::{FPS, cpu_app, set_gaze_yaw};

/// An ico sphere of 5,780 triangles (the paper's models have 5,804).
fn model() -> Mesh {
    Sphere::new(0.5).mesh().ico(16).unwrap()
}

/// Objects of radius 5 cm, 3 m ahead of the simulated eye.
fn spawn(app: &mut App, n: usize, lod: GazeLod) -> Vec<Entity> {
    let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(model());
    (0..n)
        .map(|i| {
            app.world_mut()
                .spawn((
                    Mesh3d(mesh.clone()),
                    Transform::from_xyz(0.0, 1.6 + 0.01 * i as f32, -3.0)
                        .with_scale(Vec3::splat(0.1)),
                    lod.clone(),
                    Visibility::default(),
                ))
                .id()
        })
        .collect()
}

fn state(app: &App, e: Entity) -> GazeLodState {
    app.world().get::<GazeLodState>(e).unwrap().clone()
}

/// The gaze yaw (degrees) that puts the nearest point of the 5 cm sphere 3 m
/// ahead at `level` (horizontal, paper field: level = (100° − e)/70°).
fn yaw_for_level(level: f64) -> f32 {
    let e = 100.0 - 70.0 * level;
    let rho = (0.05f64 / 3.0).asin().to_degrees();
    (e + rho) as f32
}

#[test]
fn chains_follow_eq10_and_are_built_once() {
    let mut app = cpu_app();
    let objects = spawn(&mut app, 8, GazeLod::default());
    for _ in 0..5 {
        app.update();
    }
    let chains: Vec<Arc<LodChain>> = objects
        .iter()
        .map(|&e| state(&app, e).chain.expect("built"))
        .collect();
    assert!(
        chains.iter().all(|c| Arc::ptr_eq(c, &chains[0])),
        "one chain for a shared mesh"
    );
    let chain = &chains[0];
    eprintln!(
        "chain {:?}, steps {:?}, built in {:.2} ms",
        chain.triangles, chain.step_lod, chain.build_ms
    );
    assert_eq!(*chain.triangles.last().unwrap(), 5780);
    assert!(chain.triangles.windows(2).all(|w| w[0] < w[1]));
    // N_min = 500 within meshoptimizer's reach (it stops where no collapse is left).
    assert!(
        (450..=560).contains(&chain.triangles[0]),
        "{:?}",
        chain.triangles
    );
    let steps = Foveation::default().steps;
    for k in 0..=steps {
        let level = k as f64 / steps as f64;
        let budget = polygon_budget(level, 500, 5780);
        let n = chain.triangles[chain.mesh_of_step(k)];
        // Each step draws the coarsest mesh with at least eq. 10's budget,
        // as the CPU twin chooses.
        assert!(n as f64 >= budget, "step {k}: {n} < {budget}");
        assert_eq!(
            chain.mesh_of_step(k),
            lod_for_level(&chain.triangles, level),
            "step {k}"
        );
    }
    let work = app.world().resource::<FoveationWork>().clone();
    assert_eq!(work.chains_built, 1);
    let meshes = app.world().resource::<Assets<Mesh>>().len();
    for i in 0..30 {
        set_gaze_yaw(&mut app, (i * 7 % 120) as f32 - 60.0);
        app.update();
    }
    assert_eq!(
        app.world().resource::<FoveationWork>().chains_built,
        1,
        "no rebuild per frame"
    );
    assert_eq!(app.world().resource::<Assets<Mesh>>().len(), meshes);
}

/// A gaze jittering around a step edge: within the dead band nothing
/// switches; beyond it, the dwell bounds the switches; each switch is one
/// mesh swap.
#[test]
fn hysteresis_and_dwell_stop_thrash_under_an_oscillating_gaze() {
    let run = |a: f64, b: f64| {
        let mut app = cpu_app();
        let e = spawn(&mut app, 1, GazeLod::default())[0];
        set_gaze_yaw(&mut app, yaw_for_level((a + b) / 2.0));
        for _ in 0..10 {
            app.update();
        }
        let s0 = state(&app, e).switches;
        let mut levels = (f32::INFINITY, f32::NEG_INFINITY);
        let frames = 2 * FPS as usize;
        for i in 0..frames {
            set_gaze_yaw(&mut app, yaw_for_level(if i % 2 == 0 { a } else { b }));
            app.update();
            let l = state(&app, e).level;
            levels = (levels.0.min(l), levels.1.max(l));
        }
        let s = state(&app, e);
        let swaps = app.world().resource::<FoveationWork>().mesh_swaps;
        (s.switches - s0, levels, swaps, s.switches)
    };
    // Edge 0.75 between steps 5 and 6; dead band 0.05.
    let (inside, levels, _, _) = run(0.72, 0.78);
    eprintln!("jitter ±0.03 around an edge: {inside} switches (levels {levels:?})");
    assert!(
        (levels.0 - 0.72).abs() < 0.01 && (levels.1 - 0.78).abs() < 0.01,
        "{levels:?}"
    );
    assert_eq!(inside, 0);
    let (beyond, levels, swaps, total) = run(0.65, 0.85);
    // Every frame would switch without hysteresis (120 in 2 s); a downgrade
    // waits 0.25 s, so at most one down and one up per 0.25 s.
    eprintln!("jitter ±0.10: {beyond} switches in 2 s (levels {levels:?})");
    assert!(beyond <= 2 * (2.0 / 0.25) as u64 + 2, "{beyond}");
    assert!(beyond >= 4, "it does switch: {beyond}");
    // The first frame swaps the full mesh for its level's without a switch.
    assert!(swaps <= total + 1, "mesh swaps {swaps}, switches {total}");
}

/// A saccade onto an object makes it full detail in the same frame; a
/// saccade away takes detail away only after the dwell. Behind the head it
/// is hidden when asked, and back in view at once.
#[test]
fn saccades_and_the_field_edge() {
    let mut app = cpu_app();
    let lod = GazeLod {
        hide_outside_field: true,
        ..default()
    };
    let e = spawn(&mut app, 1, lod)[0];
    set_gaze_yaw(&mut app, 80.0);
    for _ in 0..30 {
        app.update();
    }
    let far = state(&app, e);
    assert!(far.step <= 3, "{far:?}");
    set_gaze_yaw(&mut app, 0.0);
    app.update();
    let s = state(&app, e);
    assert_eq!(s.step, 8, "full detail in the frame of the saccade");
    assert_eq!(
        app.world().get::<Mesh3d>(e).unwrap().0.id(),
        s.chain.as_ref().unwrap().meshes.last().unwrap().id()
    );
    // Away again: held for the dwell (0.25 s = 15 frames), then coarse.
    set_gaze_yaw(&mut app, 80.0);
    let held = (0..40)
        .take_while(|_| {
            app.update();
            state(&app, e).step == 8
        })
        .count();
    assert!((14..=16).contains(&held), "held {held} frames");
    // Gaze behind the head: level 0, hidden after the dwell; back at once.
    set_gaze_yaw(&mut app, 180.0);
    for _ in 0..30 {
        app.update();
    }
    assert!(state(&app, e).hidden);
    assert_eq!(app.world().get::<Visibility>(e), Some(&Visibility::Hidden));
    set_gaze_yaw(&mut app, 10.0);
    app.update();
    assert!(!state(&app, e).hidden);
    assert_eq!(
        app.world().get::<Visibility>(e),
        Some(&Visibility::Inherited)
    );
}

/// A still head and still objects cost nothing: no level is recomputed.
#[test]
fn a_still_head_recomputes_nothing() {
    let mut app = cpu_app();
    spawn(&mut app, 8, GazeLod::default());
    set_gaze_yaw(&mut app, 45.0);
    for _ in 0..40 {
        app.update();
    }
    let before = app.world().resource::<FoveationWork>().clone();
    for _ in 0..30 {
        app.update();
    }
    let after = app.world().resource::<FoveationWork>().clone();
    assert_eq!(before, after);
    // One moving object is revisited alone.
    let mut q = app
        .world_mut()
        .query_filtered::<&mut Transform, With<GazeLod>>();
    q.iter_mut(app.world_mut()).next().unwrap().translation.x += 0.1;
    app.update();
    let moved = app.world().resource::<FoveationWork>().clone();
    assert_eq!(moved.levels_computed, after.levels_computed + 1);
    assert_eq!(moved.gaze_updates, after.gaze_updates);
}

/// Where the levels would save little (every object near the gaze), the
/// full meshes are drawn, exactly as without foveation; turning away to
/// where they save much switches the level meshes on.
#[test]
fn foveation_is_left_out_where_it_saves_little() {
    let mut app = cpu_app();
    let objects = spawn(&mut app, 8, GazeLod::default());
    // A ninth object far to the side: alone it would save a ninth at most.
    let side = spawn(&mut app, 1, GazeLod::default())[0];
    app.world_mut()
        .get_mut::<Transform>(side)
        .unwrap()
        .translation = Vec3::new(3.0, 1.6, -1.0);
    set_gaze_yaw(&mut app, 0.0);
    for _ in 0..40 {
        app.update();
    }
    let gate = app.world().resource::<FoveationGate>().clone();
    eprintln!(
        "gaze ahead: {gate:?}, side object step {}",
        state(&app, side).step
    );
    assert!(
        state(&app, side).step < 8,
        "the side object's level is coarse"
    );
    assert!(
        !gate.active && gate.saving > 0.0 && gate.saving < 0.2,
        "{gate:?}"
    );
    for &e in objects.iter().chain([&side]) {
        let s = state(&app, e);
        assert_eq!(s.triangles, 5780, "full meshes: {s:?}");
    }
    set_gaze_yaw(&mut app, 75.0);
    for _ in 0..40 {
        app.update();
    }
    let gate = app.world().resource::<FoveationGate>().clone();
    eprintln!("gaze 75° aside: {gate:?}");
    assert!(gate.active && gate.saving >= 0.2, "{gate:?}");
    assert!(state(&app, objects[0]).triangles < 5780);
}

/// On the head samples' clock (`FoveationClock::HeadSample`), the dwell is
/// counted in the samples' own time, whatever the app's clock does: after
/// a saccade onto an object and away, samples 1/30 s apart hold its detail
/// for 7 or 8 of them (0.25 s), where the app's 1/60 s updates hold it for
/// 15; and samples whose time is not finite stand still (the dwell does
/// not end).
#[test]
fn on_the_head_samples_clock_the_dwell_counts_sample_time() {
    use optica_foveated_lod::{FoveationClock, HeadSource, TrackedHead};
    let held = |clock: FoveationClock, stamp: &dyn Fn(u32) -> f64| {
        let mut app = cpu_app();
        app.insert_resource(HeadSource::External)
            .insert_resource(Foveation { clock, ..default() });
        let e = spawn(&mut app, 1, GazeLod::default())[0];
        let mut k = 0;
        let mut look = |app: &mut App, yaw: f32| {
            let gaze = Quat::from_rotation_y(-yaw.to_radians()) * Vec3::NEG_Z;
            let mut head =
                TrackedHead::looking(Vec3::new(0.0, 1.6, 0.0), Quat::IDENTITY, Some(gaze), 0.063);
            head.timestamp_s = stamp(k);
            k += 1;
            app.insert_resource(head);
            app.update();
        };
        for _ in 0..30 {
            look(&mut app, 80.0);
        }
        assert!(state(&app, e).step <= 3, "coarse away from the gaze");
        look(&mut app, 0.0);
        assert_eq!(
            state(&app, e).step,
            8,
            "full detail in the frame of the saccade"
        );
        (0..60)
            .take_while(|_| {
                look(&mut app, 80.0);
                state(&app, e).step == 8
            })
            .count()
    };
    let samples = held(FoveationClock::HeadSample, &|k| k as f64 / 30.0);
    let real = held(FoveationClock::Real, &|k| k as f64 / 30.0);
    eprintln!("dwell held {samples} samples on their clock, {real} updates on the app's");
    assert!((7..=8).contains(&samples), "held {samples} samples");
    assert!((14..=16).contains(&real), "held {real} updates");
    // Samples without a time after the saccade: the clock stands still.
    let frozen = held(FoveationClock::HeadSample, &|k| {
        if k <= 30 { k as f64 / 30.0 } else { f64::NAN }
    });
    assert_eq!(frozen, 60, "held {frozen}");
}
