//! Every setting a user can reach, randomised, on the CPU twins: each
//! plugin's settings components with fields redrawn over their whole type
//! range (`optica_harness::randomise`: NaN, ±∞, extremes, random bits and
//! ordinary values), a random share of the fields at a time so that both
//! outcomes come up. Each case is either refused with the crate's typed
//! error (its message naming the setting), or accepted, and then the CPU
//! twin the plugin runs on it accepts it too and gives finite numbers.
//! 5,000 cases per plugin in the test command; the release command in
//! `docs/reliability.md` runs more.

use bevy::prelude::*;
use optica_harness::randomise::randomise_some;
use optica_optics::glam::{DVec2, DVec3};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_xoshiro::SplitMix64;

/// Cases per plugin: 5,000 in the test command, `OPTICA_RANDOM_CASES` for
/// a longer run (`docs/reliability.md`).
fn cases() -> u32 {
    crate::count_from_env("OPTICA_RANDOM_CASES", 5000)
}

/// Counts of what the cases gave, so that a run that only ever refused
/// (or only accepted) fails instead of passing vacuously.
#[derive(Default)]
struct Outcomes {
    accepted: u32,
    refused: u32,
}

impl Outcomes {
    fn check(&self, what: &str) {
        eprintln!(
            "{what}: {} accepted, {} refused",
            self.accepted, self.refused
        );
        let n = self.accepted + self.refused;
        assert!(
            self.accepted * 20 >= n,
            "{what}: only {} of {n} accepted",
            self.accepted
        );
        assert!(
            self.refused * 20 >= n,
            "{what}: only {} of {n} refused",
            self.refused
        );
    }
}

/// Redraws a random share (3 % to all) of `value`'s fields from `seed`.
fn redraw<T: Reflect>(value: &mut T, seed: u64) {
    let mut rng = SplitMix64::seed_from_u64(seed);
    let share = [0.03, 0.1, 0.25, 0.5, 1.0][(seed % 5) as usize];
    randomise_some(value, &mut rng, share);
}

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: cases(),
        failure_persistence: None,
        ..ProptestConfig::default()
    }
}

/// Runs `case` on [`cases`] seeds; `case` says whether the settings were
/// accepted.
fn run(what: &str, case: impl Fn(u64) -> bool) {
    let outcomes = std::cell::RefCell::new(Outcomes::default());
    proptest::test_runner::TestRunner::new(config())
        .run(&any::<u64>(), |seed| {
            let accepted = case(seed);
            let mut o = outcomes.borrow_mut();
            if accepted {
                o.accepted += 1;
            } else {
                o.refused += 1;
            }
            Ok(())
        })
        .unwrap_or_else(|e| panic!("{what}: {e}"));
    outcomes.into_inner().check(what);
}

#[test]
fn lens_flare_settings_are_refused_by_name_or_traced_finite() {
    use optica_lens_flare::twins::{choose, ringing_image, starburst_image};
    use optica_lens_flare::{Error, LensFlare};
    let tessar = optica_optics::lens::builtin::tessar();
    run("lens flare", |seed| {
        let mut flare = LensFlare::new(Handle::default());
        redraw(&mut flare, seed);
        if let Err(e) = flare.validate() {
            assert!(!e.to_string().is_empty(), "{flare:?}");
            return false;
        }
        let (lens, aperture, ghosts) = match choose(&flare, &tessar) {
            Ok(chosen) => chosen,
            // Settings the lens cannot take (an f-number faster than the
            // Tessar's): refused by the optics, by name.
            Err(Error::Optics(e)) => {
                assert!(!e.to_string().is_empty());
                return false;
            }
            Err(e) => panic!("accepted settings refused by the twin: {e}\n{flare:?}"),
        };
        assert!(lens.stop_semi_aperture_mm().is_finite() && lens.stop_semi_aperture_mm() > 0.0);
        for g in &ghosts {
            assert!(
                g.relative.is_finite() && g.power.is_finite(),
                "{g:?}\n{flare:?}"
            );
        }
        // The diffraction textures at small sizes (an FFT a case).
        let small = |side: u32| side <= 128;
        if flare.starburst.is_some_and(|s| small(s.resolution))
            && let Some(image) = starburst_image(&flare, &aperture).expect("accepted starburst")
        {
            assert!(texels_finite(&image), "starburst\n{flare:?}");
        }
        if flare.ringing.is_some_and(|r| small(r.resolution))
            && let Some(image) = ringing_image(&flare, &aperture).expect("accepted ringing")
        {
            assert!(texels_finite(&image), "ringing\n{flare:?}");
        }
        true
    });
}

/// Every texel of an RGBA32F image finite.
fn texels_finite(image: &Image) -> bool {
    image
        .data
        .as_ref()
        .expect("texels")
        .chunks(4)
        .all(|b| f32::from_le_bytes(b.try_into().unwrap()).is_finite())
}

#[test]
fn dome_settings_are_refused_by_name_or_project_finite() {
    use optica_dome::DomeCamera;
    run("dome", |seed| {
        let mut dome = DomeCamera::default();
        redraw(&mut dome, seed);
        if let Err(e) = dome.validate() {
            assert!(!e.to_string().is_empty(), "{dome:?}");
            return false;
        }
        // The fisheye or the equirectangular panorama the lens asks for.
        let projection = dome
            .panorama(64, 48)
            .unwrap_or_else(|e| panic!("accepted dome refused by the twin: {e}\n{dome:?}"));
        for k in 0..32 {
            let a = k as f64 * 0.61;
            let dir = DVec3::new(
                a.cos() * (k as f64 * 0.1).sin(),
                a.sin() * (k as f64 * 0.1).sin(),
                -(k as f64 * 0.1).cos(),
            );
            if let Some(px) = projection.project(dir).visible_pixel() {
                assert!(px.is_finite(), "{dir} → {px}\n{dome:?}");
            }
            let pixel = DVec2::new(2.0 * k as f64 + 0.5, 1.5 * k as f64 + 0.5);
            if let Some(view) = projection.unproject(pixel) {
                assert!(
                    view.is_finite() && (view.length() - 1.0).abs() < 1e-6,
                    "{pixel} → {view}\n{dome:?}"
                );
            }
        }
        true
    });
}

#[test]
fn foveation_settings_are_refused_by_name_or_give_finite_levels() {
    use optica_foveated_lod::{Eye, Foveation};
    run("foveated LOD", |seed| {
        let mut foveation = Foveation::default();
        redraw(&mut foveation, seed);
        let checked = match foveation.check() {
            Ok(checked) => checked,
            Err(e) => {
                assert!(!e.to_string().is_empty(), "{foveation:?}");
                return false;
            }
        };
        for eye in [Eye::Left, Eye::Right] {
            let field = checked.field(eye);
            for k in 0..24 {
                let a = k as f64 * 0.4;
                let local = DVec3::new(a.cos(), (0.3 * a).sin(), a.sin());
                let level = field.level_local(local);
                assert!(
                    level.is_finite() && level >= 0.0,
                    "{local} → {level}\n{foveation:?}"
                );
            }
        }
        true
    });
}

#[test]
fn compound_eye_settings_are_refused_by_name_or_shade_finite() {
    use optica_compound_eye::CompoundEye;
    use optica_optics::compound_eye::{
        DarkCentre, Lattice, LensParams, Ray, ShadeOptions, TextureAxes, shade_with,
    };
    run("compound eye", |seed| {
        let mut eye = CompoundEye::default();
        redraw(&mut eye, seed);
        if let Err(e) = eye.validate() {
            assert!(!e.to_string().is_empty(), "{eye:?}");
            return false;
        }
        // The twin as the parity test builds it, on a unit quad.
        let facets = f64::from(eye.facets_per_uv);
        let axes = TextureAxes::from_triangle(
            [DVec3::ZERO, DVec3::X, DVec3::Z],
            [
                DVec2::ZERO,
                DVec2::new(facets, 0.0),
                DVec2::new(0.0, facets),
            ],
        );
        let Ok(axes) = axes else {
            // A facet density the unit quad's texture cannot carry
            // (1e30 facets per UV unit): the material falls back there too.
            return true;
        };
        let kind = eye.lattice_kind();
        let r = f64::from(eye.lens_radius) * kind.cell_inradius(axes.u(), axes.v());
        let lens = LensParams::new(
            r,
            f64::from(eye.lens_index),
            f64::from(eye.pigment_depth) * r,
        );
        let Ok(lens) = lens else {
            // A lens too small or large for f64 on this quad.
            return true;
        };
        DarkCentre::new(
            f64::from(eye.pigment.radius),
            f64::from(eye.pigment.softness),
            f64::from(eye.pigment.darkness),
        )
        .unwrap_or_else(|e| panic!("accepted pigment refused by the twin: {e}\n{eye:?}"));
        let lattice = Lattice::with_kind(axes, lens, kind).expect("lattice");
        let options = ShadeOptions::thesis(eye.slices.min(8));
        for k in 0..16 {
            let a = k as f64 * 0.37;
            let origin = DVec3::new(0.3 + 0.02 * k as f64, 1.0, 0.4);
            let dir = DVec3::new(0.3 * a.cos(), -1.0, 0.3 * a.sin()).normalize();
            let Ok(ray) = Ray::new(origin, dir) else {
                continue;
            };
            let shade = shade_with(&lattice, &ray, &options);
            if let Some(hit) = shade.hit() {
                assert!(
                    hit.uv.is_finite() && hit.point.is_finite(),
                    "{shade:?}\n{eye:?}"
                );
            }
        }
        true
    });
}

#[test]
fn spectacles_settings_are_refused_by_name_or_traced_finite() {
    use optica_optics::spectacles::{naked_eye_displacements, pupil_samples};
    use optica_spectacles::twins::{eye_placement, trace_lens};
    use optica_spectacles::{CurvedMirror, Eye, Spectacles};
    let placement = eye_placement();
    let samples = pupil_samples(8);
    run("spectacles", |seed| {
        let mut eye = Eye::default();
        let mut spectacles = Spectacles::sphere(-2.0);
        let mut mirror = CurvedMirror::default();
        redraw(&mut eye, seed);
        redraw(&mut spectacles, seed.rotate_left(17));
        redraw(&mut mirror, seed.rotate_left(33));
        let mut accepted = true;
        match eye.optics() {
            Ok(optics) => {
                for z in [0.1, 0.5, 2.0, 100.0] {
                    for d in naked_eye_displacements(
                        &optics,
                        &placement,
                        DVec3::new(0.05, 0.02, z),
                        &samples,
                    ) {
                        assert!(d.is_finite(), "{d}\n{eye:?}");
                    }
                }
            }
            Err(e) => {
                assert!(!e.to_string().is_empty());
                accepted = false;
            }
        }
        match spectacles.design() {
            Ok(lens) => {
                let d = spectacles.decentration_mm.as_dvec2() * 1e-3;
                let (rings, segments) = (
                    spectacles.tessellation.x.min(12),
                    spectacles.tessellation.y.min(16),
                );
                if let Ok(trace) = trace_lens(
                    &lens,
                    DVec3::new(d.x, d.y, 0.0),
                    rings as usize,
                    segments as usize,
                    false,
                ) {
                    for v in &trace.vertices {
                        assert!(
                            v.back.is_finite() && v.origin.is_finite() && v.dir.is_finite(),
                            "{v:?}\n{spectacles:?}"
                        );
                    }
                }
            }
            Err(e) => {
                assert!(!e.to_string().is_empty());
                accepted = false;
            }
        }
        if let Err(e) = mirror.optics() {
            assert!(!e.to_string().is_empty());
            accepted = false;
        }
        accepted
    });
}
