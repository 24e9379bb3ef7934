//! The voxel field of displacement-vector sets (paper §4.3, Figs. 6–7): a
//! precomputed map from a point in front of the eye to the `S` clone
//! displacements that blur it, valid while the eye and lens stay fixed.
//!
//! Precompute:
//! 1. Aims: the reference rays from the centre of rotation through the lens's
//!    back-surface points (the mesh vertex layout, "通常は頂点でよい"; ~1,500
//!    at the paper's setting). Without a lens, through the same layout on a
//!    window at the vertex plane.
//! 2. Per aim, the near bundle (`V = P_near`) and the far bundle
//!    (`V = P_far`) of `S` pupil rays ([`super::bundle`]), traced through the
//!    lens; their fitted vergences `W_near`, `W_far` place the corrected near
//!    and far points. In parallel (rayon).
//! 3. Walk the voxels the refracted reference ray crosses (Amanatides–Woo,
//!    `voxel.rs`, ref. 10 of the paper). In each, at the midpoint `s` of the
//!    ray's segment in the voxel, the set is the near bundle's displacements
//!    if nearer than the corrected near point, the far bundle's (mirrored) if
//!    beyond the corrected far point, else all zero (§4.2: in focus).
//! 4. Average the sets per voxel, clone by clone. Default, not in the paper
//!    ([`VoxelAverage::AllCrossings`]): every crossing counts, in-focus ones
//!    as zero sets. The paper (§4.3) averages only the sets recorded, the
//!    near and far crossings ([`VoxelAverage::RecordedSets`], an option of
//!    [`FieldSettings::average`]); the two differ only in voxels straddling
//!    the corrected near or far point, and the default measures slightly
//!    closer to the direct reference (see [`VoxelAverage`]). Either way a
//!    voxel crossed only in focus is zero (sharp) and counts as crossed.
//! 5. Optional, not in the paper: voxels no reference ray crossed take the
//!    mean of their filled face neighbours, repeated until every voxel is
//!    filled ([`FieldSettings::fill_empty`]). The paper leaves them at zero
//!    (sharp), which with ~1,500 aims leaves most far voxels uncovered.
//!
//! Lookup (run time): the voxel containing the vertex, one transform; clone
//! `i` takes vector `i` of the set.

use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::bundle::{EyePlacement, Region, Spread, TracedBundle, pupil_samples, region, trace_bundle_counted};
use super::error::SpectaclesError;
use super::eye::Eye;
use super::lens_design::SpectacleLens;
use super::lens_mesh::{MAX_POLAR_POINTS, polar_point_count, polar_points};
use crate::ray::Ray;
use crate::voxel::VoxelGrid;

/// Most clones (`S`) a field accepts: 1,024, a hundred times the paper's 10.
pub const MAX_CLONES: usize = 1 << 10;

/// Most aims (`1 + rings × segments`) a field accepts: [`MAX_POLAR_POINTS`]
/// (4,194,304, ~2,700 times the paper's 1,537).
pub const MAX_AIMS: usize = MAX_POLAR_POINTS;

/// Most vectors (`voxels × S`) a field accepts: 2^28 (3 GiB of `f32`
/// vectors; the paper's field has 3.6 million).
pub const MAX_FIELD_VECTORS: usize = 1 << 28;

/// Most voxel crossings the walk may record, bounded by
/// `aims × (nx + ny + nz + 3)` (a traversal's longest walk): 2^28 (6 GiB of
/// crossings at worst; the paper's setting bounds it by 0.36 million).
pub const MAX_WALK_CROSSINGS: usize = 1 << 28;

/// How the crossings of one voxel become its set (step 4).
///
/// The two differ only in voxels straddling the corrected near or far
/// point. The default is not the paper's: against the direct reference
/// (the `spectacles` sweep, quick settings, S = 10, scales 0.25 / 0.5 / 1)
/// its mean RMS-radius error is 0.413 / 0.248 / 0.118 mm, the paper's
/// averaging 0.415 / 0.253 / 0.118 mm (max error equal). The reason: a point
/// of a straddling voxel is in focus or blurred depending on where in the
/// voxel it is; diluting the blur by the in-focus fraction of the
/// crossings approximates that mix, the paper's mean of the blurred
/// crossings overstates it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum VoxelAverage {
    /// Not in the paper (the default): every crossing counts, in-focus ones
    /// as zero sets, so a voxel straddling the corrected near or far point
    /// gets a blur diluted by the fraction of its crossings in focus.
    #[default]
    AllCrossings,
    /// The paper (§4.3): the mean of the sets recorded, i.e. of the near
    /// and far crossings; in-focus crossings record nothing. A voxel
    /// straddling the corrected near or far point gets the mean blur of its
    /// blurred crossings.
    RecordedSets,
}

/// How to build a field.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FieldSettings {
    /// Min corner of the voxel box (m, eye frame).
    pub min: DVec3,
    /// Max corner of the voxel box.
    pub max: DVec3,
    /// Voxels per axis.
    pub dims: [usize; 3],
    /// `S`: clones = pupil rays per bundle = vectors per voxel.
    pub clones: usize,
    /// Rings of the aim layout on the lens (see [`polar_points`]).
    pub aim_rings: usize,
    /// Segments of the aim layout.
    pub aim_segments: usize,
    /// Without a lens: radius (m) of the window the aims go through.
    pub window_radius_m: f64,
    /// Without a lens: z (m) of that window.
    pub window_z_m: f64,
    /// Fill voxels no reference ray crossed from their neighbours.
    pub fill_empty: bool,
    /// How each voxel's crossings are averaged (default:
    /// [`VoxelAverage::AllCrossings`], not the paper's; see there).
    #[serde(default)]
    pub average: VoxelAverage,
}

impl FieldSettings {
    /// The paper's setting: 110×77×42 cubic voxels (5 cm; the box spans
    /// x ±2.75 m, y ±1.925 m, z 0.03–2.13 m in front of the eye), `S = 10`,
    /// 24×64 + 1 = 1,537 aims (the paper: ~1,500 bundles of 10 rays);
    /// this crate's additions: hole filling on, every crossing averaged
    /// ([`VoxelAverage::AllCrossings`]; the paper's is
    /// [`VoxelAverage::RecordedSets`]).
    pub fn paper() -> Self {
        let h = 0.05;
        Self {
            min: DVec3::new(-55.0 * h, -38.5 * h, 0.03),
            max: DVec3::new(55.0 * h, 38.5 * h, 0.03 + 42.0 * h),
            dims: [110, 77, 42],
            clones: 10,
            aim_rings: 24,
            aim_segments: 64,
            window_radius_m: 0.025,
            window_z_m: 0.012,
            fill_empty: true,
            average: VoxelAverage::AllCrossings,
        }
    }

    /// The same box with `k` times the voxels per axis and `k` times the aim
    /// rings and segments (so that the aims keep up with the voxels), each at
    /// least 1 (segments at least 3).
    pub fn scaled(&self, k: f64) -> Self {
        let sc = |n: usize, lo: usize| ((n as f64 * k).round() as usize).max(lo);
        Self {
            dims: [sc(self.dims[0], 1), sc(self.dims[1], 1), sc(self.dims[2], 1)],
            aim_rings: sc(self.aim_rings, 1),
            aim_segments: sc(self.aim_segments, 3),
            ..*self
        }
    }

    /// Number of aims (bundle pairs) of the layout, `1 + rings × segments`,
    /// or `None` when that overflows or exceeds [`MAX_AIMS`] (the precompute
    /// rejects such settings).
    pub fn aims(&self) -> Option<usize> {
        polar_point_count(self.aim_rings, self.aim_segments).filter(|&n| n <= MAX_AIMS)
    }
}

/// Counters of a precompute.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct FieldStats {
    /// Aims tried.
    pub aims: usize,
    /// Aims whose reference ray or a pupil ray did not get through the lens
    /// (TIR, rim, miss): skipped.
    pub aims_failed: usize,
    /// Rays actually traced through the lens: per aim the near bundle's
    /// reference and pupil rays up to the first that failed, then (if it got
    /// through) the far bundle's. 0 for the naked eye (straight rays, nothing
    /// traced).
    pub rays_traced: usize,
    /// Voxel crossings of reference rays (near, far and in focus).
    pub crossings: usize,
    /// Crossings that recorded a set (near or far; in-focus ones record
    /// nothing).
    #[serde(default)]
    pub sets_recorded: usize,
    /// Voxels crossed by at least one reference ray.
    pub voxels_crossed: usize,
    /// Voxels filled from neighbours.
    pub voxels_filled: usize,
    /// Filling layers (the largest distance, in voxels, from a crossed voxel).
    pub fill_passes: usize,
}

/// The precomputed field.
///
/// Deserialisation is validated (the grid as [`VoxelGrid`]'s, then
/// `1 <= S <= MAX_CLONES`, `vectors.len() = voxels × S`, every vector
/// finite), so a field read from disk cannot panic in a lookup.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawDisplacementField")]
pub struct DisplacementField {
    /// Geometry, and per voxel the number of reference-ray crossings (0: not
    /// crossed; filled from neighbours if the settings said so, else zeros).
    counts: VoxelGrid<u32>,
    /// `S` vectors per voxel, voxel-major (`cells × S`), in metres, `f32`
    /// (what the GPU gets).
    vectors: Vec<Vec3>,
    clones: usize,
    stats: FieldStats,
}

/// The serialised form of a [`DisplacementField`], unchecked.
#[derive(Deserialize)]
struct RawDisplacementField {
    counts: VoxelGrid<u32>,
    vectors: Vec<Vec3>,
    clones: usize,
    stats: FieldStats,
}

impl TryFrom<RawDisplacementField> for DisplacementField {
    type Error = SpectaclesError;

    fn try_from(r: RawDisplacementField) -> Result<Self, SpectaclesError> {
        if !(1..=MAX_CLONES).contains(&r.clones) {
            return Err(SpectaclesError::OutOfRange { what: "field clones", value: r.clones as f64, min: 1.0, max: MAX_CLONES as f64 });
        }
        if r.counts.len().checked_mul(r.clones) != Some(r.vectors.len()) {
            return Err(SpectaclesError::OutOfRange {
                what: "field vectors (must be voxels × clones)",
                value: r.vectors.len() as f64,
                min: r.counts.len() as f64 * r.clones as f64,
                max: r.counts.len() as f64 * r.clones as f64,
            });
        }
        if !r.vectors.iter().all(|v| v.is_finite()) {
            return Err(SpectaclesError::NonFinite("field vector"));
        }
        Ok(Self { counts: r.counts, vectors: r.vectors, clones: r.clones, stats: r.stats })
    }
}

/// One voxel crossing of one reference ray.
#[derive(Clone, Copy)]
struct Crossing {
    cell: u32,
    aim: u32,
    region: Region,
    s: f64,
}

/// The aims (unit directions from the centre of rotation).
fn aims(lens: Option<&SpectacleLens>, placement: &EyePlacement, st: &FieldSettings) -> Result<Vec<DVec3>, SpectaclesError> {
    let (radius, z_window) = match lens {
        // Just inside the rim so that the outermost ring is on the lens.
        Some(l) => (l.rim_radius_m * (1.0 - 1e-9), None),
        None => (st.window_radius_m, Some(st.window_z_m)),
    };
    Ok(polar_points(radius, st.aim_rings, st.aim_segments)?
        .into_iter()
        .filter_map(|(x, y)| {
            let p = match (lens, z_window) {
                (Some(l), _) => l.back.point(x, y)?,
                (None, Some(z)) => DVec3::new(x, y, z),
                (None, None) => return None,
            };
            (p - placement.centre_of_rotation).try_normalize()
        })
        .collect())
}

fn check(eye: &Eye, placement: &EyePlacement, st: &FieldSettings) -> Result<(), SpectaclesError> {
    Eye::new(eye.refractive_error_d, eye.accommodation_d, eye.pupil_diameter_m)?;
    if !placement.is_valid() {
        return Err(SpectaclesError::NonFinite("eye placement"));
    }
    if !(st.min.is_finite() && st.max.is_finite() && st.window_radius_m.is_finite() && st.window_z_m.is_finite()) {
        return Err(SpectaclesError::NonFinite("field box"));
    }
    if st.clones == 0 || st.aim_rings == 0 || st.aim_segments < 3 {
        return Err(SpectaclesError::OutOfRange { what: "clones (>= 1), aim rings (>= 1), aim segments (>= 3)", value: 0.0, min: 1.0, max: f64::INFINITY });
    }
    // Every size is checked (checked_mul, caps) before anything is
    // multiplied or allocated; the values reported are f64 products, which
    // cannot overflow.
    let out_of_range = |what, value: f64, max: usize| SpectaclesError::OutOfRange { what, value, min: 1.0, max: max as f64 };
    if st.clones > MAX_CLONES {
        return Err(out_of_range("clones", st.clones as f64, MAX_CLONES));
    }
    let aims = st
        .aims()
        .ok_or_else(|| out_of_range("aims 1 + aim rings × aim segments", 1.0 + st.aim_rings as f64 * st.aim_segments as f64, MAX_AIMS))?;
    let dims_f = st.dims.iter().map(|&n| n as f64).product::<f64>();
    // Cells index as u32 in the walk.
    let cells = st.dims.iter().try_fold(1usize, |a, &n| a.checked_mul(n)).filter(|&c| c <= u32::MAX as usize);
    let vectors = cells.and_then(|c| c.checked_mul(st.clones)).filter(|&n| n <= MAX_FIELD_VECTORS);
    if vectors.is_none() {
        return Err(out_of_range("voxels × clones", dims_f * st.clones as f64, MAX_FIELD_VECTORS));
    }
    let walk = st.dims.iter().try_fold(3usize, |a, &n| a.checked_add(n)).and_then(|w| w.checked_mul(aims));
    if walk.is_none_or(|w| w > MAX_WALK_CROSSINGS) {
        let w = st.dims.iter().map(|&n| n as f64).sum::<f64>() + 3.0;
        return Err(out_of_range("aims × (nx + ny + nz + 3) (bound on voxel crossings)", w * aims as f64, MAX_WALK_CROSSINGS));
    }
    Ok(())
}

/// Precomputes the field for `eye` at `placement` looking through `lens`
/// (`None`: the naked eye). See the module docs for the steps.
///
/// Errors: a bad eye, placement or settings (typed), a bad grid box
/// ([`SpectaclesError::Voxel`]). Aims that fail (TIR, rim) are skipped and
/// counted in [`FieldStats::aims_failed`].
pub fn precompute_field(
    eye: &Eye,
    placement: &EyePlacement,
    lens: Option<&SpectacleLens>,
    st: &FieldSettings,
) -> Result<DisplacementField, SpectaclesError> {
    check(eye, placement, st)?;
    let counts = VoxelGrid::from_bounds(st.min, st.max, st.dims, 0u32)?;
    let n_cells = counts.len();
    let s_clones = st.clones;
    let samples: Vec<DVec2> = pupil_samples(s_clones);
    let rho = 0.5 * eye.pupil_diameter_m;
    let aim_dirs = aims(lens, placement, st)?;

    // Step 2: bundles, in parallel, counting the rays actually traced.
    let (bundles, traced): (Vec<Option<(TracedBundle, TracedBundle)>>, Vec<usize>) = aim_dirs
        .par_iter()
        .map(|&a| {
            let mut traced = 0;
            let mut trace = |v: f64| trace_bundle_counted(lens, placement, a, rho, v, &samples, &mut traced).ok();
            let pair = trace(eye.near_point_vergence_d()).and_then(|near| Some((near, trace(eye.far_point_vergence_d())?)));
            (pair, traced)
        })
        .unzip();

    // Step 3: walk the grid along each refracted reference ray, in parallel.
    let mut crossings: Vec<Crossing> = bundles
        .par_iter()
        .enumerate()
        .flat_map_iter(|(k, b)| {
            let walk = b.as_ref().map(|(near, far)| {
                let chief = Ray::from_unit(near.chief.origin(), near.chief.dir());
                let (wn, wf) = (near.vergence_d, far.vergence_d);
                counts.traverse(&chief).filter_map(move |(cell, t0, t1)| {
                    let s = 0.5 * (t0 + t1);
                    let idx = cell[0] + st.dims[0] * (cell[1] + st.dims[1] * cell[2]);
                    (s > 0.0).then(|| Crossing { cell: idx as u32, aim: k as u32, region: region(s, wn, wf), s })
                })
            });
            walk.into_iter().flatten()
        })
        .collect();
    crossings.par_sort_unstable_by_key(|c| c.cell);

    // Step 4: average per voxel, in parallel over voxels.
    let mut vectors = vec![Vec3::ZERO; n_cells * s_clones];
    let mut cnt = vec![0u32; n_cells];
    vectors.par_chunks_mut(s_clones).zip(cnt.par_iter_mut()).enumerate().for_each(|(cell, (out, count))| {
        let lo = crossings.partition_point(|c| (c.cell as usize) < cell);
        let hi = crossings.partition_point(|c| (c.cell as usize) <= cell);
        if lo == hi {
            return;
        }
        let mut sum = vec![DVec3::ZERO; s_clones];
        let mut recorded = 0usize;
        for c in &crossings[lo..hi] {
            let Some((near, far)) = &bundles[c.aim as usize] else { continue };
            match c.region {
                Region::Near => sum.iter_mut().enumerate().for_each(|(i, v)| *v += near.displacement(i, c.s)),
                Region::Far => sum.iter_mut().enumerate().for_each(|(i, v)| *v -= far.displacement(i, c.s)),
                Region::InFocus => continue,
            }
            recorded += 1;
        }
        let n = match st.average {
            VoxelAverage::RecordedSets => recorded,
            VoxelAverage::AllCrossings => hi - lo,
        };
        // No set recorded (crossed only in focus): zero, sharp.
        if n > 0 {
            for (o, v) in out.iter_mut().zip(&sum) {
                *o = (*v / n as f64).as_vec3();
            }
        }
        *count = (hi - lo) as u32;
    });
    let sets_recorded = crossings.iter().filter(|c| c.region != Region::InFocus).count();
    let voxels_crossed = cnt.iter().filter(|&&c| c > 0).count();
    let counts = VoxelGrid::from_vec(st.min, counts.cell_size(), st.dims, cnt)?;

    let mut stats = FieldStats {
        aims: aim_dirs.len(),
        aims_failed: bundles.iter().filter(|b| b.is_none()).count(),
        rays_traced: traced.iter().sum(),
        crossings: crossings.len(),
        sets_recorded,
        voxels_crossed,
        voxels_filled: 0,
        fill_passes: 0,
    };
    drop(crossings);
    if st.fill_empty && voxels_crossed > 0 {
        let (filled, passes) = fill_empty(&counts, &mut vectors, s_clones);
        stats.voxels_filled = filled;
        stats.fill_passes = passes;
    }
    Ok(DisplacementField { counts, vectors, clones: s_clones, stats })
}

/// Step 5: every voxel with no crossing takes the mean of its face
/// neighbours that were filled before it, layer by layer outwards from the
/// crossed voxels (a breadth-first front: layer k is the voxels k steps from
/// the nearest crossed one). Each voxel is visited once per layer it borders,
/// so the cost is O(cells·S), not O(cells·S·layers). Returns (voxels filled,
/// layers).
fn fill_empty(counts: &VoxelGrid<u32>, vectors: &mut [Vec3], s: usize) -> (usize, usize) {
    let dims = counts.dims();
    let (sx, sy) = (dims[0], dims[0] * dims[1]);
    let neighbours = |i: usize| {
        let [x, y, z] = [i % dims[0], (i / dims[0]) % dims[1], i / sy];
        [
            (x > 0).then(|| i - 1),
            (x + 1 < dims[0]).then(|| i + 1),
            (y > 0).then(|| i - sx),
            (y + 1 < dims[1]).then(|| i + sx),
            (z > 0).then(|| i - sy),
            (z + 1 < dims[2]).then(|| i + sy),
        ]
    };
    // 0: unknown, 1: known (crossed or filled in an earlier layer), 2: queued.
    let mut state: Vec<u8> = counts.cells().iter().map(|&c| u8::from(c > 0)).collect();
    let mut front: Vec<usize> = Vec::new();
    for i in 0..state.len() {
        if state[i] == 0 && neighbours(i).iter().flatten().any(|&j| state[j] == 1) {
            front.push(i);
        }
    }
    for &i in &front {
        state[i] = 2;
    }
    let (mut filled, mut layers) = (0, 0);
    while !front.is_empty() {
        // Means of the known neighbours, computed in parallel from a frozen state.
        let mut means = vec![Vec3::ZERO; front.len() * s];
        means.par_chunks_mut(s).zip(front.par_iter()).for_each(|(out, &i)| {
            let mut n = 0.0f32;
            for j in neighbours(i).into_iter().flatten() {
                if state[j] == 1 {
                    n += 1.0;
                    out.iter_mut().zip(&vectors[j * s..(j + 1) * s]).for_each(|(a, b)| *a += *b);
                }
            }
            out.iter_mut().for_each(|v| *v /= n);
        });
        for (k, &i) in front.iter().enumerate() {
            vectors[i * s..(i + 1) * s].copy_from_slice(&means[k * s..(k + 1) * s]);
            state[i] = 1;
        }
        filled += front.len();
        layers += 1;
        let mut next = Vec::new();
        for &i in &front {
            for j in neighbours(i).into_iter().flatten() {
                if state[j] == 0 {
                    state[j] = 2;
                    next.push(j);
                }
            }
        }
        front = next;
    }
    (filled, layers)
}

impl DisplacementField {
    /// The grid geometry, with per-voxel crossing counts.
    pub fn counts(&self) -> &VoxelGrid<u32> {
        &self.counts
    }

    /// `S`.
    pub fn clones(&self) -> usize {
        self.clones
    }

    /// Counters of the precompute.
    pub fn stats(&self) -> &FieldStats {
        &self.stats
    }

    /// All vectors, `cells × S`, voxel-major (x fastest), for upload.
    pub fn vectors(&self) -> &[Vec3] {
        &self.vectors
    }

    /// The set of `cell`.
    pub fn displacements(&self, cell: [usize; 3]) -> Option<&[Vec3]> {
        let i = self.counts.index(cell)?;
        Some(&self.vectors[i * self.clones..(i + 1) * self.clones])
    }

    /// The set of the voxel containing `point` (the paper's lookup), `None`
    /// outside the box or for a non-finite point.
    pub fn displacements_at(&self, point: DVec3) -> Option<&[Vec3]> {
        self.displacements(self.counts.cell_of(point)?)
    }

    /// Spread of the set at `point`.
    pub fn spread_at(&self, point: DVec3) -> Option<Spread> {
        self.displacements_at(point).map(|v| Spread::of(v.iter().map(|x| x.as_dvec3())))
    }

    /// Fraction of voxels crossed by a reference ray.
    pub fn coverage(&self) -> f64 {
        self.stats.voxels_crossed as f64 / self.counts.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectacles::lens_design::{LensDesignParams, Prescription, design_lens};

    fn small() -> FieldSettings {
        FieldSettings::paper().scaled(0.25)
    }

    #[test]
    fn voxel_field_naked_eye_matches_eq_1_and_2() {
        // Naked eye (paper Fig. 8(b): near 0.5, far 1.3, A = 12 mm): on the
        // axis, the field's disc (2√2·rms) is the analytic A·z·ΔD at the
        // voxel's centre to within half the voxel's depth times the disc's
        // slope (the disc is linear in z on each side: near it is
        // A·z·(1/z − 1/n) = A(1 − z/n), slope −A/n; far it is A(z/f − 1),
        // slope A/f), i.e. max(A/n, A/f)·h/2.
        let (a, n, far) = (0.012, 0.5, 1.3);
        let eye = Eye::from_near_far(n, far, a).unwrap();
        let pl = EyePlacement::paper();
        let st = FieldSettings { fill_empty: false, ..FieldSettings::paper().scaled(0.5) };
        let f = precompute_field(&eye, &pl, None, &st).unwrap();
        assert_eq!(f.stats().aims_failed, 0);
        let h = f.counts().cell_size().z;
        for z in [0.15, 0.35, 0.9, 1.9] {
            let p = DVec3::new(0.001, 0.001, z);
            let cell = f.counts().cell_of(p).unwrap();
            assert!(*f.counts().get(cell).unwrap() > 0);
            let zc = f.counts().cell_center(cell).z - pl.centre_of_rotation.z;
            let got = f.spread_at(p).unwrap().disc_diameter_m();
            let want = eye.blur_disc_diameter_m(zc).unwrap();
            let tol = (a / n).max(a / far) * h / 2.0;
            assert!((got - want).abs() <= tol, "z {z}: {got} vs {want} (tolerance {tol})");
        }
        // In focus between 0.5 and 1.3 m: zero.
        assert_eq!(f.spread_at(DVec3::new(0.001, 0.001, 0.8)).unwrap().rms_radius_m, 0.0);
    }

    #[test]
    fn voxel_field_lens_corrects_the_myope() {
        // A −3 D myope with no accommodation (near = far = 0.333 m): through a
        // fully correcting lens a far point is nearly sharp; naked, the same
        // point at 2 m is blurred by A·z·ΔD = 0.004·2·(3 − 0.5) = 20 mm.
        let eye = Eye::new(-3.0, 0.0, 0.004).unwrap();
        let pl = EyePlacement::default();
        // Full correction at 15 mm from the pupil (lens at 12 mm, pupil 3 mm
        // behind the cornea): F = −1/(1/3 − 0.015) = −3.14 D.
        let lens = design_lens(&Prescription::sphere(-1.0 / (1.0 / 3.0 - 0.015)).unwrap(), &LensDesignParams::default()).unwrap();
        let st = small();
        let naked = precompute_field(&eye, &pl, None, &st).unwrap();
        let corrected = precompute_field(&eye, &pl, Some(&lens), &st).unwrap();
        let p = DVec3::new(0.0, 0.0, 2.0);
        let dn = naked.spread_at(p).unwrap().disc_diameter_m();
        let dc = corrected.spread_at(p).unwrap().disc_diameter_m();
        assert!((dn - 0.02).abs() < 0.003, "{dn}");
        // Corrected, the eye focuses at infinity: at 2 m ΔD = 0.5 D, disc
        // A·z·ΔD = 4 mm (a little less: the minus lens narrows the bundle).
        assert!((dc - 0.004).abs() < 0.0008, "{dc}");
        assert!(corrected.vectors().iter().all(|v| v.is_finite()));
    }

    #[test]
    fn voxel_field_axis_ray_on_cell_boundary_and_zero_pupil() {
        // Paper box: x = 0 is a cell boundary (55 cells each side) and the
        // axial reference ray runs along +z exactly on it (zero x and y
        // direction components): it must be walked in exactly one of the two
        // columns, the one `cell_of` names (the half-open rule).
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let pl = EyePlacement::paper();
        let st = FieldSettings { fill_empty: false, dims: [110, 77, 42], aim_rings: 2, aim_segments: 4, ..FieldSettings::paper() };
        let f = precompute_field(&eye, &pl, None, &st).unwrap();
        let cx = f.counts().cell_of(DVec3::new(0.0, 0.0, 1.0)).unwrap()[0];
        assert!(cx == 54 || cx == 55);
        for k in 0..42 {
            assert!(*f.counts().get([cx, 38, k]).unwrap() > 0, "{k}");
            // Beyond z ≈ 0.18 m the off-axis aims have left both columns.
            if k >= 3 {
                assert_eq!(*f.counts().get([109 - cx, 38, k]).unwrap(), 0, "{k}");
            }
        }
        // Zero pupil: every set is zero, nothing NaN.
        let eye0 = Eye::new(-2.0, 1.0, 0.0).unwrap();
        let f0 = precompute_field(&eye0, &pl, None, &small()).unwrap();
        assert!(f0.vectors().iter().all(|v| *v == Vec3::ZERO));
    }

    #[test]
    fn voxel_field_bad_settings_are_typed() {
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let pl = EyePlacement::default();
        let bad = |st: FieldSettings| precompute_field(&eye, &pl, None, &st).is_err();
        assert!(bad(FieldSettings { clones: 0, ..small() }));
        assert!(bad(FieldSettings { dims: [0, 1, 1], ..small() }));
        assert!(bad(FieldSettings { min: DVec3::NAN, ..small() }));
        assert!(bad(FieldSettings { max: DVec3::new(-10.0, 1.0, 1.0), ..small() }));
        let nan_eye = Eye { refractive_error_d: f64::NAN, ..eye };
        assert!(precompute_field(&nan_eye, &pl, None, &small()).is_err());
        let bad_pl = EyePlacement { pupil_offset_m: -1.0, ..pl };
        assert!(precompute_field(&eye, &bad_pl, None, &small()).is_err());
    }

    #[test]
    fn voxel_field_huge_settings_are_typed() {
        // Sizes that overflow or are merely huge are rejected before any
        // arithmetic or allocation: no overflow panic, no hang.
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let pl = EyePlacement::default();
        let too_big = |st: FieldSettings| matches!(precompute_field(&eye, &pl, None, &st), Err(SpectaclesError::OutOfRange { .. }));
        // aim rings × segments overflows usize, or is 67 million aims.
        assert!(too_big(FieldSettings { aim_rings: usize::MAX, aim_segments: 3, ..small() }));
        assert!(too_big(FieldSettings { aim_rings: 3, aim_segments: usize::MAX, ..small() }));
        assert!(too_big(FieldSettings { aim_rings: usize::MAX, aim_segments: usize::MAX, ..small() }));
        assert!(too_big(FieldSettings { aim_rings: 1 << 20, aim_segments: 64, ..small() }));
        // A million clones on one voxel (old cap: voxels × clones <= u32::MAX).
        assert!(too_big(FieldSettings { dims: [1, 1, 1], clones: 1 << 20, ..small() }));
        assert!(too_big(FieldSettings { clones: usize::MAX, ..small() }));
        // Voxel counts that overflow, or whose walk would be 10^11 crossings.
        assert!(too_big(FieldSettings { dims: [usize::MAX, 2, 1], ..small() }));
        assert!(too_big(FieldSettings { dims: [1 << 40, 1 << 40, 1], ..small() }));
        assert!(too_big(FieldSettings { dims: [1 << 26, 1, 1], clones: 1, ..small() }));
        assert_eq!(FieldSettings { aim_rings: usize::MAX, aim_segments: 3, ..small() }.aims(), None);
        assert_eq!(FieldSettings { aim_rings: 1 << 20, aim_segments: 64, ..small() }.aims(), None);
        assert_eq!(FieldSettings::paper().aims(), Some(1537));
    }

    #[test]
    fn voxel_field_deserialisation_is_validated() {
        use serde_json::{Value, json};
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let st = FieldSettings { dims: [3, 2, 4], clones: 4, ..small() };
        let f = precompute_field(&eye, &EyePlacement::default(), None, &st).unwrap();
        let good = serde_json::to_value(&f).unwrap();
        assert_eq!(serde_json::from_value::<DisplacementField>(good.clone()).unwrap(), f);
        let parse = |edit: &dyn Fn(&mut Value)| {
            let mut v = good.clone();
            edit(&mut v);
            serde_json::from_value::<DisplacementField>(v)
        };
        // Short storage: `displacements` would slice out of range.
        assert!(parse(&|v| {
            v["vectors"].as_array_mut().unwrap().pop();
        })
        .is_err());
        // Zero clones, and more clones than the vectors hold.
        assert!(parse(&|v| v["clones"] = json!(0)).is_err());
        assert!(parse(&|v| v["clones"] = json!(5)).is_err());
        // A grid with a zero dimension (underflow in `trilinear`) or whose
        // counts do not match its dims (panic in `get`).
        assert!(parse(&|v| v["counts"]["dims"] = json!([0, 2, 4])).is_err());
        assert!(parse(&|v| v["counts"]["dims"] = json!([4, 2, 4])).is_err());
        assert!(parse(&|v| {
            v["counts"]["cells"].as_array_mut().unwrap().pop();
        })
        .is_err());
        // Old files without the newer stats counter still load.
        assert!(parse(&|v| {
            v["stats"].as_object_mut().unwrap().remove("sets_recorded");
        })
        .is_ok());
    }

    #[test]
    fn voxel_field_average_is_over_recorded_sets() {
        // One voxel, z 0.30–0.60 m, crossed by naked-eye aims up to 40° off
        // axis (window radius 12.6 mm at 15 mm from the pupil): the segment
        // midpoints s = 0.453/cos θ fall before the near point (0.5 m) for
        // the inner rings and in focus for the outer ones. Paper §4.3: the
        // voxel's set is the mean of the sets recorded, the near ones only.
        let eye = Eye::from_near_far(0.5, 1.3, 0.012).unwrap();
        let pl = EyePlacement::paper();
        let st = FieldSettings {
            min: DVec3::new(-1.0, -1.0, 0.3),
            max: DVec3::new(1.0, 1.0, 0.6),
            dims: [1, 1, 1],
            clones: 6,
            aim_rings: 4,
            aim_segments: 6,
            window_radius_m: 0.015 * 40f64.to_radians().tan(),
            window_z_m: 0.012,
            fill_empty: false,
            average: VoxelAverage::RecordedSets,
        };
        let f = precompute_field(&eye, &pl, None, &st).unwrap();
        // The expected set, from the bundles and the box's z faces directly.
        let samples = pupil_samples(st.clones);
        let rho = 0.5 * eye.pupil_diameter_m;
        let mut want = vec![DVec3::ZERO; st.clones];
        let (mut near_n, mut total) = (0usize, 0usize);
        for a in aims(None, &pl, &st).unwrap() {
            let b = trace_bundle_counted(None, &pl, a, rho, eye.near_point_vergence_d(), &samples, &mut 0).unwrap();
            let z0 = b.chief.origin().z;
            let s = 0.5 * ((0.3 - z0) + (0.6 - z0)) / a.z;
            total += 1;
            if s < 0.5 {
                near_n += 1;
                want.iter_mut().enumerate().for_each(|(i, w)| *w += b.displacement(i, s));
            } else {
                assert!(s <= 1.3, "{s}: no far crossings in this set-up");
            }
        }
        assert!(near_n > 0 && near_n < total, "{near_n} of {total}: the voxel must straddle the near point");
        let got = f.displacements([0, 0, 0]).unwrap();
        for (g, w) in got.iter().zip(&want) {
            let w = *w / near_n as f64;
            assert!((g.as_dvec3() - w).length() < 1e-8, "{g} vs {w}");
        }
        assert_eq!((f.stats().crossings, f.stats().sets_recorded), (total, near_n));
        assert_eq!(*f.counts().get([0, 0, 0]).unwrap() as usize, total);
        // The option: every crossing counts, the in-focus ones as zeros.
        let all = precompute_field(&eye, &pl, None, &FieldSettings { average: VoxelAverage::AllCrossings, ..st }).unwrap();
        for (g, p) in all.displacements([0, 0, 0]).unwrap().iter().zip(got) {
            assert!((g.as_dvec3() - p.as_dvec3() * (near_n as f64 / total as f64)).length() < 1e-8);
        }
        // A voxel crossed only in focus is zero, not filled.
        let in_focus = FieldSettings { min: DVec3::new(-1.0, -1.0, 0.7), max: DVec3::new(1.0, 1.0, 1.0), fill_empty: true, ..st };
        let f = precompute_field(&eye, &pl, None, &in_focus).unwrap();
        assert_eq!((f.stats().sets_recorded, f.stats().voxels_filled), (0, 0));
        assert!(f.stats().crossings > 0 && f.vectors().iter().all(|v| *v == Vec3::ZERO));
    }

    #[test]
    fn voxel_field_rays_traced_counts_actual_rays() {
        // Naked eye: nothing is traced through a lens.
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let naked = precompute_field(&eye, &EyePlacement::default(), None, &small()).unwrap();
        assert_eq!(naked.stats().rays_traced, 0);
        // Through a thick −10 D lens the outer aims leave through the rim.
        // A good aim traces 2(S + 1) rays; a failed one at least its
        // reference ray and fewer than 2(S + 1).
        let eye = Eye::new(-10.0, 1.0, 0.004).unwrap();
        let lens = design_lens(&Prescription::sphere(-10.0).unwrap(), &LensDesignParams::default()).unwrap();
        let f = precompute_field(&eye, &EyePlacement::default(), Some(&lens), &small()).unwrap();
        let s = f.stats();
        let per = 2 * (f.clones() + 1);
        let good = s.aims - s.aims_failed;
        assert!(s.aims_failed > 0 && good > 0, "{s:?}");
        assert!(s.rays_traced >= good * per + s.aims_failed, "{s:?}");
        assert!(s.rays_traced <= good * per + s.aims_failed * (per - 1), "{s:?}");
    }

    #[test]
    fn voxel_field_fill_covers_every_voxel() {
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let pl = EyePlacement::default();
        let lens = design_lens(&Prescription::sphere(-2.0).unwrap(), &LensDesignParams::default()).unwrap();
        let f = precompute_field(&eye, &pl, Some(&lens), &small()).unwrap();
        let s = f.stats();
        assert_eq!(s.voxels_crossed + s.voxels_filled, f.counts().len(), "{s:?}");
        assert!(s.fill_passes >= 1 && f.coverage() > 0.0 && f.coverage() < 1.0);
    }
}
