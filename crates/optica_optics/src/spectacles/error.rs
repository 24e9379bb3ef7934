//! The one error type of the spectacles module.

use thiserror::Error;

use crate::input::InvalidInput;
use crate::voxel::VoxelError;

/// Which surface of a spectacle lens an error is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LensSide {
    /// The object-side (convex for most lenses) surface, carrying the base curve.
    Front,
    /// The eye-side surface, spherical or toric.
    Back,
}

impl std::fmt::Display for LensSide {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            LensSide::Front => "front",
            LensSide::Back => "back",
        })
    }
}

/// Which ray of a bundle did not get through the lens.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlockedRay {
    /// The reference ray from the eye's centre of rotation: it missed the
    /// lens, left through the rim or was totally reflected.
    Reference,
    /// A pupil ray: as [`BlockedRay::Reference`], or it leaves the lens
    /// travelling across or against the refracted reference ray.
    Pupil,
}

impl std::fmt::Display for BlockedRay {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            BlockedRay::Reference => "reference",
            BlockedRay::Pupil => "pupil",
        })
    }
}

/// Why a spectacles computation was rejected.
///
/// Numbers from users are checked where they enter (the checked
/// constructors of [`Eye`](super::Eye), [`Prescription`](super::Prescription),
/// [`LensDesignParams`](super::LensDesignParams),
/// [`EyePlacement`](super::EyePlacement), [`FieldSettings`](super::FieldSettings))
/// and refused as [`SpectaclesError::Input`]; the other variants are failures
/// of the optics itself.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SpectaclesError {
    /// A number that is not finite or outside the range the model accepts.
    #[error(transparent)]
    Input(#[from] InvalidInput),
    /// A material name the glass catalog does not know.
    #[error("unknown lens material `{0}`")]
    UnknownMaterial(String),
    /// A surface whose radius is smaller than the blank's radius: its sag at
    /// the rim is `R − √(R² − r²)` with `R² − r² < 0`, the square root of a
    /// negative number — the surface closes before it reaches the rim.
    /// (For example +20 D in CR-39 with Vogel's base curve: F1 = 26 D,
    /// R1 = 0.498/26 = 19.2 mm, smaller than a 25 mm blank radius.)
    #[error(
        "{side} surface radius {radius_m} m is smaller than the blank radius {blank_radius_m} m (sag would need the square root of a negative number)"
    )]
    SurfaceTooSteep {
        /// Which surface.
        side: LensSide,
        /// Its (smallest) radius of curvature, in metres, absolute value.
        radius_m: f64,
        /// The blank's radius in metres.
        blank_radius_m: f64,
    },
    /// The thick-lens relation `F2 = Fv − F1/(1 − t·F1/n)` has its pole
    /// (`t·F1/n >= 1`): the front surface focuses inside the lens.
    #[error(
        "thickness {thickness_m} m and front power {front_power_d} D put the front surface's focus inside the lens"
    )]
    ThickLensPole {
        /// Centre thickness in metres.
        thickness_m: f64,
        /// Front surface power in dioptres.
        front_power_d: f64,
    },
    /// The two surfaces meet or cross inside the blank: the edge thickness
    /// needed for the prescription is zero or negative.
    #[error("the lens surfaces cross: edge thickness {edge_thickness_m} m")]
    SurfacesCross {
        /// The (negative or zero) edge thickness found, in metres.
        edge_thickness_m: f64,
    },
    /// A ray of a bundle ([`trace_bundle`](super::trace_bundle)) did not get
    /// through the lens.
    #[error("the {0} ray of the bundle does not get through the lens")]
    BundleBlocked(BlockedRay),
    /// The direct reference found no reference ray through the lens to the
    /// point: the point is outside what the lens shows, or between the eye
    /// and the lens.
    #[error("the point is not seen through the lens ({0})")]
    NotThroughLens(&'static str),
    /// No ray to work with: an empty set or no trace through the lens for
    /// the virtual viewpoint, or a field precompute in which no aim's
    /// bundles got through the lens.
    #[error("no usable rays through the lens")]
    NoRays,
    /// The voxel grid could not be built.
    #[error(transparent)]
    Voxel(#[from] VoxelError),
    /// A numerical procedure found no answer where the geometry has none to
    /// give: the lens design's thickness iteration did not settle, the
    /// paraxial probe of a lens did not get through it, the direct
    /// reference's aim Jacobian is singular (a caustic of the lens), or a
    /// solve overflowed `f64`. The string says which.
    #[error("degenerate geometry: {0}")]
    Degenerate(&'static str),
}
