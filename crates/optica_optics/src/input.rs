//! Checked input: the one error for a number optica cannot use.
//!
//! Every public entry point that takes a user's number (a radius, a
//! wavelength, a tracker's position) checks it once, where it enters, and
//! returns [`InvalidInput`] naming the quantity, the value and what was
//! expected. Types with invariants keep their fields private and are built
//! by checked constructors, so nothing downstream re-checks them per ray.
//!
//! The paper modules' own error enums wrap this one (`#[from]`) for their
//! domain failures (a ray that misses, a lens whose surfaces cross); they do
//! not grow a "non-finite" variant of their own.
//!
//! ```
//! use optica_optics::input::{self, Expected, InvalidInput};
//!
//! assert_eq!(input::positive("lens radius (m)", 0.002), Ok(0.002));
//! let err = input::positive("lens radius (m)", f64::NAN).unwrap_err();
//! assert_eq!(err.expected, Expected::Positive);
//! assert_eq!(err.to_string(), "lens radius (m) = NaN: expected a finite number > 0");
//! ```

use glam::{DVec2, DVec3};
use thiserror::Error;

/// What a checked number had to be.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Expected {
    /// Any finite number.
    Finite,
    /// A finite number greater than zero.
    Positive,
    /// A finite number greater than or equal to zero.
    NonNegative,
    /// A finite number greater than or equal to this bound.
    AtLeast(f64),
    /// A number that is not zero and not NaN (±∞ allowed, e.g. a flat
    /// surface's radius).
    NonZero,
    /// A finite number in `min..=max`.
    Range {
        /// Smallest accepted value.
        min: f64,
        /// Largest accepted value.
        max: f64,
    },
    /// A vector with finite components.
    FiniteVector,
    /// A vector with finite components and a length that can be normalised.
    Direction,
}

impl std::fmt::Display for Expected {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Expected::Finite => f.write_str("a finite number"),
            Expected::Positive => f.write_str("a finite number > 0"),
            Expected::NonNegative => f.write_str("a finite number >= 0"),
            Expected::AtLeast(min) => write!(f, "a finite number >= {min}"),
            Expected::NonZero => f.write_str("a non-zero number (±∞ allowed)"),
            Expected::Range { min, max } => write!(f, "a finite number in {min} ..= {max}"),
            Expected::FiniteVector => f.write_str("a vector with finite components"),
            Expected::Direction => f.write_str("a finite, non-zero direction"),
        }
    }
}

/// A number handed to optica that is not finite, or outside the range the
/// model accepts.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
#[error("{what} = {value}: expected {expected}")]
pub struct InvalidInput {
    /// The quantity, with its unit where it has one (`"pupil diameter (m)"`).
    pub what: &'static str,
    /// The value received; for a vector, its first non-finite component, or
    /// its length when all components are finite.
    pub value: f64,
    /// What the value had to be.
    pub expected: Expected,
}

impl InvalidInput {
    /// An error for `what` = `value`, which had to be `expected`.
    pub fn new(what: &'static str, value: f64, expected: Expected) -> Self {
        Self {
            what,
            value,
            expected,
        }
    }
}

/// `x` if it is finite.
pub fn finite(what: &'static str, x: f64) -> Result<f64, InvalidInput> {
    if x.is_finite() {
        Ok(x)
    } else {
        Err(InvalidInput::new(what, x, Expected::Finite))
    }
}

/// `x` if it is finite and greater than zero.
pub fn positive(what: &'static str, x: f64) -> Result<f64, InvalidInput> {
    // `x > 0.0` is false for NaN, and +∞ is caught by `is_finite`.
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err(InvalidInput::new(what, x, Expected::Positive))
    }
}

/// `x` if it is finite and not negative.
pub fn non_negative(what: &'static str, x: f64) -> Result<f64, InvalidInput> {
    if x.is_finite() && x >= 0.0 {
        Ok(x)
    } else {
        Err(InvalidInput::new(what, x, Expected::NonNegative))
    }
}

/// `x` if it is finite and at least `min`.
pub fn at_least(what: &'static str, x: f64, min: f64) -> Result<f64, InvalidInput> {
    if x.is_finite() && x >= min {
        Ok(x)
    } else {
        Err(InvalidInput::new(what, x, Expected::AtLeast(min)))
    }
}

/// `x` if it is finite and in `min..=max`.
pub fn in_range(what: &'static str, x: f64, min: f64, max: f64) -> Result<f64, InvalidInput> {
    if x.is_finite() && x >= min && x <= max {
        Ok(x)
    } else {
        Err(InvalidInput::new(what, x, Expected::Range { min, max }))
    }
}

/// `v` if every component is finite.
pub fn finite_vec3(what: &'static str, v: DVec3) -> Result<DVec3, InvalidInput> {
    match v.to_array().into_iter().find(|c| !c.is_finite()) {
        None => Ok(v),
        Some(bad) => Err(InvalidInput::new(what, bad, Expected::FiniteVector)),
    }
}

/// `v` if every component is finite.
pub fn finite_vec2(what: &'static str, v: DVec2) -> Result<DVec2, InvalidInput> {
    match v.to_array().into_iter().find(|c| !c.is_finite()) {
        None => Ok(v),
        Some(bad) => Err(InvalidInput::new(what, bad, Expected::FiniteVector)),
    }
}

/// `v` normalised, if it is finite and long enough to normalise.
///
/// Callers that need a unit vector take any length and normalise it here,
/// rather than rejecting a direction that is merely not unit.
pub fn direction(what: &'static str, v: DVec3) -> Result<DVec3, InvalidInput> {
    let v = finite_vec3(what, v).map_err(|e| InvalidInput {
        expected: Expected::Direction,
        ..e
    })?;
    v.try_normalize()
        .ok_or(InvalidInput::new(what, v.length(), Expected::Direction))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scalars_are_checked_and_passed_through() {
        assert_eq!(finite("x", -3.0), Ok(-3.0));
        assert_eq!(
            finite("x", f64::INFINITY).unwrap_err().expected,
            Expected::Finite
        );
        assert_eq!(positive("x", 0.0).unwrap_err().value, 0.0);
        assert_eq!(
            positive("x", f64::INFINITY).unwrap_err().expected,
            Expected::Positive
        );
        assert_eq!(non_negative("x", 0.0), Ok(0.0));
        assert_eq!(
            non_negative("x", -1e-300).unwrap_err().expected,
            Expected::NonNegative
        );
        assert_eq!(at_least("x", 1.0, 1.0), Ok(1.0));
        assert_eq!(
            at_least("x", f64::INFINITY, 1.0).unwrap_err().expected,
            Expected::AtLeast(1.0)
        );
        assert_eq!(in_range("x", 1.0, 1.0, 3.0), Ok(1.0));
        let e = in_range("x", f64::NAN, 1.0, 3.0).unwrap_err();
        assert_eq!(e.expected, Expected::Range { min: 1.0, max: 3.0 });
        assert!(e.value.is_nan());
    }

    #[test]
    fn vectors_name_the_bad_component() {
        let e = finite_vec3("origin", DVec3::new(1.0, f64::NEG_INFINITY, f64::NAN)).unwrap_err();
        assert_eq!(
            (e.what, e.value, e.expected),
            ("origin", f64::NEG_INFINITY, Expected::FiniteVector)
        );
        assert!(finite_vec2("uv", DVec2::new(f64::NAN, 0.0)).is_err());
        assert_eq!(finite_vec2("uv", DVec2::ONE), Ok(DVec2::ONE));
    }

    #[test]
    fn directions_are_normalised_or_rejected() {
        let d = direction("dir", DVec3::new(0.0, 3.0, 4.0)).unwrap();
        assert!((d - DVec3::new(0.0, 0.6, 0.8)).length() < 1e-15);
        let zero = direction("dir", DVec3::ZERO).unwrap_err();
        assert_eq!((zero.value, zero.expected), (0.0, Expected::Direction));
        let nan = direction("dir", DVec3::new(f64::NAN, 0.0, 1.0)).unwrap_err();
        assert!(nan.value.is_nan() && nan.expected == Expected::Direction);
        // A denormal vector cannot be normalised in f64.
        assert!(direction("dir", DVec3::splat(1e-310)).is_err());
    }

    #[test]
    fn messages_say_what_and_why() {
        let e = in_range("stop opening", 1.5, 0.0, 1.0).unwrap_err();
        assert_eq!(
            e.to_string(),
            "stop opening = 1.5: expected a finite number in 0 ..= 1"
        );
    }
}
