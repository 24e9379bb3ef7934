//! Why a flare computation could not run.

use thiserror::Error;

use crate::lens::TraceError;

/// Bad input to the lens-flare reference. Rays that die inside the lens
/// (miss a sphere, total internal reflection) are not errors: they are dead
/// grid vertices (see [`super::GridRay::alive`]).
#[derive(Clone, Debug, Error, PartialEq)]
pub enum FlareError {
    /// The light direction is not finite, is zero, or does not travel
    /// towards the lens (+z).
    #[error("light direction must be finite, non-zero and travel towards +z, got ({0}, {1}, {2})")]
    InvalidLight(f64, f64, f64),
    /// Rays per side of a grid outside `2..=MAX_GRID`.
    #[error("grid needs 2..={max} rays per side, got {got}")]
    InvalidGridSize {
        /// What was asked for.
        got: usize,
        /// The largest accepted.
        max: usize,
    },
    /// Pupil bounds that are not finite or have no area.
    #[error("pupil bounds must be finite with a positive half-width, got half-width {0} mm")]
    InvalidBounds(f64),
    /// A sensor window with no pixels, a non-positive pixel size or too many pixels.
    #[error("sensor window: {0}")]
    InvalidWindow(&'static str),
    /// A gain bound that is not finite and >= 1.
    #[error("max_gain must be finite and >= 1, got {0}")]
    InvalidGain(f64),
    /// A cull threshold outside [0, 1].
    #[error("relative cull threshold must be in [0, 1], got {0}")]
    InvalidThreshold(f64),
    /// A stop opening outside (0, 1].
    #[error("stop opening must be in (0, 1], got {0}")]
    InvalidOpening(f64),
    /// A reference with no rays.
    #[error("the reference needs at least one ray per side")]
    NoRays,
    /// The lens or the path is invalid (bad prescription, wavelength, path).
    #[error(transparent)]
    Trace(#[from] TraceError),
}
