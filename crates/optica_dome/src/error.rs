//! Why a dome camera or an export is refused: the crate's one error type.

use std::ops::Range;
use std::path::PathBuf;

use optica_optics::input::InvalidInput;
use thiserror::Error;

/// Why [`DomeCamera::validate`](crate::DomeCamera::validate),
/// [`DomeExport::validate`](crate::DomeExport::validate) or
/// [`parse_frame_range`](crate::parse_frame_range) refused, or why the
/// vertex mode cannot draw ([`DomeStatus::error`](crate::DomeStatus::error)).
/// A refused camera keeps its last projection.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum Error {
    /// A number outside its range (field of view, tilt, tolerance, near,
    /// cube face size): which one, its value and what it had to be.
    #[error("dome camera: {0}")]
    Setting(#[from] InvalidInput),
    /// The far distance is not beyond the near one.
    #[error("dome far distance {far} is not beyond near ({near})")]
    FarNotBeyondNear {
        /// The far distance asked for.
        far: f32,
        /// The near distance.
        near: f32,
    },
    /// The lens cannot cover the field of view (an orthographic lens
    /// beyond 180°, a polynomial that folds back): the CPU twin's refusal.
    #[error("dome {lens} lens: {source}")]
    Lens {
        /// The lens's name ([`DomeLens::name`](crate::DomeLens::name)).
        lens: &'static str,
        /// Why the projection refused it.
        #[source]
        source: optica_optics::dome::DomeError,
    },
    /// An export or a frame range with no frames.
    #[error("frame range {0:?} is empty")]
    EmptyFrames(Range<u32>),
    /// A frame range's text is not `A..B`, `A..=B` or `A` with whole
    /// frame numbers.
    #[error("`{part}` in frame range `{text}` is not a frame number")]
    FrameNumber {
        /// The part that is not a number.
        part: String,
        /// The whole range as given.
        text: String,
    },
    /// The export folder cannot be created.
    #[error("cannot create {}: {message}", dir.display())]
    CreateDir {
        /// The folder.
        dir: PathBuf,
        /// The file system's words.
        message: String,
    },
    /// The vertex mode's projection could not be put into Bevy's
    /// `view_transformations.wgsl` (a Bevy whose shader text this version
    /// does not know): vertex-mode cameras are not drawn rather than drawn
    /// as a plain perspective. The cube mode still works.
    #[error("the dome's vertex projection could not be patched into Bevy's view shader: {0}")]
    ShaderPatch(&'static str),
    /// The exact-attribute step could not be put into Bevy's
    /// `pbr_fragment.wgsl` (a Bevy whose shader text this version does not
    /// know): vertex-mode cameras with
    /// [`DomeCamera::exact_attributes`](crate::DomeCamera::exact_attributes)
    /// are drawn, but with texture interpolated inside refined triangles.
    #[error(
        "the dome's exact-attribute step could not be patched into Bevy's fragment shader (texture is interpolated inside triangles): {0}"
    )]
    AttributePatch(&'static str),
}
