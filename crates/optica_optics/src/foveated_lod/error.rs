//! The error type of the foveated-LOD module.

use thiserror::Error;

use crate::input::InvalidInput;

/// Why a foveated-LOD input was rejected.
///
/// Numbers that are not finite or out of range are [`FoveatedError::Input`],
/// naming the quantity; the other variants are failures of the geometry or of
/// the data's shape. Every constructor checks its input once, so nothing
/// downstream (per ray, per pixel) re-checks it.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum FoveatedError {
    /// A number that is not finite, or outside the range the model accepts.
    #[error(transparent)]
    Input(#[from] InvalidInput),
    /// Two directions that must span a plane are parallel: a gaze and its up
    /// hint, a camera's forward and up, a quad's edges.
    #[error("degenerate direction: {0}")]
    DegenerateDirection(&'static str),
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
    /// The far clip plane is not beyond the near one.
    #[error("far clip plane {far} m is not beyond the near clip plane {near} m")]
    InvalidClipPlanes {
        /// The near distance given (m).
        near: f64,
        /// The far distance given (m).
        far: f64,
    },
    /// The tracker reported no sample this frame.
    #[error("the tracker reported no sample")]
    MissingSample,
    /// Two sequences that must match element for element differ in length
    /// (levels and pixels, two images, weights).
    #[error("{what}: expected {expected} entries, got {got}")]
    LengthMismatch {
        /// What was counted.
        what: &'static str,
        /// The length required.
        expected: usize,
        /// The length given.
        got: usize,
    },
    /// A mesh or scene of the reference tracer that cannot be traced (no
    /// triangles, an index out of range, an object without meshes).
    #[error("invalid mesh or scene: {0}")]
    InvalidScene(String),
}
