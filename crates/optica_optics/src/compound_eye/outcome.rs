//! What a traced view ray returns: a pigment-plane hit or a defined fallback.

use glam::{DVec2, DVec3};

use super::LatticeKind;

/// Where a view ray reached the pigment plane. Every number in a hit returned
/// by this module is finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PigmentHit {
    /// Texture coordinate of the hit (eq. 6.29), in facets.
    pub uv: DVec2,
    /// The hit point on the pigment plane, in mesh units.
    pub point: DVec3,
    /// The first lens the ray went through (cell index), or `None` when it
    /// missed every lens and reached the plane unrefracted (thesis §6.4, last
    /// paragraph).
    pub lens: Option<[i64; 2]>,
    /// How many lenses the ray passed through (0, 1 in the thesis's model,
    /// more when the path follows the ray into neighbouring lenses).
    pub lenses: u32,
    /// The power the lens surfaces let through, the product of
    /// [`super::BallExit::transmittance`] over the lenses passed (1 when no
    /// lens was passed).
    pub transmittance: f64,
}

impl PigmentHit {
    /// The hit's offset from the centre of the first lens's own cell on a
    /// lattice of `kind`, in facets (`None` without a lens). `(0, 0)` is the
    /// ommatidium's rhabdom.
    pub fn offset_from_lens(&self, kind: LatticeKind) -> Option<DVec2> {
        self.lens.map(|index| self.uv - kind.centre_of_index(index))
    }

    /// `true` when the ray went through a lens and landed within
    /// `dark_radius` facets of that ommatidium's centre: the principal
    /// pseudopupil, the dark patch of ommatidia whose axes point at the
    /// viewer (D. G. Stavenga, "Pseudopupils of compound eyes", in *Handbook
    /// of Sensory Physiology* VII/6A, Springer, 1979). (A texture tiled per cell, as in the thesis, also darkens
    /// hits near a *neighbour's* centre: the secondary pseudopupils.)
    pub fn on_own_centre(&self, kind: LatticeKind, dark_radius: f64) -> bool {
        self.offset_from_lens(kind)
            .is_some_and(|o| o.length() < dark_radius)
    }

    /// The texel of the per-facet pigment texture, in `[0, 1)²`: the thesis
    /// tiles one normalised texture over every cell (§6.2).
    pub fn texel(&self) -> DVec2 {
        self.uv - self.uv.floor()
    }
}

/// Why no pigment hit exists. The thesis has no rule for these; the CPU
/// reference treats a fallback as unabsorbed (`c_t = 1` in eq. 6.30), so none
/// of them darkens or NaNs a pixel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ShadeFallback {
    /// The ray does not reach the polygon from the front: parallel to it,
    /// leaving it, or starting below it. (A rasterised fragment never is.)
    PolygonMiss,
    /// A point on the ray's path lies beyond the range of `f64`: the ray
    /// starts, or the lattice lies, ~1e300 from the origin. NaN cannot reach
    /// here (a [`super::Ray`] and the lattice's constructors refuse it); this
    /// is what finite but extreme input gives instead of a NaN.
    Overflow,
    /// Total internal reflection in the lens `lens` (only for `n < 1`, or
    /// round-off at a tangent exit).
    TotalInternalReflection {
        /// The lens's cell.
        lens: [i64; 2],
    },
    /// After the lens `lens` the ray heads back out (upwards or parallel to
    /// the pigment plane), so it never reaches the pigment: the facet shows
    /// what lies in direction `dir` (a renderer looks it up in the
    /// environment).
    Escaped {
        /// The last lens's cell.
        lens: [i64; 2],
        /// The unit direction the ray leaves in.
        dir: DVec3,
    },
    /// The exact tracer's cell walk exceeded its cap (a ray almost parallel
    /// to the surface inside the lens layer). Only the exact tracer (cargo
    /// feature `reference`) returns it; the variant exists in every build so
    /// that a `match` does not depend on features.
    TraversalLimit,
}

/// The result of tracing one view ray into the compound eye.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shade {
    /// The ray reached the pigment plane.
    Pigment(PigmentHit),
    /// It did not; see [`ShadeFallback`].
    Fallback(ShadeFallback),
}

impl Shade {
    /// The pigment hit, if any.
    pub fn hit(&self) -> Option<&PigmentHit> {
        match self {
            Shade::Pigment(h) => Some(h),
            Shade::Fallback(_) => None,
        }
    }

    /// The pigment texture coordinate, if any.
    pub fn uv(&self) -> Option<DVec2> {
        self.hit().map(|h| h.uv)
    }

    /// `true` when every number in the result is finite (always, for results
    /// of this module: what the tests check).
    #[cfg(test)]
    pub(crate) fn is_finite(&self) -> bool {
        self.hit()
            .is_none_or(|h| h.uv.is_finite() && h.point.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Lattice, LensParams, TextureAxes, shade};
    use super::*;
    use crate::ray::Ray;

    /// A ray straight down through a lens centre lands on that lens's own
    /// centre, on either lattice (the hexagonal centres are not at
    /// `index + ½`).
    #[test]
    fn a_ray_down_a_lens_axis_lands_on_its_own_centre() {
        let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z).unwrap();
        for kind in [LatticeKind::Square, LatticeKind::Hexagonal] {
            let r = 0.5 * kind.cell_inradius(DVec3::X, DVec3::Y);
            let lattice =
                Lattice::with_kind(axes, LensParams::thesis(r, 1.5).unwrap(), kind).unwrap();
            let centre = kind.centre_of_index([2, 1]);
            let ray = Ray::new(DVec3::new(centre.x, centre.y, 1.0), -DVec3::Z).unwrap();
            let hit = *shade(&lattice, &ray, 8).hit().expect("reaches the pigment");
            assert_eq!(hit.lens, Some([2, 1]), "{kind:?}");
            assert!(
                hit.offset_from_lens(kind).unwrap().length() < 1e-9,
                "{kind:?}: {hit:?}"
            );
            assert!(hit.on_own_centre(kind, 0.01), "{kind:?}");
        }
    }
}
