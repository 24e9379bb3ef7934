//! # optica_optics — the optics under optica's Bevy plugins
//!
//! Pure optics and geometry on [`glam`], with no Bevy. Every optics routine
//! that runs in WGSL in a plugin crate has a twin here, and tests hold the two
//! to the same numbers. Shared maths first, then one module per paper, named
//! like its plugin:
//!
//! | module | what |
//! |---|---|
//! | [`ray`] | rays |
//! | [`input`] | the one error for unusable numbers, and the checks behind it |
//! | [`surface`] | sphere/plane intersection in curvature form, refraction, reflection |
//! | [`fresnel`] | unpolarised Fresnel (cos form) and single-layer anti-reflection coatings |
//! | [`glass`] | Sellmeier, the n_d/V_d dispersion model, a small catalog |
//! | [`lens`] | sequential lens systems: prescriptions, files, paraxial and real-ray traces |
//! | [`voxel`] | voxel grids and Amanatides–Woo traversal |
//! | [`spectacles`] | Kakimoto et al.: seeing through a prescription |
//! | [`compound_eye`] | Sagawa: compound-eye surface shading |
//! | [`foveated_lod`] | Mochizuki and Makino: gaze-dependent level of detail |
//! | [`lens_flare`] | Hullin et al.: physically based lens flare |
//! | [`dome`] | Johjima and Fujimura: equidistant fisheye dome projection |
//!
//! ## Conventions
//!
//! - **Units.** Lens systems (prescriptions, lens flare) are in millimetres,
//!   as patent tables give them. Scenes, spectacles, eyes, domes and the
//!   compound eye are in metres (or, for the compound eye, in the mesh's own
//!   units), with dioptres (1/m) for optical power. Wavelengths are in
//!   nanometres. Angles are radians unless a name ends in `_deg`.
//! - **Axes.** Bevy's: right-handed, +Y up, a camera looks along −Z (the
//!   dome and the foveated LOD work in it; the compound eye works in each
//!   triangle's own texture axes, whatever the frame). Two modules
//!   keep the frame of their field, each documenting its map to Bevy's: lens
//!   systems have an optical axis +Z from object to image, as optical design
//!   programs use; the spectacles' eye frame has +z along the line of sight
//!   (Bevy `(X, Y, Z) = (−x, y, −z)` relative to the eye).
//! - **Precision.** Everything here is `f64`; the GPU twins in the plugin
//!   crates are `f32`, and their tests state the tolerance between the two.
//! - **Input.** Numbers from users are checked where they enter and refused
//!   with [`input::InvalidInput`]; types with invariants (a [`ray::Ray`]'s
//!   unit direction) have private fields and checked constructors, so no
//!   routine re-checks them per ray. Failures that are part of the optics (a
//!   ray that misses, total internal reflection) are typed results of their
//!   own, never NaN.
//!
//! ## Cargo features
//!
//! - `reference` (off by default): the reference renderers and the report
//!   scaffolding (exact tracers, brute-force images, error measures, test
//!   scenes). The report runner and the tests turn it on; a plugin build
//!   compiles only the optics it runs.

#![warn(missing_docs)]
// `!(x > 0.0)` is how this crate rejects NaN together with out-of-range
// values; rewriting it as `x <= 0.0` would let NaN through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod fresnel;
pub mod glass;
pub mod input;
pub mod lens;
pub mod ray;
pub mod surface;
pub mod voxel;

pub mod compound_eye;
pub mod dome;
pub mod foveated_lod;
pub mod lens_flare;
pub mod spectacles;

pub use glam;
