//! # Spectacles — seeing through a prescription (CPU reference)
//!
//! The CPU twin of the spectacles plugin, after
//!
//! - 柿本正憲, 立川智章, 西田友是 (Masanori Kakimoto, Tomoaki Tatsukawa,
//!   Tomoyuki Nishita), 「頂点ベースのレイトレーシングを用いた屈折矯正結果の表示」
//!   ("Rendering refractive corrected image using per-vertex ray tracing"),
//!   journal paper in Japanese, SGI Japan and the University of Tokyo;
//!   cited here as "the paper", with its section, figure and equation
//!   numbers; and its English version,
//! - M. Kakimoto, T. Tatsukawa, Y. Mukai, T. Nishita, "Interactive
//!   simulation of the human eye depth of field and its correction by
//!   spectacle lenses", *Computer Graphics Forum* 26(3) (Proc. Eurographics
//!   2007), 2007.
//!
//! Two parts: lens refraction by per-vertex ray tracing into an environment
//! map (§3), and defocus of the naked or corrected eye by cloning scene
//! vertices along precomputed displacement sets (§4).
//!
//! ## The paper's equations and steps
//!
//! Per-vertex ray tracing (§3.1, Fig. 1), every frame:
//! 1. the refraction vector at every vertex of the refracting object (for a
//!    lens: after both surfaces) — [`refract_vertices`], [`LensTrace`];
//! 2. the virtual viewpoint = the point closest to the extensions of some of
//!    those vectors, and the environment map rendered from it —
//!    [`virtual_viewpoint_of_traces`];
//! 3. per vertex: (a) where the refracted ray meets the scene, (b) the line
//!    from there to the virtual viewpoint, (c) its hit on the map's projection
//!    plane, (d) that point as the vertex's texture coordinate (GPU side);
//! 4. draw the object and the scene from the real viewpoint.
//!
//! Defocus (§4.1, Fig. 4): a thin-lens eye with pupil diameter `A`, near point
//! at distance `n`, far point at `f`. A point `z_n` inside the near point, or
//! `z_f` beyond the far point, is spread over a disc perpendicular to the line
//! of sight of diameter
//!
//! ```text
//! D_n = A·z_n / n          (1)
//! D_f = A·z_f / f          (2)
//! ```
//!
//! used as the point-spread function: the scene is drawn `S` times, clone `i`
//! displaced by `dᵢ` scaled to `D_n` or `D_f` (§4.2, Fig. 5), zero between
//! the near and far points, and the `S` images accumulated.
//!
//! Through a lens (§4.3, Figs. 6–7) the displacement sets are precomputed per
//! voxel: from the viewpoint through each lens vertex a reference ray and a
//! bundle from the pupil disc converging at the near (then far) point; all
//! rays refracted twice; the point of best convergence after the lens is the
//! corrected near (far) point; nearer than it (beyond it, for the far bundle),
//! along the refracted reference ray, each voxel crossed (Amanatides–Woo
//! traversal, the paper's ref. 10) records the bundle's spread in the plane
//! perpendicular to the reference ray through the ray's midpoint in the
//! voxel; the sets are averaged per voxel — [`precompute_field`],
//! [`trace_bundle`]. At run time a vertex looks up its voxel
//! ([`DisplacementField::displacements_at`]) and clone `i` takes vector `i`.
//! Here each set is stored as its linear map of the pupil
//! ([`TracedBundle::linear_map`]: exact for the naked eye, first order
//! through a lens), two vectors per voxel instead of `S`, so the field is
//! small enough to follow a prescription slider and `S` is free at run
//! time.
//!
//! Paper's setting: ~1,500 vertices per lens surface, 110×77×42 voxels,
//! `S = 10`, ~1,500 bundles of 10 rays precomputed in ~3 s (Pentium 4
//! 3.8 GHz); `A = 0.012 m`, `n = 1.66`.
//!
//! ## What this module adds (and why)
//!
//! - The eye in dioptres ([`Eye`]): `V = 1/z`, `P_far = −R`,
//!   `P_near = P_far + Amp`, `ΔD = max(0, P_far − V) + max(0, V − P_near)`,
//!   `β = A·ΔD`, disc `A·z·ΔD` — equal to eqs. (1) and (2) but with no
//!   division by `n` or `f`, so emmetropes, `Amp = 0` and hyperopes need no
//!   special case. Accommodation by age (Hofstetter 1950,
//!   [`hofstetter_amplitude_d`]) and pupil size by luminance and age
//!   (Watson & Yellott, *Journal of Vision* 12(10):12, 2012, eq. 21,
//!   [`pupil_diameter_watson_yellott_mm`]).
//! - Lens design from a prescription ([`design_lens`]): Vogel's rule for
//!   the base curve, the thick-lens back surface
//!   `F2 = Fv − F1/(1 − t·F1/n)`, a toric back surface for cylinder
//!   (`S + C·sin²(θ − axis)`, [`ToricSurface`]), minimum edge thickness;
//!   typed errors for impossible prescriptions. A mesh of it
//!   ([`SpectacleLens::mesh`]).
//! - The corrected near/far point in vergence form (least-squares vergence
//!   of the refracted bundle), defined also when it lies at or beyond
//!   infinity; far sets point-mirrored so that averaging never cancels.
//! - Optional hole filling of voxels no reference ray crossed.
//! - The per-voxel average counts every crossing, in-focus ones as zero sets
//!   ([`VoxelAverage::AllCrossings`], the default), where the
//!   paper averages only the recorded near/far sets
//!   ([`VoxelAverage::RecordedSets`], an option). They differ
//!   in voxels straddling the corrected near or far point: the paper's mean
//!   of the blurred crossings overstates the blur of a voxel partly in
//!   focus, and the dilution measures slightly closer to the direct
//!   reference (sweep `spectacles`, quick: mean error 0.248 vs 0.253 mm at
//!   scale 0.5, 0.413 vs 0.415 mm at 0.25; max error equal).
//! - With the `reference` feature: a direct reference per point
//!   (`reference_at`) to measure the field's error.
//!
//! ## Frame, units and precision
//!
//! Metres and dioptres; angles in radians unless a name ends in `_deg`.
//! The eye's frame: right-handed, +z the line of sight from the eye into
//! the scene, +y up, so +x points to the wearer's left (the examiner's
//! right, facing the wearer); cornea at z = 0, lens back vertex at
//! z = vertex distance, centre of rotation and pupil behind the cornea
//! ([`EyePlacement`]). Cylinder axes run from +x towards +y, i.e.
//! counter-clockwise as the examiner sees the lens, the optometric (TABO)
//! convention. To place the frame in Bevy's (−Z forward, +Y up), turn it
//! half a turn about +y: Bevy `(X, Y, Z) = (−x, y, −z)` relative to the
//! eye. Everything here is `f64`; the field's vectors are stored as `f32`,
//! what the GPU gets.
//!
//! ## Input
//!
//! Numbers are checked where they enter: [`Eye`], [`Prescription`],
//! [`LensDesignParams`], [`EyePlacement`], [`ToricSurface`] and
//! [`FieldSettings`] have private fields and checked constructors, so
//! nothing downstream re-checks them; a refused number is
//! [`SpectaclesError::Input`] (or the bare [`InvalidInput`] where nothing
//! else can fail). The optics' own outcomes are typed too: a ray that
//! misses or is totally reflected is a [`LensTrace`] variant, a blocked
//! bundle [`SpectaclesError::BundleBlocked`].
//!
//! ## Example
//!
//! ```
//! use optica_optics::glam::DVec3;
//! use optica_optics::spectacles::{
//!     DEFAULT_VIEWPOINT_REGULARISATION, Eye, EyePlacement, FieldSettings, LensDesignParams, LensMesh, Prescription,
//!     design_lens, precompute_field, refract_vertices, virtual_viewpoint_of_traces,
//! };
//!
//! // A −3 D myope with 1 D of accommodation and a 4 mm pupil, and a −3 D lens.
//! let eye = Eye::new(-3.0, 1.0, 0.004)?;
//! let lens = design_lens(&Prescription::sphere(-3.0)?, &LensDesignParams::default())?;
//! let placement = EyePlacement::default();
//!
//! // §3: refraction at every back-surface vertex, and the virtual viewpoint
//! // the environment map is rendered from (a minus lens moves it forward).
//! let mesh = lens.mesh(LensMesh::PAPER_RINGS, LensMesh::PAPER_SEGMENTS)?;
//! let eye_point = placement.centre_of_rotation();
//! let traces = refract_vertices(&lens, eye_point, mesh.back_positions())?;
//! let viewpoint = virtual_viewpoint_of_traces(&traces, eye_point, DEFAULT_VIEWPOINT_REGULARISATION)?;
//! assert!(viewpoint.point.z > eye_point.z);
//!
//! // §4: the displacement sets of the corrected eye, at a quarter of the
//! // paper's resolution; a vertex 2 m away looks up its `S = 10` clones.
//! let field = precompute_field(&eye, &placement, Some(&lens), &FieldSettings::paper().scaled(0.25)?)?;
//! let clones = field.displacements_at(DVec3::new(0.0, 0.0, 2.0)).expect("inside the box");
//! assert_eq!(clones.len(), 10);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod bundle;
mod error;
mod eye;
#[cfg(feature = "reference")]
mod field_reference;
mod lens_design;
mod lens_mesh;
mod lens_surface;
mod mirror;
mod naked;
mod per_vertex;
mod viewpoint;
#[cfg(feature = "reference")]
mod view_reference;
mod voxel_field;

pub use bundle::{
    EyePlacement, Region, Spread, TracedBundle, perpendicular_frame, pupil_samples, region_of,
    set_map, trace_astigmatic_bundle, trace_bundle,
};
pub use error::{BlockedRay, LensSide, SpectaclesError};
pub use eye::{
    AdaptedEyes, Eye, HofstetterBound, MAX_ACCOMMODATION_D, MAX_EYE_CYLINDER_D, MAX_PUPIL_DIAMETER_M,
    MAX_REFRACTIVE_ERROR_D, WATSON_YELLOTT_AGE_RANGE, WATSON_YELLOTT_REFERENCE_AGE,
    hofstetter_amplitude_d, pupil_diameter_watson_yellott_mm,
};
#[cfg(feature = "reference")]
pub use field_reference::{DEFAULT_DENSE_SAMPLES, MAX_DENSE_SAMPLES, PointReference, reference_at};
pub use lens_design::{
    LENS_INDEX_RANGE, LensDesignParams, MAX_LENS_POWER_D, Prescription, SpectacleLens, design_lens,
    vogel_base_curve_d,
};
pub use lens_mesh::{LensMesh, MAX_POLAR_POINTS};
pub use lens_surface::{
    LensSurface, PROGRESSIVE_LATERAL_WIDTH_M, ProgressiveAddition, ProgressiveSurface, ToricSurface,
};
pub use mirror::{CurvedMirror, MAX_MIRROR_CELLS};
pub use naked::{defocus_factor, naked_eye_displacements};
pub use per_vertex::{LensTrace, refract_vertices};
#[cfg(feature = "reference")]
pub use view_reference::{CoordinatePlane, Pinhole, SeenPoint, plane_seen_through_lens, seen_with_mirror};
pub use viewpoint::{
    DEFAULT_VIEWPOINT_REGULARISATION, ViewpointFit, virtual_viewpoint, virtual_viewpoint_of_traces,
};
pub use voxel_field::{
    DisplacementField, FieldGrid, FieldLayout, FieldSettings, FieldStats, MAX_AIMS, MAX_CLONES, MAX_FIELD_VECTORS,
    MAX_WALK_CROSSINGS, FillRule, VoxelAverage, expand, precompute_field,
};

// The crate's types that the signatures above use, so that this module is
// all a user needs to import.
pub use crate::glass::Glass;
pub use crate::input::InvalidInput;
pub use crate::ray::Ray;
pub use crate::surface::{Hit, SphericalSurface};
pub use crate::voxel::{VoxelError, VoxelGrid};
