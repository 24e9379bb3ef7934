//! # Compound eye — the CPU reference of Sagawa's compound-eye shading
//!
//! Source: 佐川和輝 (Kazuki Sagawa), 「表面構造を考慮した複眼のリアルタイムレンダリング」
//! ("Real-time rendering of compound eyes considering their surface
//! structure"), master's thesis, Graduate School of Interdisciplinary
//! Information Studies, The University of Tokyo, academic year 2014 (平成26年度),
//! chapter 6. Equation and section numbers below are the thesis's.
//!
//! ## The model (thesis §6.1–6.2, Fig. 6.1, 6.3, 6.4)
//!
//! Every triangle of the eye mesh carries an infinite square lattice in its
//! texture coordinates: one texture unit is one facet (ommatidium). Under each
//! cell, a sphere of radius `r` (the facet lens) touches the polygon from
//! below at the cell centre; the *pigment plane* (the thesis's "texture
//! plane", which carries the pigment texture) lies parallel to the polygon at
//! a depth `d` below it. The thesis puts it at `d = 2r` (eq. 6.29); we keep
//! `d` and the index `n` separate parameters, because a ball lens focuses at
//! `n·r / (2(n−1))` from its centre ([`ball_focal_length`], derived there
//! from the thick-lens equation), i.e. at `2.5r` below the polygon for
//! `n = 1.5`. A view ray refracts into and out of one sphere and the texel it
//! reaches on the pigment plane darkens the surface colour (eq. 6.30):
//! ommatidia whose axes point at the viewer show their dark centre — the
//! moving *pseudopupil* ([`shows_dark_centre`]).
//!
//! Units: lengths (`r`, `d`, positions) are in the mesh's own units; texture
//! coordinates after eq. 6.1 are in **facets** — that is the unit every `uv`
//! in this module is in. Directions need not be unit where they enter (a
//! [`Ray`] normalises its own). Everything is `f64`; the plugin's shader
//! twin is `f32`.
//!
//! Input: constructors check what they are given ([`CompoundEyeError`]) and
//! the per-ray functions take a [`Ray`], so tracing never fails: it returns a
//! [`Shade`], a finite pigment hit or a [`ShadeFallback`], never NaN. The
//! coordinate maps of the steps ([`TextureAxes::uv_of`],
//! [`Lattice::lens_centre`], ...) are plain linear maps: finite in, finite
//! out (short of overflow at ~1e300).
//!
//! ## Equations
//!
//! Texture resolution (§6.3), [`scale_uv`]:
//! - (6.1) `T_vert = R_t · T_obj`
//!
//! Texture-axis vectors (§6.3.1), [`TextureAxes`]:
//! - (6.2) `P = P_c + a·U_p + b·V_p` — any point of the polygon from its texture coordinate `(a, b)`
//! - (6.3) `P_c = P_e − a_e·U_p − b_e·V_p` — from a known point `P_e` with texture coordinate `(a_e, b_e)`; we take `P_e = P_0`, `(a_e, b_e) = T_0`
//! - (6.4) `P_10 = P_1 − P_0`
//! - (6.5) `P_20 = P_2 − P_0`
//! - (6.6) `T_10 = T_1 − T_0`
//! - (6.7) `T_20 = T_2 − T_0`
//! - (6.8) `U_p = i·P_10 + j·P_20`
//! - (6.9) `V_p = k·P_10 + l·P_20`
//! - (6.10) `P_AB = P_A − P_B = c·P_10 + d·P_20` — a displacement in the polygon
//! - (6.11) `T_AB = T_A − T_B = c·T_10 + d·T_20` — the same displacement in texture space
//! - (6.12) `i·T_10 + j·T_20 = (1, 0)ᵀ`
//! - (6.13) `k·T_10 + l·T_20 = (0, 1)ᵀ`
//! - (6.14) `A · [[i, k], [j, l]] = I` with `A = (T_10, T_20)` (columns)
//! - (6.15) `[[i, k], [j, l]] = A⁻¹`
//!
//! `U_p`, `V_p` are the texture-space unit axes expressed in 3-D (`∂P/∂a`,
//! `∂P/∂b`); their world length is the facet size, not 1.
//!
//! Entry-sphere search (§6.4), [`Lattice`] and [`shade`]:
//! - (6.16) `P = P_c + a·U_p + b·V_p` — the view ray's polygon hit and its texture coordinate
//! - (6.17) `a' = ⌊a⌋ + 0.5` (a ≥ 0)
//! - (6.18) `b' = ⌊b⌋ + 0.5` (b ≥ 0)
//! - (6.19) `a' = ⌈a⌉ − 0.5` (a < 0)
//! - (6.20) `b' = ⌈b⌉ − 0.5` (b < 0)
//! - (6.21) `P' = P_c + a'·U_p + b'·V_p` — the cell centre on the polygon
//! - (6.22) `S = P' − r·N` — the estimated sphere centre
//! - (6.23) `P_s' = P_s + h·N` — a slice-plane hit `P_s` at depth `h`, projected back onto the polygon
//! - (6.24) `P_s' = P_c + a_s·U_p + b_s·V_p`
//! - (6.25) `P_s'c = P_s' − P_c`
//! - (6.26) `a_s = [(V_p·V_p)(P_s'c·U_p) − (V_p·U_p)(P_s'c·V_p)] / [(U_p·U_p)(V_p·V_p) − (U_p·V_p)(V_p·U_p)]`
//! - (6.27) `b_s = [(U_p·U_p)(P_s'c·V_p) − (U_p·V_p)(P_s'c·U_p)] / [(U_p·U_p)(V_p·V_p) − (U_p·V_p)(V_p·U_p)]`
//!
//! The slice planes are at depths `h = s·r/K`, `s = 0..=K` (`s = 0` is the
//! polygon itself, the last one is at `h = r`); the first sphere the view ray
//! intersects ends the search. `K` (the slice count) is the plugin's quality
//! knob. Eq. 6.17–6.20 differ from `⌊a⌋ + 0.5` only on cell edges, where they
//! break ties away from zero — which keeps the rule mirror-symmetric.
//!
//! Refraction and pigment plane (§6.5–6.6), [`refract_through_ball`], [`Lattice`]:
//! - (6.28) `N_D = (D − C) / ‖D − C‖` — the sphere normal at the entry (and, likewise, exit) point
//! - (6.29) `P_T' = P_T + 2r·N` — the pigment-plane hit projected onto the polygon; we use `P_T + d·N`
//! - (6.30) `c = c_t·(a + d) + s` — shading (texture colour times ambient plus diffuse, plus specular), left to the plugin
//!
//! ## What the thesis leaves open, and what we chose
//!
//! - Refraction into neighbouring spheres after the exit is left for future
//!   work in the thesis (§6.5); the shading path follows the thesis (one
//!   lens, [`ShadeOptions::thesis`]) or the exit ray into up to
//!   [`MAX_LENSES`] neighbours ([`ShadeOptions::neighbours`]), or, by the
//!   exact tracer's walk, through every lens the ray meets (up to
//!   [`MAX_EXACT_LENSES`], [`ShadeOptions::exact`]).
//! - Fresnel at the lens surfaces is left for future work too (§6.7's last
//!   line); every traced hit carries the power the lens surfaces transmit,
//!   and [`facet_response`] multiplies it into `c_t` on request.
//! - A hexagonal lattice, as real ommatidia are packed, beside the thesis's
//!   square one ([`LatticeKind`]).
//! - Misses, total internal reflection and escaping rays have no rule in the
//!   thesis: see [`ShadeFallback`]. A missed lens is the thesis's rule: the
//!   unrefracted ray goes on to the pigment plane (§6.4, last paragraph); an
//!   escaping ray reports its direction, so a renderer shows what lies that
//!   way.
//! - Facets smaller than a pixel: [`facet_response_prefiltered`] (nine
//!   traced rays), or the facet average per view direction precomputed
//!   into a [`PrefilterTable`] ([`facet_response_tabled`]).
//! - Degenerate and mirrored UV triangles: see [`TextureAxes`].
//!
//! ## API
//!
//! | items | what |
//! |---|---|
//! | [`scale_uv`], [`TextureAxes`] (thresholds [`UV_DET_REL_EPS`], [`AREA_REL_EPS`], [`NORMAL_COS_EPS`]), [`TextureAxes::on_normal`] ([`MIN_SHADING_COS`]), [`axis_field`] and [`TextureAxes::on_field`] (a smooth field of axes, our addition) | `U_p`, `V_p`, `P_c` per triangle (6.1–6.15), UV ↔ point (6.2, 6.26–6.27) |
//! | [`LensParams`], [`Lattice`], [`PigmentPlaneHit`], [`LatticeKind`], [`LensCell`], [`MAX_SLICES`], [`MIN_COS`] | lens parameters, the lattice of one triangle: cells, lens centres, slices, pigment plane (6.16–6.25, 6.29) |
//! | [`refract_through_ball`], [`BallExit`], [`BallFailure`], [`ball_focal_length`] | refraction into and out of one sphere (6.28), ball-lens focus |
//! | [`shade`], [`shade_with`], [`shade_fragment_with`], [`ShadeOptions`], [`MAX_LENSES`] | the per-fragment path (the thesis's, and followed into neighbouring lenses): the CPU twin of the shader |
//! | [`DarkCentre`], [`facet_response`], [`facet_response_prefiltered`], [`FacetResponse`] | pigment absorption (6.30), Fresnel loss, escape direction, prefilter: the shader's last steps |
//! | [`Shade`], [`PigmentHit`], [`ShadeFallback`] | what a traced view ray returns |
//! | [`facet_lattice`], [`ray_to_facet`], [`shows_dark_centre`] | facet frames on a curved eye and the pseudopupil test |
//! | [`CompoundEyeError`], [`InvalidInput`] | why a constructor refused its input |
//! | [`trace_exact`], [`trace_exact_capped`], [`MAX_CELLS`], [`MAX_WALK_CELLS`], [`MAX_EXACT_LENSES`], [`THESIS_MAX_LENSES`] | the exact lattice tracer: the report's reference, and (capped) the shader's exact path |
//! | `trace_exact_batch`, `shade_batch` | (feature `reference`) batches in parallel |
//!
//! ```
//! use optica_optics::compound_eye::{Lattice, LensParams, Ray, TextureAxes, shade};
//! use optica_optics::glam::DVec3;
//!
//! // Unit facets on z = 0, touching lenses (r = ½), n = 1.5, the thesis's d = 2r.
//! let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z)?;
//! let lattice = Lattice::new(axes, LensParams::thesis(0.5, 1.5)?)?;
//! // A view ray straight down through the centre of cell (2, 3) is undeviated.
//! let ray = Ray::new(DVec3::new(2.5, 3.5, 1.0), -DVec3::Z)?;
//! let hit = *shade(&lattice, &ray, 8).hit().expect("reaches the pigment");
//! assert_eq!(hit.lens, Some([2, 3]));
//! assert!(hit.on_own_centre(lattice.kind(), 0.1));
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod ball_lens;
mod error;
mod exact_tracer;
mod lattice;
mod lattice_kind;
mod outcome;
mod pigment;
mod prefilter_table;
mod pseudopupil;
mod shading_path;
mod texture_axes;

pub use crate::input::InvalidInput;
pub use crate::ray::Ray;

pub use ball_lens::{BallExit, BallFailure, ball_focal_length, refract_through_ball};
pub use error::CompoundEyeError;
#[cfg(feature = "reference")]
pub use exact_tracer::trace_exact_batch;
pub use exact_tracer::{
    MAX_CELLS, MAX_EXACT_LENSES, MAX_WALK_CELLS, THESIS_MAX_LENSES, trace_exact, trace_exact_capped,
};
pub use lattice::{Lattice, LensParams, MAX_SLICES, MIN_COS, PigmentPlaneHit};
pub use lattice_kind::{LatticeKind, LensCell};
pub use outcome::{PigmentHit, Shade, ShadeFallback};
pub use pigment::{
    DarkCentre, FacetResponse, PREFILTER_FULL, PREFILTER_OFFSETS, PREFILTER_START, facet_response,
    facet_response_prefiltered, facet_response_tabled,
};
pub use prefilter_table::{
    PrefilterTable, TABLE_AZIMUTHS, TABLE_POLARS, TABLE_SAMPLES, TableSample,
};
#[cfg(feature = "reference")]
pub use pseudopupil::dark_patch_centroid;
pub use pseudopupil::{facet_lattice, ray_to_facet, shows_dark_centre};
#[cfg(feature = "reference")]
pub use shading_path::shade_batch;
pub use shading_path::{
    MAX_LENSES, NEIGHBOUR_SPAN_CELLS, ShadeOptions, shade, shade_fragment, shade_fragment_with,
    shade_with,
};
pub use texture_axes::{
    AREA_REL_EPS, FieldVertex, axis_field, MIN_SHADING_COS, NORMAL_COS_EPS, TextureAxes, UV_DET_REL_EPS, scale_uv,
};
