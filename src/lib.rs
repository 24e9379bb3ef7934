//! # optica — optics-and-perception rendering for Bevy
//!
//! optica turns five rendering papers into Bevy plugins: seeing through a
//! spectacle prescription, insect compound eyes, gaze-driven level of detail,
//! physically based lens flare and equidistant fisheye dome projection.
//!
//! This umbrella crate re-exports each plugin behind a cargo feature of its own,
//! so a scene pays only for what it uses, and always re-exports the CPU
//! reference [`optics`] that every plugin is tested against.
//!
//! | feature | what it adds |
//! |---|---|
//! | `compound_eye` | [`compound_eye`]: a material for insect compound eyes (Sagawa 2014), `CompoundEyePlugin` |
//! | `dome` | [`dome`]: a fisheye dome camera, equidistant projection per vertex with refinement (Johjima and Fujimura) or a resampled cube map, `DomePlugin` |
//! | `foveated_lod` | [`foveated_lod`]: gaze-driven level of detail (Mochizuki and Makino): a tracked head, LOD chains switched by the visual field, off-axis CAVE walls, and the paper's foveated GPU ray tracer, `FoveatedLodPlugin` |
//! | `lens_flare` | [`lens_flare`]: physically based lens flare (Hullin et al. 2011), `LensFlarePlugin`: ghosts traced through real lens prescriptions on the GPU, bladed iris, starburst, ringing, occlusion by the scene's depth |
//! | `spectacles` | [`spectacles`]: see through a prescription (Kakimoto et al.): the eye's defocus by clone rendering, corrected through the lens's voxel field, `SpectaclesPlugin` |
//! | `egui` | settings panels (bevy_egui) of the plugins that are on |
//! | `showcase` | the five plugins, `egui` and `window`: what the `showcase` example needs |
//! | `window` | opens a real window in the examples (winit + X11); without it, or without a display, they render to PNG |
//!
//! [`OpticaPlugins`] adds every plugin whose feature is on; [`prelude`]
//! has the types a scene touches:
//!
//! ```no_run
//! use bevy::prelude::*;
//! use optica::prelude::*;
//!
//! App::new().add_plugins((DefaultPlugins, OpticaPlugins)).run();
//! ```
//!
//! The CPU reference is there whatever the features:
//!
//! ```
//! use optica::optics::glass::Glass;
//! let bk7 = Glass::catalog("N-BK7").unwrap();
//! assert!((bk7.index(587.5618) - 1.5168).abs() < 1e-4);
//! ```

#![warn(missing_docs)]

pub use optica_optics as optics;

#[cfg(feature = "compound_eye")]
pub use optica_compound_eye as compound_eye;
#[cfg(feature = "dome")]
pub use optica_dome as dome;
#[cfg(feature = "foveated_lod")]
pub use optica_foveated_lod as foveated_lod;
#[cfg(feature = "lens_flare")]
pub use optica_lens_flare as lens_flare;
#[cfg(feature = "spectacles")]
pub use optica_spectacles as spectacles;

use bevy::app::{PluginGroup, PluginGroupBuilder};

/// Every optica plugin whose cargo feature is on, as one group:
/// `app.add_plugins((DefaultPlugins, OpticaPlugins))`. A plugin does no
/// per-frame work until its components are in the scene. Add it after
/// Bevy's `DefaultPlugins` (the plugins embed shaders and lenses as
/// assets). Each can be left out or replaced as in any plugin group:
/// `OpticaPlugins.build().disable::<optica::dome::DomePlugin>()`.
pub struct OpticaPlugins;

impl PluginGroup for OpticaPlugins {
    fn build(self) -> PluginGroupBuilder {
        let group = PluginGroupBuilder::start::<Self>();
        #[cfg(feature = "compound_eye")]
        let group = group.add(optica_compound_eye::CompoundEyePlugin);
        #[cfg(feature = "dome")]
        let group = group.add(optica_dome::DomePlugin);
        #[cfg(feature = "foveated_lod")]
        let group = group.add(optica_foveated_lod::FoveatedLodPlugin);
        #[cfg(feature = "lens_flare")]
        let group = group.add(optica_lens_flare::LensFlarePlugin);
        #[cfg(feature = "spectacles")]
        let group = group.add(optica_spectacles::SpectaclesPlugin);
        group
    }
}

/// The usual imports: [`OpticaPlugins`], the optics, and each enabled
/// plugin's plugin and the types a scene touches. (The foveated LOD's `Eye`
/// is `optica::foveated_lod::Eye`: the prelude's `Eye` is the spectacles'.)
pub mod prelude {
    pub use crate::OpticaPlugins;
    pub use crate::optics;

    #[cfg(feature = "compound_eye")]
    pub use optica_compound_eye::{
        CompoundEye, CompoundEyeMaterial, CompoundEyePlugin, EyeCap, EyeLattice, EyeOutput,
    };
    #[cfg(feature = "dome")]
    pub use optica_dome::{
        DomeApparentSize, DomeCamera, DomeExport, DomeExportPlugin, DomeLens, DomeMode, DomePlugin,
    };
    #[cfg(feature = "foveated_lod")]
    pub use optica_foveated_lod::{
        CaveView, FoveatedLodPlugin, Foveation, GazeLod, GazeRayTracer, HeadSource, RayTraced,
        SimulatedGaze, TrackedHead, WallRect,
    };
    #[cfg(feature = "lens_flare")]
    pub use optica_lens_flare::{
        FlareGhosts, FlareSource, LensAsset, LensFlare, LensFlarePlugin, lenses,
    };
    #[cfg(feature = "spectacles")]
    pub use optica_spectacles::{
        CloneDefocus, CurvedMirror, Eye, Spectacles, SpectaclesPlugin, SpectaclesStatus,
    };
}
