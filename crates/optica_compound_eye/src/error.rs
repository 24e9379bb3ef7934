//! Why a compound eye is not drawn as set: the crate's one error type.

use optica_optics::compound_eye::CompoundEyeError;
use optica_optics::input::InvalidInput;
use thiserror::Error;

/// Why a [`CompoundEyeMaterial`](crate::CompoundEyeMaterial) is not drawn
/// as set, in [`CompoundEyeStatus::error`](crate::CompoundEyeStatus).
#[derive(Clone, Copy, Debug, Error, PartialEq)]
pub enum Error {
    /// A setting the shader cannot use
    /// ([`CompoundEye::validate`](crate::CompoundEye::validate)): the
    /// lattice is off and the mesh renders as its base material.
    #[error(transparent)]
    Setting(#[from] InvalidInput),
    /// The prefilter's table could not be built for these optics: the
    /// facets are traced at every size (no moiré filtering below a pixel).
    #[error("compound eye prefilter: {0}")]
    Prefilter(#[from] CompoundEyeError),
    /// [`insert_axis_field`](crate::insert_axis_field) cannot write a field
    /// into this mesh, and says why.
    #[error("compound eye axis field: {0}")]
    AxisField(&'static str),
}
