//! The one error type of the compound-eye reference.

use thiserror::Error;

/// Why a compound-eye input was rejected.
///
/// Constructors that take user numbers (triangles, lens parameters) return
/// one of these instead of panicking or letting a NaN reach a pixel; the
/// per-ray functions never fail, they return a [`super::ShadeFallback`].
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum CompoundEyeError {
    /// A triangle position or texture coordinate is NaN or infinite.
    #[error("triangle positions or UVs are not finite")]
    NonFinite,
    /// The triangle has (relatively) zero area: no plane, no normal.
    #[error("triangle has zero area (positions coincident or collinear)")]
    DegenerateTriangle,
    /// The UV triangle is degenerate: `det A` of eq. 6.14 is ~0 relative to
    /// `|T_10|·|T_20|`, so eq. 6.15 has no inverse.
    #[error("degenerate UV triangle: det(T10, T20) = {det:e} is ~0 relative to the UV edge lengths")]
    DegenerateUv {
        /// `det A`, the signed doubled UV area.
        det: f64,
    },
    /// A normal given to [`super::TextureAxes::from_axes`] is not
    /// perpendicular to the lattice plane `U_p × V_p`.
    #[error("normal is not perpendicular to the lattice plane: |cos| to U x V = {cos} < 1 - 1e-9")]
    NormalNotPerpendicular {
        /// `|N̂·(U_p × V_p)| / |U_p × V_p|` (NaN never reaches here).
        cos: f64,
    },
    /// A facet size (the side of one lattice cell) is not finite and positive.
    #[error("facet size {0} is not finite and positive")]
    BadFacet(f64),
    /// The lens radius is not finite and positive.
    #[error("lens radius {0} is not finite and positive")]
    BadRadius(f64),
    /// The refractive index of the lens (relative to the outside) is not finite and positive.
    #[error("refractive index {0} is not finite and positive")]
    BadIndex(f64),
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
    /// would overlap (the slice search and the 3×3 test assume they do not).
    #[error("lens radius {radius} exceeds half the cell height {half_cell}: lenses would overlap")]
    LensesOverlap {
        /// The lens radius.
        radius: f64,
        /// Half the smaller height of the lattice cell (a parallelogram).
        half_cell: f64,
    },
}
