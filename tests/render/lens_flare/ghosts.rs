//! Lens assets and the choice of ghosts: the shipped `.lens` files load
//! through Bevy's asset server, every two-reflection path (n(n−1)/2 for n
//! interfaces) gets a fate, and the budget and the dimness threshold are
//! kept.

use std::sync::{Arc, Mutex};

use bevy::prelude::*;
use optica_harness::Headless;
use optica_lens_flare::{Error, FlareGhosts, GhostFate, LensFlare, LensFlarePlugin};

/// The ghosts a camera with `flare` (its lens loaded from `path`) ends up
/// with after a few frames.
fn ghosts_of(
    path: &'static str,
    edit: impl Fn(&mut LensFlare) + Send + Sync + 'static,
) -> FlareGhosts {
    let seen = Arc::new(Mutex::new(None));
    let log = seen.clone();
    Headless::new(16, 16)
        .frames(12)
        .render(move |app: &mut App| {
            app.add_plugins(LensFlarePlugin);
            app.add_systems(
                Startup,
                move |mut commands: Commands, assets: Res<AssetServer>| {
                    let mut flare = LensFlare::new(assets.load(path));
                    edit(&mut flare);
                    commands.spawn((Camera3d::default(), flare));
                },
            );
            app.add_systems(Last, move |ghosts: Query<&FlareGhosts>| {
                if let Ok(g) = ghosts.single() {
                    *log.lock().expect("log") = Some(g.clone());
                }
            });
        })
        .expect("render");
    seen.lock()
        .expect("log")
        .clone()
        .expect("no FlareGhosts on the camera")
}

#[test]
fn every_ghost_of_the_shipped_lenses_gets_a_fate() {
    for (path, interfaces) in [
        ("lenses/tessar-us2854889.lens", 7),
        ("lenses/double-gauss-us2701982.lens", 14),
        ("lenses/heliar-us2645156.lens", 0),
        // The scale case: 528 ghosts.
        ("lenses/zoom-canon-us5537259.lens", 33),
    ] {
        let g = ghosts_of(path, |_| {});
        if let Some(lens) = g.lens.as_ref() {
            let p = lens.paraxial(550.0).expect("paraxial");
            eprintln!("{path}: EFL {:.1} mm, f/{:.2}", p.efl_mm, p.f_number);
        }
        assert_eq!(g.problem, None, "{path}");
        let lens = g.lens.as_ref().expect("the lens loaded");
        let n = lens.interfaces().len();
        if interfaces > 0 {
            assert_eq!(n, interfaces, "{path}");
        }
        assert_eq!(g.ghosts.len(), n * (n - 1) / 2, "{path}");
        let drawn = g.drawn().count();
        let fates = |f: GhostFate| g.ghosts.iter().filter(|c| c.fate == f).count();
        eprintln!(
            "{path}: {} ghosts, {drawn} drawn, {} too dim, {} over budget, {} blocked",
            g.ghosts.len(),
            fates(GhostFate::TooDim),
            fates(GhostFate::OverBudget),
            fates(GhostFate::Blocked)
        );
        assert!(drawn > 0 && drawn <= 64, "{path}: {drawn} drawn");
        // Brightest first; the drawn ones are the brightest unblocked.
        assert!(g.ghosts.windows(2).all(|w| w[0].relative >= w[1].relative));
        assert_eq!(g.ghosts[0].relative, 1.0);
    }
}

#[test]
fn the_budget_and_the_threshold_are_kept() {
    let g = ghosts_of("lenses/double-gauss-us2701982.lens", |f| {
        f.ghost_budget = 5;
        f.min_relative = 0.0;
    });
    assert_eq!(g.drawn().count(), 5);
    assert!(g.ghosts.iter().any(|c| c.fate == GhostFate::OverBudget));
    let g = ghosts_of("lenses/double-gauss-us2701982.lens", |f| {
        f.ghost_budget = 1000;
        f.min_relative = 0.05;
    });
    for c in &g.ghosts {
        match c.fate {
            GhostFate::Drawn => assert!(c.relative >= 0.05),
            GhostFate::TooDim => assert!(c.relative < 0.05),
            GhostFate::Blocked => assert_eq!(c.relative, 0.0),
            GhostFate::OverBudget => panic!("no budget limit here"),
        }
    }
    // Invalid settings: no choice, the reason given, no panic.
    let g = ghosts_of("lenses/tessar-us2854889.lens", |f| f.grid = 0);
    assert!(
        matches!(&g.problem, Some(Error::Setting(e)) if e.what == "flare grid" && e.value == 0.0),
        "{:?}",
        g.problem
    );
    assert!(g.ghosts.is_empty());
}

/// Adaptive grids: every drawn ghost of the double Gauss gets a grid that
/// grows with its estimated power, within 8..=512 rays per side, and the
/// rays of 16² each in all (at most, and nearly); with `adaptive_grid` off
/// every ghost gets 32².
#[test]
fn grid_sizes_follow_the_power_within_the_budget() {
    let path = "lenses/double-gauss-us2701982.lens";
    let g = ghosts_of(path, |f| {
        f.grid = 16;
        f.adaptive_grid = true;
    });
    let mut drawn: Vec<_> = g
        .ghosts
        .iter()
        .filter(|c| c.fate == GhostFate::Drawn)
        .collect();
    for c in &drawn {
        assert!((8..=512).contains(&c.grid), "{c:?}");
        assert!(
            c.power.is_finite() && (0.0..=1.0).contains(&c.power),
            "{c:?}"
        );
    }
    // Ordered by power, the sizes never fall, and they spread.
    drawn.sort_by(|a, b| a.power.total_cmp(&b.power));
    let sizes: Vec<u32> = drawn.iter().map(|c| c.grid).collect();
    eprintln!("double Gauss grid sizes by power: {sizes:?}");
    assert!(sizes.windows(2).all(|w| w[0] <= w[1]), "{sizes:?}");
    assert!(sizes[0] < 16 && sizes[sizes.len() - 1] > 32, "{sizes:?}");
    let rays = g.rays_per_light() as f64;
    let budget = (drawn.len() * 16 * 16) as f64;
    eprintln!("rays per light and wavelength: {rays} adaptive, {budget} fixed");
    assert!(rays <= budget && rays > 0.9 * budget, "{rays} vs {budget}");
    let fixed_grids = ghosts_of(path, |f| {
        f.grid = 32;
        f.adaptive_grid = false;
    });
    assert!(fixed_grids.drawn_grids().all(|(_, n)| n == 32));
}
