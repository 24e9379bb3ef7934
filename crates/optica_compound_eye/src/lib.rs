//! # optica_compound_eye — insect compound eyes as a Bevy material
//!
//! A material for any UV-mapped mesh that renders the surface of an insect's
//! compound eye: a lattice of sphere lenses just under the surface, each
//! refracting the view ray onto a pigment plane below it, so the facets
//! whose axes point at the camera show their dark pigment — the *principal
//! pseudopupil*, a dark patch that moves over the eye as the viewer moves.
//!
//! It implements chapter 6 of 佐川和輝 (Kazuki Sagawa), 「表面構造を考慮した
//! 複眼のリアルタイムレンダリング」 ("Real-time rendering of compound eyes
//! considering their surface structure"), master's thesis, The University
//! of Tokyo, 2014 (academic year 平成26年度), and goes beyond it where it
//! stopped: the exact path through the lattice at every angle (the thesis's
//! slice search is exact only near the axis), a hexagonal lattice, rays
//! followed into neighbouring lenses, Fresnel at the lens surfaces, the
//! environment seen by rays that leave the eye, a lattice that bends with
//! the surface, and a prefilter for facets smaller than a pixel. Every optics
//! step of the shader has a CPU twin in `optica_optics::compound_eye`, and
//! the tests hold the two to the same numbers.
//!
//! ## Use
//!
//! Add [`CompoundEyePlugin`], then give a mesh a [`CompoundEyeMaterial`]:
//! a `StandardMaterial` base (colour, roughness, its textures; lit and
//! shadowed by Bevy's lights like any other) and a [`CompoundEye`]
//! extension. See [`CompoundEye`] for every setting and
//! [`CompoundEye::from_preset`] for real insects ([`presets`]).
//!
//! Any UV-mapped mesh works; [`EyeCap`] is a sphere cap whose UVs have no
//! pole (a UV sphere shows its poles as rings of shrinking facets).
//!
//! ```no_run
//! use bevy::mesh::MeshBuilder;
//! use bevy::prelude::*;
//! use optica_compound_eye::{CompoundEye, CompoundEyeMaterial, CompoundEyePlugin, EyeCap, presets};
//!
//! fn setup(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>, mut materials: ResMut<Assets<CompoundEyeMaterial>>) {
//!     commands.spawn((
//!         // The cap's axis is +Z: towards the camera.
//!         Mesh3d(meshes.add(EyeCap::default().build())),
//!         MeshMaterial3d(materials.add(CompoundEyeMaterial {
//!             base: StandardMaterial { base_color: Color::srgb(0.6, 0.15, 0.1), perceptual_roughness: 0.3, ..default() },
//!             extension: CompoundEye::from_preset(&presets::HONEYBEE),
//!         })),
//!     ));
//!     commands.spawn((DirectionalLight::default(), Transform::from_xyz(2.0, 3.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y)));
//!     commands.spawn((Camera3d::default(), Transform::from_xyz(0.0, 0.0, 2.0)));
//! }
//!
//! App::new().add_plugins((DefaultPlugins, CompoundEyePlugin)).add_systems(Startup, setup).run();
//! ```
//!
//! ## How it works, and what it does not do
//!
//! - **The exact path** ([`CompoundEye::exact`], the default). The thesis
//!   looks for a ray's lens on slice planes down to the lenses' equator,
//!   which misses rays that enter a sphere below its equator or pass
//!   several lenses: most of the rays seen at oblique incidence. The
//!   shader instead walks the view ray cell by cell across the whole lens
//!   layer (a 2-D Amanatides–Woo walk over the lattice, testing each lens
//!   that can reach the cell), refracts it through the nearest lens it
//!   enters, and walks each exit ray the same way, through up to 16 lenses;
//!   total internal reflection and escape are decided as the CPU's exact
//!   tracer decides them (`trace_exact_capped`, its twin). A walk gives up
//!   after 64 cells (beyond about 88° from the normal): the pixel then
//!   shows the base material. With `exact` off the thesis's slice search
//!   runs, with [`CompoundEye::slices`] planes.
//! - **Texture axes from derivatives.** The thesis precomputes each
//!   triangle's texture axes `U_p, V_p` (eq. 6.2–6.15) on the CPU and sends
//!   them as vertex attributes. Here the fragment shader recovers them from
//!   the screen-space derivatives of the interpolated world position and
//!   facet coordinate: both are affine in the triangle's barycentrics, so
//!   `U = J_P·J_t⁻¹` is the triangle's own axis pair, exactly (up to f32).
//!   That needs no mesh preprocessing and no custom vertex shader, so any
//!   UV-mapped mesh works and the prepass and shadow passes stay Bevy's own.
//! - **The lattice bends with the surface.** The thesis lays it in each
//!   triangle's flat plane, which shows a coarse mesh's triangles as kinks
//!   in the pseudopupil. Here the axes are projected into the plane of the
//!   mesh's interpolated normal (`TextureAxes::on_normal` in
//!   `optica_optics`), which is continuous across edges: on a
//!   196-triangle sphere the output steps 1.28× as much across an edge as
//!   within a triangle, against 1.66× in the triangle's plane (the render
//!   test `a_coarse_sphere_shows_no_seams_at_its_triangle_edges`, at
//!   a9864ed, 2026-12-03). What is left comes from the mesh's
//!   piecewise-linear UVs, whose stretch changes at each edge; a finer mesh
//!   removes it (1.07× at 48 × 24 segments, the same test). A normal more
//!   than 60° off the triangle's is ignored.
//!   With [`CompoundEye::tangent_axes`] the axes follow the mesh's
//!   interpolated tangents instead (`TextureAxes::on_tangent`): square
//!   facets of the UVs' cell area, continuous across edges, 1.04× on the
//!   same sphere (the render test
//!   `along_its_tangents_a_coarse_sphere_shows_no_seams`, at e60af8c,
//!   2026-12-03), i.e. no seam. It gives up the UVs' stretch and shear, so
//!   it suits (nearly) conformal UVs; [`EyeCap`] has them, and tangents.
//!   With [`CompoundEye::axis_field`] the axes follow a smooth field that
//!   [`insert_axis_field`] writes into the mesh (each vertex's triangles'
//!   axes averaged, in its tangents and second UV channel): continuous
//!   across edges like the tangents, and with the UVs' stretch and shear
//!   kept (the render test
//!   `along_its_axis_field_a_coarse_sphere_keeps_its_stretch_and_shows_no_seams`,
//!   0.98× on the same sphere, measured 2026-12-05).
//! - **Degenerate UVs** (a triangle whose UVs collapse onto a line or a
//!   point: the facet coordinate's screen-space gradients parallel to within
//!   `1e-4` in sine) get no lattice: they render as the plain base material.
//!   The lattice is computed in a frame scaled to one facet, so tiny and
//!   huge facets (in world units) keep f32 precision.
//!   **Mirrored UVs** work: the axes follow the UVs and the lenses are put on
//!   the side away from the viewer. **Stretched UVs** make cells
//!   rectangles (or stretched hexagons): the lenses stay spheres, sized to
//!   the cell's inradius, so they never overlap.
//! - A mesh **without UVs** renders as its base material.
//! - **Every render path.** Forward and deferred: in the deferred
//!   renderer the same shader writes the G-buffer, with the pigment in the
//!   base colour, so Bevy's lighting pass lights the lattice. A ray that
//!   leaves the eye shows a mirror along its direction. Where the
//!   prefilter leaves a share of escaping rays in a pixel, the pixel shows
//!   the mirror with that probability (a fixed dither, the same in both
//!   paths), so that it is lit once. An `unlit` base material shows its
//!   base colour times the pigment, and where a ray escapes, the same lit
//!   mirror as a lit eye (what lies beyond the eye is seen either way).
//!   The deferred renderer's pixels match the forward renderer's (tested
//!   on Mesa 25's lavapipe; Mesa 22.3's llvmpipe crashes compiling the
//!   deferred variant, so use Mesa 23 or later on a CPU device).
//! - The lattice lives under the surface only optically: depth, shadows and
//!   the silhouette are those of the mesh.
//!
//! ## Settings panel
//!
//! With the cargo feature `egui`, `compound_eye_ui` draws every setting
//! and the species presets into an egui `Ui`, and `CompoundEyePanelPlugin`
//! shows them in a window (needs `bevy_egui`'s `EguiPlugin`).
//!
//! ## Cost and quality
//!
//! The report sweep `compound_eye` of `optica_report` measures image and
//! pseudopupil error against the CPU exact lattice tracer and the frame
//! time against a plain `StandardMaterial`, for the exact path (its knob
//! the lens cap) and for the thesis's slice search (its knob
//! [`CompoundEye::slices`]). On a CPU Vulkan device (lavapipe, 256², a flat
//! eye seen at 0–66°, 5.5 px facets at the pseudopupil) the slice search
//! reaches its error floor at `K = 2`–`8` (series `one lens` and
//! `neighbours`: PSNR 32.5 dB one lens, 30.7 dB with neighbours; the
//! pseudopupil within 0.01–0.02 facet of the exact tracer's) for
//! 1.25–1.49× the plain material's frame; `K = 0` leaves the pseudopupil
//! 0.2 facet off. The exact path (series `exact path`) reaches 42.0 dB
//! through one lens for 1.26–1.27× the plain frame, and 31.8 dB through
//! up to 16 lenses for 1.41–1.46× (rays through many lenses part f32 from
//! f64 ways; 99.6 % of pixels stay within 0.02 of the reference in every
//! incidence band). Its walk across the lattice tests only the four
//! lenses at the corners of each cell it crosses, the only ones that can
//! reach it. In the render test (and the `exact path` series'
//! `outcome_agrees_<band>`) it agrees with the exact tracer on the outcome
//! of 99.95–99.99 % of pixels by incidence band from 0° to 80° (square and
//! hexagonal lattices, index 1.33–1.7; the test asserts at least 99.5 % in
//! every band, so that another adapter's rounding does not fail it).
//!
//! **Facets smaller than a pixel.** What a pixel covering a facet or more
//! shows is the facet's average response, which depends only on the
//! direction the lattice is seen from. The plugin precomputes it per
//! material setting (`PrefilterTable` in `optica_optics`: 144 rays of the
//! material's own path per entry, 16 azimuths × 32 angles from the normal,
//! built on the CPU's cores when the settings change and shared between
//! materials with the same optics) and the shader blends from its own ray
//! into the table's entry as facets shrink from 4 px to 1 px, where it no
//! longer traces at all. With a pigment texture (whose average is not
//! periodic) it averages nine traced rays of the fragment's facet instead.
//! Measured (lavapipe, 256²; the stability cases of
//! `optica_report compound_eye`): at the defaults ("cost at the material's
//! defaults") the eye costs 1.37×, 1.42×, 1.41× and 1.49× the plain frame
//! in four runs; at 0.52 px per facet ("facets below a pixel (moiré)") its
//! ꟻLIP against an 8× supersampled render is 0.052 (nine traced rays:
//! 0.143, measured at 544c903, 2026-12-03; no prefilter: 0.171, moiré),
//! and lit ("facets below a pixel, lit (a partial escape share
//! dithered)"), with 3.2 % of the rays escaping, 0.054 (no prefilter:
//! 0.110; mixing the two lit colours instead of the dither: 0.053, for a
//! second lighting call that costs 0.4× the plain frame on lavapipe,
//! measured at 7dca20b, 2026-12-03).
//! Over a zoom-out from 4 px to 0.25 px per facet (series
//! `zoom-out (prefilter)`) the ꟻLIP stays at 0.047–0.052 from 1 px down
//! and below the unfiltered render's everywhere; at 2–4 px per facet
//! (0.11–0.12) it is the facets' own sharp edges aliasing, as any detail
//! does without anti-aliasing.

#![warn(missing_docs)]

use bevy::asset::{AssetEvent, embedded_asset};
use bevy::pbr::MaterialExtension;
use bevy::prelude::*;
use bevy::shader::{ShaderRef, load_shader_library};

mod axis_field;
mod error;
mod eye_cap;
#[cfg(feature = "egui")]
mod panel;
mod prefilter;
pub mod presets;
mod settings;

#[cfg(feature = "egui")]
pub use panel::{CompoundEyePanel, CompoundEyePanelPlugin, compound_eye_ui};
pub use axis_field::insert_axis_field;
pub use error::Error;
pub use eye_cap::EyeCap;
pub use presets::EyePreset;
pub use settings::{
    CompoundEye, CompoundEyeMaterial, CompoundEyeStatus, CompoundEyeUniform, EyeLattice, EyeOutput, MAX_DEPTH,
    MAX_INDEX, PigmentDisc,
};

/// Where `embedded_asset!` puts the material shader.
const SHADER_PATH: &str = "embedded://optica_compound_eye/shaders/compound_eye.wgsl";

/// Adds [`CompoundEyeMaterial`]: its shaders, its `MaterialPlugin` and a
/// check that logs invalid settings. Nothing is built or run for a scene
/// without the material: Bevy specialises material pipelines only for
/// meshes that use them.
pub struct CompoundEyePlugin;

impl Plugin for CompoundEyePlugin {
    fn build(&self, app: &mut App) {
        optica_plugin_kit::require_asset_server(app, "optica_compound_eye", "CompoundEyePlugin");
        load_shader_library!(app, "shaders/compound_eye_optics.wgsl");
        embedded_asset!(app, "shaders/compound_eye.wgsl");
        app.add_plugins(MaterialPlugin::<CompoundEyeMaterial>::default())
            .register_type::<CompoundEye>()
            .register_type::<EyeCap>()
            .register_type::<CompoundEyeStatus>()
            .init_resource::<prefilter::PrefilterTables>()
            .add_observer(add_status)
            .add_systems(
                PostUpdate,
                (
                    warn_about_invalid_settings,
                    (
                        prefilter::build_prefilter_tables,
                        update_status.run_if(any_with_component::<CompoundEyeStatus>),
                    )
                        .chain(),
                ),
            );
    }
}

impl MaterialExtension for CompoundEye {
    fn fragment_shader() -> ShaderRef {
        SHADER_PATH.into()
    }

    /// The same shader writes the G-buffer for the deferred renderer.
    fn deferred_fragment_shader() -> ShaderRef {
        SHADER_PATH.into()
    }
}

/// Gives every compound-eye mesh its [`CompoundEyeStatus`].
fn add_status(add: On<Add, MeshMaterial3d<CompoundEyeMaterial>>, mut commands: Commands) {
    commands
        .entity(add.entity)
        .insert_if_new(CompoundEyeStatus::default());
}

/// Brings each mesh's [`CompoundEyeStatus`] up to date when its material
/// changed, was swapped for another or has just arrived.
fn update_status(
    mut events: MessageReader<AssetEvent<CompoundEyeMaterial>>,
    materials: Res<Assets<CompoundEyeMaterial>>,
    tables: Res<prefilter::PrefilterTables>,
    mut meshes: Query<(
        Ref<MeshMaterial3d<CompoundEyeMaterial>>,
        &mut CompoundEyeStatus,
    )>,
) {
    let changed: Vec<AssetId<CompoundEyeMaterial>> = events
        .read()
        .filter_map(|e| match e {
            AssetEvent::Added { id } | AssetEvent::Modified { id } => Some(*id),
            _ => None,
        })
        .collect();
    for (handle, mut status) in &mut meshes {
        let id = handle.id();
        if !(changed.contains(&id) || handle.is_changed() || status.is_added()) {
            continue;
        }
        let next = match materials.get(id) {
            None => CompoundEyeStatus::default(),
            Some(material) => {
                let eye = &material.extension;
                let valid = eye.validate();
                CompoundEyeStatus {
                    lattice: valid.is_ok(),
                    prefiltered: valid.is_ok()
                        && eye.prefilter
                        && eye.prefilter_table.is_some()
                        && eye.pigment_texture.is_none(),
                    error: valid
                        .err()
                        .map(Error::from)
                        .or_else(|| tables.failed.get(&id).copied()),
                }
            }
        };
        status.set_if_neq(next);
    }
}

/// Logs, once per change of a material, the first setting the shader cannot
/// use (the mesh then renders as its base material).
fn warn_about_invalid_settings(
    mut events: MessageReader<AssetEvent<CompoundEyeMaterial>>,
    materials: Res<Assets<CompoundEyeMaterial>>,
) {
    for event in events.read() {
        let (AssetEvent::Added { id } | AssetEvent::Modified { id }) = event else {
            continue;
        };
        if let Some(material) = materials.get(*id)
            && let Err(e) = material.extension.validate()
        {
            warn!(
                "compound eye material {id}: {e}; the lattice is off and the mesh renders as its base material"
            );
        }
    }
}
