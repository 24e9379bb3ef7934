//! # Foveated LOD — Mochizuki & Makino, gaze-dependent LOD for ray tracing
//!
//! CPU reference of the foveated-LOD plugin: 望月直樹, 牧野光則, 「没入型ディスプレイでの
//! 人間の視野を利用したレイトレーシング法の詳細度制御」 (*An Efficient Ray Tracing
//! with LOD Control by Human Eyesight for Immersive Display System*),
//! `papers/mochizuki-gaze-lod-raytracing.txt`.
//!
//! Every primary ray R_i through pixel i gets a level ∈ [0, 1] from the angle
//! between it and the tracked gaze; the level sets the ray's reflection depth
//! and the polygon count of the meshes it is tested against; reflection rays
//! inherit it; level 0 is not traced at all (background).
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
//! | (10) | N_j = level_i (N_j,max − N_j,min) + N_j,min | [`polygon_budget`], [`choose_lod`] |
//!
//! Eq. 7 in polar form is L(φ) = √(a²cos²φ + b²sin²φ), a = 100° (ear side),
//! b = 60° up / 70° down; not an ellipse, and the unsigned m_α keeps the 60°
//! nose side out of it. That is the default; per-eye sides and a true ellipse
//! are options ([`EyeModel`], [`BoundaryShape`]). [`level`] documents the one
//! discontinuity the paper's angles have (straight to the ear side, ±E_r).
//!
//! ## Additions the paper does not specify (documented where they live)
//!
//! * [`hysteresis`]: level quantisation into S steps and a per-pixel dead band
//!   + minimum dwell state machine against LOD thrash under gaze jitter.
//! * [`tracker`]: NaN/dropout input keeps the last valid pose for a timeout,
//!   then renders full quality (level 1 everywhere).
//! * [`cave`]: the off-axis projection of each CAVE wall from the tracked eye
//!   (the paper's CAVE had front, right and floor screens).
//! * [`mesh`]: the paper's progressive meshes are replaced by a discrete chain
//!   of tessellations per object; eq. 10's budget picks the coarsest mesh
//!   with at least N_j triangles.
//! * [`bvh`]: the paper's per-object BVH (§3.2.2), a small binned-SAH BVH.
//!
//! ## Modules
//!
//! | module | what |
//! |---|---|
//! | [`level`] | eq. 1–8: gaze frame, angles, boundary, level |
//! | [`budget`] | eq. 9–10: reflection limit, polygon budget, LOD choice |
//! | [`hysteresis`] | quantisation, dead band and dwell state machine |
//! | [`tracker`] | tracker dropout policy |
//! | [`bvh`] | boxes and the BVH |
//! | [`mesh`] | triangle meshes and their generators |
//! | [`scene`] | LOD objects, materials, lights, the demo scene |
//! | [`tracer`] | the Whitted tracer with a level per ray |
//! | [`cave`] | CAVE walls, off-axis projection |
//! | [`image_error`] | RMSE and gaze-weighted RMSE |

pub mod budget;
pub mod bvh;
pub mod cave;
pub mod error;
pub mod hysteresis;
pub mod image_error;
pub mod level;
pub mod mesh;
pub mod scene;
pub mod tracer;
pub mod tracker;

pub use budget::{choose_lod, polygon_budget, reflect_limit};
pub use bvh::{Aabb, Bvh};
pub use cave::{CaveWall, DepthConvention, OffAxisProjection, front_right_floor};
pub use error::FoveatedError;
pub use hysteresis::{HysteresisParams, LevelQuantization, LodHysteresis, PixelLodGrid};
pub use image_error::{rmse, weighted_rmse};
pub use level::{BoundaryShape, EyeModel, FieldAngles, FieldRegion, GazeFrame, VisualField};
pub use mesh::TriangleMesh;
pub use scene::{DemoDetail, LodObject, Material, PointLight, Scene, demo_scene};
pub use tracer::{
    Camera, RenderedImage, TraceSettings, TraceStats, pixel_levels, render, render_full_quality, trace_ray,
};
pub use tracker::{GazeEstimate, GazeTracker, TrackerSample};
