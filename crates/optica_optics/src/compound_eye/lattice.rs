//! The lens lattice of one triangle: lens parameters, lattice cells, lens
//! centres, slice planes and the pigment plane (thesis §6.2, §6.4, §6.6;
//! eq. 6.16–6.25, 6.29).
//!
//! Everything here is shared by the shading path and the exact tracer, so the
//! two differ only in *which* lens they pick.

use glam::{DVec2, DVec3};
use serde::Serialize;

use super::ball_lens::ball_focal_length;
use super::error::CompoundEyeError;
use super::lattice_kind::{LatticeKind, LensCell};
use super::texture_axes::TextureAxes;
use crate::input;
use crate::ray::Ray;
use crate::surface::intersect_sphere;

/// Most slice planes the shading path takes: the bound of the WGSL loop,
/// which must be a constant. Larger slice counts are clamped to it. The
/// wrong-lens fraction against the exact tracer reaches its floor from
/// `K = 32` on (see [`super::shade`]); 64 is twice that.
pub const MAX_SLICES: u32 = 64;

/// Relative slack of the `d ≥ 2r` and `r ≤ ½·cell height` checks, so that a
/// bound computed elsewhere in `f64` (`2.0 * r`, a cell height from the
/// same axes) passes: about 4500 ulps, far below any visible difference.
const BOUND_REL_TOL: f64 = 1e-12;

/// Length tolerance of the lattice, relative to the lens radius: a point this
/// close to a lens's surface or the polygon is on it. The round-off of an
/// `f64` sphere intersection is ~1e-15 relative; `1e-9` leaves six orders of
/// margin and is still far below a visible distance (a picometre on a
/// millimetre lens).
const LENGTH_REL_EPS: f64 = 1e-9;

/// Rays closer than this to parallel with the polygon (`−dir·N`, the cosine
/// of the angle to the inward normal) do not go deeper: they miss the
/// polygon ([`super::ShadeFallback::PolygonMiss`]) or, after a lens, never
/// reach the pigment plane ([`super::ShadeFallback::Escaped`]). At `1e-12`
/// the distance to the pigment plane, `d / cos`, is still finite for any
/// `d` below ~1e296; the WGSL twin uses the `f32` equivalent.
pub const MIN_COS: f64 = 1e-12;

/// The optics of one facet: lens radius, lens index and pigment-plane depth.
///
/// The thesis ties the pigment plane to the lens (`d = 2r`, eq. 6.29) and
/// gives no index; we keep all three separate because a ball lens focuses at
/// `n·r / (2(n−1))` from its centre ([`ball_focal_length`]), which is `2r`
/// below the polygon only for `n = 2`.
///
/// The fields are private and checked once, by the constructors: `r > 0`,
/// `n > 0`, `d ≥ 2r`, all finite.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LensParams {
    radius: f64,
    index: f64,
    pigment_depth: f64,
}

impl LensParams {
    /// Checked parameters: lens radius `r > 0` and pigment-plane depth
    /// `d ≥ 2r` below the polygon, in mesh units, and the lens's refractive
    /// index `n > 0` relative to the outside medium, all finite.
    ///
    /// Errors: [`CompoundEyeError::Input`] for a radius or index that is not
    /// finite and positive or a depth that is not finite,
    /// [`CompoundEyeError::PigmentInsideLens`] for `d < 2r`.
    pub fn new(radius: f64, index: f64, pigment_depth: f64) -> Result<Self, CompoundEyeError> {
        let radius = input::positive("lens radius r (mesh units)", radius)?;
        let index = input::positive("lens refractive index n", index)?;
        let pigment_depth = input::finite("pigment-plane depth d (mesh units)", pigment_depth)?;
        if !(pigment_depth >= 2.0 * radius * (1.0 - BOUND_REL_TOL)) {
            return Err(CompoundEyeError::PigmentInsideLens {
                depth: pigment_depth,
                min: 2.0 * radius,
            });
        }
        Ok(Self {
            radius,
            index,
            pigment_depth: pigment_depth.max(2.0 * radius),
        })
    }

    /// The thesis's layout: pigment plane at the lens bottom, `d = 2r` (eq. 6.29).
    pub fn thesis(radius: f64, index: f64) -> Result<Self, CompoundEyeError> {
        Self::new(radius, index, 2.0 * radius)
    }

    /// Pigment plane at the paraxial focus of the ball lens:
    /// `d = r + n·r / (2(n−1))` ([`ball_focal_length`] from the lens centre,
    /// which is `r` below the polygon). Needs `1 < n ≤ 2`: for `n ≤ 1` there
    /// is no real focus ([`CompoundEyeError::NoFocus`]), for `n > 2` it is
    /// inside the lens ([`CompoundEyeError::PigmentInsideLens`]).
    pub fn focused(radius: f64, index: f64) -> Result<Self, CompoundEyeError> {
        let radius = input::positive("lens radius r (mesh units)", radius)?;
        let index = input::positive("lens refractive index n", index)?;
        if !(index > 1.0) {
            return Err(CompoundEyeError::NoFocus(index));
        }
        Self::new(radius, index, radius + ball_focal_length(radius, index))
    }

    /// Lens (sphere) radius `r`, in mesh units.
    #[inline]
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// Refractive index `n` of the lens relative to the outside medium.
    #[inline]
    pub fn index(&self) -> f64 {
        self.index
    }

    /// Depth `d` of the pigment plane below the polygon, in mesh units (`≥ 2r`).
    #[inline]
    pub fn pigment_depth(&self) -> f64 {
        self.pigment_depth
    }
}

/// The lens lattice of one triangle: its texture axes, the arrangement of
/// its lenses and checked lens parameters, with lenses that do not overlap
/// (`r ≤` the cell's inradius).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lattice {
    axes: TextureAxes,
    lens: LensParams,
    kind: LatticeKind,
}

impl Lattice {
    /// The thesis's square lattice of `lens` on `axes`. See [`Lattice::with_kind`].
    pub fn new(axes: TextureAxes, lens: LensParams) -> Result<Self, CompoundEyeError> {
        Self::with_kind(axes, lens, LatticeKind::Square)
    }

    /// A lattice of `kind` of `lens` on `axes`. Fails with
    /// [`CompoundEyeError::LensesOverlap`] when `r` exceeds the cell's
    /// inradius ([`LatticeKind::cell_inradius`]; half the smaller cell height
    /// of the square lattice): the slice search and the exact tracer both
    /// rely on each lens staying inside its own cell's column.
    pub fn with_kind(
        axes: TextureAxes,
        lens: LensParams,
        kind: LatticeKind,
    ) -> Result<Self, CompoundEyeError> {
        let half_cell = kind.cell_inradius(axes.u(), axes.v());
        if !(lens.radius <= half_cell * (1.0 + BOUND_REL_TOL)) {
            return Err(CompoundEyeError::LensesOverlap {
                radius: lens.radius,
                half_cell,
            });
        }
        Ok(Self { axes, lens, kind })
    }

    /// The arrangement of the lenses.
    pub fn kind(&self) -> LatticeKind {
        self.kind
    }

    /// The lens whose cell holds the texture coordinate `uv` (eq. 6.17–6.20
    /// for the square lattice; [`LatticeKind::cell_of`]).
    #[inline]
    pub fn cell_of(&self, uv: DVec2) -> LensCell {
        self.kind.cell_of(uv)
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

    /// Where `ray` meets the pigment plane (step 4 of the shading path, before
    /// eq. 6.29), or why it does not.
    ///
    /// A ray that starts below the plane meets it at its origin's projection
    /// (`t` is clamped to 0), so a lens that reaches the plane (`d = 2r`)
    /// still gives a hit.
    #[inline]
    pub fn to_pigment_plane(&self, ray: &Ray) -> PigmentPlaneHit {
        let down = -ray.dir().dot(self.axes.normal());
        if !(down > MIN_COS) {
            return PigmentPlaneHit::Escapes;
        }
        let t = (self.lens.pigment_depth - self.axes.depth(ray.origin())) / down;
        let p = ray.at(t.max(0.0));
        if p.is_finite() {
            PigmentPlaneHit::At(p)
        } else {
            PigmentPlaneHit::Overflow
        }
    }

    /// The distance along `view` at which it enters the lens centred at
    /// `centre`, or `None` when it misses it (or only touches it behind its
    /// origin). The origin may lie on the lens's surface (the polygon touches
    /// every lens at its apex), so a root behind it by less than the lattice's
    /// length tolerance (`1e-9 r`, round-off of the intersection) counts as 0.
    #[inline]
    pub fn lens_entry(&self, view: &Ray, centre: DVec3) -> Option<f64> {
        let eps = self.eps();
        let hits = intersect_sphere(view, centre, self.lens.radius)?;
        (hits.t_far > eps && hits.t_near > -eps).then(|| hits.t_near.max(0.0))
    }

    /// The lattice's length tolerance, [`LENGTH_REL_EPS`]` · r`.
    #[inline]
    pub(crate) fn eps(&self) -> f64 {
        LENGTH_REL_EPS * self.lens.radius
    }
}

/// Where a ray meets the pigment plane: [`Lattice::to_pigment_plane`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PigmentPlaneHit {
    /// The hit point, finite.
    At(DVec3),
    /// The ray does not go deeper (`−dir·N ≤` [`MIN_COS`]): it never reaches
    /// the plane.
    Escapes,
    /// The hit lies beyond the range of `f64` (the ray or the lattice is
    /// ~1e300 from the origin, or the ray is nearly parallel to a plane far
    /// away).
    Overflow,
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::{Expected, InvalidInput};

    fn unit_lattice(r: f64, n: f64) -> Lattice {
        let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z).unwrap();
        Lattice::new(axes, LensParams::thesis(r, n).unwrap()).unwrap()
    }

    #[test]
    fn lens_centre_is_under_the_cell_centre() {
        let l = unit_lattice(0.5, 1.5);
        let s = l.lens_centre(DVec2::new(2.5, -0.5));
        assert_eq!(s, DVec3::new(2.5, -0.5, -0.5));
        // A point on the slice plane at depth h projects back to its own (x, y).
        let uv = l.slice_uv(DVec3::new(0.2, 0.7, -0.3), 0.3);
        assert!((uv - DVec2::new(0.2, 0.7)).length() < 1e-15);
        let down = Ray::new(DVec3::ZERO, DVec3::new(0.6, 0.0, -0.8)).unwrap();
        // d = 1, down = 0.8 → t = 1.25 → x = 0.75.
        match l.to_pigment_plane(&down) {
            PigmentPlaneHit::At(p) => assert!((p - DVec3::new(0.75, 0.0, -1.0)).length() < 1e-15),
            other => panic!("{other:?}"),
        }
        // Below the plane already: its projection.
        let deep = Ray::new(DVec3::new(0.2, 0.3, -1.5), DVec3::new(0.6, 0.0, -0.8)).unwrap();
        assert_eq!(
            l.to_pigment_plane(&deep),
            PigmentPlaneHit::At(DVec3::new(0.2, 0.3, -1.5))
        );
        let level = Ray::new(DVec3::ZERO, DVec3::X).unwrap();
        assert_eq!(l.to_pigment_plane(&level), PigmentPlaneHit::Escapes);
        let up = Ray::new(DVec3::new(0.0, 0.0, -0.5), DVec3::new(0.0, 0.1, 1.0)).unwrap();
        assert_eq!(l.to_pigment_plane(&up), PigmentPlaneHit::Escapes);
        // Finite but extreme: 1.5e308 up, at 45°, overflows.
        let far = Ray::new(DVec3::new(0.0, 0.0, 1.5e308), DVec3::new(1.0, 0.0, -1.0)).unwrap();
        assert_eq!(l.to_pigment_plane(&far), PigmentPlaneHit::Overflow);
    }

    /// The `InvalidInput` inside a `CompoundEyeError::Input`, or a panic.
    fn input_error<T: std::fmt::Debug>(r: Result<T, CompoundEyeError>) -> InvalidInput {
        match r {
            Err(CompoundEyeError::Input(e)) => e,
            other => panic!("expected an input error, got {other:?}"),
        }
    }

    #[test]
    fn parameters_are_checked() {
        let e = input_error(LensParams::new(0.0, 1.5, 1.0));
        assert_eq!(
            (e.what, e.value, e.expected),
            ("lens radius r (mesh units)", 0.0, Expected::Positive)
        );
        let e = input_error(LensParams::new(0.5, f64::NAN, 1.0));
        assert_eq!(
            (e.what, e.expected),
            ("lens refractive index n", Expected::Positive)
        );
        let e = input_error(LensParams::new(0.5, 1.5, f64::INFINITY));
        assert_eq!(
            (e.what, e.expected),
            ("pigment-plane depth d (mesh units)", Expected::Finite)
        );
        assert_eq!(
            LensParams::new(0.5, 1.5, 0.9),
            Err(CompoundEyeError::PigmentInsideLens {
                depth: 0.9,
                min: 1.0
            })
        );
        assert_eq!(
            LensParams::focused(0.5, 1.0),
            Err(CompoundEyeError::NoFocus(1.0))
        );
        assert_eq!(
            input_error(LensParams::focused(0.5, -1.0)).what,
            "lens refractive index n"
        );
        assert_eq!(
            input_error(LensParams::focused(f64::NAN, 1.5)).what,
            "lens radius r (mesh units)"
        );
        assert!(matches!(
            LensParams::focused(0.5, 2.5),
            Err(CompoundEyeError::PigmentInsideLens { .. })
        ));
        // n = 1.5, r = 0.5: f = n r / (2(n − 1)) = 0.75 from the centre → d = 1.25 = 2.5 r.
        let f = LensParams::focused(0.5, 1.5).unwrap();
        assert!((f.pigment_depth() - 1.25).abs() < 1e-15);
        assert_eq!((f.radius(), f.index()), (0.5, 1.5));
        // A depth a few ulps short of 2r is taken as 2r.
        let t = LensParams::new(0.5, 1.5, 1.0 - 1e-15).unwrap();
        assert_eq!(t.pigment_depth(), 1.0);
        let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, 0.8 * DVec3::Y, DVec3::Z).unwrap();
        assert!(matches!(
            Lattice::new(axes, LensParams::thesis(0.45, 1.5).unwrap()),
            Err(CompoundEyeError::LensesOverlap { .. })
        ));
        assert!(Lattice::new(axes, LensParams::thesis(0.4, 1.5).unwrap()).is_ok());
    }
}
