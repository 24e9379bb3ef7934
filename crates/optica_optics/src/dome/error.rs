//! Typed failures of the dome projection, its refinement and its error measure.

use thiserror::Error;

use crate::input::InvalidInput;

/// Why a dome camera, a split rule, a mesh or a primitive could not be used.
///
/// Bad numbers (a field of view out of range, a NaN vertex, a tolerance of
/// zero) are [`DomeError::Input`]; they are refused where they enter: when a
/// [`DomeProjection`](super::DomeProjection) or a
/// [`SplitRule`](super::SplitRule) is built, and per primitive by the
/// single-primitive functions. The other variants are the places where the
/// projection itself is singular, and a malformed mesh. The batch functions
/// ([`refine_mesh`](super::refine_mesh), [`refine_segments`](super::refine_segments),
/// [`refine_polyline`](super::refine_polyline)) do not fail: they leave bad
/// primitives out and count them per cause in
/// [`RefineStats`](super::RefineStats).
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum DomeError {
    /// A number that is not finite or out of range: a camera setting, a
    /// split rule's parameter or a vertex coordinate.
    #[error(transparent)]
    Input(#[from] InvalidInput),
    /// A vertex is at the camera origin, where no direction is defined.
    #[error("a vertex is at the camera origin")]
    AtOrigin,
    /// The segment passes through the viewer: its endpoints are seen in
    /// opposite directions and its image is two points, not an arc.
    #[error("the segment passes through the viewer")]
    ThroughViewer,
    /// The great-circle arc passes (within [`ANTIPODE_EPS_RAD`](super::ANTIPODE_EPS_RAD))
    /// through the antipode of the dome axis, where its image tears and no
    /// chord can stand for it (from the exact error measure, feature
    /// `reference`; the refiners clip or cull there instead).
    #[error("the arc passes through the antipode of the dome axis")]
    Antipode,
    /// A polynomial fisheye whose radius stops rising inside the field of
    /// view: two directions would land on one pixel.
    #[error(
        "the polynomial fisheye's radius stops rising at {theta_deg:.2} deg, inside the field of view"
    )]
    LensFolds {
        /// The first polar angle checked where dr/dθ ≤ 0, degrees.
        theta_deg: f64,
    },
    /// A fisheye's projection was asked of an equirectangular panorama,
    /// which has no image circle, focal length or axis of its own.
    #[error("an equirectangular panorama is not a fisheye")]
    NotAFisheye,
    /// A triangle refers to a vertex that does not exist.
    #[error("triangle index {index} is out of range for {len} vertices")]
    IndexOutOfRange {
        /// The offending index.
        index: u32,
        /// Number of vertices in the mesh.
        len: usize,
    },
}
