//! The voxel field of displacement-vector sets (documented on [`precompute_field`]).

use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::bundle::{
    EyePlacement, Region, Spread, TracedBundle, perpendicular_frame, pupil_samples, region,
    set_map, trace_bundle_counted,
};
use super::error::{LensSide, SpectaclesError};
use super::eye::Eye;
use super::lens_design::SpectacleLens;
use super::lens_mesh::{MAX_POLAR_POINTS, polar_point_count, polar_points, too_many_points};
use crate::input::{self, Expected, InvalidInput};
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

/// How to build a field: the voxel box and resolution, `S`, the aim layout.
///
/// Start from [`FieldSettings::paper`] and change what differs with the
/// checked `with_*` methods (or [`FieldSettings::scaled`]); every size is
/// checked against the caps ([`MAX_CLONES`], [`MAX_AIMS`],
/// [`MAX_FIELD_VECTORS`], [`MAX_WALK_CROSSINGS`]) before anything is
/// allocated, so a [`FieldSettings`] always describes a field that can be
/// built. Deserialisation runs the same checks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawFieldSettings")]
pub struct FieldSettings {
    min: DVec3,
    max: DVec3,
    dims: [usize; 3],
    clones: usize,
    aim_rings: usize,
    aim_segments: usize,
    window_radius_m: f64,
    window_z_m: f64,
    fill_empty: bool,
    average: VoxelAverage,
    fill_rule: FillRule,
    grid: FieldGrid,
}

/// How the field's voxels are laid out (not in the paper; the journal
/// version names "a voxel grid in eye coordinates" as future work).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum FieldGrid {
    /// The paper's: a box of voxels in the eye's frame, from the settings'
    /// min to max corner; a point beyond it takes the set where its sight
    /// line leaves the box, scaled by distance.
    #[default]
    Box,
    /// Eye coordinates: cells uniform in the sight line's direction from
    /// the centre of rotation (`x/z'`, `y/z'`, z' measured from it) and in
    /// its dioptric distance `1/z'`, so voxels are small near the eye and
    /// grow with distance as the blur's own scale does, and the last layer
    /// reaches infinity. The settings' box gives the extent: the angles of
    /// its far face seen from the centre of rotation, every distance from
    /// its near face to infinity. Each voxel keeps its set for the
    /// distance of its centre; a point takes its voxel's set scaled by its
    /// distance over that one (a set is an angle times distance), and a
    /// point beyond the angles takes the set at the grid's edge. The
    /// projection `(x, y, z') ↦ (x/z', y/z', 1/z')` maps straight lines in
    /// front of the centre to straight lines, so the reference rays are
    /// walked through these cells by the same Amanatides–Woo traversal, to
    /// their vanishing point at `1/z' = 0`.
    Eye,
}

/// How the voxels no reference ray crossed are filled (step 5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum FillRule {
    /// Each empty voxel takes the set of its nearest crossed voxel (face
    /// steps, the L1 distance): a distance transform of a few sequential
    /// sweeps, then one copy per voxel. The default: about as close to the
    /// direct reference as [`FillRule::LayeredMean`] (the `spectacles`
    /// sweep compares them) at a fraction of its time.
    #[default]
    Nearest,
    /// Layer by layer outwards from the crossed voxels, each empty voxel
    /// takes the mean of its neighbours in the layer before (a smoother
    /// extrapolation; its layers must be done one after another, with
    /// scattered reads).
    LayeredMean,
}

/// The serialised form of [`FieldSettings`], unchecked.
#[derive(Deserialize)]
struct RawFieldSettings {
    min: DVec3,
    max: DVec3,
    dims: [usize; 3],
    clones: usize,
    aim_rings: usize,
    aim_segments: usize,
    window_radius_m: f64,
    window_z_m: f64,
    fill_empty: bool,
    #[serde(default)]
    average: VoxelAverage,
    #[serde(default)]
    fill_rule: FillRule,
    #[serde(default)]
    grid: FieldGrid,
}

impl TryFrom<RawFieldSettings> for FieldSettings {
    type Error = InvalidInput;

    fn try_from(r: RawFieldSettings) -> Result<Self, InvalidInput> {
        Self {
            min: r.min,
            max: r.max,
            dims: r.dims,
            clones: r.clones,
            aim_rings: r.aim_rings,
            aim_segments: r.aim_segments,
            window_radius_m: r.window_radius_m,
            window_z_m: r.window_z_m,
            fill_empty: r.fill_empty,
            average: r.average,
            fill_rule: r.fill_rule,
            grid: r.grid,
        }
        .checked()
    }
}

/// Fewest segments of the aim layout: a triangle is the smallest ring.
const MIN_AIM_SEGMENTS: usize = 3;

/// The outermost ring of aims sits this fraction inside the lens's rim, so
/// that round-off never puts it just outside the blank, where the trace
/// reports a miss (25 pm on a 50 mm blank).
const RIM_AIM_INSET: f64 = 1e-9;

impl FieldSettings {
    /// The paper's setting: 110×77×42 cubic voxels (5 cm; the box spans
    /// x ±2.75 m, y ±1.925 m, z 0.03–2.13 m in front of the eye), `S = 10`,
    /// 24×64 + 1 = 1,537 aims (the paper: ~1,500 bundles of 10 rays), a
    /// naked-eye aim window of the default blank (25 mm radius at the 12 mm
    /// vertex plane); this crate's additions: hole filling on, every
    /// crossing averaged ([`VoxelAverage::AllCrossings`]; the paper's is
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
            fill_rule: FillRule::Nearest,
            grid: FieldGrid::Box,
        }
    }

    /// These settings with the voxel box from corner `min` to corner `max`
    /// (m, eye frame). Errors: non-finite corners, or a box that is not
    /// longer than zero (and finite) along every axis.
    pub fn with_box(self, min: DVec3, max: DVec3) -> Result<Self, InvalidInput> {
        Self { min, max, ..self }.checked()
    }

    /// These settings with `dims` voxels per axis. Errors: a zero, or a
    /// size beyond the caps.
    pub fn with_dims(self, dims: [usize; 3]) -> Result<Self, InvalidInput> {
        Self { dims, ..self }.checked()
    }

    /// These settings with `S = clones` (pupil rays per bundle, and the
    /// clones a voxel's set is expanded to). Errors: 0, more than
    /// [`MAX_CLONES`], or more vectors than [`MAX_FIELD_VECTORS`].
    pub fn with_clones(self, clones: usize) -> Result<Self, InvalidInput> {
        Self { clones, ..self }.checked()
    }

    /// These settings with aims through `1 + rings × segments` points of
    /// the lens (the polar layout of [`SpectacleLens::mesh`]). Errors:
    /// `rings < 1`, `segments < 3`, more aims than [`MAX_AIMS`] or a walk
    /// bound beyond [`MAX_WALK_CROSSINGS`].
    pub fn with_aims(self, rings: usize, segments: usize) -> Result<Self, InvalidInput> {
        Self {
            aim_rings: rings,
            aim_segments: segments,
            ..self
        }
        .checked()
    }

    /// These settings with, for the naked eye (no lens), the aims through a
    /// window of `radius_m` (m) at `z = z_m` (m). Errors: a radius that is
    /// not finite and positive, a non-finite z. (The window must also lie
    /// in front of the eye's centre of rotation, which
    /// [`precompute_field`] checks.)
    pub fn with_naked_eye_window(self, radius_m: f64, z_m: f64) -> Result<Self, InvalidInput> {
        Self {
            window_radius_m: radius_m,
            window_z_m: z_m,
            ..self
        }
        .checked()
    }

    /// These settings with hole filling on or off (step 5 of the module
    /// docs).
    pub fn with_fill_empty(self, fill_empty: bool) -> Self {
        Self { fill_empty, ..self }
    }

    /// These settings with hole filling by `rule` (step 5).
    pub fn with_fill_rule(self, fill_rule: FillRule) -> Self {
        Self { fill_rule, ..self }
    }

    /// How holes are filled.
    pub fn fill_rule(&self) -> FillRule {
        self.fill_rule
    }

    /// These settings with the per-voxel average `average` (step 4).
    pub fn with_average(self, average: VoxelAverage) -> Self {
        Self { average, ..self }
    }

    /// These settings with the voxels laid out by `grid`.
    pub fn with_grid(self, grid: FieldGrid) -> Self {
        Self { grid, ..self }
    }

    /// How the voxels are laid out.
    pub fn grid(&self) -> FieldGrid {
        self.grid
    }

    /// The same box with `k` times the voxels per axis and `k` times the aim
    /// rings and segments (so that the aims keep up with the voxels), each
    /// rounded and at least 1 (segments at least 3).
    ///
    /// Errors: `k` not finite and positive, or sizes beyond the caps.
    pub fn scaled(&self, k: f64) -> Result<Self, InvalidInput> {
        let k = input::positive("field resolution scale", k)?;
        // `as usize` saturates: a huge k gives usize::MAX, which the caps refuse.
        let sc = |n: usize, lo: usize| ((n as f64 * k).round() as usize).max(lo);
        Self {
            dims: [
                sc(self.dims[0], 1),
                sc(self.dims[1], 1),
                sc(self.dims[2], 1),
            ],
            aim_rings: sc(self.aim_rings, 1),
            aim_segments: sc(self.aim_segments, MIN_AIM_SEGMENTS),
            ..*self
        }
        .checked()
    }

    /// Min corner of the voxel box (m, eye frame).
    pub fn min(&self) -> DVec3 {
        self.min
    }

    /// Max corner of the voxel box (m, eye frame).
    pub fn max(&self) -> DVec3 {
        self.max
    }

    /// Voxels per axis.
    pub fn dims(&self) -> [usize; 3] {
        self.dims
    }

    /// `S`: pupil rays per bundle, and the clones a voxel's map is
    /// expanded to by [`DisplacementField::displacements`].
    pub fn clones(&self) -> usize {
        self.clones
    }

    /// Rings of the aim layout.
    pub fn aim_rings(&self) -> usize {
        self.aim_rings
    }

    /// Segments of the aim layout.
    pub fn aim_segments(&self) -> usize {
        self.aim_segments
    }

    /// Radius (m) of the naked eye's aim window.
    pub fn window_radius_m(&self) -> f64 {
        self.window_radius_m
    }

    /// z (m) of the naked eye's aim window.
    pub fn window_z_m(&self) -> f64 {
        self.window_z_m
    }

    /// Whether voxels no reference ray crossed are filled from neighbours.
    pub fn fill_empty(&self) -> bool {
        self.fill_empty
    }

    /// How each voxel's crossings are averaged.
    pub fn average(&self) -> VoxelAverage {
        self.average
    }

    /// Number of aims (bundle pairs), `1 + rings × segments`.
    pub fn aims(&self) -> usize {
        1 + self.aim_rings * self.aim_segments
    }

    /// `self` if every number is usable and every size within the caps.
    /// Every size is checked (checked_mul, caps) before anything is
    /// multiplied or allocated; the values reported are f64 products, which
    /// cannot overflow.
    fn checked(self) -> Result<Self, InvalidInput> {
        let min = input::finite_vec3("field box min corner (m)", self.min)?;
        let max = input::finite_vec3("field box max corner (m)", self.max)?;
        for e in (max - min).to_array() {
            input::positive("field box size (m)", e)?;
        }
        input::positive("naked-eye window radius (m)", self.window_radius_m)?;
        input::finite("naked-eye window z (m)", self.window_z_m)?;
        let at_least = |what, n: usize, min: usize| {
            if n < min {
                Err(InvalidInput::new(
                    what,
                    n as f64,
                    Expected::Range {
                        min: min as f64,
                        max: f64::INFINITY,
                    },
                ))
            } else {
                Ok(())
            }
        };
        for n in self.dims {
            at_least("voxels per axis", n, 1)?;
        }
        at_least("aim rings", self.aim_rings, 1)?;
        at_least("aim segments", self.aim_segments, MIN_AIM_SEGMENTS)?;
        let capped = |what, value: f64, max: usize| {
            InvalidInput::new(
                what,
                value,
                Expected::Range {
                    min: 1.0,
                    max: max as f64,
                },
            )
        };
        if !(1..=MAX_CLONES).contains(&self.clones) {
            return Err(capped("clones", self.clones as f64, MAX_CLONES));
        }
        let aims = polar_point_count(self.aim_rings, self.aim_segments)
            .filter(|&n| n <= MAX_AIMS)
            .ok_or_else(|| {
                too_many_points(
                    "aims 1 + aim rings × aim segments",
                    self.aim_rings,
                    self.aim_segments,
                )
            })?;
        let dims_f = self.dims.iter().map(|&n| n as f64).product::<f64>();
        // Cells index as u32 in the walk.
        let cells = self
            .dims
            .iter()
            .try_fold(1usize, |a, &n| a.checked_mul(n))
            .filter(|&c| c <= u32::MAX as usize);
        let vectors = cells
            .and_then(|c| c.checked_mul(self.clones))
            .filter(|&n| n <= MAX_FIELD_VECTORS);
        if vectors.is_none() {
            return Err(capped(
                "voxels × clones",
                dims_f * self.clones as f64,
                MAX_FIELD_VECTORS,
            ));
        }
        let walk = self
            .dims
            .iter()
            .try_fold(3usize, |a, &n| a.checked_add(n))
            .and_then(|w| w.checked_mul(aims));
        if walk.is_none_or(|w| w > MAX_WALK_CROSSINGS) {
            let w = self.dims.iter().map(|&n| n as f64).sum::<f64>() + 3.0;
            return Err(capped(
                "aims × (nx + ny + nz + 3) (bound on voxel crossings)",
                w * aims as f64,
                MAX_WALK_CROSSINGS,
            ));
        }
        Ok(self)
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
/// `1 <= S <= MAX_CLONES`, `maps.len() = voxels × 2`, every vector
/// finite), so a field read from disk cannot panic in a lookup.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawDisplacementField")]
pub struct DisplacementField {
    /// Geometry, and per voxel the number of reference-ray crossings (0: not
    /// crossed; filled from neighbours if the settings said so, else zeros).
    counts: VoxelGrid<u32>,
    /// Per voxel the set as a linear map of the pupil, `[m_x, m_y]`
    /// ([`TracedBundle::linear_map`]), voxel-major (`cells × 2`), in
    /// metres, `f32` (what the GPU gets).
    maps: Vec<Vec3>,
    clones: usize,
    stats: FieldStats,
    /// Where the voxels lie: `counts`' box in the eye's frame, or in eye
    /// coordinates `(x/z', y/z', 1/z')` about the centre of rotation.
    #[serde(default)]
    layout: FieldLayout,
}

/// A field's voxel layout and, for eye coordinates, their centre.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub enum FieldLayout {
    /// A box in the eye's frame.
    #[default]
    Box,
    /// Eye coordinates about the centre of rotation at `(0, 0, centre_z)`.
    Eye {
        /// z of the centre of rotation (m).
        centre_z: f64,
    },
}

/// The serialised form of a [`DisplacementField`], unchecked.
#[derive(Deserialize)]
struct RawDisplacementField {
    counts: VoxelGrid<u32>,
    maps: Vec<Vec3>,
    clones: usize,
    stats: FieldStats,
    #[serde(default)]
    layout: FieldLayout,
}

impl TryFrom<RawDisplacementField> for DisplacementField {
    type Error = InvalidInput;

    fn try_from(r: RawDisplacementField) -> Result<Self, InvalidInput> {
        let clones = Expected::Range {
            min: 1.0,
            max: MAX_CLONES as f64,
        };
        if !(1..=MAX_CLONES).contains(&r.clones) {
            return Err(InvalidInput::new("field clones", r.clones as f64, clones));
        }
        if r.counts.len().checked_mul(2) != Some(r.maps.len()) {
            let n = r.counts.len() as f64 * 2.0;
            return Err(InvalidInput::new(
                "field maps (voxels × 2)",
                r.maps.len() as f64,
                Expected::Range { min: n, max: n },
            ));
        }
        for v in &r.maps {
            input::finite_vec3("field map vector (m)", v.as_dvec3())?;
        }
        if let FieldLayout::Eye { centre_z } = r.layout {
            input::finite("field centre z (m)", centre_z)?;
        }
        Ok(Self {
            counts: r.counts,
            maps: r.maps,
            clones: r.clones,
            stats: r.stats,
            layout: r.layout,
        })
    }
}

/// One voxel crossing of one reference ray.
#[derive(Clone, Copy)]
struct Crossing {
    cell: u32,
    aim: u32,
    region: Region,
    s: f64,
    /// The set's scale to the voxel's own distance (eye coordinates; 1 in
    /// a box).
    scale: f64,
}

/// Eye coordinates `(x/z', y/z', 1/z')` of an eye-frame point, z' from the
/// centre of rotation at `centre_z`; `None` at or behind the centre.
fn eye_coordinates(p: DVec3, centre_z: f64) -> Option<DVec3> {
    let z = p.z - centre_z;
    (z > 0.0).then(|| DVec3::new(p.x / z, p.y / z, 1.0 / z))
}

/// The aims (unit directions from the centre of rotation).
fn aims(
    lens: Option<&SpectacleLens>,
    placement: &EyePlacement,
    st: &FieldSettings,
) -> Result<Vec<DVec3>, SpectaclesError> {
    let centre = placement.centre_of_rotation();
    let radius = match lens {
        Some(l) => l.rim_radius_m() * (1.0 - RIM_AIM_INSET),
        None => {
            let ahead = st.window_z_m - centre.z;
            input::positive(
                "naked-eye window z in front of the centre of rotation (m)",
                ahead,
            )?;
            st.window_radius_m
        }
    };
    polar_points(radius, st.aim_rings, st.aim_segments)?
        .into_iter()
        .map(|(x, y)| {
            let p = match lens {
                // Over the blank wherever a decentred lens sits.
                Some(l) => {
                    l.back()
                        .point(x, y)
                        .ok_or_else(|| l.not_to_rim(LensSide::Back))?
                        + l.decentration_m().extend(0.0)
                }
                None => DVec3::new(x, y, st.window_z_m),
            };
            Ok(input::direction(
                "aim from the centre of rotation",
                p - centre,
            )?)
        })
        .collect()
}

/// The near and far bundles of one aim (`None` when a ray of either does
/// not get through the lens: the aim is skipped), and the rays traced.
fn trace_pair(
    lens: Option<&SpectacleLens>,
    placement: &EyePlacement,
    eye: &Eye,
    aim: DVec3,
    samples: &[DVec2],
) -> (
    Result<Option<(TracedBundle, TracedBundle)>, SpectaclesError>,
    usize,
) {
    let rho = 0.5 * eye.pupil_diameter_m();
    let mut traced = 0;
    let (e1, e2) = perpendicular_frame(aim);
    let mut trace = |accommodation: f64| {
        let v = eye.vergence_matrix(e1, e2, accommodation);
        match trace_bundle_counted(lens, placement, aim, rho, v, samples, &mut traced) {
            Ok(b) => Ok(Some(b)),
            Err(SpectaclesError::BundleBlocked(_)) => Ok(None),
            Err(e) => Err(e),
        }
    };
    let pair = match trace(eye.accommodation_d()) {
        Ok(Some(near)) => trace(0.0).map(|far| far.map(|far| (near, far))),
        other => other.map(|_| None),
    };
    (pair, traced)
}

/// Precomputes the field for `eye` at `placement` looking through `lens`
/// (`None`: the naked eye) with settings `st`: the voxel field of
/// displacement-vector sets (paper §4.3, Figs. 6–7), a map from a point in
/// front of the eye to the `S` clone displacements that blur it, valid
/// while the eye and lens stay fixed.
///
/// Precompute:
/// 1. Aims: the reference rays from the centre of rotation through the lens's
///    back-surface points (the mesh vertex layout; the paper: "usually the
///    vertices will do", 通常は頂点でよい; ~1,500 at the paper's setting).
///    Without a lens, through the same layout on a window at the vertex
///    plane.
/// 2. Per aim, the near bundle (`V = P_near`) and the far bundle
///    (`V = P_far`) of `S` pupil rays ([`trace_bundle`](super::trace_bundle)), traced through the
///    lens; their fitted vergences `W_near`, `W_far` place the corrected near
///    and far points. In parallel (rayon).
/// 3. Walk the voxels the refracted reference ray crosses (J. Amanatides and
///    A. Woo, "A fast voxel traversal algorithm for ray tracing",
///    Eurographics 1987; the paper's ref. 10). In each, at the midpoint `s` of the
///    ray's segment in the voxel, the set is the near bundle's displacements
///    if nearer than the corrected near point, the far bundle's (mirrored) if
///    beyond the corrected far point, else all zero (§4.2: in focus).
/// 4. Average the sets per voxel. Each set is kept as its linear map of
///    the pupil (not in the paper: [`TracedBundle::linear_map`], two
///    vectors per voxel instead of `S`), which is exact for the naked eye
///    and to first order through a lens, makes the field `S/2` times
///    smaller, and lets the number of clones drawn change without a new
///    precompute; averaging maps is averaging their sets. Default, not in the paper
///    ([`VoxelAverage::AllCrossings`]): every crossing counts, in-focus ones
///    as zero sets. The paper (§4.3) averages only the sets recorded, the
///    near and far crossings ([`VoxelAverage::RecordedSets`], an option of
///    [`FieldSettings::with_average`]); the two differ only in voxels straddling
///    the corrected near or far point, and the default measures slightly
///    closer to the direct reference (see [`VoxelAverage`]). Either way a
///    voxel crossed only in focus is zero (sharp) and counts as crossed.
/// 5. Optional, not in the paper: voxels no reference ray crossed take the
///    set of their nearest crossed voxel, or the mean of their filled face
///    neighbours layer by layer ([`FillRule`], [`FieldSettings::with_fill_rule`];
///    on or off: [`FieldSettings::with_fill_empty`]). The paper leaves them at zero
///    (sharp), which with ~1,500 aims leaves most far voxels uncovered.
///
/// Lookup (run time): the voxel containing the vertex, one transform; clone
/// `i` takes vector `i` of the set.
///
/// Errors: a bad grid box ([`SpectaclesError::Voxel`]); for the naked eye,
/// an aim window not in front of the centre of rotation, and a centre of
/// rotation on the lens's back surface ([`SpectaclesError::Input`]). Aims
/// whose bundles do not get through the lens (TIR, rim) are skipped and
/// counted in [`FieldStats::aims_failed`]; if no aim gets through (an eye
/// placed where it does not look through the lens),
/// [`SpectaclesError::NoRays`].
pub fn precompute_field(
    eye: &Eye,
    placement: &EyePlacement,
    lens: Option<&SpectacleLens>,
    st: &FieldSettings,
) -> Result<DisplacementField, SpectaclesError> {
    // The grid's geometry alone (no storage: `()` cells) for the walk; the
    // counts are made in step 4.
    let centre_z = placement.centre_of_rotation().z;
    let (layout, grid_lo, grid_hi) = match st.grid {
        FieldGrid::Box => (FieldLayout::Box, st.min, st.max),
        FieldGrid::Eye => {
            let (near, far) = (st.min.z - centre_z, st.max.z - centre_z);
            if !(near > 0.0) {
                return Err(InvalidInput::new(
                    "field box near face (m), in front of the centre of rotation",
                    st.min.z,
                    Expected::AtLeast(centre_z),
                )
                .into());
            }
            (
                FieldLayout::Eye { centre_z },
                DVec3::new(st.min.x / far, st.min.y / far, 0.0),
                DVec3::new(st.max.x / far, st.max.y / far, 1.0 / near),
            )
        }
    };
    let grid = VoxelGrid::from_bounds(grid_lo, grid_hi, st.dims, ())?;
    let n_cells = grid.len();
    let s_clones = st.clones;
    let samples: Vec<DVec2> = pupil_samples(s_clones);
    let aim_dirs = aims(lens, placement, st)?;
    // Step 2: bundles, in parallel, counting the rays actually traced.
    let (bundles, traced): (Vec<_>, Vec<usize>) = aim_dirs
        .par_iter()
        .map(|&a| trace_pair(lens, placement, eye, a, &samples))
        .unzip();
    let bundles: Vec<Option<(TracedBundle, TracedBundle)>> =
        bundles.into_iter().collect::<Result<_, _>>()?;
    // Some aims fail at the rim; if all do, the eye does not look through
    // the lens at all, and an all-sharp field would hide that.
    if bundles.iter().all(Option::is_none) {
        return Err(SpectaclesError::NoRays);
    }
    // Step 3: walk the grid along each refracted reference ray, in parallel.
    let mut crossings: Vec<Crossing> = bundles
        .par_iter()
        .enumerate()
        .flat_map_iter(|(k, b)| {
            let walk = b.as_ref().map(|(near, far)| {
                let chief = *near.chief();
                let (wn, wf) = (near.vergence_d(), far.vergence_d());
                let cells = crossed_cells(&grid, &chief, layout);
                cells.into_iter().filter_map(move |(cell, s, scale)| {
                    let idx = cell[0] + st.dims[0] * (cell[1] + st.dims[1] * cell[2]);
                    (s > 0.0).then(|| Crossing {
                        cell: idx as u32,
                        aim: k as u32,
                        region: region(s, wn, wf),
                        s,
                        scale,
                    })
                })
            });
            walk.into_iter().flatten()
        })
        .collect();
    crossings.par_sort_unstable_by_key(|c| c.cell);
    // Step 4: average per voxel. The crossings are sorted by voxel, so
    // each crossed voxel is one run of them: the runs are averaged in
    // parallel, then written into the (otherwise zero) field.
    let mut runs: Vec<(usize, usize, usize)> = Vec::new();
    let mut lo = 0;
    for hi in 1..=crossings.len() {
        if hi == crossings.len() || crossings[hi].cell != crossings[lo].cell {
            runs.push((crossings[lo].cell as usize, lo, hi));
            lo = hi;
        }
    }
    // An astigmatic eye is never quite in focus: between its corrected
    // near and far points it keeps the astigmatism the lens leaves.
    let astigmatic = eye.cylinder_d() != 0.0;
    let mut sets = vec![Vec3::ZERO; runs.len() * 2];
    sets.par_chunks_mut(2)
        .zip(&runs)
        .for_each(|(out, &(_, lo, hi))| {
            let mut sum = [DVec3::ZERO; 2];
            let mut recorded = 0usize;
            for c in &crossings[lo..hi] {
                let Some((near, far)) = &bundles[c.aim as usize] else {
                    continue;
                };
                let Some(m) = set_map(near, far, c.region, c.s, astigmatic) else {
                    continue;
                };
                sum[0] += m[0] * c.scale;
                sum[1] += m[1] * c.scale;
                recorded += 1;
            }
            let n = match st.average {
                VoxelAverage::RecordedSets => recorded,
                VoxelAverage::AllCrossings => hi - lo,
            };
            // No set recorded (crossed only in focus): zero, sharp.
            if n > 0 {
                out[0] = (sum[0] / n as f64).as_vec3();
                out[1] = (sum[1] / n as f64).as_vec3();
            }
        });
    let mut maps = vec![Vec3::ZERO; n_cells * 2];
    let mut cnt = vec![0u32; n_cells];
    for (k, &(cell, lo, hi)) in runs.iter().enumerate() {
        maps[cell * 2..cell * 2 + 2].copy_from_slice(&sets[k * 2..k * 2 + 2]);
        cnt[cell] = (hi - lo) as u32;
    }
    drop(sets);
    let sets_recorded = crossings
        .iter()
        .filter(|c| astigmatic || c.region != Region::InFocus)
        .count();
    let voxels_crossed = cnt.iter().filter(|&&c| c > 0).count();
    let counts = VoxelGrid::from_vec(grid_lo, grid.cell_size(), st.dims, cnt)?;

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
        // In eye coordinates a voxel's set is for its centre's distance:
        // filled as angles (divided by that distance), so that a set
        // carried across layers keeps its angle, not its size.
        let per_layer = st.dims[0] * st.dims[1];
        let layer_w =
            |i: usize| grid_lo.z + ((i / 2 / per_layer) as f64 + 0.5) * grid.cell_size().z;
        if layout != FieldLayout::Box {
            for (i, v) in maps.iter_mut().enumerate() {
                *v *= layer_w(i) as f32;
            }
        }
        let (filled, passes) = match st.fill_rule {
            FillRule::Nearest => fill_nearest(&counts, &mut maps, 2),
            FillRule::LayeredMean => fill_empty(&counts, &mut maps, 2),
        };
        if layout != FieldLayout::Box {
            for (i, v) in maps.iter_mut().enumerate() {
                *v /= layer_w(i) as f32;
            }
        }
        stats.voxels_filled = filled;
        stats.fill_passes = passes;
    }
    Ok(DisplacementField {
        counts,
        maps,
        clones: s_clones,
        stats,
        layout,
    })
}

/// The voxels a refracted reference ray crosses (step 3): each with the
/// distance `s` along the ray where its set is taken and the factor that
/// carries that set to the voxel's own distance.
///
/// In a box: the segment's midpoint, factor 1. In eye coordinates the ray
/// is a straight segment from its origin's image to its vanishing point
/// `(d_x/d_z, d_y/d_z, 0)`; in each voxel the set is taken at the
/// segment's dioptric midpoint (blur is linear in dioptres), and carried
/// to the voxel centre's distance (`1/z'` at the centre) by the ratio of
/// the distances. A ray that does not travel away from the eye crosses
/// nothing.
fn crossed_cells(
    grid: &VoxelGrid<()>,
    chief: &Ray,
    layout: FieldLayout,
) -> Vec<([usize; 3], f64, f64)> {
    match layout {
        FieldLayout::Box => grid
            .traverse(chief)
            .map(|(cell, t0, t1)| (cell, 0.5 * (t0 + t1), 1.0))
            .collect(),
        FieldLayout::Eye { centre_z } => {
            let (o, d) = (chief.origin(), chief.dir());
            let (Some(start), true) = (eye_coordinates(o, centre_z), d.z > 0.0) else {
                return Vec::new();
            };
            let vanishing = DVec3::new(d.x / d.z, d.y / d.z, 0.0);
            let length = (vanishing - start).length();
            let Ok(segment) = Ray::new(start, vanishing - start) else {
                return Vec::new();
            };
            let z_origin = o.z - centre_z;
            let (w_lo, w_size) = (grid.origin().z, grid.cell_size().z);
            grid.traverse_segment(&segment, 0.0, length)
                .filter_map(|(cell, t0, t1)| {
                    let w = |t: f64| start.z * (1.0 - t / length);
                    let w_mid = 0.5 * (w(t0) + w(t1));
                    let w_centre = w_lo + (cell[2] as f64 + 0.5) * w_size;
                    (w_mid > 0.0).then(|| (cell, (1.0 / w_mid - z_origin) / d.z, w_mid / w_centre))
                })
                .collect()
        }
    }
}

/// The L1 distance transform of [`fill_nearest`] and [`fill_empty`]: in
/// a grid of face neighbours, a voxel's breadth-first layer from the
/// crossed voxels is its L1 distance to the nearest of them, which a
/// forward and a backward sweep along each axis find exactly (the metric
/// is separable). `dist` starts at 0 on crossed voxels and "far" elsewhere;
/// `carry` (the nearest crossed voxel) is carried along every improvement.
/// Each sweep steps whole rows (along y) or planes (along z) at a time, so
/// memory is read in order and the work splits across threads.
fn l1_sweeps(dims: [usize; 3], dist: &mut [u32], carry: &mut [u32]) {
    let (sx, sy) = (dims[0], dims[0] * dims[1]);
    // `to[i] ← from[i] + 1` where that is nearer, element-wise.
    fn relax(from_d: &[u32], from_c: &[u32], to_d: &mut [u32], to_c: &mut [u32]) {
        for i in 0..to_d.len() {
            if from_d[i] + 1 < to_d[i] {
                to_d[i] = from_d[i] + 1;
                to_c[i] = from_c[i];
            }
        }
    }
    // Sweeps over consecutive blocks of `block` elements (rows of a slab,
    // planes of the grid), forwards then backwards.
    fn blocks(dist: &mut [u32], carry: &mut [u32], block: usize, parallel: bool) {
        let n = dist.len() / block;
        let step = |dist: &mut [u32], carry: &mut [u32], a: usize, b: usize| {
            let (lo, hi) = (a.min(b), a.max(b));
            let (d_lo, d_hi) = dist.split_at_mut(hi * block);
            let (c_lo, c_hi) = carry.split_at_mut(hi * block);
            let (d_lo, c_lo) = (&mut d_lo[lo * block..], &mut c_lo[lo * block..]);
            let (d_hi, c_hi) = (&mut d_hi[..block], &mut c_hi[..block]);
            let chunk = 4096;
            if a < b {
                if parallel {
                    d_lo.par_chunks(chunk)
                        .zip(c_lo.par_chunks(chunk))
                        .zip(d_hi.par_chunks_mut(chunk).zip(c_hi.par_chunks_mut(chunk)))
                        .for_each(|((fd, fc), (td, tc))| relax(fd, fc, td, tc));
                } else {
                    relax(d_lo, c_lo, d_hi, c_hi);
                }
            } else if parallel {
                d_hi.par_chunks(chunk)
                    .zip(c_hi.par_chunks(chunk))
                    .zip(d_lo.par_chunks_mut(chunk).zip(c_lo.par_chunks_mut(chunk)))
                    .for_each(|((fd, fc), (td, tc))| relax(fd, fc, td, tc));
            } else {
                relax(d_hi, c_hi, d_lo, c_lo);
            }
        };
        for k in 1..n {
            step(dist, carry, k - 1, k);
        }
        for k in (1..n).rev() {
            step(dist, carry, k, k - 1);
        }
    }
    // Along x: within each row, in parallel over rows.
    dist.par_chunks_mut(sx)
        .zip(carry.par_chunks_mut(sx))
        .for_each(|(d, c)| {
            for k in 1..sx {
                if d[k - 1] + 1 < d[k] {
                    d[k] = d[k - 1] + 1;
                    c[k] = c[k - 1];
                }
            }
            for k in (1..sx).rev() {
                if d[k] + 1 < d[k - 1] {
                    d[k - 1] = d[k] + 1;
                    c[k - 1] = c[k];
                }
            }
        });
    // Along y: row by row within each slab, in parallel over slabs.
    dist.par_chunks_mut(sy)
        .zip(carry.par_chunks_mut(sy))
        .for_each(|(d, c)| blocks(d, c, sx, false));
    // Along z: plane by plane, each plane split across threads.
    blocks(dist, carry, sy, true);
}

/// The L1 distance of every voxel to the nearest crossed voxel, and that
/// voxel (`u32::MAX / 2` and itself where the grid has none crossed).
fn nearest_crossed(counts: &VoxelGrid<u32>) -> (Vec<u32>, Vec<u32>) {
    let unreached = u32::MAX / 2;
    let mut dist: Vec<u32> = counts
        .cells()
        .iter()
        .map(|&c| if c > 0 { 0 } else { unreached })
        .collect();
    let mut nearest: Vec<u32> = (0..dist.len() as u32).collect();
    l1_sweeps(counts.dims(), &mut dist, &mut nearest);
    (dist, nearest)
}

/// Step 5, [`FillRule::Nearest`]: every voxel with no crossing takes the
/// values of its nearest crossed voxel (L1, ties broken by the sweeps).
/// Returns (voxels filled, the largest distance in voxels).
fn fill_nearest(counts: &VoxelGrid<u32>, values: &mut [Vec3], s: usize) -> (usize, usize) {
    let (dist, nearest) = nearest_crossed(counts);
    // The crossed voxels are never written: copy their values out once,
    // so the gather below reads one array and writes another.
    let crossed: Vec<usize> = (0..dist.len()).filter(|&i| dist[i] == 0).collect();
    let mut rank = vec![0u32; dist.len()];
    let mut known = Vec::with_capacity(crossed.len() * s);
    for (r, &i) in crossed.iter().enumerate() {
        rank[i] = r as u32;
        known.extend_from_slice(&values[i * s..(i + 1) * s]);
    }
    values
        .par_chunks_mut(s)
        .zip(dist.par_iter().zip(nearest.par_iter()))
        .for_each(|(out, (&d, &n))| {
            if d > 0 {
                let r = rank[n as usize] as usize;
                out.copy_from_slice(&known[r * s..(r + 1) * s]);
            }
        });
    let layers = dist.iter().copied().max().unwrap_or(0) as usize;
    (dist.len() - crossed.len(), layers)
}

/// Step 5, [`FillRule::LayeredMean`]: every voxel with no crossing takes
/// the mean of its face neighbours that were filled before it, layer by
/// layer outwards from the crossed voxels (layer k is the voxels at L1
/// distance k from the nearest crossed one, [`l1_sweeps`]; the voxels are
/// ordered by layer by a counting sort). The known neighbours of a layer-k
/// voxel are exactly its layer-(k − 1) neighbours (face neighbours' layers
/// differ by at most one), so each layer is filled in parallel from the
/// one before it and every voxel is visited once: O(cells·s). Returns
/// (voxels filled, layers).
fn fill_empty(counts: &VoxelGrid<u32>, values: &mut [Vec3], s: usize) -> (usize, usize) {
    let dims = counts.dims();
    let (sx, sy) = (dims[0], dims[0] * dims[1]);
    let (layer, _) = nearest_crossed(counts);
    // Voxels by layer, index order within a layer (counting sort).
    let layers = layer.iter().copied().max().unwrap_or(0) as usize;
    let mut start = vec![0usize; layers + 2];
    for &l in &layer {
        start[l as usize + 1] += 1;
    }
    for k in 1..start.len() {
        start[k] += start[k - 1];
    }
    let mut order = vec![0u32; layer.len()];
    let mut next = start.clone();
    for (i, &l) in layer.iter().enumerate() {
        order[next[l as usize]] = i as u32;
        next[l as usize] += 1;
    }
    let neighbours = |i: usize| {
        let [x, y, z] = [i % sx, (i / sx) % dims[1], i / sy];
        [
            (x > 0).then(|| i - 1),
            (x + 1 < dims[0]).then(|| i + 1),
            (y > 0).then(|| i - sx),
            (y + 1 < dims[1]).then(|| i + sx),
            (z > 0).then(|| i - sy),
            (z + 1 < dims[2]).then(|| i + sy),
        ]
    };
    let mut means = Vec::new();
    for k in 1..=layers {
        let front = &order[start[k]..start[k + 1]];
        means.clear();
        means.resize(front.len() * s, Vec3::ZERO);
        let known: &[Vec3] = values;
        let layer = &layer;
        means
            .par_chunks_mut(s)
            .zip(front.par_iter())
            .for_each(|(out, &i)| {
                let mut n = 0.0f32;
                for j in neighbours(i as usize).into_iter().flatten() {
                    if layer[j] + 1 == k as u32 {
                        n += 1.0;
                        out.iter_mut()
                            .zip(&known[j * s..(j + 1) * s])
                            .for_each(|(a, b)| *a += *b);
                    }
                }
                out.iter_mut().for_each(|v| *v /= n);
            });
        for (m, &i) in means.chunks_exact(s).zip(front) {
            let i = i as usize;
            values[i * s..(i + 1) * s].copy_from_slice(m);
        }
    }
    (counts.len() - start[1], layers)
}

/// The vectors of `map` for `clones` pupil samples ([`pupil_samples`]):
/// clone `i` moves by `xᵢ·m_x + yᵢ·m_y`. The plugin's vertex shader does
/// the same per clone.
pub fn expand(map: [Vec3; 2], clones: usize) -> Vec<Vec3> {
    pupil_samples(clones)
        .iter()
        .map(|p| map[0] * p.x as f32 + map[1] * p.y as f32)
        .collect()
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

    /// The maps of every voxel, `cells × 2` vectors (`m_x`, `m_y` of
    /// voxel 0, then of voxel 1, …; voxels x fastest), for upload.
    pub fn maps(&self) -> &[Vec3] {
        &self.maps
    }

    /// The set of `cell` as a linear map of the pupil, `[m_x, m_y]`: clone
    /// of pupil point `(x, y)` moves by `x·m_x + y·m_y`.
    pub fn map(&self, cell: [usize; 3]) -> Option<[Vec3; 2]> {
        let i = self.counts.index(cell)?;
        Some([self.maps[2 * i], self.maps[2 * i + 1]])
    }

    /// How the voxels are laid out.
    pub fn layout(&self) -> FieldLayout {
        self.layout
    }

    /// In eye coordinates: the set at `point`, blended linearly in
    /// dioptric distance between the two layers of voxels around it (a
    /// set is linear in dioptres between the corrected near and far
    /// points), each voxel's set carried to the point's distance (the
    /// point's over the voxel centre's). A point beyond the grid's angles,
    /// nearer than its near face or beyond the last layer's centre takes
    /// the voxels at the grid's edge. `None` at or behind the centre, for a
    /// non-finite point, or in a box.
    fn eye_map(&self, point: DVec3) -> Option<[Vec3; 2]> {
        let FieldLayout::Eye { centre_z } = self.layout else {
            return None;
        };
        let q = eye_coordinates(point, centre_z).filter(|q| q.is_finite())?;
        let (lo, size, dims) = (
            self.counts.origin(),
            self.counts.cell_size(),
            self.counts.dims(),
        );
        let across = |a: usize| {
            (((q[a] - lo[a]) / size[a]).floor()).clamp(0.0, (dims[a] - 1) as f64) as usize
        };
        // Layers by their centres: `k` below the point, `k + 1` above.
        let layer = ((q.z - lo.z) / size.z - 0.5).clamp(0.0, (dims[2] - 1) as f64);
        let k = (layer.floor() as usize).min(dims[2] - 1);
        let above = (k + 1).min(dims[2] - 1);
        let f = (layer - k as f64) as f32;
        let z = point.z - centre_z;
        let carried = |k: usize| -> Option<[Vec3; 2]> {
            let scale = (z * (lo.z + (k as f64 + 0.5) * size.z)) as f32;
            let [x, y] = self.map([across(0), across(1), k])?;
            Some([x * scale, y * scale])
        };
        let (a, b) = (carried(k)?, carried(above)?);
        Some([a[0] * (1.0 - f) + b[0] * f, a[1] * (1.0 - f) + b[1] * f])
    }

    /// The map of the voxel containing `point` (the paper's lookup), `None`
    /// outside the box or for a non-finite point. In eye coordinates, the
    /// voxel's map scaled to the point's distance (see [`FieldGrid::Eye`]).
    pub fn map_at(&self, point: DVec3) -> Option<[Vec3; 2]> {
        match self.layout {
            FieldLayout::Box => self.map(self.counts.cell_of(point)?),
            FieldLayout::Eye { .. } => self.eye_map(point),
        }
    }

    /// The set of `cell`: its map applied to the field's `S` pupil samples
    /// ([`pupil_samples`]), one vector per clone.
    pub fn displacements(&self, cell: [usize; 3]) -> Option<Vec<Vec3>> {
        Some(expand(self.map(cell)?, self.clones))
    }

    /// The set of the voxel containing `point` (the paper's lookup), `None`
    /// outside the box or for a non-finite point.
    pub fn displacements_at(&self, point: DVec3) -> Option<Vec<Vec3>> {
        Some(expand(self.map_at(point)?, self.clones))
    }

    /// The map for a vertex at `point` seen from `from` (the eye's pupil),
    /// and the factor its vectors are scaled by: inside the box the map of
    /// the voxel that holds `point` ([`DisplacementField::map_at`],
    /// factor 1); beyond it, the map of the voxel where the sight line from
    /// `from` to `point` leaves the box, scaled by `|point − from| / |exit −
    /// from|` (documented fallback: far from focus a set grows about
    /// linearly with distance, so the blur's angle is kept). `None` when
    /// the sight line never enters the box or a point is not finite (no
    /// blur). The plugin's vertex shader is the twin of this.
    pub fn displacement_along_sight(&self, point: DVec3, from: DVec3) -> Option<([Vec3; 2], f64)> {
        if !point.is_finite() || !from.is_finite() {
            return None;
        }
        if let FieldLayout::Eye { .. } = self.layout {
            return Some((self.eye_map(point)?, 1.0));
        }
        if let Some(map) = self.map_at(point) {
            return Some((map, 1.0));
        }
        let (lo, hi) = self.counts.bounds();
        let d = point - from;
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for a in 0..3 {
            if d[a] == 0.0 {
                if from[a] < lo[a] || from[a] > hi[a] {
                    return None;
                }
            } else {
                let (ta, tb) = ((lo[a] - from[a]) / d[a], (hi[a] - from[a]) / d[a]);
                t0 = t0.max(ta.min(tb));
                t1 = t1.min(ta.max(tb));
            }
        }
        if t1 < t0 || !(t1 > 0.0) {
            return None;
        }
        let q = from + d * t1;
        let size = self.counts.cell_size();
        let dims = self.counts.dims();
        let cell = [0, 1, 2].map(|a| {
            let c = ((q[a] - lo[a]) / size[a]).floor();
            c.clamp(0.0, (dims[a] - 1) as f64) as usize
        });
        Some((self.map(cell)?, 1.0 / t1))
    }

    /// Spread of the set at `point`.
    pub fn spread_at(&self, point: DVec3) -> Option<Spread> {
        self.displacements_at(point)
            .map(|v| Spread::of(v.iter().map(|x| x.as_dvec3())))
    }

    /// The `S` clone vectors of `map` ([`expand`]) for this field's `S`.
    pub fn expand(&self, map: [Vec3; 2]) -> Vec<Vec3> {
        expand(map, self.clones)
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
        FieldSettings::paper().scaled(0.25).unwrap()
    }

    /// Near the eye the paper's voxels (10 cm at half its resolution) span
    /// dioptres (0.1 to 0.2 m is 5 D) and tens of degrees; eye coordinates
    /// at the same voxel count keep a blur's scale across each voxel, so
    /// the sets of points 0.1–0.2 m away come tens of times closer to the
    /// direct reference, and farther ones closer too.
    #[test]
    fn eye_coordinates_follow_the_blur_near_the_eye() {
        use crate::spectacles::field_reference::reference_at;
        let eye = Eye::from_near_far(0.5, 1.3, 0.012).unwrap();
        let pl = EyePlacement::default();
        let lens = design_lens(
            &Prescription::sphere(1.5).unwrap(),
            &LensDesignParams::paper(),
        )
        .unwrap();
        let st = FieldSettings::paper().scaled(0.5).unwrap();
        let boxed = precompute_field(&eye, &pl, Some(&lens), &st).unwrap();
        let eyed = precompute_field(&eye, &pl, Some(&lens), &st.with_grid(FieldGrid::Eye)).unwrap();
        assert!(matches!(eyed.layout(), FieldLayout::Eye { .. }));
        let centre = pl.centre_of_rotation();
        let error = |f: &DisplacementField, z: f64| {
            let mut sum = 0.0;
            let mut n = 0;
            for k in 0..12 {
                let a = k as f64 * 0.5;
                let dir = DVec3::new(
                    0.1 * a.cos() * (k % 3) as f64,
                    0.1 * a.sin() * (k % 3) as f64,
                    1.0,
                )
                .normalize();
                let p = centre + dir * ((z - centre.z) / dir.z);
                let Ok(r) = reference_at(&eye, &pl, Some(&lens), p, 64) else {
                    continue;
                };
                let got = f.spread_at(p).expect("inside the field").rms_radius_m;
                sum += (got - r.spread.rms_radius_m).abs() / r.distance_m;
                n += 1;
            }
            assert!(n >= 8, "{n} points");
            sum / n as f64
        };
        // Near the eye, tens of times closer; over 0.12–1.8 m, several
        // times closer on average. Where the corrected near point falls
        // between two layers (0.3–0.45 m here) the blend across the kink
        // leaves about the box's error.
        let (mut sum_box, mut sum_eye) = (0.0, 0.0);
        for z in [0.12, 0.2, 0.3, 0.45, 0.7, 1.0, 1.8] {
            let (b, e) = (error(&boxed, z), error(&eyed, z));
            eprintln!("{z} m: eye coordinates {e:.2e} rad, box {b:.2e} rad");
            if z < 0.25 {
                assert!(
                    e < 0.1 * b,
                    "at {z} m: eye coordinates {e:.2e} rad, box {b:.2e} rad"
                );
            }
            sum_box += b;
            sum_eye += e;
        }
        assert!(sum_eye < 0.5 * sum_box, "{sum_eye} {sum_box}");
        // Beyond the box's far face the eye grid goes on (its last layer
        // reaches infinity); a point behind the centre has no set.
        assert!(eyed.map_at(DVec3::new(0.0, 0.0, 50.0)).is_some());
        assert!(eyed.map_at(DVec3::new(0.0, 0.0, centre.z - 0.01)).is_none());
    }

    /// A decentred lens blurs from where it sits: its field agrees with
    /// the direct reference through the decentred lens, where the field of
    /// the same lens centred (what the plugin drew before) does not.
    #[test]
    fn a_decentred_lens_s_field_follows_the_lens() {
        use crate::spectacles::field_reference::reference_at;
        let eye = Eye::from_near_far(0.5, 1.3, 0.012).unwrap();
        let pl = EyePlacement::default();
        let rx = Prescription::sphere(1.5)
            .unwrap()
            .with_addition(2.0)
            .unwrap();
        let centred = design_lens(&rx, &LensDesignParams::paper()).unwrap();
        let decentred = centred.decentred(DVec2::new(0.004, -0.006)).unwrap();
        let st = FieldSettings::paper().with_grid(FieldGrid::Eye);
        let moved = precompute_field(&eye, &pl, Some(&decentred), &st).unwrap();
        let kept = precompute_field(&eye, &pl, Some(&centred), &st).unwrap();
        let centre = pl.centre_of_rotation();
        let (mut moved_err, mut kept_err, mut n) = (0.0, 0.0, 0);
        // Beyond the corrected near point (0.45 m here), where the near
        // zone's blur, which decentring moves, shows.
        for z in [0.7, 1.0, 1.5, 2.5] {
            for k in 0..12 {
                let a = k as f64 * 0.5;
                let r = 0.12 * (k % 3) as f64;
                let dir = DVec3::new(r * a.cos(), r * a.sin(), 1.0).normalize();
                let p = centre + dir * ((z - centre.z) / dir.z);
                let Ok(truth) = reference_at(&eye, &pl, Some(&decentred), p, 64) else {
                    continue;
                };
                let err = |f: &DisplacementField| {
                    let got = f.spread_at(p).expect("inside the field").rms_radius_m;
                    (got - truth.spread.rms_radius_m).abs() / truth.distance_m
                };
                moved_err += err(&moved);
                kept_err += err(&kept);
                n += 1;
            }
        }
        assert!(n >= 30, "{n} points");
        let (moved_err, kept_err) = (moved_err / n as f64, kept_err / n as f64);
        eprintln!("decentred field {moved_err:.2e} rad, centred field {kept_err:.2e} rad");
        assert!(moved_err < 0.3 * kept_err, "{moved_err:.2e} {kept_err:.2e}");
        // Through a decentred lens the trace is the centred one moved.
        let ray = Ray::new(centre, DVec3::new(0.05, 0.02, 1.0)).unwrap();
        let shift = DVec3::new(0.004, -0.006, 0.0);
        let local = Ray::new(centre - shift, ray.dir()).unwrap();
        match (
            decentred.trace_from_eye(&ray),
            centred.trace_from_eye(&local),
        ) {
            (
                crate::spectacles::LensTrace::Exit {
                    front: a, dir: da, ..
                },
                crate::spectacles::LensTrace::Exit {
                    front: b, dir: db, ..
                },
            ) => {
                assert!((a - (b + shift)).length() < 1e-15 && (da - db).length() < 1e-15);
            }
            other => panic!("{other:?}"),
        }
        // Off the blank: refused.
        assert!(centred.decentred(DVec2::new(0.03, 0.0)).is_err());
        assert!(centred.decentred(DVec2::NAN).is_err());
    }

    #[test]
    fn voxel_field_beyond_the_box_scales_the_exit_voxel() {
        // Box z 0.03–2.13 m. Inside: the voxel's own set, factor 1. A point
        // 5 m out on a sight line: the set of the voxel where the line
        // leaves the far face, scaled by 5/2.133. A line that passes beside
        // the box, a NaN: no set.
        let eye = Eye::from_near_far(0.5, 1.3, 0.012).unwrap();
        let pl = EyePlacement::default();
        let f = precompute_field(&eye, &pl, None, &small()).unwrap();
        let from = DVec3::new(0.0, 0.0, -0.003);
        let inside = DVec3::new(0.1, -0.2, 1.0);
        let (map, k) = f.displacement_along_sight(inside, from).unwrap();
        assert_eq!((map, k), (f.map_at(inside).unwrap(), 1.0));
        let far = DVec3::new(0.4, 0.2, 5.0);
        let (map, k) = f.displacement_along_sight(far, from).unwrap();
        let t = (f.counts().bounds().1.z - from.z) / (far.z - from.z);
        assert!((k - 1.0 / t).abs() < 1e-12, "{k}");
        let exit = from + (far - from) * t;
        let exit_cell = f.counts().cell_of(exit - DVec3::Z * 1e-9).unwrap();
        assert_eq!(map, f.map(exit_cell).unwrap());
        // Beside the box (x beyond ±2.75 m all the way), behind the eye, NaN.
        assert!(
            f.displacement_along_sight(DVec3::new(9.0, 0.0, 0.02), from)
                .is_none()
        );
        assert!(f.displacement_along_sight(DVec3::NAN, from).is_none());
        assert!(
            f.displacement_along_sight(DVec3::new(0.0, 0.0, 5.0), DVec3::NAN)
                .is_none()
        );
    }

    #[test]
    fn voxel_field_toric_glasses_correct_an_astigmat_at_their_axis() {
        // An eye "−1.00 / −2.00 × 30" (1 D of accommodation, 4 mm pupil).
        // Naked, a point 1.5 m out is blurred (2 D of spherical equivalent
        // and ±1 D across the meridians); through its own prescription it
        // is in focus, and through the same lens turned to axis 120° the
        // astigmatism doubles instead of cancelling (±2 D).
        let pl = EyePlacement::default();
        let eye = Eye::new(-1.0, 1.0, 0.004)
            .unwrap()
            .with_astigmatism(-2.0, 30.0)
            .unwrap();
        let samples = pupil_samples(10);
        let field = |axis: f64| {
            let rx = Prescription::new(-1.0, -2.0, axis).unwrap();
            let lens = design_lens(&rx, &LensDesignParams::default()).unwrap();
            precompute_field(&eye, &pl, Some(&lens), &small()).unwrap()
        };
        let (matching, crossed) = (field(30.0), field(120.0));
        for p in [DVec3::new(0.0, 0.0, 1.5), DVec3::new(0.15, -0.1, 1.0)] {
            let naked = Spread::of(crate::spectacles::naked_eye_displacements(
                &eye, &pl, p, &samples,
            ))
            .rms_radius_m;
            let rms = |f: &DisplacementField| {
                Spread::of(f.displacements_at(p).unwrap().iter().map(|v| v.as_dvec3())).rms_radius_m
            };
            let (m, c) = (rms(&matching), rms(&crossed));
            assert!(m < 0.1 * naked, "{p}: matching {m} vs naked {naked}");
            assert!(c > 0.5 * naked, "{p}: crossed {c} vs naked {naked}");
        }
    }

    #[test]
    fn voxel_field_progressive_lens_sharpens_near_below_and_far_ahead() {
        // A 60-year-old emmetrope (0.5 D of accommodation, 4 mm pupil) in
        // plano progressives with a +2.00 add: the chart 5 m straight ahead
        // is sharp through the top; a book 40 cm away, looked at through
        // the near zone (18 mm below the centre), is sharp too, where
        // single-vision plano glasses leave it 2 D out of focus.
        let pl = EyePlacement::default();
        let eye = Eye::new(0.0, 0.5, 0.004).unwrap();
        let field = |add: f64| {
            let rx = Prescription::sphere(0.0)
                .unwrap()
                .with_addition(add)
                .unwrap();
            let lens = design_lens(&rx, &LensDesignParams::default()).unwrap();
            // 2 cm voxels over the book's region and the way ahead.
            let st = FieldSettings::paper()
                .with_box(DVec3::new(-0.3, -0.5, 0.03), DVec3::new(0.3, 0.3, 2.0))
                .and_then(|st| st.with_dims([30, 40, 99]))
                .unwrap();
            (precompute_field(&eye, &pl, Some(&lens), &st).unwrap(), lens)
        };
        let ((progressive, lens), (single, _)) = (field(2.0), field(0.0));
        let rms = |f: &DisplacementField, p: DVec3| {
            Spread::of(f.displacements_at(p).unwrap().iter().map(|v| v.as_dvec3())).rms_radius_m
        };
        let c = pl.centre_of_rotation();
        let through = lens.back().point(0.0, -0.018).unwrap();
        let dir = (through - c).normalize();
        let book = c + dir * ((0.4 - c.z) / dir.z);
        let chart = DVec3::new(0.0, 0.0, 5.0);
        let naked_book = 0.5 * eye.blur_disc_diameter_m((book - c).length()).unwrap() / 2f64.sqrt();
        let (pb, sb) = (rms(&progressive, book), rms(&single, book));
        eprintln!(
            "book: progressive {pb:.2e} m, single vision {sb:.2e} m (naked {naked_book:.2e})"
        );
        assert!(sb > 0.5 * naked_book, "{sb} vs {naked_book}");
        assert!(pb < 0.25 * sb, "{pb} vs {sb}");
        // Far ahead, through the top: sharp in both (the box ends at
        // 2.1 m: the set where the sight line leaves it, scaled).
        let from = pl.pupil_centre(DVec3::Z);
        let far = |f: &DisplacementField| {
            let (m, k) = f.displacement_along_sight(chart, from).unwrap();
            (m[0].length().max(m[1].length()) as f64) * k
        };
        assert!(
            far(&progressive) < 2e-4 && far(&single) < 2e-4,
            "{} {}",
            far(&progressive),
            far(&single)
        );
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
        let st = FieldSettings::paper()
            .scaled(0.5)
            .unwrap()
            .with_fill_empty(false);
        let f = precompute_field(&eye, &pl, None, &st).unwrap();
        assert_eq!(f.stats().aims_failed, 0);
        let h = f.counts().cell_size().z;
        for z in [0.15, 0.35, 0.9, 1.9] {
            let p = DVec3::new(0.001, 0.001, z);
            let cell = f.counts().cell_of(p).unwrap();
            assert!(*f.counts().get(cell).unwrap() > 0);
            let zc = f.counts().cell_center(cell).z - pl.centre_of_rotation().z;
            let got = f.spread_at(p).unwrap().disc_diameter_m();
            let want = eye.blur_disc_diameter_m(zc).unwrap();
            let tol = (a / n).max(a / far) * h / 2.0;
            assert!(
                (got - want).abs() <= tol,
                "z {z}: {got} vs {want} (tolerance {tol})"
            );
        }
        // In focus between 0.5 and 1.3 m: zero.
        assert_eq!(
            f.spread_at(DVec3::new(0.001, 0.001, 0.8))
                .unwrap()
                .rms_radius_m,
            0.0
        );
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
        let lens = design_lens(
            &Prescription::sphere(-1.0 / (1.0 / 3.0 - 0.015)).unwrap(),
            &LensDesignParams::default(),
        )
        .unwrap();
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
        assert!(corrected.maps().iter().all(|v| v.is_finite()));
    }

    #[test]
    fn voxel_field_axis_ray_on_cell_boundary_and_zero_pupil() {
        // Paper box: x = 0 is a cell boundary (55 cells each side) and the
        // axial reference ray runs along +z exactly on it (zero x and y
        // direction components): it must be walked in exactly one of the two
        // columns, the one `cell_of` names (the half-open rule).
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let pl = EyePlacement::paper();
        let st = FieldSettings::paper()
            .with_fill_empty(false)
            .with_aims(2, 4)
            .unwrap();
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
        assert!(f0.maps().iter().all(|v| *v == Vec3::ZERO));
    }

    #[test]
    fn voxel_field_bad_settings_are_refused_where_they_enter() {
        let what = |r: Result<FieldSettings, InvalidInput>| r.unwrap_err().what;
        assert_eq!(what(small().with_clones(0)), "clones");
        assert_eq!(what(small().with_dims([0, 1, 1])), "voxels per axis");
        assert_eq!(
            what(small().with_box(DVec3::NAN, DVec3::ONE)),
            "field box min corner (m)"
        );
        assert_eq!(
            what(small().with_box(DVec3::ZERO, DVec3::new(1.0, f64::INFINITY, 1.0))),
            "field box max corner (m)"
        );
        let inverted = small()
            .with_box(DVec3::new(-2.75, -1.0, 0.0), DVec3::new(-10.0, 1.0, 1.0))
            .unwrap_err();
        assert_eq!(
            (inverted.what, inverted.value),
            ("field box size (m)", -7.25)
        );
        assert_eq!(what(small().with_aims(0, 8)), "aim rings");
        assert_eq!(what(small().with_aims(2, 2)), "aim segments");
        assert_eq!(
            what(small().with_naked_eye_window(0.0, 0.012)),
            "naked-eye window radius (m)"
        );
        assert_eq!(
            what(small().with_naked_eye_window(0.02, f64::NAN)),
            "naked-eye window z (m)"
        );
        assert_eq!(what(small().scaled(0.0)), "field resolution scale");
        assert_eq!(what(small().scaled(f64::NAN)), "field resolution scale");
        // Where the eye is only known at precompute: a naked-eye window
        // behind the centre of rotation (13.5 mm behind the cornea).
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let behind = small().with_naked_eye_window(0.02, -0.02).unwrap();
        match precompute_field(&eye, &EyePlacement::default(), None, &behind) {
            Err(SpectaclesError::Input(e)) => assert_eq!(
                e.what,
                "naked-eye window z in front of the centre of rotation (m)"
            ),
            other => panic!("{other:?}"),
        }
        // An eye in front of the lens looks through it with no aim.
        let lens = design_lens(
            &Prescription::sphere(-2.0).unwrap(),
            &LensDesignParams::default(),
        )
        .unwrap();
        let beyond = EyePlacement::new(DVec3::new(0.0, 0.0, 0.05), 0.0).unwrap();
        assert_eq!(
            precompute_field(&eye, &beyond, Some(&lens), &small()),
            Err(SpectaclesError::NoRays)
        );
        // Deserialised settings are checked the same way.
        let mut v = serde_json::to_value(small()).unwrap();
        assert_eq!(
            serde_json::from_value::<FieldSettings>(v.clone()).unwrap(),
            small()
        );
        v["clones"] = serde_json::json!(0);
        assert!(
            serde_json::from_value::<FieldSettings>(v)
                .unwrap_err()
                .to_string()
                .contains("clones")
        );
    }

    #[test]
    fn voxel_field_huge_settings_are_typed() {
        // Sizes that overflow or are merely huge are rejected before any
        // arithmetic or allocation: no overflow panic, no hang.
        let capped = |r: Result<FieldSettings, InvalidInput>, what: &str| match r {
            Err(e) => e.what == what && matches!(e.expected, Expected::Range { .. }),
            Ok(_) => false,
        };
        // aim rings × segments overflows usize, or is 67 million aims.
        let aims = "aims 1 + aim rings × aim segments";
        assert!(capped(small().with_aims(usize::MAX, 3), aims));
        assert!(capped(small().with_aims(3, usize::MAX), aims));
        assert!(capped(small().with_aims(usize::MAX, usize::MAX), aims));
        assert!(capped(small().with_aims(1 << 20, 64), aims));
        // A million clones on one voxel (old cap: voxels × clones <= u32::MAX).
        assert!(capped(
            small().with_dims([1, 1, 1]).unwrap().with_clones(1 << 20),
            "clones"
        ));
        assert!(capped(small().with_clones(usize::MAX), "clones"));
        // Voxel counts that overflow, or whose walk would be 10^11 crossings.
        assert!(capped(
            small().with_dims([usize::MAX, 2, 1]),
            "voxels × clones"
        ));
        assert!(capped(
            small().with_dims([1 << 40, 1 << 40, 1]),
            "voxels × clones"
        ));
        let walk = "aims × (nx + ny + nz + 3) (bound on voxel crossings)";
        assert!(capped(
            small().with_clones(1).unwrap().with_dims([1 << 26, 1, 1]),
            walk
        ));
        // A scale whose sizes saturate.
        assert!(capped(small().scaled(1e30), aims));
        assert_eq!(FieldSettings::paper().aims(), 1537);
        // The caps' largest sizes are accepted (settings only; nothing is built).
        assert_eq!(
            small()
                .with_dims([1, 1, 1])
                .unwrap()
                .with_clones(MAX_CLONES)
                .unwrap()
                .clones(),
            MAX_CLONES
        );
    }

    #[test]
    fn voxel_field_deserialisation_is_validated() {
        use serde_json::{Value, json};
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let st = small()
            .with_dims([3, 2, 4])
            .unwrap()
            .with_clones(4)
            .unwrap();
        let f = precompute_field(&eye, &EyePlacement::default(), None, &st).unwrap();
        let good = serde_json::to_value(&f).unwrap();
        assert_eq!(
            serde_json::from_value::<DisplacementField>(good.clone()).unwrap(),
            f
        );
        let parse = |edit: &dyn Fn(&mut Value)| {
            let mut v = good.clone();
            edit(&mut v);
            serde_json::from_value::<DisplacementField>(v)
        };
        let refusal = |edit: &dyn Fn(&mut Value)| parse(edit).unwrap_err().to_string();
        // Short storage: `displacements` would slice out of range.
        let short = refusal(&|v| {
            v["maps"].as_array_mut().unwrap().pop();
        });
        assert!(short.starts_with("field maps (voxels × 2) = 47"), "{short}");
        // Zero clones, and a vector that is not finite.
        assert!(refusal(&|v| v["clones"] = json!(0)).starts_with("field clones = 0"));
        // 1e39 overflows f32 to infinity.
        let infinite = refusal(&|v| v["maps"][3] = json!([1.0, 1e39, 0.0]));
        assert!(infinite.starts_with("field map vector (m)"), "{infinite}");
        // A grid with a zero dimension (underflow in `trilinear`) or whose
        // counts do not match its dims (panic in `get`): the grid's own errors.
        assert!(
            refusal(&|v| v["counts"]["dims"] = json!([0, 2, 4]))
                .contains("grid dimensions [0, 2, 4]")
        );
        assert!(
            refusal(&|v| v["counts"]["dims"] = json!([4, 2, 4])).contains("needs 32 cells, got 24")
        );
        let cells = refusal(&|v| {
            v["counts"]["cells"].as_array_mut().unwrap().pop();
        });
        assert!(cells.contains("needs 24 cells, got 23"), "{cells}");
        // Old files without the newer stats counter still load.
        assert!(
            parse(&|v| {
                v["stats"].as_object_mut().unwrap().remove("sets_recorded");
            })
            .is_ok()
        );
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
        let st = FieldSettings::paper()
            .with_box(DVec3::new(-1.0, -1.0, 0.3), DVec3::new(1.0, 1.0, 0.6))
            .and_then(|st| st.with_dims([1, 1, 1]))
            .and_then(|st| st.with_clones(6))
            .and_then(|st| st.with_aims(4, 6))
            .and_then(|st| st.with_naked_eye_window(0.015 * 40f64.to_radians().tan(), 0.012))
            .unwrap()
            .with_fill_empty(false)
            .with_average(VoxelAverage::RecordedSets);
        let f = precompute_field(&eye, &pl, None, &st).unwrap();
        // The expected set, from the bundles and the box's z faces directly.
        let samples = pupil_samples(st.clones());
        let rho = 0.5 * eye.pupil_diameter_m();
        let mut want = vec![DVec3::ZERO; st.clones()];
        let (mut near_n, mut total) = (0usize, 0usize);
        for a in aims(None, &pl, &st).unwrap() {
            let b = trace_bundle_counted(
                None,
                &pl,
                a,
                rho,
                glam::DMat2::IDENTITY * eye.near_point_vergence_d(),
                &samples,
                &mut 0,
            )
            .unwrap();
            let z0 = b.chief().origin().z;
            let s = 0.5 * ((0.3 - z0) + (0.6 - z0)) / a.z;
            total += 1;
            if s < 0.5 {
                near_n += 1;
                want.iter_mut()
                    .zip(b.displacements(s))
                    .for_each(|(w, d)| *w += d);
            } else {
                assert!(s <= 1.3, "{s}: no far crossings in this set-up");
            }
        }
        assert!(
            near_n > 0 && near_n < total,
            "{near_n} of {total}: the voxel must straddle the near point"
        );
        let got = f.displacements([0, 0, 0]).unwrap();
        for (g, w) in got.iter().zip(&want) {
            let w = *w / near_n as f64;
            assert!((g.as_dvec3() - w).length() < 1e-8, "{g} vs {w}");
        }
        assert_eq!(
            (f.stats().crossings, f.stats().sets_recorded),
            (total, near_n)
        );
        assert_eq!(*f.counts().get([0, 0, 0]).unwrap() as usize, total);
        // The option: every crossing counts, the in-focus ones as zeros.
        let all = precompute_field(
            &eye,
            &pl,
            None,
            &st.with_average(VoxelAverage::AllCrossings),
        )
        .unwrap();
        for (g, p) in all.displacements([0, 0, 0]).unwrap().iter().zip(got) {
            assert!((g.as_dvec3() - p.as_dvec3() * (near_n as f64 / total as f64)).length() < 1e-8);
        }
        // A voxel crossed only in focus is zero, not filled.
        let in_focus = st
            .with_box(DVec3::new(-1.0, -1.0, 0.7), DVec3::new(1.0, 1.0, 1.0))
            .unwrap()
            .with_fill_empty(true);
        let f = precompute_field(&eye, &pl, None, &in_focus).unwrap();
        assert_eq!((f.stats().sets_recorded, f.stats().voxels_filled), (0, 0));
        assert!(f.stats().crossings > 0 && f.maps().iter().all(|v| *v == Vec3::ZERO));
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
        let lens = design_lens(
            &Prescription::sphere(-10.0).unwrap(),
            &LensDesignParams::default(),
        )
        .unwrap();
        let f = precompute_field(&eye, &EyePlacement::default(), Some(&lens), &small()).unwrap();
        let s = f.stats();
        let per = 2 * (f.clones() + 1);
        let good = s.aims - s.aims_failed;
        assert!(s.aims_failed > 0 && good > 0, "{s:?}");
        assert!(s.rays_traced >= good * per + s.aims_failed, "{s:?}");
        assert!(
            s.rays_traced <= good * per + s.aims_failed * (per - 1),
            "{s:?}"
        );
    }

    #[test]
    fn voxel_field_fill_covers_every_voxel() {
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let pl = EyePlacement::default();
        let lens = design_lens(
            &Prescription::sphere(-2.0).unwrap(),
            &LensDesignParams::default(),
        )
        .unwrap();
        let f = precompute_field(&eye, &pl, Some(&lens), &small()).unwrap();
        let s = f.stats();
        assert_eq!(
            s.voxels_crossed + s.voxels_filled,
            f.counts().len(),
            "{s:?}"
        );
        assert!(s.fill_passes >= 1 && f.coverage() > 0.0 && f.coverage() < 1.0);
        // Both rules fill every voxel with a finite map, and agree on the
        // crossed voxels: only the holes differ.
        let layered = precompute_field(
            &eye,
            &pl,
            Some(&lens),
            &small().with_fill_rule(FillRule::LayeredMean),
        )
        .unwrap();
        assert_eq!(layered.stats(), f.stats());
        for cell in 0..f.counts().len() {
            let c = f.counts().cell_at_index(cell).unwrap();
            let (a, b) = (f.map(c).unwrap(), layered.map(c).unwrap());
            assert!(a.iter().chain(&b).all(|v| v.is_finite()));
            if *f.counts().get(c).unwrap() > 0 {
                assert_eq!(a, b);
            }
        }
    }

    /// Breadth-first layers from the `true` voxels (6-neighbours), the
    /// definition [`l1_sweeps`] must meet.
    fn bfs_layers(dims: [usize; 3], seeds: &[bool]) -> Vec<u32> {
        let mut layer = vec![u32::MAX; seeds.len()];
        let mut queue: std::collections::VecDeque<usize> =
            (0..seeds.len()).filter(|&i| seeds[i]).collect();
        for &i in &queue {
            layer[i] = 0;
        }
        let (sx, sy) = (dims[0], dims[0] * dims[1]);
        while let Some(i) = queue.pop_front() {
            let [x, y, z] = [i % sx, (i / sx) % dims[1], i / sy];
            let next = [
                (x > 0).then(|| i - 1),
                (x + 1 < dims[0]).then(|| i + 1),
                (y > 0).then(|| i - sx),
                (y + 1 < dims[1]).then(|| i + sx),
                (z > 0).then(|| i - sy),
                (z + 1 < dims[2]).then(|| i + sy),
            ];
            for j in next.into_iter().flatten() {
                if layer[j] == u32::MAX {
                    layer[j] = layer[i] + 1;
                    queue.push_back(j);
                }
            }
        }
        layer
    }

    proptest::proptest! {
        #[test]
        fn voxel_field_distance_transform_is_the_bfs(
            nx in 1usize..7, ny in 1usize..7, nz in 1usize..7,
            bits in proptest::collection::vec(0u8..8, 343),
        ) {
            // Random seeds (about one voxel in eight), at least one.
            let dims = [nx, ny, nz];
            let n = nx * ny * nz;
            let mut seeds: Vec<bool> = bits[..n].iter().map(|&b| b == 0).collect();
            seeds[n / 2] = true;
            let counts = VoxelGrid::from_vec(
                DVec3::ZERO, DVec3::ONE, dims,
                seeds.iter().map(|&s| u32::from(s)).collect(),
            ).unwrap();
            let (dist, nearest) = nearest_crossed(&counts);
            let want = bfs_layers(dims, &seeds);
            proptest::prop_assert_eq!(&dist, &want);
            // The nearest voxel carried along is crossed and at that distance.
            for i in 0..n {
                let j = nearest[i] as usize;
                proptest::prop_assert!(seeds[j]);
                let (a, b) = (counts.cell_at_index(i).unwrap(), counts.cell_at_index(j).unwrap());
                let l1: usize = (0..3).map(|k| a[k].abs_diff(b[k])).sum();
                proptest::prop_assert_eq!(l1 as u32, dist[i]);
            }
        }
    }
}
