//! # optica_spectacles — see a Bevy scene through a prescription
//!
//! A camera with an [`Eye`] sees the scene as that eye does: blurred where
//! it cannot focus, by the clone rendering of
//! 柿本正憲, 立川智章, 西田友是 (Masanori Kakimoto, Tomoaki Tatsukawa,
//! Tomoyuki Nishita), 「頂点ベースのレイトレーシングを用いた屈折矯正結果の表示」
//! ("Rendering refractive corrected image using per-vertex ray tracing"),
//! SGI Japan and the University of Tokyo (the paper; its English version:
//! Kakimoto, Tatsukawa, Mukai, Nishita, *Computer Graphics Forum* 26(3),
//! 2007). With [`Spectacles`] on the same camera the blur is taken through
//! the lens, so the glasses correct it (or, wrongly chosen, do not). The
//! optics run on the CPU in `optica_optics::spectacles`, the shaders' twin.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use optica_spectacles::{Eye, Pupil, Spectacles, SpectaclesPlugin};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, SpectaclesPlugin))
//!     .add_systems(Startup, |mut commands: Commands| {
//!         commands.spawn((
//!             Camera3d::default(),
//!             // A −3 D myope of 30 with a 4 mm pupil, in −3 D glasses.
//!             Eye { refractive_error_d: -3.0, pupil: Pupil::Diameter { mm: 4.0 }, ..default() },
//!             Spectacles::sphere(-3.0),
//!         ));
//!     })
//!     .run();
//! ```
//!
//! ## Defocus by clones (the paper's §4)
//!
//! The eye is a thin lens with a pupil of diameter `A` that can focus from
//! its far point (vergence `P_far = −R`) to its near point
//! (`P_near = P_far + Amp`); a point at distance `z` is `ΔD` dioptres out
//! of that range and spread over a disc of `A·z·ΔD` across the line of
//! sight (the paper's eqs. (1)–(2), in dioptres so that emmetropes,
//! presbyopes with no accommodation left and hyperopes need no special
//! case). The scene is drawn `S` times ([`CloneDefocus::clones`]); clone
//! `i` moves every vertex by the `i`-th vector of the set (a sunflower of
//! `S` points over the disc), and the `S` drawings are averaged in linear
//! HDR. The eye accommodates point by point (the paper's §6.2): everything
//! between the near and far points is sharp at once, the sharp *zone* that
//! a camera's depth of field (one focal plane) cannot show.
//!
//! - **The displacement is done in the vertex shader** (the paper's stated
//!   future work): every `StandardMaterial` mesh the eye camera sees gets
//!   `S` twin entities carrying a [`CloneMaterial`](twins::CloneMaterial) — the same material,
//!   with a vertex shader that moves the vertex — tagged with their clone
//!   number. A clone is shaded where its original is, under Bevy's lights
//!   and shadows, so what is in focus looks exactly as without the eye.
//! - **Without glasses** the sets are computed per vertex in closed form
//!   (`optica_optics::spectacles::naked_eye_displacements`).
//! - **With glasses** they come from the paper's voxel field (§4.3):
//!   bundles from the pupil through the lens's ~1,500 points, converging at
//!   the near and far points, traced through both surfaces; their spreads
//!   recorded in the voxels their refracted reference rays cross, averaged
//!   per voxel, holes filled from the nearest crossed voxel. Each voxel
//!   keeps its set as a linear map of the pupil (two vectors instead of
//!   `S`: exact for the naked eye, first order through a lens, elliptical
//!   for an astigmatic bundle), so the field is 8.5 MB at the paper's
//!   110×77×42 voxels, is precomputed in about 20 ms on two cores (the
//!   `spectacles` report's main series, S = 10; the paper: ~3 s) whenever
//!   the eye, the lens or the field's settings change, and `S` can change
//!   without a new precompute. Each vertex looks up its voxel; a vertex
//!   beyond the field's box takes the set where its line of sight leaves
//!   the box, scaled by distance ([`FieldBox`]).
//!
//! ## A voxel grid in eye coordinates (the journal version's future work)
//!
//! [`FieldBox::eye_coordinates`] lays the field's voxels out in eye
//! coordinates instead of the paper's box: uniform in the sight line's
//! direction from the eye's centre of rotation (`x/z'`, `y/z'`) and in its
//! dioptric distance (`1/z'`), so voxels are small near the eye and grow
//! with distance as a blur does, and the last layer reaches infinity (no
//! far face to fall back from). The projection maps straight lines to
//! straight lines, so the reference rays are walked through these cells by
//! the same Amanatides–Woo traversal, to their vanishing point; each voxel
//! keeps its set for the distance of its centre, and a vertex blends the
//! two layers around it in dioptres, each carried to its own distance (a
//! set is an angle times a distance, and linear in dioptres between the
//! corrected near and far points). At the paper's voxel count (110×77×42,
//! the Fig. 8 eye in +1.5 D reading glasses, against the direct reference
//! at 300 points 0.1–2 m away; the `spectacles` report's `_eyegrid`
//! series against its main one, release) the set's error falls from 0.44
//! to 0.081 mrad on average and from 1.04 to 0.10 mrad nearer than 0.3 m,
//! where the box's 5 cm voxels span several dioptres; the precompute takes
//! 25 ms against the box's 20 ms on two cores, and at three quarters of the
//! voxels (12 ms) eye coordinates are still closer than the box at one and
//! a half times them (0.11 against 0.29 mrad, 70 ms). Where the corrected
//! near or far point falls between two layers the blend across that kink
//! leaves about the box's error. Beyond the box's far face (2.13 m), where
//! the box falls back to the set where the sight line leaves it, scaled by
//! distance, eye coordinates are 4× closer: 0.27 against 1.04 mrad at
//! 2.5–10 m (the `far_mean_mrad` columns; 30 points, `--quick`, release).
//! It is on by default ([`FieldBox::eye_coordinates`]; off gives the
//! paper's box); the GPU lookup is held to its CPU twin within 3.3e-6 of the
//! set's size (the render test
//! `naked_eye_and_field_lookup_match_the_cpu_twin`, at 5e8c293,
//! 2026-12-02).
//!
//! ## Astigmatism (the journal version's extension)
//!
//! An eye with [`Astigmatism`] has a cylinder at an axis, written as on
//! its prescription (the optometric convention: degrees counter-clockwise
//! from the wearer's left as the examiner facing the wearer sees them). Its
//! focus is a 2×2 vergence matrix across each line of sight, and it
//! accommodates to the circle of least confusion (its spherical
//! equivalent), so a clone's displacement is a linear map of the pupil
//! point: the blur is an ellipse, drawn out across the axis for a point
//! beyond the far point of a myopic cylinder, and a disc `A·|C|/2` wide
//! where the eye can focus. A toric lens ([`Spectacles::cylinder_d`]) at
//! the eye's axis corrects it through the voxel field (its bundles are
//! traced from the matrix focus, and between the corrected near and far
//! points the field keeps what astigmatism the lens leaves); the same lens
//! turned 90° doubles it. Tested from pixels: the blur's second-moment
//! tensor lies across the axis at the screen angle the convention gives
//! and matches the CPU twin's set within 1 % (shaded in full) and 3 %
//! (reprojected; the render test
//! `astigmatic_blur_from_pixels_lies_across_the_cylinder_axis`, at
//! 5470e03, 2026-12-01).
//!
//! ## Progressive lenses
//!
//! [`Spectacles::addition_d`] makes the lens a progressive-addition lens:
//! its back surface gains an addition whose power grows from nothing at
//! the fitting point (the lens's centre, where the eye looks straight
//! ahead) down a corridor ([`Spectacles::corridor_mm`], 14 mm) to the full
//! add in the near zone, umbilic along the corridor (sharp down it) and,
//! as Minkwitz's theorem says every such surface must, astigmatic beside
//! it (`optica_optics::spectacles::ProgressiveAddition`; a lensmeter
//! trace reads +2.00 in both meridians in the near zone of a +2.00 add,
//! and 2.1 D of cylinder 8 mm beside the corridor half-way down: the
//! optics test `lens_design_progressive_addition_by_lensmeter`, at
//! 4922485, 2026-12-01). The voxel field is traced through it like any
//! lens: the eye turned down to a book 30 cm away sees it sharp through
//! the near zone, straight ahead it sees the far wall sharp, and beside
//! the corridor both blur. Left
//! out: the near zone's inset towards the nose, and the lateral blending
//! commercial designs tune (ours fades the lateral terms over 8 mm).
//!
//! ## The lens's refraction (the paper's §3)
//!
//! With [`Spectacles`] the lens is drawn over the view (on by default:
//! [`Spectacles::refraction`]): on the CPU a ray from the eye through every
//! vertex of the lens's back surface (the paper's ~1,500, 24 rings × 64
//! segments, [`Spectacles::tessellation`]) is traced through both
//! surfaces, only when the lens or its place before the eye changes
//! ([`Spectacles::decentration_mm`] slides it, and the defocus field is
//! traced through the lens where it sits, so its blur moves with it too:
//! on a +1.5 D lens with a 2 D addition decentred (4, −6) mm, the field's
//! blur is 3.7e-5 rad from the direct reference through that lens, against
//! 4.0e-4 for the field of the lens centred, the optics crate's test
//! `a_decentred_lens_s_field_follows_the_lens`; ~0.2 ms a trace, series
//! `refraction, −4 D (knob rings)`); on the GPU each vertex's exit ray
//! finds the scene in the eye camera's depth (a march of 64 geometric
//! steps and 16 bisections), and that point's place in the view is the
//! vertex's texture coordinate; the lens's back
//! surface, drawn over the view, shows the view there, interpolated between
//! vertices (the paper's steps 3(a)–(d)). Vertices whose ray is totally
//! reflected or leaves through the rim mask their triangles as the lens's
//! dark edge. The environment map is the eye camera's own view, not a view
//! rendered from the paper's virtual viewpoint (which [`LensRefraction`](twins::LensRefraction)
//! still gives): for spectacles that point lies within millimetres of the
//! eye, the hits are found exactly in the depth, and the scene is not drawn
//! once more; what this gives up is the part of the scene a minus lens
//! shows past the view's edge (its rays there take the edge pixel).
//! Against an exact per-pixel trace through the same lens the scene seen
//! through it lies within 0.1 px (mean 0.02–0.03 px at 128², −4 and
//! +4 D; the render test `refraction_matches_an_exact_trace_per_pixel`,
//! at 3fa4df9, 2026-12-01), magnified or minified as the lens does. The
//! `spectacles` report sweeps the tessellation (series
//! `refraction, −4 D (knob rings)`: release, lavapipe, 256², −4 D):
//! 0.74 px mean at 6 rings, 0.13 px at 12, 0.04 px at the default 24;
//! there a −4 D lens in a 46° view shows 13 % of its pixels from past the
//! view's edge.
//!
//! The lens's chromatic aberration ([`Spectacles::chromatic_aberration`],
//! on by default, from the material's Abbe number): the CPU traces every
//! vertex's ray at the C and F lines too, and the view's red, green and
//! blue are taken where the C, d and F rays land, so that towards the rim,
//! where the lens is a prism, the colours part by the prism over `V` —
//! the fringes of strong polycarbonate lenses. Against the exact trace at
//! each wavelength: −8 D polycarbonate at 128², each colour within
//! 0.03 px on average, their parting 0.18 px against the exact 0.19 px
//! (5 %; the render test
//! `chromatic_aberration_parts_the_colours_by_the_abbe_number`, at
//! d5a7f6e, 2026-12-01). What is left out: the lens's longitudinal
//! chromatic aberration in the defocus (its power differs by `F/V` between
//! red and blue, 0.27 D for that lens; the clones share one field) and the
//! eye's own (about 2 D across the visible, which every eye has and the
//! brain discounts).
//!
//! ## A curved mirror (the paper's §3.2)
//!
//! A [`CurvedMirror`] entity (a car's door mirror: convex, `R` = 1.4 m,
//! 24 × 16 cm by default) seen by the camera marked [`MirrorViewer`] is
//! drawn by the same per-vertex ray tracing: whenever the mirror or the
//! viewer moves, the CPU reflects the ray from the viewer at each of the
//! mirror's vertices (33 × 25 by default, ~0.07 ms: series
//! `mirror, per vertex (knob columns)`), fits the virtual
//! viewpoint those rays come from (behind a convex mirror) and points an
//! environment camera from there along them, its field of view holding
//! every reflected ray; on the GPU each vertex's reflected ray finds the
//! scene in that camera's depth (the lens's march), and the mirror, an
//! ordinary mesh in the scene with [`MirrorMaterial`](twins::MirrorMaterial), shows the
//! environment image there, interpolated between vertices. Mirrors live
//! on [`MIRROR_LAYER`], which the viewer is given and the environment
//! camera lacks, so a mirror never renders itself.
//!
//! [`MirrorMethod::CubeMap`] draws the same mirror as a Bevy user would:
//! a metallic, smooth `StandardMaterial` lit by a cube map captured at the
//! mirror every frame (six cameras, copied into the cube's layers),
//! uncorrected for parallax (treated as infinitely far): a reflection
//! probe around the mirror where the device has Bevy's reflection probes,
//! else the viewer's environment map, which then lights every mesh the
//! viewer sees too. Bevy also adds its ambient light to a metallic
//! surface, which washes such a mirror out in a room lit by ambient light;
//! the per-vertex mirror shows only what it reflects. [`MirrorMethod::ParallaxCorrectedCubeMap`] captures at
//! a room's centre and lets a Bevy reflection probe correct the parallax
//! against the room's box; Bevy's reflection probes need binding arrays,
//! which lavapipe and WebGL2 lack, and there the plain cube map stands in
//! ([`MirrorState::parallax_corrected`] says which was drawn).
//!
//! Against an exact per-pixel reflection (`optica_optics::spectacles::
//! seen_with_mirror`; the `spectacles` report's series
//! `mirror, per vertex (knob columns)` and
//! `mirror, Bevy cube map (knob face px)`: a convex
//! mirror of `R` = 1.2 m, 60 × 45 cm, 1 m before the camera, a wall 2.5 m
//! from it and a card 0.5 m before it; 256², lavapipe, release; the march
//! takes no scene nearer than a ray's start, so a wall the mirror hangs on
//! does not show in it): per
//! vertex, the point a pixel shows lies 0.86 px from the exact one on
//! average at 8 × 6 cells, 0.23 px at 16 × 12 and 0.094 px at 32 × 24
//! (95 % of pixels within 0.09 px; the card 0.31 px, whose edge the
//! viewpoint's parallax shifts), 0.1 % of pixels showing the wrong
//! surface; the cube map, 9.4 px on average whatever its face size (the
//! error is parallax, not resolution), the card 31 px off, 11.5 % of pixels
//! the wrong surface: the paper's Fig. 2. The frame costs 3.5–4.0× the
//! frame without the mirror per vertex (the environment camera draws the
//! scene once more, with its own shadow cascades; the march is 1.4–3 ms
//! and the CPU trace 0.15 ms of it) and 9.8–19.6× with the cube map
//! (six drawings, 128² to 512² faces).
//!
//! The `spectacles` example hangs one on the room's wall (`--mirror
//! per-vertex|cube-map`; its panel switches the method and the grid).
//! The environment camera looks from behind the mirror: what stands
//! between that viewpoint and the mirror and faces it (a two-sided wall
//! the mirror hangs on, a door mirror's closed housing) hides what the
//! mirror reflects wherever it lies past the camera's near plane (the
//! nearest vertex), as it does behind the far side of a mirror seen
//! obliquely; one-sided surfaces seen from behind are culled and do no
//! harm, and the march ignores any scene nearer than a ray's start. Turned
//! 25° on a one-sided wall the mirror stays within 0.3 px (128², quick
//! report, series
//! `mirror, per vertex, turned 25° on its wall (knob columns)`); with the
//! wall two-sided 97 % of its pixels show the wall (at ee358f5,
//! 2026-12-02; no current series measures it). An
//! oblique near plane along the mirror's rim would lift this; it is not
//! done.
//!
//! Left out: several viewers (the trace is for one); the mirror in the
//! clones' blur (its material is not a `StandardMaterial`, so an eye
//! camera that draws clones does not show it: the example draws the view
//! sharp when it hangs a mirror); a mirror seen in another mirror.
//!
//! ## How the clones are drawn, and why
//!
//! One clone camera (a child of the eye camera) draws all `S` clones in a
//! single pass into an atlas of `S` tiles, each clone's vertices mapped
//! into its tile and cut at the tile's edges by clip distances (a discard
//! where the device has none). One camera culls, batches and sorts once
//! for all clones; the twins of a mesh share their material and are
//! instanced. The eye camera's view then becomes the tiles' mean (the
//! paper's accumulation buffer), written over its main texture before
//! Bevy's post-processing, so bloom, exposure and tonemapping treat the
//! blurred view as the sharp one.
//!
//! How each clone is shaded decides the cost ([`CloneShading`]). Measured
//! by the `spectacles` report on lavapipe (release, 256², a lit room with
//! shadows, `S = 10`; the range of two runs): shading every clone in full,
//! the paper's way, costs 5.8–7.4× the sharp frame (series
//! `rendered: naked, full shading (knob S)`), and `S` cameras each
//! drawing the scene 8.4–10.5× (series
//! `mechanism: S cameras, each drawing the scene shaded (knob S)`; they
//! also draw the shadow maps `S` times) — every clone pays a shaded
//! drawing of the scene. The default instead lets the eye camera draw the
//! scene once, sharp, with all its shading, and each clone only records
//! where its undisplaced surface point lies in that view; the resolve
//! takes the sharp view's colour there when the point is visible in it:
//! 1.7–2.1× the sharp frame (series
//! `rendered: naked, reprojected (knob S)`; 2.0× at 512², series
//! `rendered at 512²: −0.78 D glasses, reprojected (knob S)`; 2.6–3.4×
//! at `S = 40`), and its clone camera needs no shadow maps at all. What reprojection gives up (points the sharp view hides,
//! and a slight extra blur from resampling the view) is measured in the
//! same report against `S = 128` clones shaded in full, and documented on
//! [`CloneShading::Reprojected`].
//!
//! ## Status and limits
//!
//! - One eye camera per app draws clones (the first active one). It is
//!   made HDR (the clones are averaged, and the lens resamples the view, in
//!   linear light), and it still draws the scene sharp: reprojected clones
//!   take their colours from that view and the lens finds the scene in its
//!   depth (with full shading it is one extra drawing of `S + 1`).
//! - Meshes with `StandardMaterial` are cloned; other materials are not
//!   blurred. The eye camera's `Exposure` is carried to the clone camera;
//!   its environment map and fog are not (they matter only to clones
//!   shaded in full). Transparent and alpha-masked materials are cloned as
//!   opaque when reprojected.
//! - Objects must be tessellated finely enough that a vertex's blur stands
//!   for its neighbourhood (the paper's §6.1): a large quad has one blur
//!   per corner.

#![warn(missing_docs)]

use bevy::asset::uuid_handle;
use bevy::prelude::*;
use bevy::shader::{Shader, load_shader_library};

mod clones;
mod error;
mod mirror;
#[cfg(feature = "egui")]
mod panel;
mod precompute;
pub mod presets;
mod refraction;
mod render;
mod settings;

#[cfg(feature = "egui")]
pub use panel::{SpectaclesPanelPlugin, mirror_ui, spectacles_ui};
pub use error::Error;
pub use clones::{CLONE_LAYER, CloneCamera, CloneCameraOf, CloneOf, CloneTwins};
pub use precompute::{SpectaclesStatus, corrected_points};
pub use mirror::{MAX_ENVIRONMENT_FOV_DEG, MIRROR_LAYER, MirrorHelperOf, MirrorHelpers, MirrorState};

/// A query filter that leaves out the entities the plugin makes for itself
/// (clone twins, clone cameras, a mirror's cameras and probe):
/// `Query<&Mesh3d, NotSpectaclesHelper>` sees the scene's own meshes only.
pub type NotSpectaclesHelper = (Without<CloneOf>, Without<CloneCameraOf>, Without<MirrorHelperOf>);

/// The CPU and WGSL twins of what the plugin's shaders compute, the GPU
/// layouts, and the components the plugin puts on its own cameras and
/// materials: what the readback tests and the report hold the shaders to.
/// An app using the plugin needs none of it.
pub mod twins {
    pub use crate::clones::{
        CloneExtension, CloneMaterial, CloneResolve, CloneRig, MAX_ATLAS_SIDE, max_tiles,
        tile_layout,
    };
    pub use crate::mirror::{CubeFace, MirrorEnvironment, MirrorMaterial};
    pub use crate::precompute::{
        CloneUniform, EyeOptics, FieldGeometry, camera_z, eye_placement, field_bytes,
    };
    pub use crate::refraction::{LensRefraction, LensVertex, trace_lens};
    pub use crate::render::MARCH_STEPS;

    /// `displacement.wgsl`: the clones' displacement sets (pupil samples,
    /// the frame across a sight line, the naked eye, the box exit), the
    /// WGSL twin of `optica_optics::spectacles`, as a
    /// `#define_import_path optica::spectacles` library.
    pub const DISPLACEMENT_WGSL: &str = include_str!("shaders/displacement.wgsl");

    /// `field_lookup.wgsl`: the voxel field's lookup, the twin of
    /// `DisplacementField::displacement_along_sight`, as a
    /// `#define_import_path optica::spectacles::field` library that reads
    /// the clone material's storage array `field` of `f32`.
    pub const FIELD_LOOKUP_WGSL: &str = include_str!("shaders/field_lookup.wgsl");
}
pub use settings::{
    CurvedMirror, MirrorMethod, MirrorViewer,
    Accommodation, Astigmatism, CloneDefocus, CloneShading, Eye, FieldBox, LensMaterial, MAX_CLONES,
    MAX_LENS_VERTICES, Pupil, Spectacles,
};

/// The clone material's vertex stage where the device has clip distances
/// (`clone_clip.wgsl`, whose `enable` directive must open the file). A
/// handle rather than an embedded path because the material's `specialize`,
/// which picks it, has no asset server to load a path with; the other
/// shaders are embedded assets.
pub(crate) const CLONE_CLIP_SHADER: Handle<Shader> =
    uuid_handle!("0d6f1c2a-94b7-4f3e-8a51-6c2e9b7d3f10");

/// What the render device offers the plugin, known once the app's plugins
/// have finished (before the first update; absent, all `false`, without a
/// renderer). Read it to know which path a scene takes on this machine.
#[derive(Resource, Reflect, Clone, Copy, Debug, Default, PartialEq, Eq)]
#[reflect(Resource, Default)]
pub struct SpectaclesDevice {
    /// The device clips by distances the vertex shader writes
    /// (`wgpu::Features::CLIP_DISTANCES`): clones are cut at their tiles
    /// by the rasteriser, with early depth testing; without it, by a
    /// discard in the fragment shader.
    pub clip_distances: bool,
    /// Bevy's reflection probes work here (they need binding arrays of
    /// textures: most desktop GPUs, not lavapipe or WebGL2). Without them
    /// a [`MirrorMethod::ParallaxCorrectedCubeMap`] draws the plain cube
    /// map (the view's environment map), and [`MirrorState`] says so.
    pub reflection_probes: bool,
}

/// The plugin's systems in `PostUpdate`, one set per feature (each added
/// by its own sub-plugin): the eye's optics and the clones, the lens's
/// refraction (after them), and the curved mirrors.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SpectaclesSystems {
    /// The eye's optics, the lens design and field, and the clones.
    Defocus,
    /// The lens's refraction, traced when the lens changes.
    Refraction,
    /// The curved mirrors' cameras, traced after transforms propagate.
    Mirrors,
}

/// Adds [`Eye`], [`Spectacles`] and [`CloneDefocus`]. Without an `Eye`
/// camera it adds no pass, builds no pipeline and does no per-frame work.
pub struct SpectaclesPlugin;

impl Plugin for SpectaclesPlugin {
    fn build(&self, app: &mut App) {
        optica_plugin_kit::require_asset_server(app, "optica_spectacles", "SpectaclesPlugin");
        load_shader_library!(app, "shaders/displacement.wgsl");
        app.add_plugins(render::SpectaclesRenderPlugin)
            .register_type::<Eye>()
            .register_type::<Spectacles>()
            .register_type::<CloneDefocus>()
            .register_type::<SpectaclesStatus>()
            .register_type::<SpectaclesDevice>()
            // The eye's optics first (the clones and the lens read them).
            .configure_sets(
                PostUpdate,
                (SpectaclesSystems::Defocus, SpectaclesSystems::Refraction)
                    .chain()
                    .before(bevy::camera::CameraUpdateSystems),
            )
            .configure_sets(
                PostUpdate,
                // Also while clones outlive the last eye: the frame after
                // it goes, `sync_twins` despawns them (gated on the eye
                // alone they stayed, ten entities a mesh, found by the soak).
                (SpectaclesSystems::Defocus, SpectaclesSystems::Refraction).distributive_run_if(
                    any_with_component::<Eye>
                        .or_else(any_with_component::<clones::CloneRig>)
                        .or_else(any_with_component::<CloneOf>)
                        .or_else(any_with_component::<Spectacles>)
                        .or_else(any_with_component::<refraction::LensRefraction>),
                ),
            )
            // Mirrors: placed after transforms propagate (they follow the
            // mirror and the viewer this frame), before cameras update.
            .configure_sets(
                PostUpdate,
                SpectaclesSystems::Mirrors
                    .after(bevy::transform::TransformSystems::Propagate)
                    .before(bevy::camera::CameraUpdateSystems)
                    .run_if(
                        any_with_component::<CurvedMirror>
                            .or_else(any_with_component::<mirror::MirrorState>)
                            .or_else(any_with_component::<mirror::MirrorHelperOf>)
                            .or_else(any_with_component::<mirror::LitByMirrorCube>),
                    ),
            )
            .add_plugins((
                clones::DefocusPlugin,
                refraction::LensRefractionPlugin,
                mirror::MirrorPlugin,
            ));
    }

    fn finish(&self, app: &mut App) {
        // Clones are cut at their tiles by clip distances where the device
        // has them (no discard: early depth testing stays on).
        let clip = app
            .get_sub_app(bevy::render::RenderApp)
            .and_then(|r| r.world().get_resource::<bevy::render::renderer::RenderDevice>())
            .is_some_and(|d| {
                d.features()
                    .contains(bevy::render::render_resource::WgpuFeatures::CLIP_DISTANCES)
            });

        // Bevy's condition for reflection probes: binding arrays of at
        // least its material's 16 textures and 8 probes.
        let probes = app
            .get_sub_app(bevy::render::RenderApp)
            .and_then(|r| r.world().get_resource::<bevy::render::renderer::RenderDevice>())
            .is_some_and(|d| {
                use bevy::render::render_resource::WgpuFeatures as F;
                d.features().contains(
                    F::TEXTURE_BINDING_ARRAY | F::SAMPLED_TEXTURE_AND_STORAGE_BUFFER_ARRAY_NON_UNIFORM_INDEXING,
                ) && d.limits().max_binding_array_elements_per_shader_stage >= 24
                    && d.limits().max_binding_array_sampler_elements_per_shader_stage >= 24
            });
        app.insert_resource(SpectaclesDevice {
            clip_distances: clip,
            reflection_probes: probes,
        });
        if clip && app.world().contains_resource::<Assets<Shader>>() {
            bevy::asset::load_internal_asset!(
                app,
                CLONE_CLIP_SHADER,
                "shaders/clone_clip.wgsl",
                Shader::from_wgsl
            );
        }
    }
}
