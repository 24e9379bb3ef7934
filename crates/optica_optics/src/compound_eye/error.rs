//! The one error type of the compound-eye model.

use thiserror::Error;

use crate::input::InvalidInput;

use super::texture_axes::NORMAL_COS_EPS;

/// Why a compound-eye input was rejected.
///
/// Constructors that take user numbers (triangles, lens parameters, facet
/// frames) return one of these instead of panicking or letting a NaN reach a
/// pixel; the per-ray functions never fail, they return a
/// [`super::ShadeFallback`].
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum CompoundEyeError {
    /// A number that is not finite or out of range: a triangle position or
    /// texture coordinate, a lens radius or index, a facet size, an axis.
    #[error(transparent)]
    Input(#[from] InvalidInput),
    /// The triangle has (relatively) zero area, `|P_10 × P_20| ≤`
    /// [`AREA_REL_EPS`](super::AREA_REL_EPS)` · |P_10|·|P_20|`: no plane, no normal.
    #[error("triangle has zero area (positions coincident or collinear)")]
    DegenerateTriangle,
    /// The UV triangle is degenerate: `|det A|` of the thesis's eq. 6.14 is at
    /// most [`UV_DET_REL_EPS`](super::UV_DET_REL_EPS)` · |T_10|·|T_20|`, so eq. 6.15 has no usable
    /// inverse. From [`super::TextureAxes::from_axes`]: `U_p`, `V_p` (nearly)
    /// parallel, with `det` their `|U_p × V_p| / (|U_p|·|V_p|)`.
    #[error(
        "degenerate UV triangle: det(T10, T20) = {det:e} is ~0 relative to the UV edge lengths"
    )]
    DegenerateUv {
        /// `det A`, the signed doubled UV area (for [`super::TextureAxes::from_axes`]:
        /// the sine of the angle between `U_p` and `V_p`).
        det: f64,
    },
    /// A normal given to [`super::TextureAxes::from_axes`] is not
    /// perpendicular to the lattice plane `U_p × V_p`: `|cos|` is below
    /// `1 −` [`NORMAL_COS_EPS`].
    #[error("normal is not perpendicular to the lattice plane: |cos| to U x V = {cos} < 1 - {eps:e}", eps = NORMAL_COS_EPS)]
    NormalNotPerpendicular {
        /// `|N̂·(U_p × V_p)| / |U_p × V_p|`.
        cos: f64,
    },
    /// The pigment plane would cut the lenses: it must lie at or below their
    /// bottom, `d ≥ 2r`.
    #[error("pigment depth {depth} is inside the lens (must be >= 2r = {min})")]
    PigmentInsideLens {
        /// The depth asked for.
        depth: f64,
        /// `2r`.
        min: f64,
    },
    /// A ball lens with `n ≤ 1` does not converge light: it has no real focus.
    #[error("a ball lens with n = {0} <= 1 has no real focus")]
    NoFocus(f64),
    /// The lens radius exceeds half the cell height, so neighbouring lenses
    /// would overlap (the slice search and the exact tracer's 3×3
    /// neighbourhood assume they do not).
    #[error("lens radius {radius} exceeds half the cell height {half_cell}: lenses would overlap")]
    LensesOverlap {
        /// The lens radius.
        radius: f64,
        /// Half the smaller height of the lattice cell (a parallelogram).
        half_cell: f64,
    },
}
