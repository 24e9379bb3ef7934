//! The lens lattice of one triangle: lens parameters, lattice cells, lens
//! centres, slice planes and the pigment plane (thesis §6.2, §6.4, §6.6;
//! eq. 6.16–6.25, 6.29).
//!
//! Everything here is shared by the shading path and the exact tracer, so the
//! two differ only in *which* lens they pick.

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::error::CompoundEyeError;
use crate::ray::Ray;
use crate::surface::intersect_sphere;
use super::texture_axes::TextureAxes;

/// Most slice planes the shading path takes (the WGSL loop's bound). Larger
/// slice counts are clamped to it.
pub const MAX_SLICES: u32 = 64;

/// The optics of one facet: lens radius, lens index and pigment-plane depth.
///
/// The thesis ties the pigment plane to the lens (`d = 2r`, eq. 6.29) and
/// gives no index; we keep all three separate because a ball lens focuses at
/// `n·r / (2(n−1))` from its centre (REFERENCE.md), which is `2r` below the
/// polygon only for `n = 2`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LensParams {
    /// Lens (sphere) radius `r`, in world units.
    pub radius: f64,
    /// Refractive index of the lens relative to the outside medium.
    pub index: f64,
    /// Depth `d` of the pigment plane below the polygon, in world units (`≥ 2r`).
    pub pigment_depth: f64,
}

impl LensParams {
    /// Checked parameters: `r > 0`, `n > 0`, `d ≥ 2r`, all finite.
    pub fn new(radius: f64, index: f64, pigment_depth: f64) -> Result<Self, CompoundEyeError> {
        if !(radius.is_finite() && radius > 0.0) {
            return Err(CompoundEyeError::BadRadius(radius));
        }
        if !(index.is_finite() && index > 0.0) {
            return Err(CompoundEyeError::BadIndex(index));
        }
        // A relative tolerance lets `2.0 * r` computed elsewhere pass.
        if !(pigment_depth.is_finite() && pigment_depth >= 2.0 * radius * (1.0 - 1e-12)) {
            return Err(CompoundEyeError::PigmentInsideLens { depth: pigment_depth, min: 2.0 * radius });
        }
        Ok(Self { radius, index, pigment_depth: pigment_depth.max(2.0 * radius) })
    }

    /// The thesis's layout: pigment plane at the lens bottom, `d = 2r` (eq. 6.29).
    pub fn thesis(radius: f64, index: f64) -> Result<Self, CompoundEyeError> {
        Self::new(radius, index, 2.0 * radius)
    }

    /// Pigment plane at the paraxial focus of the ball lens:
    /// `d = r + n·r / (2(n−1))`. Needs `1 < n ≤ 2` (for `n > 2` the focus is
    /// inside the lens: [`CompoundEyeError::PigmentInsideLens`]).
    pub fn focused(radius: f64, index: f64) -> Result<Self, CompoundEyeError> {
        if !(index.is_finite() && index > 1.0) {
            return Err(if index.is_finite() && index > 0.0 {
                CompoundEyeError::NoFocus(index)
            } else {
                CompoundEyeError::BadIndex(index)
            });
        }
        let f = super::ball_lens::ball_focal_length(radius, index);
        Self::new(radius, index, radius + f)
    }
}

/// Thesis eq. 6.17–6.20: the texture coordinate of the centre of the cell that
/// holds `x` — `⌊x⌋ + 0.5` for `x ≥ 0`, `⌈x⌉ − 0.5` for `x < 0` (ties on a
/// cell edge go away from zero, which keeps the rule mirror-symmetric).
#[inline]
pub fn cell_centre_coord(x: f64) -> f64 {
    if x >= 0.0 { x.floor() + 0.5 } else { x.ceil() - 0.5 }
}

/// Eq. 6.17–6.20 on both coordinates.
#[inline]
pub fn cell_centre_uv(uv: DVec2) -> DVec2 {
    DVec2::new(cell_centre_coord(uv.x), cell_centre_coord(uv.y))
}

/// Integer index `[i, j]` of the cell whose centre is `centre_uv` (saturating
/// for coordinates beyond `i64`).
#[inline]
pub fn cell_index(centre_uv: DVec2) -> [i64; 2] {
    [(centre_uv.x - 0.5).round() as i64, (centre_uv.y - 0.5).round() as i64]
}

/// The lens lattice of one triangle: its texture axes and checked lens
/// parameters, with lenses that do not overlap (`r ≤` half the cell height).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lattice {
    axes: TextureAxes,
    lens: LensParams,
}

impl Lattice {
    /// A lattice of `lens` on `axes`. Fails with
    /// [`CompoundEyeError::LensesOverlap`] when `r` exceeds half the smaller
    /// cell height: the slice search and the 3×3 neighbourhood of the exact
    /// tracer both rely on each lens staying inside its own cell's column.
    pub fn new(axes: TextureAxes, lens: LensParams) -> Result<Self, CompoundEyeError> {
        // The fields are public: check them again.
        let lens = LensParams::new(lens.radius, lens.index, lens.pigment_depth)?;
        let (hu, hv) = axes.cell_heights();
        let half_cell = 0.5 * hu.min(hv);
        if !(lens.radius <= half_cell * (1.0 + 1e-12)) {
            return Err(CompoundEyeError::LensesOverlap { radius: lens.radius, half_cell });
        }
        Ok(Self { axes, lens })
    }

    /// The texture axes.
    pub fn axes(&self) -> &TextureAxes {
        &self.axes
    }

    /// The lens parameters.
    pub fn lens(&self) -> &LensParams {
        &self.lens
    }

    /// Eq. 6.21–6.22: the centre `S = P' − r·N` of the lens under the cell
    /// whose centre has texture coordinate `centre_uv`.
    #[inline]
    pub fn lens_centre(&self, centre_uv: DVec2) -> DVec3 {
        let p_prime = self.axes.point_of(centre_uv); // (6.21)
        p_prime - self.lens.radius * self.axes.normal() // (6.22)
    }

    /// Eq. 6.23–6.27: the texture coordinate of a point `p_s` on the slice
    /// plane at depth `h`, by projecting it back onto the polygon
    /// (`P_s' = P_s + h·N`) and solving eq. 6.24 by least squares.
    #[inline]
    pub fn slice_uv(&self, p_s: DVec3, h: f64) -> DVec2 {
        let p_s_prime = p_s + h * self.axes.normal(); // (6.23)
        self.axes.uv_of(p_s_prime) // (6.24)–(6.27)
    }

    /// Eq. 6.29 with depth `d`: the texture coordinate of a pigment-plane point
    /// `p_t` (`P_T' = P_T + d·N`, then eq. 6.26–6.27).
    #[inline]
    pub fn pigment_uv(&self, p_t: DVec3) -> DVec2 {
        self.slice_uv(p_t, self.lens.pigment_depth)
    }

    /// Where the ray from `origin` along unit `dir` meets the pigment plane,
    /// or `None` when it does not go deeper (`−dir·N ≤ 1e-12`): it escapes.
    #[inline]
    pub fn to_pigment_plane(&self, origin: DVec3, dir: DVec3) -> Option<DVec3> {
        let down = -dir.dot(self.axes.normal());
        if !(down > 1e-12) {
            return None;
        }
        let t = (self.lens.pigment_depth - self.axes.depth(origin)) / down;
        let p = origin + t.max(0.0) * dir;
        p.is_finite().then_some(p)
    }

    /// The distance along `view` at which it enters the lens centred at
    /// `centre`, or `None` when it misses it (or only touches it behind its
    /// origin). The origin may lie on the lens's surface (the polygon touches
    /// every lens at its apex), so a root a hair behind it counts as 0.
    #[inline]
    pub fn lens_entry(&self, view: &Ray, centre: DVec3) -> Option<f64> {
        let eps = self.eps();
        let hits = intersect_sphere(view, centre, self.lens.radius)?;
        (hits.t_far > eps && hits.t_near > -eps).then(|| hits.t_near.max(0.0))
    }

    /// A length scale for tolerances: `1e-9 r`.
    #[inline]
    pub(crate) fn eps(&self) -> f64 {
        1e-9 * self.lens.radius
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_lattice(r: f64, n: f64) -> Lattice {
        let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z).unwrap();
        Lattice::new(axes, LensParams::thesis(r, n).unwrap()).unwrap()
    }

    #[test]
    fn cell_centre_rule_is_eq_6_17_to_6_20() {
        // Hand values: inside cells, on edges (ties away from zero), at zero.
        let cases = [
            (0.3, 0.5),
            (0.0, 0.5),
            (-0.0, 0.5),
            (1.0, 1.5),
            (2.7, 2.5),
            (-0.3, -0.5),
            (-1.0, -1.5),
            (-2.7, -2.5),
        ];
        for (x, want) in cases {
            assert_eq!(cell_centre_coord(x), want, "x = {x}");
        }
        // Mirror symmetry of the rule (except at 0, which belongs to the + side).
        for k in 1..200 {
            let x = k as f64 * 0.0137;
            assert_eq!(cell_centre_coord(-x), -cell_centre_coord(x));
        }
        assert_eq!(cell_index(DVec2::new(-0.5, 2.5)), [-1, 2]);
    }

    #[test]
    fn lens_centre_is_under_the_cell_centre() {
        let l = unit_lattice(0.5, 1.5);
        let s = l.lens_centre(DVec2::new(2.5, -0.5));
        assert_eq!(s, DVec3::new(2.5, -0.5, -0.5));
        // A point on the slice plane at depth h projects back to its own (x, y).
        let uv = l.slice_uv(DVec3::new(0.2, 0.7, -0.3), 0.3);
        assert!((uv - DVec2::new(0.2, 0.7)).length() < 1e-15);
        let p = l.to_pigment_plane(DVec3::new(0.0, 0.0, 0.0), DVec3::new(0.6, 0.0, -0.8)).unwrap();
        // d = 1, down = 0.8 → t = 1.25 → x = 0.75.
        assert!((p - DVec3::new(0.75, 0.0, -1.0)).length() < 1e-15);
        assert!(l.to_pigment_plane(DVec3::ZERO, DVec3::X).is_none());
    }

    #[test]
    fn parameters_are_checked() {
        assert_eq!(LensParams::new(0.0, 1.5, 1.0), Err(CompoundEyeError::BadRadius(0.0)));
        assert!(matches!(LensParams::new(0.5, f64::NAN, 1.0), Err(CompoundEyeError::BadIndex(_))));
        assert!(matches!(LensParams::new(0.5, 1.5, 0.9), Err(CompoundEyeError::PigmentInsideLens { .. })));
        assert_eq!(LensParams::focused(0.5, 1.0), Err(CompoundEyeError::NoFocus(1.0)));
        assert!(matches!(LensParams::focused(0.5, 2.5), Err(CompoundEyeError::PigmentInsideLens { .. })));
        // n = 1.5, r = 0.5: f = 0.75 from the centre → d = 1.25 = 2.5 r (REFERENCE.md).
        let f = LensParams::focused(0.5, 1.5).unwrap();
        assert!((f.pigment_depth - 1.25).abs() < 1e-15);
        let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, 0.8 * DVec3::Y, DVec3::Z).unwrap();
        assert!(matches!(
            Lattice::new(axes, LensParams::thesis(0.45, 1.5).unwrap()),
            Err(CompoundEyeError::LensesOverlap { .. })
        ));
        assert!(Lattice::new(axes, LensParams::thesis(0.4, 1.5).unwrap()).is_ok());
    }
}
