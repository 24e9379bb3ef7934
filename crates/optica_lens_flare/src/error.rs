//! Why a flare is not drawn as set: the crate's one error type.

use optica_optics::input::InvalidInput;
use optica_optics::lens_flare::FlareError;
use thiserror::Error;

/// Why [`LensFlare::validate`](crate::LensFlare::validate) refused a
/// setting, or why a flare could not be built
/// ([`FlareGhosts::problem`](crate::FlareGhosts::problem)); the flare then
/// keeps its last good ghosts.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum Error {
    /// The lens asset has not loaded (yet), or failed to load.
    #[error("the lens is not loaded (yet)")]
    LensNotLoaded,
    /// A number outside its range (grid, wavelengths, intensity, the
    /// iris's roundness and f-number, occlusion, starburst, ringing,
    /// coating): which one, its value and what it had to be.
    #[error(transparent)]
    Setting(#[from] InvalidInput),
    /// The iris's blade count is neither 0 (round) nor in `3..=32`.
    #[error("aperture blades = {0}: expected 0 (round) or 3 ..= 32")]
    Blades(u32),
    /// A diffraction texture's side is not an even number in `32..=1024`.
    #[error("{what} resolution = {side}: expected an even number in 32 ..= 1024")]
    Resolution {
        /// `"starburst"` or `"ringing"`.
        what: &'static str,
        /// The side asked for.
        side: u32,
    },
    /// More dust (`> 10000` specks) or scratches (`> 1000`) than a
    /// starburst draws.
    #[error(
        "starburst dirt of {specks} specks and {scratches} scratches: expected at most 10000 and 1000"
    )]
    Dirt {
        /// Specks asked for.
        specks: u32,
        /// Scratches asked for.
        scratches: u32,
    },
    /// The optics refused: an f-number faster than the lens, a coating
    /// that is not a valid layer, a prescription that traces no ghost.
    #[error(transparent)]
    Optics(#[from] FlareError),
}
