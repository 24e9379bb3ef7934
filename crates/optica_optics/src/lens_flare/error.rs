//! Why a flare computation could not run.

use thiserror::Error;

use crate::input::InvalidInput;
use crate::lens::{ParaxialError, PrescriptionError, TraceError};

/// Why a lens-flare computation could not run. Rays that die inside the lens
/// (miss a sphere, total internal reflection) are not errors: they are dead
/// grid vertices (see [`super::GridRay::alive`]).
#[derive(Clone, Debug, Error, PartialEq)]
pub enum FlareError {
    /// A number that is not finite or out of range: a light direction, grid
    /// size, gain bound, cull threshold, stop opening, f-number, pupil bound,
    /// sensor window or sensor z.
    #[error(transparent)]
    Input(#[from] InvalidInput),
    /// The light travels away from the lens or parallel to it (its unit
    /// direction has `d_z <=` [`super::MIN_LIGHT_Z`]): a source behind the
    /// camera or beside it makes no flare.
    #[error(
        "the light does not travel into the lens (unit direction z = {dir_z}): it makes no flare"
    )]
    LightBehindLens {
        /// z component of the unit light direction.
        dir_z: f64,
    },
    /// The path does not exist in this lens, or a glass has no index at the
    /// wavelength.
    #[error(transparent)]
    Trace(#[from] TraceError),
    /// The paraxial entrance pupil or f-number does not exist (an afocal
    /// lens, a pupil at infinity).
    #[error(transparent)]
    Paraxial(#[from] ParaxialError),
    /// A changed prescription (stopped down, coated) is not a valid lens.
    #[error(transparent)]
    Prescription(#[from] PrescriptionError),
}
