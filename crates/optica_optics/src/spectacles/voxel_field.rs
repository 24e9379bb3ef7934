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
//! 4. Average the sets per voxel, clone by clone (all crossings count,
//!    in-focus ones as zeros).
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

use super::bundle::{EyePlacement, Region, Spread, TracedBundle, pupil_samples, region, trace_bundle};
use super::error::SpectaclesError;
use super::eye::Eye;
use super::lens_design::SpectacleLens;
use super::lens_mesh::polar_points;
use crate::ray::Ray;
use crate::voxel::VoxelGrid;

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
}

impl FieldSettings {
    /// The paper's setting: 110×77×42 cubic voxels (5 cm; the box spans
    /// x ±2.75 m, y ±1.925 m, z 0.03–2.13 m in front of the eye), `S = 10`,
    /// 24×64 + 1 = 1,537 aims (the paper: ~1,500 bundles of 10 rays),
    /// hole filling on.
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

    /// Number of aims (bundle pairs).
    pub fn aims(&self) -> usize {
        1 + self.aim_rings * self.aim_segments
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
    /// Rays traced through the lens (reference + pupil rays).
    pub rays_traced: usize,
    /// Voxel crossings recorded (sets accumulated, including in-focus zeros).
    pub crossings: usize,
    /// Voxels crossed by at least one reference ray.
    pub voxels_crossed: usize,
    /// Voxels filled from neighbours.
    pub voxels_filled: usize,
    /// Filling layers (the largest distance, in voxels, from a crossed voxel).
    pub fill_passes: usize,
}

/// The precomputed field.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DisplacementField {
    /// Geometry, and per voxel the number of crossings averaged (0: not
    /// crossed; filled from neighbours if the settings said so, else zeros).
    counts: VoxelGrid<u32>,
    /// `S` vectors per voxel, voxel-major (`cells × S`), in metres, `f32`
    /// (what the GPU gets).
    vectors: Vec<Vec3>,
    clones: usize,
    stats: FieldStats,
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
fn aims(lens: Option<&SpectacleLens>, placement: &EyePlacement, st: &FieldSettings) -> Vec<DVec3> {
    let (radius, z_window) = match lens {
        // Just inside the rim so that the outermost ring is on the lens.
        Some(l) => (l.rim_radius_m * (1.0 - 1e-9), None),
        None => (st.window_radius_m, Some(st.window_z_m)),
    };
    polar_points(radius, st.aim_rings, st.aim_segments)
        .into_iter()
        .filter_map(|(x, y)| {
            let p = match (lens, z_window) {
                (Some(l), _) => l.back.point(x, y)?,
                (None, Some(z)) => DVec3::new(x, y, z),
                (None, None) => return None,
            };
            (p - placement.centre_of_rotation).try_normalize()
        })
        .collect()
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
    let cells = st.dims.iter().try_fold(1usize, |a, &n| a.checked_mul(n));
    match cells.and_then(|c| c.checked_mul(st.clones)) {
        Some(n) if n <= u32::MAX as usize => Ok(()),
        _ => Err(SpectaclesError::OutOfRange { what: "voxels × clones", value: f64::INFINITY, min: 1.0, max: u32::MAX as f64 }),
    }
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
    let aim_dirs = aims(lens, placement, st);

    // Step 2: bundles, in parallel.
    let bundles: Vec<Option<(TracedBundle, TracedBundle)>> = aim_dirs
        .par_iter()
        .map(|&a| {
            let near = trace_bundle(lens, placement, a, rho, eye.near_point_vergence_d(), &samples).ok()?;
            let far = trace_bundle(lens, placement, a, rho, eye.far_point_vergence_d(), &samples).ok()?;
            Some((near, far))
        })
        .collect();

    // Step 3: walk the grid along each refracted reference ray, in parallel.
    let mut crossings: Vec<Crossing> = bundles
        .par_iter()
        .enumerate()
        .flat_map_iter(|(k, b)| {
            let walk = b.as_ref().map(|(near, far)| {
                let chief = Ray { origin: near.chief.origin, dir: near.chief.dir };
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
        for c in &crossings[lo..hi] {
            let Some((near, far)) = &bundles[c.aim as usize] else { continue };
            match c.region {
                Region::Near => sum.iter_mut().enumerate().for_each(|(i, v)| *v += near.displacement(i, c.s)),
                Region::Far => sum.iter_mut().enumerate().for_each(|(i, v)| *v -= far.displacement(i, c.s)),
                Region::InFocus => {}
            }
        }
        let n = (hi - lo) as f64;
        for (o, v) in out.iter_mut().zip(&sum) {
            *o = (*v / n).as_vec3();
        }
        *count = (hi - lo) as u32;
    });
    let voxels_crossed = cnt.iter().filter(|&&c| c > 0).count();
    let counts = VoxelGrid::from_vec(st.min, counts.cell_size(), st.dims, cnt)?;

    let mut stats = FieldStats {
        aims: aim_dirs.len(),
        aims_failed: bundles.iter().filter(|b| b.is_none()).count(),
        rays_traced: aim_dirs.len() * 2 * (s_clones + 1),
        crossings: crossings.len(),
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
        // voxel's depth to within the voxel's depth range (the blur grows
        // linearly across the voxel).
        let eye = Eye::from_near_far(0.5, 1.3, 0.012).unwrap();
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
            // d(A z ΔD)/dz = A (near side: A/n·... ≤ A·z/n) — bound by A·h.
            assert!((got - want).abs() <= 0.012 * h, "z {z}: {got} vs {want}");
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
