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
//!   `S` twin entities carrying a [`CloneMaterial`] — the same material,
//!   with a vertex shader that moves the vertex — tagged with their clone
//!   number. The clones are shaded where the original is, under Bevy's
//!   lights and shadows, so what is in focus looks exactly as without the
//!   eye.
//! - **How the clones are drawn, and why.** One clone camera (a child of
//!   the eye camera) draws all `S` clones into an atlas of `S` tiles in a
//!   single pass: each clone's vertices are mapped into its tile, and each
//!   fragment outside its tile is discarded. The eye camera then draws only
//!   the tiles' mean. Against `S` cameras, one per clone, this draws the
//!   shadow maps once instead of `S` times and culls, batches and sorts
//!   once; the twins of a mesh share one material and are instanced. The
//!   `spectacles` report measures both (see its `mechanism` series).
//! - **Without glasses** the sets are computed per vertex in closed form
//!   (`optica_optics::spectacles::naked_eye_displacements`).
//! - **With glasses** they come from the paper's voxel field (§4.3):
//!   bundles from the pupil through the lens's ~1,500 points, converging at
//!   the near and far points, traced through both surfaces; their spreads
//!   recorded in the voxels their refracted reference rays cross, averaged
//!   per voxel, holes filled from neighbours. It is precomputed when the
//!   eye, the lens or the field's settings change and uploaded once; each
//!   vertex looks up its voxel. A vertex beyond the field's box takes the
//!   set where its line of sight leaves the box, scaled by distance
//!   ([`FieldBox`]).
//!
//! ## Status and limits
//!
//! - One eye camera per app draws clones (the first active one). It is
//!   made HDR; its own `RenderLayers` are kept and given back when the
//!   [`Eye`] is removed or [`CloneDefocus::enabled`] is off.
//! - Meshes with `StandardMaterial` are cloned; other materials are not
//!   drawn through the eye. The camera's `Exposure`, environment map and
//!   fog are not carried to the clone camera yet.
//! - Objects must be tessellated finely enough that a vertex's blur stands
//!   for its neighbourhood (the paper's §6.1): a large quad has one blur
//!   per corner.
//! - Screen-space effects of the clone camera (SSAO, SSR, TAA) are off.

#![warn(missing_docs)]

use bevy::asset::uuid_handle;
use bevy::pbr::MaterialPlugin;
use bevy::prelude::*;
use bevy::shader::{Shader, load_shader_library};

mod clones;
#[cfg(feature = "egui")]
mod panel;
mod precompute;
pub mod presets;
mod render;
mod settings;

#[cfg(feature = "egui")]
pub use panel::{SpectaclesPanelPlugin, spectacles_ui};
pub use clones::{
    CLONE_LAYER, CloneCameraOf, CloneExtension, CloneMaterial, CloneOf, CloneResolve, CloneRig,
    CloneTwins, MAX_ATLAS_SIDE, max_tiles, tile_layout,
};
pub use precompute::{
    CloneUniform, EyeOptics, FieldGeometry, SpectaclesStatus, camera_z, corrected_points,
    eye_placement, field_bytes,
};
pub use settings::{
    Accommodation, CloneDefocus, CloneShading, Eye, FieldBox, LensMaterial, MAX_CLONES, Pupil,
    Spectacles,
};

/// The clone material's shader: `clone.wgsl` with the field lookup pasted in.
pub(crate) const CLONE_SHADER: Handle<Shader> =
    uuid_handle!("0d6f1c2a-94b7-4f3e-8a51-6c2e9b7d3f10");
/// The resolve pass's shader.
pub(crate) const RESOLVE_SHADER: Handle<Shader> =
    uuid_handle!("5a3e8c71-2b94-4d6f-b0a2-e91c47f6d385");

/// `displacement.wgsl`: the clones' displacement sets (pupil samples, the
/// frame across a sight line, the naked eye, the box exit), the WGSL twin of
/// `optica_optics::spectacles`, as a `#define_import_path optica::spectacles`
/// library.
pub const DISPLACEMENT_WGSL: &str = include_str!("shaders/displacement.wgsl");

/// `field_lookup.wgsl`: the voxel field's lookup, the twin of
/// `DisplacementField::displacement_along_sight`; it reads a storage array
/// `field` of `f32` that the including shader declares.
pub const FIELD_LOOKUP_WGSL: &str = include_str!("shaders/field_lookup.wgsl");

/// Puts the clone material's shader in the assets: `clone.wgsl` with the
/// field lookup pasted in and, where the device clips by distances the
/// vertex shader writes, the `enable` directive that allows them (it must
/// open the file, so it cannot sit under a shader def).
fn insert_clone_shader(app: &mut App, clip_distances: bool) {
    if let Some(mut shaders) = app.world_mut().get_resource_mut::<Assets<Shader>>() {
        let clone = include_str!("shaders/clone.wgsl")
            .replace("//FIELD_LOOKUP", FIELD_LOOKUP_WGSL)
            .replace(
                "//ENABLE_CLIP_DISTANCES",
                if clip_distances { "enable clip_distances;" } else { "" },
            );
        let _ = shaders.insert(
            CLONE_SHADER.id(),
            Shader::from_wgsl(clone, "optica_spectacles/shaders/clone.wgsl"),
        );
    }
}

/// Adds [`Eye`], [`Spectacles`] and [`CloneDefocus`]. Without an `Eye`
/// camera it adds no pass, builds no pipeline and does no per-frame work.
pub struct SpectaclesPlugin;

impl Plugin for SpectaclesPlugin {
    fn build(&self, app: &mut App) {
        load_shader_library!(app, "shaders/displacement.wgsl");
        insert_clone_shader(app, false);
        if let Some(mut shaders) = app.world_mut().get_resource_mut::<Assets<Shader>>() {
            let _ = shaders.insert(
                RESOLVE_SHADER.id(),
                Shader::from_wgsl(
                    include_str!("shaders/resolve.wgsl"),
                    "optica_spectacles/shaders/resolve.wgsl",
                ),
            );
        }
        app.add_plugins(MaterialPlugin::<CloneMaterial>::default())
            .add_plugins(render::CloneRenderPlugin)
            .register_type::<Eye>()
            .register_type::<Spectacles>()
            .register_type::<CloneDefocus>()
            .register_type::<SpectaclesStatus>()
            .init_resource::<clones::CloneMaterials>()
            .add_systems(
                PostUpdate,
                (
                    precompute::update_optics,
                    clones::stop_removed,
                    clones::sync_rig,
                    clones::sync_twins,
                    clones::follow_base_materials,
                    clones::light_the_clones,
                )
                    .chain()
                    .before(bevy::camera::CameraUpdateSystems)
                    .run_if(any_with_component::<Eye>.or_else(any_with_component::<CloneRig>)),
            );
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
        clones::CLIP_DISTANCES.store(clip, std::sync::atomic::Ordering::Relaxed);
        insert_clone_shader(app, clip);
    }
}
