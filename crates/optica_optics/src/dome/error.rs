//! Typed failures of the dome projection, its refinement and its error measure.

use thiserror::Error;

/// Why a dome camera, a split rule or a primitive could not be used.
///
/// Bad parameters are rejected when a [`DomeProjection`](super::DomeProjection)
/// or a [`SplitRule`](super::SplitRule) is built; bad geometry is rejected per
/// primitive by the single-primitive functions and counted (not fatal) by the
/// batch functions (see [`RefineStats`](super::RefineStats)).
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum DomeError {
    /// The field of view must lie in [1e-6°, 360°)
    /// ([`MIN_FOV_DEG`](super::MIN_FOV_DEG)): 360° would put the
    /// antipode, where the projection is singular, on the rim; below 1e-6°
    /// the scale f = (size/2)/(FOV/2) grows without use to ∞ (NaN pixels).
    #[error("field of view {0}° is outside [1e-6°, 360°)")]
    InvalidFov(f64),
    /// The tilt must be finite.
    #[error("dome tilt {0}° is not finite")]
    InvalidTilt(f64),
    /// The domemaster must be at least one pixel wide.
    #[error("domemaster size must be at least 1 px")]
    InvalidSize,
    /// A pixel tolerance must be finite and positive.
    #[error("pixel tolerance {0} must be finite and positive")]
    InvalidTolerance(f64),
    /// A maximum piece angle must be finite and positive.
    #[error("maximum piece angle {0} rad must be finite and positive")]
    InvalidPieceAngle(f64),
    /// A vertex has a NaN or infinite coordinate.
    #[error("a vertex is not finite")]
    NonFiniteVertex,
    /// A vertex is at the camera origin, where no direction is defined.
    #[error("a vertex is at the camera origin")]
    AtOrigin,
    /// The segment passes through the viewer: its endpoints are seen in
    /// opposite directions and its image is two points, not an arc.
    #[error("the segment passes through the viewer")]
    ThroughViewer,
    /// The great-circle arc passes (within [`ANTIPODE_EPS_RAD`](super::ANTIPODE_EPS_RAD))
    /// through the antipode of the dome axis, where its image tears.
    #[error("the arc passes through the antipode of the dome axis")]
    Antipode,
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle index {index} is out of range for {len} vertices")]
    IndexOutOfRange {
        /// The offending index.
        index: u32,
        /// Number of vertices in the mesh.
        len: usize,
    },
}
