//! # optica_optics — the CPU reference of optica
//!
//! Pure optics and geometry on [`glam`], with no Bevy. Every optics routine that
//! runs in WGSL in a plugin crate has a twin here, and tests hold the two to the
//! same numbers. Precomputation and references work in `f64`; the GPU is `f32`.
//!
//! Shared maths first, then one module per paper (named like its plugin):
//!
//! | module | what |
//! |---|---|
//! | [`ray`] | rays |
//! | [`surface`] | sphere/plane intersection in curvature form, refraction, reflection |
//! | [`fresnel`] | unpolarised Fresnel (cos form) and single-layer anti-reflection coatings |
//! | [`glass`] | Sellmeier, the n_d/V_d dispersion model, a small catalog |
//! | [`lens`] | sequential lens systems: prescriptions, files, paraxial and real-ray traces |
//! | [`voxel`] | voxel grids and Amanatides–Woo traversal |
//! | [`spectacles`] | Kakimoto et al.: seeing through a prescription |
//! | [`compound_eye`] | Sagawa: compound-eye surface shading |
//! | [`foveated_lod`] | Mochizuki et al.: gaze-dependent level of detail |
//! | [`lens_flare`] | Hullin et al.: physically based lens flare |
//! | [`dome`] | Johjima: equidistant fisheye dome projection |

#![warn(missing_docs)]
// `!(x > 0.0)` is how this crate rejects NaN together with out-of-range
// values; rewriting it as `x <= 0.0` would let NaN through.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod fresnel;
pub mod glass;
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
