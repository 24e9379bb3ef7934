//! `randomise` reaches every field: numbers nested in structs, options,
//! enum variants and glam vectors are redrawn over their whole range, the
//! special values among them; `randomise_some` leaves the rest alone.

use bevy::prelude::*;
use optica_harness::randomise::{randomise, randomise_some};
use rand::SeedableRng;
use rand_xoshiro::SplitMix64;

#[derive(Reflect, Clone, Debug, PartialEq, Default)]
enum Mode {
    #[default]
    Plain,
    Fancy,
    Scaled(f32),
}

#[derive(Reflect, Clone, Debug, PartialEq)]
struct Inner {
    depth: f64,
    steps: u32,
}

#[derive(Reflect, Clone, Debug, PartialEq)]
struct Knobs {
    gain: f32,
    on: bool,
    offset: Vec3,
    inner: Option<Inner>,
    mode: Mode,
}

fn knobs() -> Knobs {
    Knobs {
        gain: 1.0,
        on: false,
        offset: Vec3::ZERO,
        inner: Some(Inner {
            depth: 2.0,
            steps: 4,
        }),
        mode: Mode::Scaled(0.5),
    }
}

#[test]
fn every_field_and_the_special_values_come_up() {
    let mut rng = SplitMix64::seed_from_u64(1);
    let (mut nan, mut inf, mut none, mut fancy, mut plain) = (0, 0, 0, 0, 0);
    let (mut depth, mut steps, mut offset, mut scaled, mut on) = (0, 0, 0, 0, 0);
    for _ in 0..500 {
        let mut k = knobs();
        randomise(&mut k, &mut rng);
        nan += usize::from(k.gain.is_nan());
        inf += usize::from(k.gain.is_infinite());
        on += usize::from(k.on);
        offset += usize::from(k.offset.x != 0.0);
        match &k.inner {
            None => none += 1,
            Some(i) => {
                depth += usize::from(i.depth != 2.0);
                steps += usize::from(i.steps != 4);
            }
        }
        match k.mode {
            Mode::Plain => plain += 1,
            Mode::Fancy => fancy += 1,
            Mode::Scaled(s) => scaled += usize::from(s != 0.5),
        }
    }
    for (what, n) in [
        ("NaN gain", nan),
        ("infinite gain", inf),
        ("flag on", on),
        ("offset redrawn", offset),
        ("inner None", none),
        ("inner depth redrawn", depth),
        ("inner steps redrawn", steps),
        ("Plain", plain),
        ("Fancy", fancy),
        ("Scaled redrawn", scaled),
    ] {
        assert!(n >= 5, "{what}: {n} of 500");
    }
}

#[test]
fn a_zero_share_changes_nothing_and_a_small_one_little() {
    let mut rng = SplitMix64::seed_from_u64(2);
    let mut k = knobs();
    randomise_some(&mut k, &mut rng, 0.0);
    assert_eq!(k, knobs());
    let mut unchanged = 0;
    for _ in 0..200 {
        let mut k = knobs();
        randomise_some(&mut k, &mut rng, 0.1);
        unchanged += usize::from(k == knobs());
    }
    // Eight leaves at 10 % each: about 0.9^8 = 43 % unchanged.
    assert!(
        (50..130).contains(&unchanged),
        "{unchanged} of 200 unchanged"
    );
}
