//! The one error type of the spectacles reference.

use thiserror::Error;

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

/// Why a spectacles computation was rejected.
///
/// Every function that takes user numbers (a prescription, an eye, a pupil
/// formula's inputs, field settings) checks them and returns one of these
/// instead of panicking or letting a NaN through.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SpectaclesError {
    /// An input was NaN or infinite; the string names it.
    #[error("non-finite input: {0}")]
    NonFinite(&'static str),
    /// A number outside the range the model accepts.
    #[error("{what} = {value} is outside the accepted range {min} ..= {max}")]
    OutOfRange {
        /// What the number is.
        what: &'static str,
        /// The value given.
        value: f64,
        /// Smallest accepted value.
        min: f64,
        /// Largest accepted value.
        max: f64,
    },
    /// A material name the glass catalog does not know.
    #[error("unknown lens material `{0}`")]
    UnknownMaterial(String),
    /// A surface whose radius is smaller than the blank's radius: its sag at
    /// the rim is `R − √(R² − r²)` with `R² − r² < 0`, the square root of a
    /// negative number — the surface closes before it reaches the rim.
    /// (For example +20 D in CR-39 with Vogel's base curve: F1 = 26 D,
    /// R1 = 0.498/26 = 19.2 mm, smaller than a 25 mm blank radius.)
    #[error("{side} surface radius {radius_m} m is smaller than the blank radius {blank_radius_m} m (sag would need the square root of a negative number)")]
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
    #[error("thickness {thickness_m} m and front power {front_power_d} D put the front surface's focus inside the lens")]
    ThickLensPole {
        /// Centre thickness in metres.
        thickness_m: f64,
        /// Front surface power in dioptres.
        front_power_d: f64,
    },
    /// The two surfaces cross inside the blank (negative edge or centre thickness).
    #[error("the lens surfaces cross: thickness {thickness_m} m at {where_}")]
    SurfacesCross {
        /// The (negative or zero) thickness found.
        thickness_m: f64,
        /// `"centre"` or `"edge"`.
        where_: &'static str,
    },
    /// A direction that is zero, or a geometry with no defined ray.
    #[error("degenerate geometry: {0}")]
    Degenerate(&'static str),
    /// A set of rays for the virtual viewpoint that is empty or has no finite ray.
    #[error("no usable rays for the virtual viewpoint")]
    NoRays,
    /// The voxel grid could not be built.
    #[error(transparent)]
    Voxel(#[from] VoxelError),
    /// The direct reference found no chief ray through the lens to the point.
    #[error("no chief ray through the lens reaches the point ({0})")]
    NotThroughLens(&'static str),
}
