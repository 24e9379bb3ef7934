//! Settings drawn at random over their whole type range, for property
//! tests of a plugin's components: [`randomise`] walks any `Reflect` value
//! (a settings component, say) and redraws every number, flag and unit
//! enum variant it can reach, nested structs, tuples, lists and the fields
//! of the current enum variant included. Numbers come from their full type
//! range, not a documented one: NaN, ±∞, ±0, the extremes, subnormals and
//! random bit patterns as well as ordinary values, so that a `validate()`
//! meets what a user's slider, file or code can hand it.
//!
//! ```
//! # use bevy::prelude::*;
//! # use optica_harness::randomise::randomise;
//! # use rand::SeedableRng;
//! #[derive(Reflect, Default, Debug)]
//! struct Knobs {
//!     gain: f32,
//!     steps: u32,
//!     on: bool,
//! }
//! let mut rng = rand_xoshiro::SplitMix64::seed_from_u64(7);
//! let mut knobs = Knobs::default();
//! randomise(&mut knobs, &mut rng);
//! ```

use bevy::reflect::enums::{DynamicEnum, DynamicVariant, VariantInfo};
use bevy::reflect::{PartialReflect, ReflectMut, TypeInfo};
use rand::{Rng, RngExt};

/// Redraws every number, flag and unit enum variant of `value` that
/// reflection reaches (see the module docs); opaque types it does not know
/// (handles, strings) are left as they are.
pub fn randomise(value: &mut dyn PartialReflect, rng: &mut impl Rng) {
    randomise_some(value, rng, 1.0);
}

/// [`randomise`], each number, flag and enum redrawn with probability
/// `share` (the others keep their values): with a valid value to start
/// from, a small share gives settings that are mostly accepted, a large one
/// settings that are mostly refused.
pub fn randomise_some(value: &mut dyn PartialReflect, rng: &mut impl Rng, share: f64) {
    if randomise_primitive(value, rng, share) {
        return;
    }
    match value.reflect_mut() {
        ReflectMut::Struct(s) => {
            for i in 0..s.field_len() {
                if let Some(f) = s.field_at_mut(i) {
                    randomise_some(f, rng, share);
                }
            }
        }
        ReflectMut::TupleStruct(s) => {
            for i in 0..s.field_len() {
                if let Some(f) = s.field_mut(i) {
                    randomise_some(f, rng, share);
                }
            }
        }
        ReflectMut::Tuple(t) => {
            for i in 0..t.field_len() {
                if let Some(f) = t.field_mut(i) {
                    randomise_some(f, rng, share);
                }
            }
        }
        ReflectMut::List(l) => {
            for i in 0..l.len() {
                if let Some(f) = l.get_mut(i) {
                    randomise_some(f, rng, share);
                }
            }
        }
        ReflectMut::Array(a) => {
            for i in 0..a.len() {
                if let Some(f) = a.get_mut(i) {
                    randomise_some(f, rng, share);
                }
            }
        }
        ReflectMut::Enum(e) => {
            // One time in three, a unit variant (`None` of an `Option`
            // among them) in place of the current one; otherwise the
            // current variant with its fields redrawn.
            let units: Vec<&'static str> = match e.get_represented_type_info() {
                Some(TypeInfo::Enum(info)) => info
                    .iter()
                    .filter(|v| matches!(v, VariantInfo::Unit(_)))
                    .map(VariantInfo::name)
                    .collect(),
                _ => Vec::new(),
            };
            if !units.is_empty() && coin(rng, share) && rng.random_range(0..3) == 0 {
                let name = units[rng.random_range(0..units.len())];
                let _ = e.try_apply(&DynamicEnum::new(name, DynamicVariant::Unit));
                return;
            }
            for i in 0..e.field_len() {
                if let Some(f) = e.field_at_mut(i) {
                    randomise_some(f, rng, share);
                }
            }
        }
        _ => {}
    }
}

/// `true` with probability `p`.
fn coin(rng: &mut impl Rng, p: f64) -> bool {
    rng.random_range(0.0..1.0) < p
}

/// A float over its whole range: a special value, an ordinary one at any
/// scale, or random bits.
fn any_f64(rng: &mut impl Rng) -> f64 {
    const SPECIAL: [f64; 12] = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::MIN_POSITIVE,
        f64::EPSILON,
        1e-30,
        1e30,
        -1e30,
    ];
    match rng.random_range(0..4) {
        0 => SPECIAL[rng.random_range(0..SPECIAL.len())],
        1 => rng.random_range(-1.0..1.0),
        2 => rng.random_range(-1.0..1.0) * 10f64.powi(rng.random_range(-12..13)),
        _ => f64::from_bits(rng.random()),
    }
}

/// An integer over its whole range: a small one, an extreme, or random bits.
fn any_u64(rng: &mut impl Rng) -> u64 {
    match rng.random_range(0..4) {
        0 => [0, 1, 2, 3, u64::MAX][rng.random_range(0..5)],
        1 => rng.random_range(0..100),
        2 => rng.random_range(0..100_000),
        _ => rng.random(),
    }
}

/// When `value` is a number or a flag: redraws it with probability
/// `share` and returns `true`; `false` otherwise.
fn randomise_primitive(value: &mut dyn PartialReflect, rng: &mut impl Rng, share: f64) -> bool {
    macro_rules! draw {
        ($($t:ty => $make:expr),* $(,)?) => {
            $(
                if let Some(v) = value.try_downcast_mut::<$t>() {
                    if coin(rng, share) {
                        *v = $make;
                    }
                    return true;
                }
            )*
        };
    }
    draw!(
        f32 => any_f64(rng) as f32,
        f64 => any_f64(rng),
        u8 => any_u64(rng) as u8,
        u16 => any_u64(rng) as u16,
        u32 => any_u64(rng) as u32,
        u64 => any_u64(rng),
        usize => any_u64(rng) as usize,
        i32 => any_u64(rng) as i32,
        i64 => any_u64(rng) as i64,
        bool => rng.random(),
    );
    false
}
