//! # Foveated LOD — Mochizuki and Makino, gaze-dependent LOD for ray tracing
//!
//! The CPU twin of the foveated-LOD plugin, after Naoki Mochizuki and
//! Mitsunori Makino, "An Efficient Ray Tracing with LOD Control by Human
//! Eyesight for Immersive Display System" (望月直樹, 牧野光則,
//! 「没入型ディスプレイでの人間の視野を利用したレイトレーシング法の詳細度制御」),
//! Graduate School of Science and Engineering, Chuo University. The paper
//! does not print its venue or year; its newest reference is from 2009.
//!
//! Every primary ray R_i through pixel i gets a level ∈ [0, 1] from the angle
//! between it and the tracked gaze; the level sets the ray's reflection depth
//! and the polygon count of the meshes it is tested against; reflection rays
//! inherit it; level 0 is not traced at all (background).
//!
//! Units and axes are the crate's: metres, radians, seconds; Bevy's axes
//! (+Y up, a camera looks along −Z).
//!
//! ## The paper's equations
//!
//! Gaze frame: eye V, unit gaze E_f, right E_r, up E_u; D'_i the world
//! direction of R_i, D_i = (d_f, d_r, d_u) the same in the gaze frame.
//!
//! | eq. | formula | here |
//! |---|---|---|
//! | (1) | d_f = E_f · D'_i | [`GazeFrame::to_local`] |
//! | (2) | d_r = E_r · D'_i | [`GazeFrame::to_local`] |
//! | (3) | d_u = E_u · D'_i | [`GazeFrame::to_local`] |
//! | (4) | m_α = cos⁻¹( d_f / √(d_f² + d_r²) ) | [`VisualField::angles`], as atan2(\|d_r\|, d_f) |
//! | (5) | m_β = +cos⁻¹\|d_f / √(d_f² + d_u²)\| if d_u ≥ 0, −cos⁻¹\|…\| if d_u < 0 | [`VisualField::angles`], as atan2(d_u, \|d_f\|) |
//! | (6) | l = √(m_α² + m_β²) | [`FieldAngles::eccentricity`] |
//! | (7) | L = √( ((5π/9)² m_α² + (π/3)² m_β²) / (m_α² + m_β²) ) if m_β ≥ 0; (π/3 → 7π/18) if m_β < 0 | [`VisualField::boundary`] |
//! | (8) | level = 1 if l ≤ π/6; (L − l)/(L − π/6) if π/6 < l ≤ L; 0 if L < l | [`VisualField::level_of_angles`] |
//! | (9) | Reflect_i = level_i × Reflect_max | [`reflect_limit`] (⌊·⌋: tracing stops when the count *exceeds* Reflect_i) |
//! | (10) | N_j = level_i (N_j,max − N_j,min) + N_j,min | [`polygon_budget`], [`choose_lod`], [`lod_for_level`] |
//!
//! The numbers of eq. 7–8 are the visual-field extents of the paper's §2: a
//! central field of π/6 (30°), 5π/9 (100°) to the ear side, π/3 (60°) up and
//! 7π/18 (70°) down ([`FieldExtents::PAPER`] gives them with their sources).
//! Eq. 7 in polar form is L(φ) = √(a²cos²φ + b²sin²φ), a = 100°, b = 60° up /
//! 70° down; not an ellipse, and the unsigned m_α keeps the 60° nose side out
//! of it. That is the default; per-eye sides and a true ellipse are options
//! ([`EyeModel`], [`BoundaryShape`]). [`VisualField`] documents the one
//! discontinuity the paper's angles have (straight to the ear side, ±E_r).
//!
//! ## What a plugin runs
//!
//! * [`GazeTracker`]: a head/eye tracker's samples to a [`GazeEstimate`];
//!   NaN and dropouts keep the last valid pose for a timeout, then render
//!   full quality (level 1 everywhere).
//! * [`VisualField`] and [`GazeFrame`]: the level of a ray or an object's
//!   direction (eq. 1–8).
//! * [`reflect_limit`], [`polygon_budget`], [`choose_lod`], [`lod_for_level`]:
//!   what a level buys (eq. 9–10).
//! * [`LevelQuantization`], [`LodHysteresis`], [`PixelLodGrid`]: level steps
//!   and a dead band + minimum dwell against LOD thrash under gaze jitter.
//! * [`CaveWall`], [`front_right_floor`]: the off-axis projection of each
//!   CAVE wall from the tracked eye (the paper's CAVE had front, right and
//!   floor screens).
//!
//! ```
//! use optica_optics::foveated_lod::{GazeTracker, TrackerSample, VisualField, lod_for_level, reflect_limit};
//! use optica_optics::glam::DVec3;
//!
//! // The tracker's sample of this frame: eye 1.5 m up, looking along −Z.
//! let mut tracker = GazeTracker::new(0.2)?;
//! let sample = TrackerSample::Gaze { eye: DVec3::new(0.0, 1.5, 0.0), gaze: DVec3::NEG_Z, up: DVec3::Y };
//! let gaze = tracker.update(sample, 0.0);
//! // A ray 65° to the right of the gaze: (100° − 65°)/(100° − 30°) = 0.5.
//! let a = 65f64.to_radians();
//! let level = gaze.level(&VisualField::paper(), DVec3::new(a.sin(), 0.0, -a.cos()));
//! assert!((level - 0.5).abs() < 1e-12);
//! // Eq. 9 with Reflect_max = 3: ⌊1.5⌋ = 1 reflection. Eq. 10 over a chain
//! // of 500, 1500 and 5804 triangles: 3152 needed, so the 5804 mesh.
//! assert_eq!(reflect_limit(level, 3), 1);
//! assert_eq!(lod_for_level(&[500, 1500, 5804], level), 2);
//! # Ok::<(), optica_optics::foveated_lod::FoveatedError>(())
//! ```
//!
//! ## Additions the paper does not specify
//!
//! The tracker policy, the quantisation and hysteresis, and the CAVE
//! projection are documented where they live. The paper's progressive
//! meshes are replaced by a discrete chain of meshes per object
//! (`TriangleMesh`, `LodObject`): eq. 10's budget picks the coarsest mesh
//! with at least N_j triangles.
//!
//! ## The ray tracer
//!
//! A small Whitted tracer (reflection and refraction) with a level per ray
//! (`render`, `trace_ray`, `TracerCamera`) over a per-object BVH (the
//! paper's §3.2.2), and its scene (`TracerScene`, `demo_scene`). It is the
//! reference of the plugin's GPU tracer, whose buffers `FlatScene` lays
//! out. With the `reference` feature, the image error measures (`rmse`,
//! `weighted_rmse`) that the report compares foveated renders with.

mod budget;
mod cave;
mod error;
mod hysteresis;
mod level;
mod tracker;

mod bvh;
mod flat;
#[cfg(feature = "reference")]
mod image_error;
mod mesh;
mod scene;
mod tracer;

pub use crate::input::InvalidInput;
pub use crate::ray::Ray;
pub use budget::{choose_lod, lod_for_level, polygon_budget, reflect_limit};
pub use cave::{CaveWall, DepthConvention, OffAxisProjection, front_right_floor};
pub use error::FoveatedError;
pub use hysteresis::{
    DEFAULT_DEAD_BAND, DEFAULT_LEVEL_STEPS, DEFAULT_MIN_DWELL_S, HysteresisParams,
    LevelQuantization, LodHysteresis, PixelLodGrid,
};
pub use level::{
    BoundaryShape, EyeModel, FieldAngles, FieldExtents, FieldRegion, GazeFrame, VisualField,
};
pub use tracker::{GazeEstimate, GazeTracker, TrackerSample};

pub use flat::{FlatMesh, FlatNode, FlatObject, FlatScene, FlatVertex, LEAF_BIT};
#[cfg(feature = "reference")]
pub use image_error::{rmse, weighted_rmse};
pub use mesh::TriangleMesh;
pub use scene::{DemoDetail, LodObject, TracerLight, TracerMaterial, TracerScene, demo_scene};
pub use tracer::{
    Layers, RenderedImage, TraceSettings, TraceStats, TracerCamera, pixel_levels, render,
    render_full_quality, render_layered, trace_ray,
};
