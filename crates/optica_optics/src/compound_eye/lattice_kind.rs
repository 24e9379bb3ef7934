//! How lenses are laid out in texture space: the thesis's square lattice, or
//! the hexagonal lattice of real compound eyes.
//!
//! Texture coordinates are in facets (eq. 6.1). A square lattice has a lens
//! centre at every `(i + ½, j + ½)` (eq. 6.17–6.20). A hexagonal lattice has
//! its centres at `i·e₁ + j·e₂` with `e₁ = (1, 0)` and `e₂ = (½, √3/2)`: the
//! same pitch (one facet) along `u`, rows `√3/2` facets apart, each lens with
//! six neighbours at one facet — the packing of insect ommatidia
//! (M. F. Land and D.-E. Nilsson, *Animal Eyes*, 2nd ed., Oxford University
//! Press 2012, ch. 7).
//!
//! Both are used through *lattice coordinates* `w`, a linear map of the
//! texture coordinate in which the centres sit on the integer points (square:
//! `w = uv − ½`; hexagonal: the axial coordinates `w = (u − v/√3, 2v/√3)`).
//! The exact tracer walks unit cells of `w`; the shading path only needs the
//! nearest centre.

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

/// `√3/2`: the row spacing of the hexagonal lattice, in facets.
const ROW: f64 = 0.866_025_403_784_438_6;

/// The arrangement of lenses in texture space.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
pub enum LatticeKind {
    /// One lens per unit cell, centres at `(i + ½, j + ½)` facets: the
    /// thesis's layout (§6.2, Fig. 6.4).
    #[default]
    Square,
    /// Hexagonal close packing with a pitch of one facet along `u`, like real
    /// ommatidia.
    Hexagonal,
}

/// A lens of the lattice: its integer index and the texture coordinate of
/// its centre on the polygon.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LensCell {
    /// Integer lattice index: `[i, j]` of the square cell, or the axial
    /// coordinates of the hexagonal one.
    pub index: [i64; 2],
    /// Texture coordinate (facets) of the lens's centre as seen along the
    /// polygon normal (`P'` of eq. 6.21).
    pub centre_uv: DVec2,
}

/// The offsets (in lattice coordinates) of the lenses whose columns can hold
/// a point of the lattice cell `[k, k + 1)²`: the cell's four corners, for
/// both kinds. A lens of at most the cell inradius lies inside its own cell
/// (the unit square around it, or its hexagon), and the lattice cell is
/// covered by its corners' cells: the square one by four quarters of them,
/// the hexagonal parallelogram by two equilateral triangles whose every point
/// is nearest to one of their corners. Every other lens keeps half a facet
/// away (square) or 0.37 of one (hexagonal) on undistorted axes, far beyond
/// the walk's round-off.
pub(crate) const WALK_CORNERS: [[i64; 2]; 4] = [[0, 0], [1, 0], [0, 1], [1, 1]];

impl LatticeKind {
    /// The lens whose cell holds `uv` (facets): for the square lattice the
    /// thesis's rule (eq. 6.17–6.20: `⌊x⌋ + ½` for `x ≥ 0`, `⌈x⌉ − ½` for
    /// `x < 0`, so ties on a cell edge go away from zero and the rule is
    /// mirror-symmetric); for the hexagonal lattice the nearest centre
    /// (cube-coordinate rounding).
    pub fn cell_of(self, uv: DVec2) -> LensCell {
        match self {
            LatticeKind::Square => {
                let c = DVec2::new(square_centre_coord(uv.x), square_centre_coord(uv.y));
                LensCell {
                    index: [(c.x - 0.5).round() as i64, (c.y - 0.5).round() as i64],
                    centre_uv: c,
                }
            }
            LatticeKind::Hexagonal => {
                let w = self.to_lattice(uv);
                let index = hex_round(w);
                LensCell {
                    index,
                    centre_uv: self.centre_of_index(index),
                }
            }
        }
    }

    /// The texture coordinate of the centre of lens `index`.
    pub fn centre_of_index(self, index: [i64; 2]) -> DVec2 {
        self.from_lattice(DVec2::new(index[0] as f64, index[1] as f64))
    }

    /// Lattice coordinates of a texture coordinate (centres on integers).
    pub fn to_lattice(self, uv: DVec2) -> DVec2 {
        match self {
            LatticeKind::Square => uv - DVec2::splat(0.5),
            LatticeKind::Hexagonal => {
                let j = uv.y / ROW;
                DVec2::new(uv.x - 0.5 * j, j)
            }
        }
    }

    /// Texture coordinate of a point in lattice coordinates.
    pub fn from_lattice(self, w: DVec2) -> DVec2 {
        match self {
            LatticeKind::Square => w + DVec2::splat(0.5),
            LatticeKind::Hexagonal => DVec2::new(w.x + 0.5 * w.y, ROW * w.y),
        }
    }

    /// How fast the lattice coordinate changes with the texture coordinate
    /// along a direction whose texture rate is `duv` (the map is linear).
    pub fn lattice_rate(self, duv: DVec2) -> DVec2 {
        match self {
            LatticeKind::Square => duv,
            LatticeKind::Hexagonal => {
                let dj = duv.y / ROW;
                DVec2::new(duv.x - 0.5 * dj, dj)
            }
        }
    }

    /// The radius of the largest circle inside one lens's cell, in world
    /// units, for texture axes `u`, `v` (world vectors of one facet along
    /// each texture axis): a lens of at most this radius stays inside its own
    /// cell's column, which the slice search and the exact tracer rely on.
    /// For the square lattice it is half the smaller cell height; for the
    /// hexagonal one, half the smallest distance between opposite edges of
    /// the (affinely mapped) hexagon.
    pub fn cell_inradius(self, u: DVec3, v: DVec3) -> f64 {
        // Half the distance between the cell's opposite edge pairs: an edge
        // is the perpendicular bisector (in texture space) of the vector to
        // a neighbour `n`, mapped to world space; its distance from the centre
        // in world space is |½n_w · m| with m the unit normal of the mapped edge.
        let neighbours: &[DVec2] = match self {
            LatticeKind::Square => &[DVec2::X, DVec2::Y],
            LatticeKind::Hexagonal => &[
                DVec2::new(1.0, 0.0),
                DVec2::new(0.5, ROW),
                DVec2::new(-0.5, ROW),
            ],
        };
        let normal = u.cross(v);
        let to_world = |t: DVec2| t.x * u + t.y * v;
        neighbours
            .iter()
            .map(|n| {
                let edge = to_world(n.perp()); // the bisector's direction
                let m = normal.cross(edge).normalize_or_zero(); // in the plane, ⟂ the edge
                (0.5 * to_world(*n).dot(m)).abs()
            })
            .fold(f64::INFINITY, f64::min)
    }
}

/// The thesis's rule for one coordinate (eq. 6.17–6.20).
#[inline]
fn square_centre_coord(x: f64) -> f64 {
    if x >= 0.0 {
        x.floor() + 0.5
    } else {
        x.ceil() - 0.5
    }
}

/// Nearest hexagon in axial coordinates, by rounding the cube coordinates
/// `(q, −q−r, r)` and fixing the one that moved most (the standard method,
/// e.g. A. Patel, "Hexagonal Grids", Red Blob Games, 2013).
fn hex_round(w: DVec2) -> [i64; 2] {
    let (q, r) = (w.x, w.y);
    let s = -q - r;
    let (mut rq, mut rr, rs) = (q.round(), r.round(), s.round());
    let (dq, dr, ds) = ((rq - q).abs(), (rr - r).abs(), (rs - s).abs());
    if dq > dr && dq > ds {
        rq = -rr - rs;
    } else if dr > ds {
        rr = -rq - rs;
    }
    [rq as i64, rr as i64]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn square_cells_follow_the_thesis() {
        let k = LatticeKind::Square;
        for (x, want) in [
            (0.3, 0.5),
            (0.0, 0.5),
            (1.0, 1.5),
            (2.7, 2.5),
            (-0.3, -0.5),
            (-1.0, -1.5),
        ] {
            assert_eq!(
                k.cell_of(DVec2::new(x, x)).centre_uv,
                DVec2::splat(want),
                "x = {x}"
            );
        }
        assert_eq!(k.cell_of(DVec2::new(-0.5, 2.5)).index, [-1, 2]);
        let c = k.cell_of(DVec2::new(3.2, -1.7));
        assert_eq!(k.centre_of_index(c.index), c.centre_uv);
    }

    #[test]
    fn hex_cells_are_the_nearest_centre() {
        let k = LatticeKind::Hexagonal;
        // Brute force over a patch: the chosen centre is the nearest one.
        for a in 0..60 {
            for b in 0..60 {
                let uv = DVec2::new(-3.0 + a as f64 * 0.1037, -3.0 + b as f64 * 0.0991);
                let cell = k.cell_of(uv);
                let best = (-6..=6)
                    .flat_map(|i| (-6..=6).map(move |j| [i, j]))
                    .map(|ij| (k.centre_of_index(ij) - uv).length())
                    .fold(f64::INFINITY, f64::min);
                assert!(
                    (cell.centre_uv - uv).length() <= best + 1e-12,
                    "{uv}: {cell:?}"
                );
            }
        }
        // Neighbours one facet apart, in six directions.
        let c = k.centre_of_index([0, 0]);
        for ij in [[1, 0], [0, 1], [-1, 1], [-1, 0], [0, -1], [1, -1]] {
            assert!(
                ((k.centre_of_index(ij) - c).length() - 1.0).abs() < 1e-12,
                "{ij:?}"
            );
        }
        let w = DVec2::new(2.3, -1.4);
        assert!((k.to_lattice(k.from_lattice(w)) - w).length() < 1e-12);
        let d = DVec2::new(0.3, 0.8);
        assert!(
            (k.lattice_rate(d) - (k.to_lattice(d) - k.to_lattice(DVec2::ZERO))).length() < 1e-12
        );
    }

    #[test]
    fn inradius_is_half_the_pitch_on_unit_axes() {
        assert!((LatticeKind::Square.cell_inradius(DVec3::X, DVec3::Y) - 0.5).abs() < 1e-12);
        assert!((LatticeKind::Hexagonal.cell_inradius(DVec3::X, DVec3::Y) - 0.5).abs() < 1e-12);
        // Stretched along v: the square cell's narrow side decides.
        assert!((LatticeKind::Square.cell_inradius(DVec3::X, 0.6 * DVec3::Y) - 0.3).abs() < 1e-12);
        // A sheared square cell: half the height, not half the side.
        let h = LatticeKind::Square.cell_inradius(DVec3::X, DVec3::new(0.6, 0.8, 0.0));
        assert!((h - 0.4).abs() < 1e-12, "{h}");
    }
}
