//! # Dome — fisheye projection with adaptive refinement
//!
//! The CPU reference of the dome plugin, after Yuna Johjima and Masao
//! Fujimura (城島由奈・藤村真生), *Fragment refinement for real-time
//! equidistant projection* (「リアルタイム等距離射影変換のためのフラグメント精緻化」;
//! the paper's own English title: *Enhancing the exquisite fragment to
//! equidistant projection technique in real-time*), Graduate School of
//! Engineering, Osaka Institute of Technology. The paper's text names
//! neither its venue nor its year; its newest reference is from 2008.
//!
//! The paper projects every vertex of a planetarium scene equidistantly in
//! the vertex shader (its earlier work \[1\]) and observes that the straight
//! edges drawn between projected vertices are visibly wrong when an edge
//! subtends a large angle (§2, fig. 1). It splits such edges in a geometry
//! shader, by the angle they subtend (§3.2), splits triangles along their
//! edges and triangulates the inside so that neighbours share edges (§3.3),
//! and leaves small primitives of constant apparent size to a subdivision done
//! once in advance (§3.1).
//!
//! ```
//! use optica_optics::dome::{DomeSettings, DomeProjection, SplitRule, refine_segment};
//! use optica_optics::glam::DVec3;
//!
//! // A 4K, 180° dome; the camera looks along −Z (the zenith).
//! let dome = DomeProjection::new(&DomeSettings::default())?;
//! let rule = SplitRule::chord_gap(0.5)?; // at most 0.5 px off the true arc
//! // A 10° edge along the horizon in front of the audience (view −Y).
//! let h = 5f64.to_radians();
//! let (a, b) = (DVec3::new(h.sin(), -h.cos(), -0.01), DVec3::new(-h.sin(), -h.cos(), -0.01));
//! let refined = refine_segment(&dome, a, b, rule)?;
//! assert_eq!(refined.segment_count(), 4);
//! let pixel = dome.project(a).visible_pixel().unwrap();
//! assert!((pixel.y - 4096.0).abs() < 30.0); // near the bottom of the frame
//! # Ok::<(), optica_optics::dome::DomeError>(())
//! ```
//!
//! ## Equations
//!
//! The paper has no numbered equations: it states the method as numbered
//! steps (§3.2 steps 1–3, §3.3 steps 1–7, figs. 3–8) and takes r = fθ from
//! its reference \[1\]. The formulas used here are numbered D1–D8; each says
//! where it comes from.
//!
//! * **D1** (the equidistant, or f-θ, fisheye model, which the paper takes
//!   from \[1\], §2) — a direction at polar angle θ from the dome axis and
//!   azimuth φ lands at radius `r = f·θ` from the image centre, at angle φ.
//! * **D2** (ours, numerics) — polar angle of a view-space point p in dome
//!   coordinates (x, y, z) = (p·right, p·up, p·axis):
//!   `θ = atan2(√(x² + y²), z)` — never `acos(z/|p|)`, which loses half the
//!   digits near θ = 0 and θ = π. Pixel = `centre + f·θ·(x, −y)/√(x² + y²)`.
//! * **D3** (the common domemaster convention, as in Paul Bourke's notes on
//!   fisheye domemaster images) — square frame of side S, inscribed image
//!   circle, zenith at the centre, audience front at the bottom:
//!   `f = (S/2)/(FOV/2)` px/rad (4K, 180°: f = 1303.8).
//! * **D4** (paper §3.2 step 1, §3.3 step 1: "compute the visual angle θ",
//!   視野角 θ を算出する) — the angle an edge a–b subtends at the viewer,
//!   `α = atan2(|a × b|, a·b)`; the paper's split "according to the visual
//!   angle" is `n = ⌈α/Δ⌉` pieces ([`SplitRule::visual_angle`]).
//! * **D5** (ours, from the curvature of the projected great circle; derived
//!   in the docs of [`SplitRule`]) — chord gap of a tangential piece
//!   subtending α at polar angle θ: `s ≈ f·α²·(θ/sin θ − cos θ)/(8·sin θ)`,
//!   ≈ `f·α²·θ/12` near the centre, `(π/16)·f·α²` on the 180° rim. So at
//!   4K/180° a 10° rim edge is off by ~8 px (7.8; the exact rim sagitta is
//!   2048·(1 − cos 5°) = 7.79 px) and 0.5 px needs ≤ ~2.5° pieces there. A
//!   test holds D5 to the exact error D8 within 1% for 1° pieces.
//! * **D6** (ours, generalising D5 to any orientation) — normal acceleration
//!   of the image of a great circle crossing the meridian at angle ψ:
//!   `N(θ, ψ) = f·sin ψ·[T sin²ψ + K cos²ψ]/√(cos²ψ + (θ/sin θ)² sin²ψ)`,
//!   `T = θ(θ − sin θ cos θ)/sin³θ`, `K = 2(sin θ − θ cos θ)/sin²θ`,
//!   `s ≈ α²·N/8`; with Clairaut's `sin θ·sin ψ = sin θ₀` along the circle.
//!   ψ = 90° gives D5, ψ = 0 (radial) gives 0. [`SplitRule::chord_gap`] uses
//!   `n = ⌈α·√(N_max/(8·tol))⌉`, N_max at the arc's largest θ.
//! * **D7** (ours, for paper §3.2 step 2, "generate new vertices", 新しく頂点を生成する)
//!   — new vertices at equal angles along the arc, placed on the 3D segment
//!   (so they keep the segment's depth): the point seen at angle
//!   β from a is `a + t·(b − a)` with
//!   `t = |a| sin β / (|a| sin β + |b| sin(α − β))`.
//! * **D8** (ours) — exact error of a chord: the largest pixel distance from
//!   the projected great-circle arc to the chord between the projected
//!   endpoints (`chord_error_px`, feature `reference`).
//! * **D9** (the radial fisheye models; Kannala and Brandt's polynomial for
//!   calibrated lenses) — the paper's r = f·θ generalised to `r = f·g(θ)`:
//!   equidistant θ, equisolid 2 sin(θ/2), stereographic 2 tan(θ/2),
//!   orthographic sin θ, polynomial k₁θ + k₂θ³ + k₃θ⁵ + k₄θ⁷, with
//!   `f = R/g(θ_max)` so the rim lies on the image circle of radius R (half
//!   the shorter side of the image). See [`FisheyeLens`].
//! * **D10** (ours, D6 for any g) — the normal acceleration of the image of
//!   a great circle under r = F(θ): velocity `(F′ cos ψ, F sin ψ/sin θ)`,
//!   acceleration `(F″ cos²ψ + F′ cos θ sin²ψ/sin θ − F sin²ψ/sin²θ,
//!   2 cos ψ sin ψ (F′/sin θ − F cos θ/sin²θ))` in the image's polar frame,
//!   `N = |v × a|/|v|`. It equals D6 for F = fθ. The chord-gap rule takes
//!   its largest value over samples along the arc (for the equidistant lens
//!   the arc's largest θ, where D6 is largest).
//! * **D11** (ours) — exact attributes inside a refined triangle: each
//!   fragment moves its interpolated position along its screen
//!   differences to where its own ray meets the triangle's plane, and its
//!   attributes by the same step ([`plane_step`], `fragment.rs`).
//! * **E1, E2** (the equirectangular panorama, not a fisheye: longitude
//!   and latitude on a 2:1 image, and the curvature of a great circle's
//!   image there) — see [`EquirectProjection`]; its seam and poles are cut
//!   and mended by [`refine_mesh_equirect`].
//!
//! ## Conventions
//!
//! Bevy view space (camera looks along −Z, +Y up), in metres, though only
//! directions matter to the image. At tilt 0 the dome axis is
//! view −Z and the image's up is view +Y, so the audience front (bottom centre
//! of the domemaster) is view −Y: mount the camera like a fisheye pointing at
//! the zenith, up vector towards the back of the theatre. `tilt_deg` leans the
//! dome forward: axis `(0, −sin τ, −cos τ)`. See [`DomeSettings`].
//!
//! ## Where the projection is singular
//!
//! * The camera origin: [`Projected::Origin`]; segments through the viewer:
//!   [`DomeError::ThroughViewer`]; triangles touching the origin are left out.
//! * The antipode (θ → π): [`Projected::Antipode`] within [`ANTIPODE_EPS_RAD`].
//! * Behind the viewer, FOV ≤ 180°: clip against the view plane z = 0
//!   before projecting (segments and triangles). Unclipped, a floor under a
//!   zenith camera has vertices near the antipode and its triangles cover
//!   the whole disk. Next to 180° (within [`RIM_MARGIN_DEG`]) the cut lies on
//!   the rim and its chords sag inside the image circle; a cut triangle then
//!   gets a *rim skirt*, its own plane carried 1° on past the cut
//!   ([`DomeProjection::rim_skirt_rad`]).
//! * FOV > 180°: the visible set is not convex. Segments are clipped exactly to
//!   the guard cone θ ≤ θ_clip = (θ_max + π)/2 along their arc; triangles are
//!   refined whole (edges leaving the guard cone get pieces of at most
//!   [`DomeProjection::guard_piece_rad`]) and the sub-triangles reaching past
//!   the guard cone, or covering the antipode, are culled. Between rim and
//!   guard, geometry lands outside the image circle, where a renderer
//!   discards fragments. See [`clip_segment`] and
//!   [`DomeProjection::theta_reach`].
//!
//! ## Triangles
//!
//! §3.3 as written spaces the interior by the split points of the two
//! shorter sides; where the inside of a triangle is nearer the viewer than
//! its sides this leaves interior edges several times too long (we measured
//! 4.5× the tolerance at 0.5 px on an inside-out room, 8 × 9 × 4.7 m, seen
//! from 1.7 m above its floor). We add a conforming bisection of such
//! interior edges that never touches the triangle's boundary, so shared
//! edges still split identically from both sides (`interior.rs`).
//!
//! ## Modules
//!
//! | file | what |
//! |---|---|
//! | `camera.rs` | [`DomeSettings`] settings, [`DomeProjection`] frame |
//! | `lens.rs` | D9: [`FisheyeLens`], the radial mappings and their inverses |
//! | `projection.rs` | D1–D3, D9 forward and inverse, [`Projected`] |
//! | `arc.rs` | D4, D7: subtended angles, split points |
//! | `rule.rs` | D4–D6, D10: [`SplitRule`] |
//! | `clip.rs` | view-plane and guard-cone clipping |
//! | `refine.rs` | §3.2: segments and polylines |
//! | `triangle.rs` | §3.3: triangles and meshes, crack-free |
//! | `interior.rs` | conforming bisection of interior edges (our addition) |
//! | `fragment.rs` | D11: exact attributes per fragment (our addition) |
//! | `equirect.rs` | E1, E2: [`EquirectProjection`], the 360° × 180° panorama |
//! | `equirect_refine.rs` | panorama refinement: quarter cuts, seam and poles |
//! | `panorama.rs` | [`Panorama`]: either projection behind one type |
//! | `classify.rs` | §3.1: dynamic vs pre-subdivided primitives |
//! | `error.rs` | [`DomeError`] |
//! | `measure.rs` | D8: exact chord error (feature `reference`) |
//! | `scenes.rs` | test scenes: a box mesh, seeded random edges (feature `reference`) |
//!
//! \[1\] Yuna Johjima, Masao Fujimura et al. (城島由奈, 高野敦史, 藤村真生,
//! 東利香), *Equidistant projection for real-time
//! 3D CG using shaders* (シェーダを用いたリアルタイム3次元CGのための等距離射影変換),
//! Proceedings of the ITE (Institute of Image Information and Television
//! Engineers) Annual Convention (映像情報メディア学会年次大会講演予稿集), 17-6, 2008.

mod arc;
mod camera;
mod classify;
mod clip;
mod equirect;
mod equirect_refine;
mod error;
mod fragment;
mod interior;
mod lens;
#[cfg(feature = "reference")]
mod measure;
mod panorama;
mod projection;
mod refine;
mod rule;
#[cfg(feature = "reference")]
mod scenes;
mod triangle;

pub use arc::split_segment;
pub use camera::{DomeProjection, DomeSettings, MIN_FOV_DEG, RIM_MARGIN_DEG};
pub use classify::{
    ApparentSize, PrimitiveKind, Treatment, classify, pre_subdivide, pre_subdivision_piece_rad,
};
pub use clip::clip_segment;
pub use fragment::{MAX_STEP_PX, plane_step};
#[cfg(feature = "reference")]
pub use equirect::equirect_chord_error_px;
pub use equirect::{
    CURVATURE_SAMPLES, EquirectProjection, EquirectSettings, POLE_EPS_RAD, SEAM_NUDGE_RAD,
};
pub use equirect_refine::POLE_SNAP_RAD;
pub use equirect_refine::{
    refine_mesh_equirect, refine_segment_equirect, refine_segments_equirect,
    refine_triangle_equirect,
};
pub use error::DomeError;
pub use lens::FisheyeLens;
#[cfg(feature = "reference")]
pub use measure::{EdgeErrors, SAMPLES, chord_error_px, polyline_error_px};
pub use panorama::Panorama;
pub use projection::{ANTIPODE_EPS_RAD, ImagePoint, Projected};
pub use refine::{
    RefineStats, RefinedLines, RefinedSegment, refine_polyline, refine_segment, refine_segments,
};
pub use rule::{MAX_PIECES, Pieces, SplitRule};
#[cfg(feature = "reference")]
pub use scenes::{RANDOM_EDGE_DISTANCE_M, cube_face_axis, random_edges};
pub use triangle::{RefinedMesh, TriMesh, is_left_whole, refine_mesh, refine_triangle};

/// The types in this module's signatures that come from the crate's core:
/// [`InvalidInput`] (inside [`DomeError::Input`] and returned by the
/// [`SplitRule`] constructors) and what it expects.
pub use crate::input::{Expected, InvalidInput};

/// A seeded uniform generator on [0, 1) for tests (a 64-bit LCG): the same
/// numbers every run.
#[cfg(test)]
pub(crate) fn test_uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// The projection of a test: `fov` degrees, `tilt` degrees, `size` px.
#[cfg(test)]
pub(crate) fn test_dome(fov: f64, tilt: f64, size: u32) -> DomeProjection {
    DomeProjection::new(&DomeSettings {
        fov_deg: fov,
        tilt_deg: tilt,
        size_px: size,
        ..Default::default()
    })
    .expect("valid test dome")
}

/// [`test_dome`] with another lens.
#[cfg(test)]
pub(crate) fn test_lens_dome(lens: FisheyeLens, fov: f64, tilt: f64, size: u32) -> DomeProjection {
    DomeProjection::new(&DomeSettings {
        fov_deg: fov,
        tilt_deg: tilt,
        size_px: size,
        lens,
        ..Default::default()
    })
    .expect("valid test dome")
}
