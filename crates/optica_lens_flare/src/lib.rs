//! # optica_lens_flare — physically based lens flare for Bevy
//!
//! Ghosts — light reflected twice inside a camera lens — traced through
//! real lens prescriptions, after Hullin, Eisemann, Seidel and Lee,
//! *Physically-Based Real-Time Lens Flare Rendering* (SIGGRAPH 2011), as
//! the CPU twin in `optica_optics::lens_flare` implements it.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use optica_lens_flare::{FlareSource, LensFlare, LensFlarePlugin, lenses};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, LensFlarePlugin))
//!     .add_systems(Startup, |mut commands: Commands, assets: Res<AssetServer>| {
//!         commands.spawn((
//!             Camera3d::default(),
//!             LensFlare::new(assets.load(lenses::TESSAR)),
//!         ));
//!         commands.spawn((DirectionalLight::default(), FlareSource::default()));
//!     })
//!     .run();
//! ```
//!
//! ## Lenses
//!
//! [`LensAsset`]s load from `.lens` files (the format of
//! `optica_optics::lens`: a patent table, one surface per row); the
//! project ships a Brendel Tessar, an Angénieux double Gauss and a Heliar,
//! and a 33-interface zoom (US 5,537,259, 528 ghosts) as the scale case,
//! embedded in the crate: load them by the paths in [`lenses`]
//! (`assets.load(lenses::TESSAR)`). Your own `.lens` files load from your
//! assets folder; with Bevy's `file_watcher` feature an edited file is
//! reloaded; a file that does not parse is refused with its line
//! and field named, and the flare keeps the last good lens.
//!
//! ## Ghosts
//!
//! Every pair of reflecting surfaces is a ghost (n(n−1)/2 for n
//! interfaces: 21 for the Tessar, 91 for the double Gauss). They are
//! estimated once per lens, coating and aperture, ranked, and the
//! brightest within [`LensFlare::ghost_budget`] and
//! [`LensFlare::min_relative`] are drawn ([`FlareGhosts`] says what became
//! of each).
//!
//! ## Per frame, on the GPU
//!
//! For each drawn ghost, wavelength and [`FlareSource`] light whose light
//! enters the lens (directional lights, point and spot lights, in view or
//! not), a grid of parallel rays over the part of the pupil plane whose
//! light gets through that ghost's path is traced through the lens by a
//! compute pass (`shaders/lens_trace.wgsl`, [`LENS_TRACE_WGSL`](twins::LENS_TRACE_WGSL), the WGSL
//! twin of `PreparedLens::trace_to`, held to it by readback), keeping
//! `r_rel` so the grid stays continuous. A second compute pass colours
//! every grid cell once, with the irradiance its change of area gives
//! (bounded gain) in the wavelength's colour scaled by the ghost's
//! spectral gains (its throughput over the whole band, measured per
//! degree of field angle, [`spectral_gains`](twins::spectral_gains), so that any wavelength
//! count carries the band's light and colour), and writes the triangles of the cells that add light
//! into an index buffer; a draw pass adds them (each ray shaded once,
//! shared by its cells), clipped per pixel where `r_rel > 1`, at
//! [`LensFlare::ghost_resolution`] (a quarter of the view's side by
//! default), scaled up and added to the HDR view target (`LensFlare`
//! requires `Hdr`) before bloom, which spreads the ghosts, and
//! tonemapping. The
//! rays are traced again only when the grids, the lens or the settings
//! change: a still camera and lights trace them once. The sensor is sized
//! so that the lens sees the camera's field of view ([`SensorMapping`](twins::SensorMapping)); a
//! light's irradiance at the camera (illuminance, or a point light's lumens
//! over 4πd²) times the camera's exposure scales its ghosts, so they sit in
//! the scene's light levels. Pass time shows as the `optica/lens_flare`
//! diagnostic span, and each pass in it as `optica/lens_flare/occlusion`,
//! `/trace`, `/fill`, `/cells`, `/coarse` (the large ghosts), `/draw`
//! and `/composite` (the scaling up), with the shader invocations it ran
//! where the adapter has pipeline-statistics queries.
//!
//! ## The blog's speed-ups
//!
//! - *Adaptive resolution* ([`LensFlare::adaptive_grid`], on by default),
//!   with power as the measure: the rays of `grid²` per ghost are shared so
//!   that each ghost's grid follows the cube root of its estimated power
//!   (8 … 512 rays per side), which least misplaces the flare's light for
//!   the rays. The blog's measure, how much a ghost deforms, gave the
//!   double Gauss's smooth bright ghosts too few rays; one of its ghosts
//!   carries half the light, and by power it gets 73² of a mean 16².
//! - *Dead rays continued*: a ray that misses a sphere dies, and the cells
//!   around it would go undrawn though their part nearer the live rays
//!   passes; a fill pass after the trace continues the live rays into the
//!   dead ones beside them, and the per-pixel clip cuts those cells where
//!   the light stops (coarse grids lost a tenth of their light without:
//!   an optics test in `optica_optics`, at 1e45d9f, 2026-12-03).
//! - *Symmetry* ([`LensFlare::symmetry`], on by default): a grid is traced
//!   for the light turned into one meridional plane, where the ghost is
//!   mirror symmetric, so half its rows are traced; the rays are turned
//!   back to the light's azimuth before the iris test.
//! - *Bundle bounding*, measured: with symmetry, where each ghost's light
//!   passes the lens is traced on a coarse grid ([`FIT_RAYS`](twins::FIT_RAYS)²) at every
//!   degree of field angle ([`passing_at_step`](twins::passing_at_step), kept per camera until the
//!   ghosts change), and the ghost's grid covers only that rectangle (the
//!   union of the two degrees round the light's angle, grown by a coarse
//!   step) instead of the pupil bounds' square, of which wide open only
//!   about 15 % passes (measured at dae9e45, 2026-12-02); a ghost that
//!   passes at neither is not traced. Each
//!   grid is also cut to cells of at least [`CELL_PX`](twins::CELL_PX) pixels of the
//!   target the ghosts are added up in ([`screen_grid`](twins::screen_grid)). The ghost's
//!   spectrum (for its spectral gains) is measured at the same degrees,
//!   at most [`SPECTRUM_BUDGET_MS`](twins::SPECTRUM_BUDGET_MS) a frame once each ghost has one.
//! - *Intensity LOD* and *aperture culling*: [`FlareGhosts`].
//!
//! Beyond the blog, two savings that trade a little error for time (each
//! a knob with its series in the report): a ghost whose image moves by
//! less than two pixels across the band is drawn once, at the middle
//! wavelength, in the band's colour, losing colour fringes at most that
//! wide ([`LensFlare::merge_wavelengths_px`]); and a ghost wider than
//! [`LensFlare::coarse_ghost_px`] (a defocused one, smooth inside) is
//! added up at half the ghosts' resolution in a pass of its own
//! (`optica/lens_flare/coarse`) and scaled up into theirs, each smooth
//! 2 × 2 block of its cells drawn as one ([`LensFlare::merge_cells`]).
//! The cells' colours and triangles are made only when the rays are
//! traced again (the draw applies the intensity and each light's
//! visibility), so a still view pays only for the draw.
//!
//! ## Diffraction
//!
//! [`StarburstSettings`]: the Fraunhofer pattern of the iris (with seeded
//! dust and scratches) by FFT, summed over the wavelengths with the 1/λ
//! scale, drawn round each light, occluded with it. [`RingingSettings`]:
//! the iris's field carried by the angular spectrum method, looked up
//! where each ghost's rays crossed the stop. Both are made on the CPU when
//! the iris or their settings change.
//!
//! ## Occlusion
//!
//! A light behind geometry does not flare: each frame a compute pass reads
//! the camera's depth on a small disk round each light's image and scales
//! the light's ghosts by the fraction that is not hidden, blended over a
//! few frames ([`FlareOcclusion`]), so the flare fades instead of popping
//! or flickering at an edge. MSAA depth is read too.
//!
//! ## What it leaves out
//!
//! - Ringing uses one propagation distance for every ghost (a Fresnel
//!   number), not a per-ghost distance from its defocus (the paper's
//!   fractional Fourier transform per ghost); the ripples lie inside the
//!   ghost, not past its edge, since rays beyond the iris are clipped.
//! - The starburst's angular size is a setting: a real iris diffracts into
//!   a fraction of a degree.
//! - Lights off the screen have no depth to read and flare fully.

#![warn(missing_docs)]

use bevy::asset::embedded_asset;
use bevy::prelude::*;
use bevy::shader::load_shader_library;

mod asset;
mod diffraction;
mod draws;
mod error;
mod fit;
mod frame;
mod gpu_lens;
pub mod lenses;
#[cfg(feature = "egui")]
mod panel;
mod precompute;
mod render;
mod settings;

pub use asset::{LensAsset, LensLoadError, LensLoader};
pub use error::Error;
#[cfg(feature = "egui")]
pub use panel::{LensFlarePanelPlugin, lens_flare_ui};
pub use precompute::{FlareGhosts, GhostChoice, GhostFate};
pub use settings::{
    ApertureSettings, CoatingSettings, DEFAULT_COARSE_GHOST_PX, DEFAULT_MERGE_CELLS,
    DEFAULT_MERGE_WAVELENGTHS_PX, FlareOcclusion, FlareSource, GhostResolution, LensFlare,
    MAX_GRID, MAX_WAVELENGTHS, RingingSettings, StarburstSettings,
};

/// The CPU and WGSL twins of what the flare's passes compute, and the
/// constants they share: what the readback tests and the report hold the
/// shaders to. An app using the plugin needs none of it.
pub mod twins {
    pub use crate::diffraction::{RINGING_NM, ringing_image, starburst_image};
    pub use crate::draws::starburst_scale;
    pub use crate::fit::{
        CELL_PX, FIT_RAYS, FIT_STEP_DEG, MIN_SCREEN_GRID, SPECTRUM_BUDGET_MS, fit_steps,
        passing_at_step, screen_grid, spectral_gains, spectrum_at_step,
    };
    pub use crate::frame::{SensorMapping, light_in_lens};
    pub use crate::gpu_lens::{
        APERTURE_WGSL, LENS_TRACE_WGSL, SURFACE_FLOATS, aperture_params, pack_surfaces,
    };
    pub use crate::precompute::{RANKING_FIELD_DEG, choose};
}

/// Adds [`LensAsset`] loading, [`LensFlare`] and [`FlareSource`]. Without a
/// `LensFlare` camera it does no per-frame work.
pub struct LensFlarePlugin;

impl Plugin for LensFlarePlugin {
    fn build(&self, app: &mut App) {
        optica_plugin_kit::require_asset_server(app, "optica_lens_flare", "LensFlarePlugin");
        load_shader_library!(app, "shaders/flare_types.wgsl");
        load_shader_library!(app, "shaders/lens_trace.wgsl");
        load_shader_library!(app, "shaders/aperture.wgsl");
        embedded_asset!(app, "shaders/ghost_trace.wgsl");
        embedded_asset!(app, "shaders/ghost_cells.wgsl");
        embedded_asset!(app, "shaders/ghost_draw.wgsl");
        embedded_asset!(app, "shaders/upsample.wgsl");
        embedded_asset!(app, "shaders/visibility.wgsl");
        lenses::embed(app);
        app.init_asset::<LensAsset>()
            .init_asset_loader::<LensLoader>()
            .register_type::<LensFlare>()
            .register_type::<FlareSource>()
            .add_plugins(render::FlareRenderPlugin)
            .add_systems(
                PostUpdate,
                (
                    make_depth_readable,
                    (precompute::choose_ghosts, draws::prepare_draws).chain(),
                )
                    .after(bevy::transform::TransformSystems::Propagate)
                    .run_if(any_with_component::<LensFlare>),
            );
    }
}

/// Lets the occlusion pass read the depth of every [`LensFlare`] camera
/// with occlusion on (by default a camera's depth can only be drawn to).
fn make_depth_readable(mut cameras: Query<(&mut Camera3d, &LensFlare)>) {
    use bevy::render::render_resource::TextureUsages;
    for (mut camera, flare) in &mut cameras {
        let usages = TextureUsages::from(camera.depth_texture_usages);
        if flare.occlusion.is_some() && !usages.contains(TextureUsages::TEXTURE_BINDING) {
            camera.depth_texture_usages = (usages | TextureUsages::TEXTURE_BINDING).into();
        }
    }
}
