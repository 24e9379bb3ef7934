//! Why a setting of the spectacles plugin is refused: the crate's one
//! error type.

use optica_optics::spectacles::SpectaclesError;
use thiserror::Error;

/// What was refused and why, in
/// [`SpectaclesStatus::error`](crate::SpectaclesStatus::error) and from the
/// plugin's checked constructors. Each variant names the component whose
/// settings were refused and wraps the optics' reason (a number out of
/// range is [`SpectaclesError::Input`], naming the quantity); the plugin
/// then keeps the last good eye, lens, field or mirror.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum Error {
    /// The [`Eye`](crate::Eye)'s numbers.
    #[error("eye: {0}")]
    Eye(SpectaclesError),
    /// The [`Spectacles`](crate::Spectacles) prescription or lens design.
    #[error("spectacles: {0}")]
    Spectacles(SpectaclesError),
    /// The [`CloneDefocus`](crate::CloneDefocus) voxel field's settings or
    /// its precompute.
    #[error("defocus field: {0}")]
    Field(SpectaclesError),
    /// The lens refraction's trace (the mesh or its virtual viewpoint).
    #[error("lens refraction: {0}")]
    Refraction(SpectaclesError),
    /// The [`CurvedMirror`](crate::CurvedMirror)'s shape or tessellation.
    #[error("curved mirror: {0}")]
    Mirror(SpectaclesError),
    /// A point asked about ([`Preset::sight`](crate::presets::Preset::sight))
    /// is not seen through the lens.
    #[error("the point is not seen through the lens")]
    NotSeenThroughLens,
}
