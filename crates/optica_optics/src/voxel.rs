//! Regular voxel grids and Amanatides–Woo ray traversal.
//!
//! A [`VoxelGrid`] is an axis-aligned box split into `dims[0] × dims[1] × dims[2]`
//! equal cells, stored x-fastest in a `Vec<T>`. Cells are half-open,
//! `[lo, lo + size)` on each axis, so every point of the box except its max
//! faces belongs to exactly one cell ([`VoxelGrid::cell_of`]).
//!
//! [`GridTraversal`] walks the cells a ray (or a segment of it) crosses, in
//! order, with the ray parameters where it enters and leaves each
//! (Amanatides & Woo, "A Fast Voxel Traversal Algorithm for Ray Tracing",
//! Eurographics 1987). It is the lookup path of precomputed voxel fields
//! (spectacles) and of any grid-accelerated tracing.

use std::iter::FusedIterator;
use std::ops::{Add, Mul};

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::input::{self, InvalidInput};
use crate::ray::Ray;

/// Why a voxel grid could not be built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum VoxelError {
    /// An origin that is not finite, or a cell size that is not finite and
    /// positive on every axis.
    #[error(transparent)]
    Input(#[from] InvalidInput),
    /// A zero dimension, or a cell count that overflows `usize`.
    #[error("grid dimensions {0:?} are zero or too large")]
    BadDims([usize; 3]),
    /// The storage length does not match the dimensions.
    #[error("grid of dimensions {dims:?} needs {expected} cells, got {got}")]
    WrongLength {
        /// The dimensions.
        dims: [usize; 3],
        /// Their product.
        expected: usize,
        /// The length given.
        got: usize,
    },
}

/// A regular grid of cells holding one `T` each.
///
/// Deserialisation goes through [`VoxelGrid::from_vec`], so a grid read from
/// disk has the same invariants as a built one (finite origin, positive cell
/// size, non-zero dims, `cells.len()` = their product); a bad one is a
/// [`VoxelError`] (as the deserialiser's error), never a later panic.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawVoxelGrid<T>")]
pub struct VoxelGrid<T> {
    origin: DVec3,
    cell_size: DVec3,
    dims: [usize; 3],
    cells: Vec<T>,
}

/// The serialised form of a [`VoxelGrid`], unchecked; only used to route
/// deserialisation through [`VoxelGrid::from_vec`].
#[derive(Deserialize)]
struct RawVoxelGrid<T> {
    origin: DVec3,
    cell_size: DVec3,
    dims: [usize; 3],
    cells: Vec<T>,
}

impl<T> TryFrom<RawVoxelGrid<T>> for VoxelGrid<T> {
    type Error = VoxelError;

    fn try_from(r: RawVoxelGrid<T>) -> Result<Self, VoxelError> {
        Self::from_vec(r.origin, r.cell_size, r.dims, r.cells)
    }
}

fn check_geometry(origin: DVec3, cell_size: DVec3, dims: [usize; 3]) -> Result<usize, VoxelError> {
    input::finite_vec3("voxel grid origin", origin)?;
    for c in cell_size.to_array() {
        input::positive("voxel cell size", c)?;
    }
    dims.iter()
        .try_fold(
            1usize,
            |acc, &n| if n == 0 { None } else { acc.checked_mul(n) },
        )
        .ok_or(VoxelError::BadDims(dims))
}

impl<T> VoxelGrid<T> {
    /// A grid with min corner `origin`, cells of `cell_size`, `dims` cells per
    /// axis, every cell built by `f(cell)`.
    pub fn from_fn(
        origin: DVec3,
        cell_size: DVec3,
        dims: [usize; 3],
        mut f: impl FnMut([usize; 3]) -> T,
    ) -> Result<Self, VoxelError> {
        let n = check_geometry(origin, cell_size, dims)?;
        let cells = (0..n).map(|i| f(unflatten(i, dims))).collect();
        Ok(Self {
            origin,
            cell_size,
            dims,
            cells,
        })
    }

    /// [`VoxelGrid::from_fn`] evaluated in parallel (rayon), for expensive
    /// per-cell precomputation.
    pub fn from_fn_par(
        origin: DVec3,
        cell_size: DVec3,
        dims: [usize; 3],
        f: impl Fn([usize; 3]) -> T + Sync,
    ) -> Result<Self, VoxelError>
    where
        T: Send,
    {
        let n = check_geometry(origin, cell_size, dims)?;
        let cells = (0..n)
            .into_par_iter()
            .map(|i| f(unflatten(i, dims)))
            .collect();
        Ok(Self {
            origin,
            cell_size,
            dims,
            cells,
        })
    }

    /// A grid over existing storage (x fastest, then y, then z).
    pub fn from_vec(
        origin: DVec3,
        cell_size: DVec3,
        dims: [usize; 3],
        cells: Vec<T>,
    ) -> Result<Self, VoxelError> {
        let n = check_geometry(origin, cell_size, dims)?;
        if cells.len() != n {
            return Err(VoxelError::WrongLength {
                dims,
                expected: n,
                got: cells.len(),
            });
        }
        Ok(Self {
            origin,
            cell_size,
            dims,
            cells,
        })
    }

    /// Min corner of the grid.
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// Size of one cell.
    pub fn cell_size(&self) -> DVec3 {
        self.cell_size
    }

    /// Cells per axis.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// All cells, x fastest.
    pub fn cells(&self) -> &[T] {
        &self.cells
    }

    /// All cells, mutable, x fastest.
    pub fn cells_mut(&mut self) -> &mut [T] {
        &mut self.cells
    }

    /// The storage, consuming the grid.
    pub fn into_cells(self) -> Vec<T> {
        self.cells
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Always false (a valid grid has at least one cell); for clippy's sake.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// `(min, max)` corners of the grid box.
    pub fn bounds(&self) -> (DVec3, DVec3) {
        (self.origin, self.max_corner())
    }

    fn max_corner(&self) -> DVec3 {
        self.origin + self.cell_size * dims_vec(self.dims)
    }

    /// Linear storage index of `cell`, or `None` outside the grid.
    pub fn index(&self, cell: [usize; 3]) -> Option<usize> {
        let [nx, ny, nz] = self.dims;
        let [x, y, z] = cell;
        (x < nx && y < ny && z < nz).then(|| x + nx * (y + ny * z))
    }

    /// The cell of a linear storage index, or `None` when out of range.
    pub fn cell_at_index(&self, i: usize) -> Option<[usize; 3]> {
        (i < self.cells.len()).then(|| unflatten(i, self.dims))
    }

    /// The value of `cell`, or `None` outside the grid.
    pub fn get(&self, cell: [usize; 3]) -> Option<&T> {
        self.index(cell).map(|i| &self.cells[i])
    }

    /// The value of `cell`, mutable, or `None` outside the grid.
    pub fn get_mut(&mut self, cell: [usize; 3]) -> Option<&mut T> {
        self.index(cell).map(|i| &mut self.cells[i])
    }

    /// The cell containing `point` (half-open cells), or `None` outside the
    /// box, on its max faces, or for a non-finite point.
    pub fn cell_of(&self, point: DVec3) -> Option<[usize; 3]> {
        let u = (point - self.origin) / self.cell_size;
        let mut cell = [0usize; 3];
        for a in 0..3 {
            let f = u[a].floor();
            // NaN fails both comparisons.
            if !(f >= 0.0 && f < self.dims[a] as f64) {
                return None;
            }
            cell[a] = f as usize;
        }
        Some(cell)
    }

    /// `(min, max)` corners of `cell` (not checked against the dims).
    pub fn cell_bounds(&self, cell: [usize; 3]) -> (DVec3, DVec3) {
        let lo = self.origin + self.cell_size * cell_vec(cell);
        (lo, lo + self.cell_size)
    }

    /// Centre of `cell` (not checked against the dims).
    pub fn cell_center(&self, cell: [usize; 3]) -> DVec3 {
        self.origin + self.cell_size * (cell_vec(cell) + 0.5)
    }

    /// The cells `ray` crosses for `t >= 0`.
    pub fn traverse(&self, ray: &Ray) -> GridTraversal {
        self.traverse_segment(ray, 0.0, f64::INFINITY)
    }

    /// The cells `ray` crosses for `t` in `[t_min, t_max]`.
    pub fn traverse_segment(&self, ray: &Ray, t_min: f64, t_max: f64) -> GridTraversal {
        GridTraversal::new(self.origin, self.cell_size, self.dims, ray, t_min, t_max)
    }

    /// Trilinear interpolation between cell centres; outside the centre
    /// lattice the nearest centres are used (clamp), so any finite point has
    /// a value. `None` for a non-finite point.
    pub fn trilinear(&self, point: DVec3) -> Option<T>
    where
        T: Copy + Add<Output = T> + Mul<f64, Output = T>,
    {
        // (A grid has at least one cell on every axis; the emptiness check
        // keeps this total even so.)
        if !point.is_finite() || self.cells.is_empty() {
            return None;
        }
        let u = (point - self.origin) / self.cell_size - 0.5;
        let mut i0 = [0usize; 3];
        let mut i1 = [0usize; 3];
        let mut w = [0.0f64; 3];
        for a in 0..3 {
            // One cell on an axis: max = 0, both corners are cell 0, weight 0.
            let last = self.dims[a].saturating_sub(1);
            let max = last as f64;
            let x = u[a].clamp(0.0, max);
            let f = x.floor().min((max - 1.0).max(0.0));
            i0[a] = f as usize;
            i1[a] = (i0[a] + 1).min(last);
            w[a] = x - f;
        }
        let v =
            |x: usize, y: usize, z: usize| self.cells[x + self.dims[0] * (y + self.dims[1] * z)];
        let lerp = |a: T, b: T, t: f64| a * (1.0 - t) + b * t;
        let c00 = lerp(v(i0[0], i0[1], i0[2]), v(i1[0], i0[1], i0[2]), w[0]);
        let c10 = lerp(v(i0[0], i1[1], i0[2]), v(i1[0], i1[1], i0[2]), w[0]);
        let c01 = lerp(v(i0[0], i0[1], i1[2]), v(i1[0], i0[1], i1[2]), w[0]);
        let c11 = lerp(v(i0[0], i1[1], i1[2]), v(i1[0], i1[1], i1[2]), w[0]);
        Some(lerp(lerp(c00, c10, w[1]), lerp(c01, c11, w[1]), w[2]))
    }
}

impl<T: Clone> VoxelGrid<T> {
    /// A grid with every cell set to `fill`.
    pub fn new(
        origin: DVec3,
        cell_size: DVec3,
        dims: [usize; 3],
        fill: T,
    ) -> Result<Self, VoxelError> {
        let n = check_geometry(origin, cell_size, dims)?;
        Ok(Self {
            origin,
            cell_size,
            dims,
            cells: vec![fill; n],
        })
    }

    /// A grid spanning the box `[min, max]` with `dims` cells per axis.
    pub fn from_bounds(
        min: DVec3,
        max: DVec3,
        dims: [usize; 3],
        fill: T,
    ) -> Result<Self, VoxelError> {
        Self::new(min, (max - min) / dims_vec(dims), dims, fill)
    }
}

fn unflatten(i: usize, dims: [usize; 3]) -> [usize; 3] {
    [
        i % dims[0],
        (i / dims[0]) % dims[1],
        i / (dims[0] * dims[1]),
    ]
}

fn dims_vec(d: [usize; 3]) -> DVec3 {
    DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64)
}

fn cell_vec(c: [usize; 3]) -> DVec3 {
    DVec3::new(c[0] as f64, c[1] as f64, c[2] as f64)
}

/// Amanatides–Woo walk over the cells of a grid crossed by a ray segment.
///
/// Yields `(cell, t_enter, t_exit)` with `t_enter <= t_exit`, consecutive
/// intervals touching (`t_exit` of one is `t_enter` of the next), each cell at
/// most once, consecutive cells face neighbours. Rules:
/// - the segment is first clipped to the grid box (slab test); a ray that
///   misses, or only touches an edge or corner (zero length inside), yields
///   nothing; a ray lying in a face plane with a zero direction component
///   follows the half-open rule (inside on the min face, outside on the max);
/// - an axis with a zero direction component is never stepped (`t_delta = ∞`);
/// - on a cell boundary the ray is in the cell it is heading into (on an axis
///   it does not move along, the half-open rule);
/// - where the ray passes exactly through an edge or corner, the axes are
///   stepped one at a time, x before y before z, so the in-between cells are
///   yielded with zero length (`t_enter == t_exit`) and the face-neighbour
///   property holds;
/// - at most `dims[0] + dims[1] + dims[2] + 3` cells are yielded, whatever
///   round-off does.
///
/// Documented fallback: a non-finite or zero direction, non-finite origin,
/// NaN or empty `[t_min, t_max]`, or a bad grid yields nothing.
#[derive(Debug, Clone)]
pub struct GridTraversal {
    origin: DVec3,
    dir: DVec3,
    grid_lo: DVec3,
    cell_size: DVec3,
    dims: [usize; 3],
    cell: [usize; 3],
    t_cur: f64,
    t_end: f64,
    remaining: usize,
}

impl GridTraversal {
    /// The walk of `ray` for `t` in `[t_min, t_max]` over the grid with min
    /// corner `grid_origin`, cells of `cell_size`, `dims` cells per axis.
    pub fn new(
        grid_origin: DVec3,
        cell_size: DVec3,
        dims: [usize; 3],
        ray: &Ray,
        t_min: f64,
        t_max: f64,
    ) -> Self {
        let mut it = Self {
            origin: ray.origin(),
            dir: ray.dir(),
            grid_lo: grid_origin,
            cell_size,
            dims,
            cell: [0; 3],
            t_cur: 0.0,
            t_end: 0.0,
            remaining: 0,
        };
        let d = ray.dir();
        let o = ray.origin();
        if check_geometry(grid_origin, cell_size, dims).is_err()
            || !o.is_finite()
            || !d.is_finite()
            || d == DVec3::ZERO
            || t_min.is_nan()
            || t_max.is_nan()
            || t_min > t_max
        {
            return it;
        }
        // Slab test: clip [t_min, t_max] to the box.
        let hi = grid_origin + cell_size * dims_vec(dims);
        let (mut t0, mut t1) = (t_min, t_max);
        for a in 0..3 {
            if d[a] == 0.0 {
                // Parallel to this slab: inside on [lo, hi), never crossing it.
                if !(o[a] >= grid_origin[a] && o[a] < hi[a]) {
                    return it;
                }
            } else {
                let ta = (grid_origin[a] - o[a]) / d[a];
                let tb = (hi[a] - o[a]) / d[a];
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
        }
        // Zero length inside (miss, or grazing an edge or corner): nothing.
        if t0.is_nan() || t1.is_nan() || t0 >= t1 || !t0.is_finite() {
            return it;
        }
        // Start cell, heading-into rule on boundaries; clamp for round-off at
        // the entry face.
        for a in 0..3 {
            let u = (o[a] - grid_origin[a]) / cell_size[a] + d[a] / cell_size[a] * t0;
            let k = if d[a] < 0.0 {
                u.ceil() - 1.0
            } else {
                u.floor()
            };
            it.cell[a] = k.clamp(0.0, (dims[a] - 1) as f64) as usize;
        }
        // `u` can round to the wrong side of a boundary the ray starts on;
        // decide it again in t, with the very expression `t_next` uses, so the
        // first cell never has zero length (it would be one the ray leaves at
        // once, i.e. an extra cell before the real start).
        for a in 0..3 {
            for _ in 0..2 {
                if it.t_next(a) > t0 {
                    break;
                }
                if d[a] > 0.0 && it.cell[a] + 1 < dims[a] {
                    it.cell[a] += 1;
                } else if d[a] < 0.0 && it.cell[a] > 0 {
                    it.cell[a] -= 1;
                } else {
                    break;
                }
            }
        }
        it.t_cur = t0;
        it.t_end = t1;
        it.remaining = dims[0] + dims[1] + dims[2] + 3;
        it
    }

    /// Ray parameter of the next boundary of the current cell on `axis`
    /// (∞ when the ray does not move along it). Computed from the boundary's
    /// index each time rather than accumulated, so no drift over long walks.
    fn t_next(&self, axis: usize) -> f64 {
        let d = self.dir[axis];
        if d == 0.0 {
            return f64::INFINITY;
        }
        let k = self.cell[axis] as f64 + if d > 0.0 { 1.0 } else { 0.0 };
        (self.grid_lo[axis] + k * self.cell_size[axis] - self.origin[axis]) / d
    }
}

impl Iterator for GridTraversal {
    type Item = ([usize; 3], f64, f64);

    fn next(&mut self) -> Option<Self::Item> {
        if self.remaining == 0 {
            return None;
        }
        self.remaining -= 1;
        // Axis of the nearest boundary; ties go to the lowest axis.
        let mut axis = 0;
        let mut t_hit = self.t_next(0);
        for a in 1..3 {
            let t = self.t_next(a);
            if t < t_hit {
                axis = a;
                t_hit = t;
            }
        }
        let t_enter = self.t_cur;
        let t_exit = t_hit.clamp(t_enter, self.t_end);
        let cell = self.cell;
        if t_exit >= self.t_end {
            self.remaining = 0;
        } else {
            let d = self.dir[axis];
            if d > 0.0 {
                if self.cell[axis] + 1 >= self.dims[axis] {
                    self.remaining = 0;
                } else {
                    self.cell[axis] += 1;
                }
            } else if self.cell[axis] == 0 {
                self.remaining = 0;
            } else {
                self.cell[axis] -= 1;
            }
            self.t_cur = t_exit;
        }
        Some((cell, t_enter, t_exit))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (0, Some(self.remaining))
    }
}

impl FusedIterator for GridTraversal {}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::collections::HashSet;

    fn grid441() -> VoxelGrid<u8> {
        VoxelGrid::new(DVec3::ZERO, DVec3::ONE, [4, 4, 1], 0).unwrap()
    }

    fn walk(g: &VoxelGrid<u8>, o: [f64; 3], d: [f64; 3]) -> Vec<([usize; 3], f64, f64)> {
        // A ray that cannot be built (zero or NaN) walks no cell.
        Ray::new(DVec3::from(o), DVec3::from(d))
            .map(|r| g.traverse(&r).collect())
            .unwrap_or_default()
    }

    fn cells(w: &[([usize; 3], f64, f64)]) -> Vec<[usize; 3]> {
        w.iter().map(|s| s.0).collect()
    }

    #[test]
    fn voxel_grid_indexing_and_cell_of() {
        let g = VoxelGrid::from_fn(
            DVec3::new(-1.0, 0.0, 2.0),
            DVec3::new(0.5, 1.0, 2.0),
            [3, 2, 2],
            |c| c,
        )
        .unwrap();
        assert_eq!(g.len(), 12);
        for i in 0..12 {
            let c = g.cell_at_index(i).unwrap();
            assert_eq!(g.index(c), Some(i));
            assert_eq!(*g.get(c).unwrap(), c);
        }
        assert_eq!(g.index([3, 0, 0]), None);
        assert_eq!(
            g.bounds(),
            (DVec3::new(-1.0, 0.0, 2.0), DVec3::new(0.5, 2.0, 6.0))
        );
        assert_eq!(g.cell_of(DVec3::new(-0.75, 1.5, 5.0)), Some([0, 1, 1]));
        // Half-open: min faces in, max faces out.
        assert_eq!(g.cell_of(DVec3::new(-1.0, 0.0, 2.0)), Some([0, 0, 0]));
        assert_eq!(g.cell_of(DVec3::new(0.5, 1.0, 3.0)), None);
        assert_eq!(g.cell_of(DVec3::new(f64::NAN, 1.0, 3.0)), None);
        assert_eq!(g.cell_center([1, 0, 0]), DVec3::new(-0.25, 0.5, 3.0));
        let input = |e: VoxelError| match e {
            VoxelError::Input(i) => (i.what, i.value),
            other => panic!("expected an input error, got {other:?}"),
        };
        assert_eq!(
            input(
                VoxelGrid::new(DVec3::ZERO, DVec3::new(1.0, 0.0, 1.0), [1, 1, 1], 0).unwrap_err()
            ),
            ("voxel cell size", 0.0)
        );
        assert_eq!(
            input(
                VoxelGrid::new(DVec3::new(0.0, f64::NAN, 0.0), DVec3::ONE, [1, 1, 1], 0)
                    .unwrap_err()
            )
            .0,
            "voxel grid origin"
        );
        assert_eq!(
            VoxelGrid::new(DVec3::ZERO, DVec3::ONE, [1, 0, 1], 0).unwrap_err(),
            VoxelError::BadDims([1, 0, 1])
        );
        assert_eq!(
            VoxelGrid::new(DVec3::ZERO, DVec3::ONE, [usize::MAX, 2, 1], 0).unwrap_err(),
            VoxelError::BadDims([usize::MAX, 2, 1])
        );
        assert_eq!(
            VoxelGrid::from_vec(DVec3::ZERO, DVec3::ONE, [2, 1, 1], vec![0]).unwrap_err(),
            VoxelError::WrongLength {
                dims: [2, 1, 1],
                expected: 2,
                got: 1
            }
        );
        let mut g = grid441();
        *g.get_mut([3, 3, 0]).unwrap() = 7;
        assert_eq!(g.cells()[15], 7);
        let p = VoxelGrid::from_fn_par(DVec3::ZERO, DVec3::ONE, [5, 4, 3], |c| {
            c[0] + 10 * c[1] + 100 * c[2]
        })
        .unwrap();
        let s = VoxelGrid::from_fn(DVec3::ZERO, DVec3::ONE, [5, 4, 3], |c| {
            c[0] + 10 * c[1] + 100 * c[2]
        })
        .unwrap();
        assert_eq!(p, s);
    }

    #[test]
    fn voxel_trilinear_reproduces_linear_fields() {
        // A linear field sampled at cell centres is reproduced exactly inside
        // the centre lattice and clamped outside it.
        let f = |p: DVec3| 2.0 * p.x - p.y + 0.5 * p.z + 1.0;
        let g = VoxelGrid::from_fn(DVec3::ZERO, DVec3::new(1.0, 2.0, 0.5), [4, 3, 5], |c| {
            f(DVec3::new(
                c[0] as f64 + 0.5,
                2.0 * c[1] as f64 + 1.0,
                0.5 * c[2] as f64 + 0.25,
            ))
        })
        .unwrap();
        for p in [
            DVec3::new(1.3, 2.2, 1.1),
            DVec3::new(0.5, 1.0, 0.25),
            DVec3::new(3.5, 5.0, 2.25),
        ] {
            assert!((g.trilinear(p).unwrap() - f(p)).abs() < 1e-12, "{p}");
        }
        assert!(
            (g.trilinear(DVec3::new(-5.0, 1.0, 0.25)).unwrap() - f(DVec3::new(0.5, 1.0, 0.25)))
                .abs()
                < 1e-12
        );
        assert!(g.trilinear(DVec3::NAN).is_none());
    }

    #[test]
    fn voxel_grid_deserialisation_is_validated() {
        // A good grid round-trips.
        let g = VoxelGrid::from_fn(
            DVec3::new(-1.0, 0.0, 2.0),
            DVec3::new(0.5, 1.0, 2.0),
            [3, 2, 1],
            |c| c[0] as u32,
        )
        .unwrap();
        let json = serde_json::to_string(&g).unwrap();
        assert_eq!(serde_json::from_str::<VoxelGrid<u32>>(&json).unwrap(), g);
        // Zero dims (would underflow `dims − 1` in `trilinear`), short
        // storage (would panic in `get`), a bad cell size: all rejected by
        // the deserialiser with the constructor's message.
        let bad = |origin: &str, size: &str, dims: &str, cells: &str| {
            let j = format!(
                r#"{{"origin":{origin},"cell_size":{size},"dims":{dims},"cells":{cells}}}"#
            );
            serde_json::from_str::<VoxelGrid<f64>>(&j)
                .err()
                .map(|e| e.to_string())
        };
        assert_eq!(bad("[0,0,0]", "[1,1,1]", "[1,1,1]", "[5.0]"), None);
        let e = bad("[0,0,0]", "[1,1,1]", "[0,1,1]", "[]").expect("zero dims must be rejected");
        assert!(e.contains("zero or too large"), "{e}");
        let e =
            bad("[0,0,0]", "[1,1,1]", "[2,2,1]", "[1.0]").expect("short storage must be rejected");
        assert!(e.contains("needs 4 cells, got 1"), "{e}");
        let e = bad("[0,0,0]", "[1,-1,1]", "[1,1,1]", "[1.0]")
            .expect("negative cell size must be rejected");
        assert!(e.contains("cell size"), "{e}");
        assert!(bad("[0,0,0]", "[1,1,1]", "[18446744073709551615,2,1]", "[1.0]").is_some());
    }

    #[test]
    fn voxel_trilinear_with_single_cell_axes() {
        // One cell per axis: the value everywhere (clamped), no underflow.
        let g = VoxelGrid::new(DVec3::ZERO, DVec3::ONE, [1, 1, 1], 3.5).unwrap();
        for p in [
            DVec3::splat(0.5),
            DVec3::splat(-7.0),
            DVec3::new(1e300, -1e300, 0.0),
        ] {
            assert_eq!(g.trilinear(p), Some(3.5), "{p}");
        }
        // One cell on x and z, three on y: linear along y only.
        let g = VoxelGrid::from_fn(DVec3::ZERO, DVec3::ONE, [1, 3, 1], |c| c[1] as f64).unwrap();
        assert_eq!(g.trilinear(DVec3::new(0.2, 1.5, 0.9)), Some(1.0));
        assert_eq!(g.trilinear(DVec3::new(5.0, 2.0, -3.0)), Some(1.5));
        assert_eq!(g.trilinear(DVec3::new(0.5, 9.0, 0.5)), Some(2.0));
    }

    #[test]
    fn traversal_axis_ray_from_outside() {
        // From x = −1 along +x at y = z = 0.5: cells x = 0..3, entering at t = 1.
        let w = walk(&grid441(), [-1.0, 0.5, 0.5], [1.0, 0.0, 0.0]);
        assert_eq!(cells(&w), vec![[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0]]);
        for (i, s) in w.iter().enumerate() {
            assert_eq!((s.1, s.2), (1.0 + i as f64, 2.0 + i as f64));
        }
        // Only [1.5, 2.5] of that ray: half of cell 0, half of cell 1.
        let w: Vec<_> = grid441()
            .traverse_segment(
                &Ray::new(DVec3::new(-1.0, 0.5, 0.5), DVec3::X).unwrap(),
                1.5,
                2.5,
            )
            .collect();
        assert_eq!(w, vec![([0, 0, 0], 1.5, 2.0), ([1, 0, 0], 2.0, 2.5)]);
    }

    #[test]
    fn traversal_hand_worked_oblique() {
        // From (0.5, 0.2) along (1, 0.5) (unnormalised parameter s, t = s·√1.25):
        // x = 1, 2, 3, 4 at s = 0.5, 1.5, 2.5, 3.5; y = 1 at s = 1.6 (y = 2 at
        // s = 3.6 is past the exit). Cells and s-intervals:
        // (0,0) [0, .5], (1,0) [.5, 1.5], (2,0) [1.5, 1.6], (2,1) [1.6, 2.5], (3,1) [2.5, 3.5].
        let w = walk(&grid441(), [0.5, 0.2, 0.5], [1.0, 0.5, 0.0]);
        let k = 1.25f64.sqrt();
        let expect = [
            ([0, 0, 0], 0.0, 0.5),
            ([1, 0, 0], 0.5, 1.5),
            ([2, 0, 0], 1.5, 1.6),
            ([2, 1, 0], 1.6, 2.5),
            ([3, 1, 0], 2.5, 3.5),
        ];
        assert_eq!(w.len(), expect.len());
        for (got, want) in w.iter().zip(expect) {
            assert_eq!(got.0, want.0);
            assert!(
                (got.1 - want.1 * k).abs() < 1e-12 && (got.2 - want.2 * k).abs() < 1e-12,
                "{got:?}"
            );
        }
        // The same ray reversed visits the same cells backwards.
        let back = walk(&grid441(), [4.0, 1.7, 0.5], [-1.0, -0.5, 0.0]);
        let mut rev = cells(&w);
        rev.reverse();
        assert_eq!(cells(&back), rev);
    }

    #[test]
    fn traversal_boundaries_and_corners() {
        let g = grid441();
        // Origin on the x = 1 boundary: the cell it heads into.
        assert_eq!(
            cells(&walk(&g, [1.0, 0.5, 0.5], [1.0, 0.0, 0.0]))[0],
            [1, 0, 0]
        );
        assert_eq!(
            cells(&walk(&g, [1.0, 0.5, 0.5], [-1.0, 0.0, 0.0])),
            vec![[0, 0, 0]]
        );
        // On a boundary of an axis it does not move along: half-open rule.
        assert_eq!(
            cells(&walk(&g, [1.0, 0.5, 0.5], [0.0, 1.0, 0.0])),
            vec![[1, 0, 0], [1, 1, 0], [1, 2, 0], [1, 3, 0]]
        );
        // Exactly through the corners (1,1), (2,2), (3,3): x steps before y,
        // the in-between cells have zero length, no cell is skipped or repeated.
        let w = walk(&g, [0.5, 0.5, 0.5], [1.0, 1.0, 0.0]);
        assert_eq!(
            cells(&w),
            vec![
                [0, 0, 0],
                [1, 0, 0],
                [1, 1, 0],
                [2, 1, 0],
                [2, 2, 0],
                [3, 2, 0],
                [3, 3, 0]
            ]
        );
        assert_eq!(w[1].1, w[1].2);
        // Along the max face y = 4 (outside, half-open) and the min face y = 0 (inside).
        assert!(walk(&g, [-1.0, 4.0, 0.5], [1.0, 0.0, 0.0]).is_empty());
        assert_eq!(walk(&g, [-1.0, 0.0, 0.5], [1.0, 0.0, 0.0]).len(), 4);
        // Only touching the corner (4, 0): nothing.
        assert!(walk(&g, [3.0, -1.0, 0.5], [1.0, 1.0, 0.0]).is_empty());
        // Misses, points away, starts past the grid, degenerate direction.
        assert!(walk(&g, [-1.0, 5.0, 0.5], [1.0, 0.0, 0.0]).is_empty());
        assert!(walk(&g, [-1.0, 0.5, 0.5], [-1.0, 0.0, 0.0]).is_empty());
        assert!(walk(&g, [5.0, 0.5, 0.5], [1.0, 0.1, 0.0]).is_empty());
        assert!(walk(&g, [0.5, 0.5, 0.5], [0.0, 0.0, 0.0]).is_empty());
        assert!(walk(&g, [0.5, f64::NAN, 0.5], [1.0, 0.0, 0.0]).is_empty());
        assert_eq!(
            g.traverse_segment(&Ray::new(DVec3::splat(0.5), DVec3::X).unwrap(), 2.0, 1.0)
                .count(),
            0
        );
        assert_eq!(
            g.traverse_segment(
                &Ray::new(DVec3::splat(0.5), DVec3::X).unwrap(),
                f64::NAN,
                1.0
            )
            .count(),
            0
        );
        // Whole line (t from −∞): all four cells of the row.
        assert_eq!(
            g.traverse_segment(
                &Ray::new(DVec3::new(2.5, 0.5, 0.5), DVec3::X).unwrap(),
                f64::NEG_INFINITY,
                f64::INFINITY
            )
            .count(),
            4
        );
    }

    /// A coordinate that is sometimes snapped onto a cell boundary, to
    /// exercise the boundary rules.
    fn coord(lo: f64, size: f64, n: usize) -> impl Strategy<Value = f64> {
        prop_oneof![
            (-1.5f64..(n as f64 + 1.5)).prop_map(move |u| lo + u * size),
            (-1i32..=(n as i32 + 1)).prop_map(move |k| lo + k as f64 * size),
        ]
    }

    fn dir_component() -> impl Strategy<Value = f64> {
        prop_oneof![4 => -1.0f64..1.0, 1 => Just(0.0), 1 => Just(1.0), 1 => Just(-1.0)]
    }

    fn case() -> impl Strategy<Value = (VoxelGrid<u8>, DVec3, DVec3, f64, f64)> {
        (
            prop::array::uniform3(-3.0f64..3.0),
            prop::array::uniform3(0.1f64..3.0),
            prop::array::uniform3(1usize..7),
        )
            .prop_flat_map(|(lo, size, dims)| {
                let g = VoxelGrid::new(DVec3::from(lo), DVec3::from(size), dims, 0u8).unwrap();
                (
                    Just(g),
                    coord(lo[0], size[0], dims[0]),
                    coord(lo[1], size[1], dims[1]),
                    coord(lo[2], size[2], dims[2]),
                    prop::array::uniform3(dir_component()),
                    prop_oneof![Just(0.0), -5.0f64..5.0],
                    prop_oneof![Just(f64::INFINITY), 0.0f64..20.0],
                )
            })
            .prop_filter_map("non-zero direction", |(g, x, y, z, d, t0, dt)| {
                let d = DVec3::from(d).try_normalize()?;
                Some((g, DVec3::new(x, y, z), d, t0, t0 + dt))
            })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]
        #[test]
        fn traversal_properties((g, o, d, t_min, t_max) in case()) {
            let ray = Ray::new(o, d).unwrap();
            let w: Vec<_> = g.traverse_segment(&ray, t_min, t_max).collect();
            let scale = 1.0 + o.abs().max_element() + g.bounds().1.abs().max_element();
            let tol = 1e-9 * scale;
            let dims = g.dims();
            prop_assert!(w.len() <= dims[0] + dims[1] + dims[2]);
            // Heading-into rule: the walk never starts in a cell it leaves at once.
            if let Some(&(_, te, tx)) = w.first() {
                prop_assert!(tx > te, "zero-length first cell: {:?}", w);
            }
            let mut seen = HashSet::new();
            for (i, &(cell, te, tx)) in w.iter().enumerate() {
                prop_assert!(g.index(cell).is_some());
                prop_assert!(seen.insert(cell), "cell {:?} twice", cell);
                prop_assert!(te.is_finite() && tx.is_finite());
                prop_assert!(te <= tx);
                prop_assert!(te >= t_min && tx <= t_max);
                if i > 0 {
                    let (prev, _, ptx) = w[i - 1];
                    prop_assert_eq!(ptx, te);
                    let diff: usize = (0..3).map(|a| prev[a].abs_diff(cell[a])).sum();
                    prop_assert_eq!(diff, 1, "{:?} -> {:?} not face neighbours", prev, cell);
                }
                // The midpoint of the interval lies in the (closed) cell.
                let m = ray.at(0.5 * (te + tx));
                let (lo, hi) = g.cell_bounds(cell);
                prop_assert!((m - lo).min_element() >= -tol && (hi - m).min_element() >= -tol,
                    "midpoint {} outside cell {:?} [{}, {}]", m, cell, lo, hi);
            }
            // Dense sampling of the segment: every cell found is in the walk.
            let (blo, bhi) = g.bounds();
            let far = (o - 0.5 * (blo + bhi)).length() + (bhi - blo).length();
            let (a, b) = (t_min.max(-far), t_max.min(far));
            if a < b {
                let n = 4000;
                for i in 0..=n {
                    let t = a + (b - a) * i as f64 / n as f64;
                    let p = ray.at(t);
                    if let Some(c) = g.cell_of(p) {
                        // Skip samples on a boundary (round-off decides those).
                        let (lo, hi) = g.cell_bounds(c);
                        if (p - lo).min_element() < tol || (hi - p).min_element() < tol {
                            continue;
                        }
                        prop_assert!(seen.contains(&c), "sample t={} in {:?} not visited; walk {:?}", t, c, w);
                    }
                }
            }
        }

        #[test]
        fn traversal_finite_input_never_panics(
            o in prop::array::uniform3(-1e6f64..1e6),
            d in prop::array::uniform3(-1.0f64..1.0),
            t0 in -1e6f64..1e6,
            dt in 0.0f64..1e7,
        ) {
            let g = VoxelGrid::new(DVec3::splat(-2.0), DVec3::splat(0.37), [11, 3, 7], 0u8).unwrap();
            for (cell, te, tx) in g.traverse_segment(&Ray::new(DVec3::from(o), DVec3::from(d)).unwrap(), t0, t0 + dt) {
                prop_assert!(g.index(cell).is_some() && te.is_finite() && tx.is_finite() && te <= tx);
            }
        }
    }
}
