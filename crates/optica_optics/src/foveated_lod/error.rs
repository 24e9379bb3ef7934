//! The one error type of the foveated-LOD reference.

use thiserror::Error;

/// Why a foveated-LOD input was rejected.
///
/// Every constructor that takes user numbers (a gaze, a wall, a mesh, a
/// visual field, clip planes) checks them and returns one of these instead of
/// panicking or letting a NaN into a frame.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FoveatedError {
    /// An input had a NaN or infinite component; the string names it.
    #[error("non-finite input: {0}")]
    NonFinite(&'static str),
    /// A direction was zero, or two directions that must span a plane were parallel.
    #[error("degenerate direction: {0}")]
    DegenerateDirection(&'static str),
    /// Visual-field angles that cannot define eq. 8 (for example a boundary
    /// inside the central field).
    #[error("invalid visual field: {0}")]
    InvalidField(String),
    /// The eye is on the wall's plane or behind it, so the off-axis frustum
    /// (which divides by the eye–wall distance) does not exist.
    #[error("eye is not in front of the wall (signed distance {distance} m)")]
    EyeNotInFront {
        /// Signed distance of the eye from the wall plane along the wall normal.
        distance: f64,
    },
    /// The wall's corners do not form a rectangle of positive area.
    #[error("degenerate wall: {0}")]
    DegenerateWall(&'static str),
    /// Clip planes with `0 < near < far` violated.
    #[error("invalid clip planes: near = {near}, far = {far}")]
    InvalidClipPlanes {
        /// The near distance given.
        near: f64,
        /// The far distance given.
        far: f64,
    },
    /// A mesh or scene that cannot be traced.
    #[error("invalid mesh or scene: {0}")]
    InvalidScene(String),
    /// Any other parameter out of range.
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
}
