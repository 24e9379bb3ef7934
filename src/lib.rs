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
//! | `foveated_lod` | [`foveated_lod`]: gaze-driven level of detail (Mochizuki and Makino): a tracked head, LOD chains switched by the visual field, off-axis CAVE walls, `FoveatedLodPlugin`; the paper's ray tracer is still to come |
//! | `lens_flare` | [`lens_flare`]: physically based lens flare (Hullin et al. 2011), `LensFlarePlugin`: ghosts traced through real lens prescriptions on the GPU, bladed iris, starburst, ringing, occlusion by the scene's depth |
//! | `spectacles` | [`spectacles`]: see through a prescription (Kakimoto et al.): the eye's defocus by clone rendering, corrected through the lens's voxel field, `SpectaclesPlugin` |
//! | `egui` | settings panels (bevy_egui) of the plugins that are on |
//! | `window` | opens a real window in the examples (winit + X11); without it, or without a display, they render to PNG |
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

/// The usual imports: the optics and each enabled plugin's plugin and
/// user-facing types.
pub mod prelude {
    pub use crate::optics;

    #[cfg(feature = "compound_eye")]
    pub use optica_compound_eye::{
        CompoundEye, CompoundEyeMaterial, CompoundEyePlugin, EyeLattice, EyeOutput,
    };
    #[cfg(feature = "dome")]
    pub use optica_dome::{DomeCamera, DomePlugin};
    #[cfg(feature = "foveated_lod")]
    pub use optica_foveated_lod::{
        CaveView, FoveatedLodPlugin, Foveation, GazeLod, HeadSource, TrackedHead,
    };
    #[cfg(feature = "lens_flare")]
    pub use optica_lens_flare::{FlareSource, LensFlare, LensFlarePlugin};
    #[cfg(feature = "spectacles")]
    pub use optica_spectacles::{CloneDefocus, Eye, Spectacles, SpectaclesPlugin};
}
