//! The lens-flare plugin itself on the adapter: its rows in the
//! `lens_flare` report (series named in [`rendered_rows`]).
//!
//! * Scene: the coated Angénieux double Gauss (US 2,701,982; every
//!   unblocked ghost of its 91 drawn in the full run, the 8 brightest in
//!   the quick one), three wavelengths, a round iris, a sun 10° off axis.
//! * Knobs: rays per side of every ghost's grid (the plugin's
//!   `LensFlare::grid`: in `rendered`, the default, the mean of grids
//!   shared by power; in `fixed grid` every ghost's), in the series
//!   `wavelengths (32² fixed)` the number of wavelengths
//!   (`LensFlare::wavelengths`, at half resolution), and in `ghost resolution (defaults)` the
//!   divisor of the view's side the ghosts are added up at
//!   (`LensFlare::ghost_resolution`; the other series use the default, a
//!   quarter). The row `rendered` at 16 is the plugin's defaults.
//! * Error: the flare layer (a black scene, HDR readback, no tonemapping)
//!   against the CPU reference of the same frame: every drawn ghost traced
//!   at 512² rays (quick: 128²) per wavelength with
//!   `optica_optics::lens_flare::trace_grid` and rasterised with exact
//!   coverage over the frame's sensor window, weighted like the plugin's
//!   colours (each ghost's three samples scaled by its spectral gains;
//!   for the wavelength series, the band integral: 33 samples at 128²
//!   rays, quick 64², their weights alone). `rel_l1` = Σ|gpu − ref| / Σ
//!   ref over all channels,
//!   `rel_energy` the signed total, `psnr_db` against the reference's
//!   peak, `flip_mean` the mean ꟻLIP of the two layers shown as a person
//!   sees them (divided by the reference's 99.5th percentile, clamped,
//!   gamma 2.2).
//! * Time: the frame of a lit scene (ground, pillars, shadows) with the
//!   flare against the same frame without it, in the same run
//!   (`baseline_time_ms`); `flare_ms` the flare's passes (GPU timestamps
//!   where the adapter has them, else the frame's wall time — see
//!   `flare_source`), and each pass's share as `{pass}_ms` (`trace_ms`,
//!   `cells_ms`, `coarse_ms`, `draw_ms`, `composite_ms`, …, GPU timestamps
//!   only). The camera is still, so its rays are traced once
//!   (`trace_frames`); the row `turning camera (defaults)` turns it a tenth
//!   of a degree a frame, tracing every frame: the cost a game pays while
//!   the view moves.

use std::sync::{Arc, Mutex};

use bevy::camera::Exposure;
use bevy::prelude::*;
use optica_harness::{FrameTimings, TimeSource};
use optica_lens_flare::twins::{
    SPECTRUM_BUDGET_MS, SensorMapping, passing_at_step, spectral_gains, spectrum_at_step,
};
use optica_lens_flare::{
    DEFAULT_COARSE_GHOST_PX, DEFAULT_MERGE_CELLS, DEFAULT_MERGE_WAVELENGTHS_PX, FlareGhosts,
    FlareSource, GhostResolution, LensAsset, LensFlare, LensFlarePlugin,
};
use optica_optics::glam::{DVec2, DVec3};
use optica_optics::glass::LAMBDA_D_NM;
use optica_optics::lens::{LensPrescription, PreparedLens, TracePath, builtin};
use optica_optics::lens_flare::{
    Beam, GridOptions, SensorImage, SensorWindow, rasterise_into, spectral_weight, spectrum_lenses,
    trace_grid,
};

use super::SweepError;
use crate::fixtures::black_hdr_camera;
use crate::{Report, Row, SweepContext};

const LUX: f32 = 100_000.0;

/// `LensFlare::grid`'s default: the mean rays per side of the default
/// grids, shared among the ghosts by power.
const DEFAULT_GRID: u32 = 16;

/// The sun's direction of travel in view space: 10° off axis, up and right.
fn travel() -> Vec3 {
    let t = 10f32.to_radians();
    Vec3::new(-t.sin() * 0.6, -t.sin() * 0.8, t.cos())
}

/// How the flare is set up in one render.
#[derive(Clone)]
pub(super) struct Setup {
    lens: LensPrescription,
    grid: u32,
    budget: u32,
    adaptive: bool,
    symmetry: bool,
    /// Starburst and ringing on (their defaults); off for the rows held to
    /// the CPU reference, which has neither.
    diffraction: bool,
    wavelengths: u32,
    /// `LensFlare::merge_wavelengths_px`.
    merge_px: f32,
    /// `LensFlare::coarse_ghost_px`.
    coarse_px: Option<f32>,
    /// `LensFlare::merge_cells`.
    merge_cells: f32,
    /// The resolution the ghosts are added up at.
    resolution: GhostResolution,
    /// The timed camera turns a little every frame (its rays are traced
    /// again each frame; a still camera's are traced once).
    turning: bool,
}

impl Setup {
    /// The coated double Gauss, `grid`, the plugin's speed-ups on, no
    /// diffraction textures.
    fn double_gauss(grid: u32, budget: u32) -> Self {
        Self {
            // The compiled-in copy of assets/lenses/double-gauss-us2701982.lens:
            // the runner needs no asset folder wherever it runs.
            lens: builtin::double_gauss(),
            grid,
            budget,
            adaptive: true,
            symmetry: true,
            diffraction: false,
            wavelengths: 3,
            merge_px: DEFAULT_MERGE_WAVELENGTHS_PX,
            coarse_px: Some(DEFAULT_COARSE_GHOST_PX),
            merge_cells: DEFAULT_MERGE_CELLS,
            resolution: GhostResolution::default(),
            turning: false,
        }
    }
}

/// The 33-interface zoom (assets/lenses/zoom-canon-us5537259.lens), as
/// `optica_optics` compiles it in.
fn zoom() -> Result<LensPrescription, SweepError> {
    let (_, text) = optica_optics::lens::ALL_LENS_FILES
        .iter()
        .find(|(name, _)| name.starts_with("zoom-canon"))
        .ok_or_else(|| SweepError::Setup("no zoom among the shipped lenses".into()))?;
    LensPrescription::parse(text).map_err(|e| SweepError::Setup(e.to_string()))
}

/// The zoom with every one of its 528 ghosts allowed, the default grid
/// (16² on average) and the double Gauss rows' other settings.
pub(super) fn zoom_setup() -> Result<Setup, SweepError> {
    Ok(Setup {
        lens: zoom()?,
        ..Setup::double_gauss(DEFAULT_GRID, 528)
    })
}

/// A camera at the origin looking along −Z, the sun and, with `lit`, a
/// ground and pillars; the flare on the camera when `setup` is given.
pub(super) fn scene(
    setup: Option<Setup>,
    lit: bool,
    log: Option<Arc<Mutex<Option<FlareGhosts>>>>,
) -> impl FnOnce(&mut App) {
    move |app: &mut App| {
        let turning = lit && setup.as_ref().is_some_and(|s| s.turning);
        app.add_plugins(LensFlarePlugin);
        app.add_systems(
            Startup,
            move |mut commands: Commands,
                  mut lenses: ResMut<Assets<LensAsset>>,
                  mut meshes: ResMut<Assets<Mesh>>,
                  mut materials: ResMut<Assets<StandardMaterial>>| {
                commands.spawn((
                    DirectionalLight {
                        illuminance: LUX,
                        shadow_maps_enabled: lit,
                        ..default()
                    },
                    Transform::IDENTITY.looking_to(travel(), Vec3::Y),
                    FlareSource::default(),
                ));
                if lit {
                    let grey = materials.add(StandardMaterial::default());
                    commands.spawn((
                        Mesh3d(meshes.add(Plane3d::default().mesh().size(200.0, 200.0))),
                        MeshMaterial3d(grey.clone()),
                        Transform::from_xyz(0.0, -1.7, 0.0),
                    ));
                    for k in 0..6 {
                        commands.spawn((
                            Mesh3d(meshes.add(Cuboid::new(1.0, 6.0, 1.0))),
                            MeshMaterial3d(grey.clone()),
                            // Between the pillars: the sun stays in sight (not occluded).
                            Transform::from_xyz(-9.0 + 3.0 * k as f32, 1.3, -12.0),
                        ));
                    }
                }
                let mut camera = commands.spawn(black_hdr_camera());
                if let Some(setup) = &setup {
                    let defaults = LensFlare::new(lenses.add(LensAsset(setup.lens.clone())));
                    let mut flare = LensFlare {
                        grid: setup.grid,
                        adaptive_grid: setup.adaptive,
                        symmetry: setup.symmetry,
                        wavelengths: setup.wavelengths,
                        merge_wavelengths_px: setup.merge_px,
                        coarse_ghost_px: setup.coarse_px,
                        merge_cells: setup.merge_cells,
                        ghost_budget: setup.budget,
                        min_relative: 0.0,
                        starburst: defaults.starburst.filter(|_| setup.diffraction),
                        ringing: defaults.ringing.filter(|_| setup.diffraction),
                        ghost_resolution: setup.resolution,
                        ..defaults
                    };
                    flare.aperture.blades = 0;
                    camera.insert(flare);
                }
            },
        );
        if turning {
            // A tenth of a degree a frame: the sun moves across the lens's
            // field, so every frame traces its rays again.
            app.add_systems(
                Update,
                |mut cameras: Query<&mut Transform, With<LensFlare>>| {
                    for mut t in &mut cameras {
                        t.rotate_y(0.1f32.to_radians());
                    }
                },
            );
        }
        if let Some(log) = log {
            app.add_systems(Last, move |ghosts: Query<&FlareGhosts>| {
                if let Ok(g) = ghosts.single() {
                    *log.lock().expect("log") = Some(g.clone());
                }
            });
        }
    }
}

/// What a new degree of field angle costs the main thread, ms (a turning
/// camera meets one per degree; a still one none): where each drawn
/// ghost's light passes, and its spectrum over the band, at one fit step
/// (10°, the report's sun), timed here on the CPU as the plugin makes them.
fn fit_cost(ghosts: &FlareGhosts) -> Result<(f64, f64), SweepError> {
    let setup = |e: String| SweepError::Setup(e);
    let lens = ghosts
        .lens
        .as_ref()
        .ok_or_else(|| setup("no lens".into()))?;
    let aperture = ghosts.aperture.ok_or_else(|| setup("no aperture".into()))?;
    let middle = PreparedLens::new(lens, 550.0).map_err(|e| setup(e.to_string()))?;
    let lenses = spectrum_lenses(lens).map_err(|e| setup(e.to_string()))?;
    let step = 10;
    let start = std::time::Instant::now();
    let passing: Vec<_> = ghosts
        .drawn()
        .map(|ghost| passing_at_step(lens, &middle, ghost, &aperture, step))
        .collect();
    let passing_ms = start.elapsed().as_secs_f64() * 1e3;
    let start = std::time::Instant::now();
    let spectra = ghosts
        .drawn()
        .zip(passing)
        .filter_map(|(ghost, p)| spectrum_at_step(lens, &lenses, ghost, &aperture, step, p))
        .count();
    let spectrum_ms = start.elapsed().as_secs_f64() * 1e3;
    std::hint::black_box(spectra);
    Ok((passing_ms, spectrum_ms))
}

/// How the CPU reference weights its wavelengths.
#[derive(Clone, Copy, PartialEq)]
enum Spectrum {
    /// As the plugin does: each ghost's samples scaled by the plugin's own
    /// spectral gains (`optica_lens_flare::twins::spectral_gains`), so that the
    /// reference differs from the plugin by the grids and the drawing only
    /// (the gains' own error is the wavelength series').
    Gained,
    /// The samples' weights alone: with many samples, the band integral
    /// itself (33 samples are within 1 % of 65 on the double Gauss).
    Plain,
}

/// The CPU reference of the flare layer at `wavelengths` samples: RGB per
/// pixel of a `size`² frame.
fn reference(
    ghosts: &FlareGhosts,
    size: u32,
    rays: usize,
    wavelengths: u32,
    spectrum: Spectrum,
) -> Result<Vec<[f64; 3]>, SweepError> {
    let setup = |e: String| SweepError::Setup(e);
    let lens = ghosts
        .lens
        .as_ref()
        .ok_or_else(|| setup("no lens".into()))?;
    let aperture = ghosts.aperture.ok_or_else(|| setup("no aperture".into()))?;
    let efl = lens
        .paraxial(LAMBDA_D_NM)
        .map_err(|e| setup(e.to_string()))?
        .efl_mm;
    let map = SensorMapping::new(efl, std::f64::consts::FRAC_PI_4, 1.0)
        .ok_or_else(|| setup("no sensor mapping".into()))?;
    let n = size as usize;
    let px = 2.0 * map.half_height_mm / f64::from(size);
    let window = SensorWindow::new(DVec2::splat(-map.half_height_mm), px, n, n)
        .map_err(|e| setup(e.to_string()))?;
    let wavelengths = LensFlare {
        wavelengths,
        ..LensFlare::new(Handle::default())
    }
    .wavelengths_nm();
    let d = travel().as_dvec3();
    let scale = f64::from(LUX) * f64::from(Exposure::default().exposure()) / (px * px);
    // Per drawn ghost, the gains of its samples (one: plain weights).
    let gains: Vec<DVec3> = match spectrum {
        Spectrum::Plain => vec![DVec3::ONE; ghosts.drawn().count()],
        Spectrum::Gained => ghosts
            .drawn()
            .map(|ghost| spectral_gains(lens, ghost, &aperture, d, &wavelengths))
            .collect(),
    };
    let mut rgb = vec![[0.0; 3]; n * n];
    for &wl in &wavelengths {
        let prepared = PreparedLens::new(lens, wl).map_err(|e| setup(e.to_string()))?;
        for ((first, second), gain) in ghosts.drawn().zip(&gains) {
            let path = TracePath::ghost(first, second);
            let Ok(beam) = Beam::for_path(lens, path, d, wl) else {
                continue;
            };
            let Ok(grid) = trace_grid(&prepared, path, &beam, rays, &GridOptions::default()) else {
                continue;
            };
            let mut image = SensorImage::new(window);
            rasterise_into(&grid, &aperture, &mut image);
            let w = spectral_weight(wl, &wavelengths) * *gain;
            for (k, p) in image.power().iter().enumerate() {
                // Sensor pixel (ix, iy) shows at frame pixel (n − 1 − ix, iy).
                let (ix, iy) = (k % n, k / n);
                let out = &mut rgb[iy * n + (n - 1 - ix)];
                for (c, weight) in w.to_array().into_iter().enumerate() {
                    out[c] += p * scale * weight;
                }
            }
        }
    }
    Ok(rgb)
}

/// The value shown as white when the flare layers are compared as a person
/// sees them (ꟻLIP): the reference's 99.5th percentile of lit channel
/// values, so that the ghosts, not a caustic's peak, fill the range.
fn white_point(reference: &[[f64; 3]]) -> f64 {
    let mut lit: Vec<f64> = reference
        .iter()
        .flatten()
        .copied()
        .filter(|v| *v > 0.0)
        .collect();
    if lit.is_empty() {
        return 1.0;
    }
    lit.sort_by(f64::total_cmp);
    lit[(lit.len() * 995 / 1000).min(lit.len() - 1)]
}

/// A flare layer as an 8-bit sRGB-ish picture: divided by `white`, clamped,
/// gamma 2.2.
fn displayed(rgb: &[[f64; 3]], size: u32, white: f64) -> image::RgbaImage {
    image::RgbaImage::from_fn(size, size, |x, y| {
        let p = rgb[(y * size + x) as usize];
        let t = |v: f64| ((v / white).clamp(0.0, 1.0).powf(1.0 / 2.2) * 255.0).round() as u8;
        image::Rgba([t(p[0]), t(p[1]), t(p[2]), 255])
    })
}

/// The work the device counted per frame (medians of the frames a pass
/// ran in), where it has pipeline-statistics queries: the flare's passes
/// (`trace_invocations` and `cells_invocations` where the rays were
/// traced in the timed frames, `occlusion_invocations`,
/// `draw_vertices`, `draw_fragments`, the large ghosts' `coarse_vertices`
/// and `coarse_fragments`, `composite_fragments`) and the
/// scene's main pass (`main_vertices`, `main_fragments`), so that the
/// flare's cost can be judged on any device (lavapipe counts fragments in
/// whole 4×4 blocks per triangle); and `trace_frames`, the timed frames
/// the trace ran in (a still camera's rays are traced once).
fn counted(mut row: Row, timed: &FrameTimings) -> Row {
    let traced = timed
        .span("optica/lens_flare/trace")
        .and_then(|s| s.counts.get("compute_shader_invocations"))
        .filter(|c| c.median > 0.0)
        .map_or(0, |c| c.n);
    row = row.work("trace_frames", traced as f64);
    for (key, span, count) in [
        (
            "trace_invocations",
            "optica/lens_flare/trace",
            "compute_shader_invocations",
        ),
        (
            "cells_invocations",
            "optica/lens_flare/cells",
            "compute_shader_invocations",
        ),
        (
            "composite_fragments",
            "optica/lens_flare/composite",
            "fragment_shader_invocations",
        ),
        (
            "occlusion_invocations",
            "optica/lens_flare/occlusion",
            "compute_shader_invocations",
        ),
        (
            "draw_vertices",
            "optica/lens_flare/draw",
            "vertex_shader_invocations",
        ),
        (
            "draw_fragments",
            "optica/lens_flare/draw",
            "fragment_shader_invocations",
        ),
        (
            "coarse_vertices",
            "optica/lens_flare/coarse",
            "vertex_shader_invocations",
        ),
        (
            "coarse_fragments",
            "optica/lens_flare/coarse",
            "fragment_shader_invocations",
        ),
        (
            "main_vertices",
            "main_opaque_pass_3d",
            "vertex_shader_invocations",
        ),
        (
            "main_fragments",
            "main_opaque_pass_3d",
            "fragment_shader_invocations",
        ),
    ] {
        if let Some(c) = timed.span(span).and_then(|s| s.counts.get(count)) {
            row = row.work(key, c.median);
        }
    }
    // Each pass's own GPU time (median over the frames it ran in), where
    // the adapter has timestamps: where the flare's cost goes.
    for pass in [
        "occlusion",
        "trace",
        "fill",
        "cells",
        "coarse",
        "draw",
        "composite",
    ] {
        let span = timed.span(&format!("optica/lens_flare/{pass}"));
        if let Some(ms) = span.and_then(|s| s.gpu_ms) {
            row = row.work(&format!("{pass}_ms"), ms.median);
        }
    }
    row
}

/// One row: the flare of `setup` rendered on black against `reference`
/// (when given), and the lit scene timed with it against the scene
/// without the flare, in alternating blocks.
#[allow(clippy::too_many_arguments)]
fn row(
    ctx: &SweepContext,
    report: &mut Report,
    series: &str,
    setup: Setup,
    size: u32,
    reference: Option<&[[f64; 3]]>,
    timing: (u32, u32),
    knob: f64,
) -> Result<(), SweepError> {
    let log = Arc::new(Mutex::new(None));
    let headless = ctx.headless(size, size).hdr(true).frames(12);
    let frame = headless.render(scene(Some(setup.clone()), false, Some(log.clone())))?;
    report.adapter.get_or_insert(frame.adapter.clone());
    let ghosts = log
        .lock()
        .map_err(|_| SweepError::Setup("log".into()))?
        .clone()
        .ok_or_else(|| SweepError::Setup("the flare chose no ghosts".into()))?;
    // The lit scene with the flare against it without, in alternating blocks.
    let (blocks, per_block) = ctx.blocks();
    let paired = ctx.headless(size, size).hdr(true).time_paired(
        timing.0,
        blocks,
        per_block,
        scene(Some(setup.clone()), true, None),
        scene(None, true, None),
    )?;
    let timed = &paired.effect;
    let flare = timed.pass("optica/lens_flare");
    let mut row = Row::paired(knob, &paired)
        .series(series)
        .work("ghosts", ghosts.drawn().count() as f64)
        .work(
            "rays_per_light_and_wavelength",
            ghosts.rays_per_light() as f64,
        )
        .work("wavelengths", f64::from(setup.wavelengths))
        .work("grid", f64::from(setup.grid))
        .work("size_px", f64::from(size))
        .work("flare_ms", flare.map_or(f64::NAN, |p| p.ms.median))
        .work(
            "flare_source_gpu",
            f64::from(u8::from(
                flare.is_some_and(|p| p.source == TimeSource::GpuTimestamps),
            )),
        );
    row = counted(row, timed);
    if let Some(reference) = reference {
        let img = frame
            .hdr()
            .ok_or_else(|| SweepError::Setup("no HDR frame".into()))?;
        let ref_total: f64 = reference.iter().flatten().sum();
        let ref_peak = reference.iter().flatten().copied().fold(0.0, f64::max);
        let (mut l1, mut total, mut se) = (0.0, 0.0, 0.0);
        for (p, want) in img.pixels().zip(reference) {
            for (c, &r) in want.iter().enumerate() {
                let g = f64::from(p.0[c]);
                l1 += (g - r).abs();
                total += g;
                se += (g - r) * (g - r);
            }
        }
        let mse = se / (3 * reference.len()) as f64;
        let psnr = 10.0 * (ref_peak * ref_peak / mse.max(1e-300)).log10();
        let gpu: Vec<[f64; 3]> = img
            .pixels()
            .map(|p| [0, 1, 2].map(|c| f64::from(p.0[c])))
            .collect();
        let white = white_point(reference);
        let flip = optica_harness::metrics::compare(
            &displayed(reference, size, white),
            &displayed(&gpu, size, white),
        )
        .map_err(|e| SweepError::Setup(format!("{e:?}")))?;
        row = row
            .err("rel_l1", l1 / ref_total)
            .err("rel_energy", (total - ref_total) / ref_total)
            .err("psnr_db", psnr)
            .err("flip_mean", flip.flip_mean);
    }
    report.rows.push(row);
    Ok(())
}

/// Appends the plugin's rows: series `rendered` (grids shared by power,
/// the default, with symmetry), `fixed grid` (every ghost at grid²) and,
/// at 32², `no symmetry` against the CPU reference at three wavelengths
/// (with the plugin's spectral gains);
/// `wavelengths (32² fixed)`, whose knob is the wavelength count, against
/// the band integral (a reference at 33 wavelengths, plain weights); `ghost resolution
/// (defaults)`, whose knob is the divisor of the view's side the ghosts
/// are added up at (1 and 4 quick, 1, 2, 4 full); `merged wavelengths
/// (defaults)`, whose knob is `merge_wavelengths_px` (0 and 2 quick; 0,
/// 0.5, 1, 2 full); `coarse ghosts (defaults)`, whose knob is
/// `coarse_ghost_px` (16 quick; 32, 64, 128, 192 full), and `no coarse
/// ghosts (defaults)`; `merged cells (defaults)`, whose knob is
/// `merge_cells` (0 and 0.5 quick; 0, 0.25, 0.5, 1 full); `turning camera
/// (defaults)` (timed only); the full
/// run adds `diffraction` (starburst and ringing on, timed only) and the
/// zoom's scale case (every unblocked ghost of 528 with the default
/// settings, and again with every wavelength drawn, 1280×720, timed
/// only).
pub fn rendered_rows(ctx: &SweepContext, report: &mut Report) -> Result<(), SweepError> {
    let size = ctx.pick(128, 512);
    let budget = ctx.pick(8, 91);
    // (128² for all 83 ghosts at three wavelengths is 4.1 M rays, past a
    // 128 MiB storage binding such as lavapipe's: the plugin then leaves
    // grids out, so the sweep stops at 64²; the CPU sweep goes to 128².)
    let grids: Vec<u32> = ctx.pick(vec![8, 32], vec![4, 8, 16, 32, 64]);
    let rays = ctx.pick(128, 512);
    // Warm-up past the flare's first frames (the ghosts chosen, the rays
    // of the still view traced once), so that no block times them: with
    // one frame of warm-up the first block's ratio was ~15×.
    let timing = ctx.pick((6, 3), (8, 8));
    // The ghosts the plugin draws, from a first render; the reference.
    let log = Arc::new(Mutex::new(None));
    ctx.headless(size, size).hdr(true).frames(12).render(scene(
        Some(Setup::double_gauss(grids[0], budget)),
        false,
        Some(log.clone()),
    ))?;
    let ghosts = log
        .lock()
        .map_err(|_| SweepError::Setup("log".into()))?
        .clone()
        .ok_or_else(|| SweepError::Setup("the flare chose no ghosts".into()))?;
    ctx.progress(
        0,
        grids.len(),
        &format!("CPU reference, {rays}² rays per ghost"),
    );
    let reference_3 = reference(&ghosts, size, rays, 3, Spectrum::Gained)?;
    // A row of `series` at `knob`, against `reference` when given.
    let add =
        |report: &mut Report,
         series: &str,
         setup: Setup,
         reference: Option<&[[f64; 3]]>,
         knob: f64| { row(ctx, report, series, setup, size, reference, timing, knob) };
    let r = Some(reference_3.as_slice());
    for (i, &grid) in grids.iter().enumerate() {
        ctx.progress(i + 1, grids.len(), &format!("rendered, grid {grid}²"));
        let knob = f64::from(grid);
        let adaptive = Setup::double_gauss(grid, budget);
        let fixed = Setup {
            adaptive: false,
            ..adaptive.clone()
        };
        let ours = [("rendered", adaptive.clone()), ("fixed grid", fixed)];
        for (series, setup) in ours {
            add(report, series, setup, r, knob)?;
        }
        if grid == 32 {
            let whole = Setup {
                symmetry: false,
                ..adaptive.clone()
            };
            add(report, "no symmetry", whole, r, knob)?;
            if !ctx.quick {
                let full = Setup {
                    diffraction: true,
                    ..adaptive
                };
                add(report, "diffraction", full, None, knob)?;
            }
        }
    }
    // The second knob, wavelengths, at a fixed 32² grid, against the band
    // integral: a reference at 33 wavelengths with their weights alone.
    let fine = 33;
    ctx.progress(
        grids.len(),
        grids.len(),
        &format!("reference at {fine} wavelengths"),
    );
    let reference_fine = reference(&ghosts, size, ctx.pick(64, 128), fine, Spectrum::Plain)?;
    let r = Some(reference_fine.as_slice());
    for wavelengths in ctx.pick(vec![1, 3], vec![1, 2, 3, 5]) {
        // (At half resolution: at a quarter of the quick run's 128², the
        // ghosts' 32² target blurs them more than the wavelengths differ.)
        let setup = Setup {
            wavelengths,
            // Every wavelength drawn, each at the ghosts' resolution: the
            // knob's own effect.
            merge_px: 0.0,
            coarse_px: None,
            adaptive: false,
            resolution: GhostResolution::Half,
            ..Setup::double_gauss(32, budget)
        };
        let knob = f64::from(wavelengths);
        add(report, "wavelengths (32² fixed)", setup, r, knob)?;
    }
    let r = Some(reference_3.as_slice());
    default_rows(ctx, report, budget, &add, r)?;
    if !ctx.quick {
        zoom_rows(ctx, report)?;
    }
    // The goal is the plugin's defaults: in each knob's series, the row at
    // the knob's default. The turning camera (every frame traced) is
    // judged apart.
    let defaults = LensFlare::new(Handle::default());
    let default_knob = |series: &str| match series {
        "ghost resolution (defaults)" => Some(f64::from(defaults.ghost_resolution.divisor())),
        "merged wavelengths (defaults)" => Some(f64::from(defaults.merge_wavelengths_px)),
        "coarse ghosts (defaults)" => defaults.coarse_ghost_px.map(f64::from),
        "merged cells (defaults)" => Some(f64::from(defaults.merge_cells)),
        _ => None,
    };
    report.ratio_goal(
        "the flare at its defaults, still camera, against the frame without it",
        1.5,
        |r| default_knob(&r.series) == Some(r.knob),
    );
    report.ratio_goal(
        "the flare at its defaults, turning camera, against the frame without it",
        1.5,
        |r| r.series == "turning camera (defaults)",
    );
    Ok(())
}

/// A row-adding closure: a series, its setup, the reference (if any) and
/// the knob.
type AddRow<'a> =
    dyn Fn(&mut Report, &str, Setup, Option<&[[f64; 3]]>, f64) -> Result<(), SweepError> + 'a;

/// The knobs round the defaults: the resolution the ghosts are added up
/// at, the spread below which wavelengths merge, the size above which a
/// ghost is added up coarsely; and the defaults with the camera turning.
fn default_rows(
    ctx: &SweepContext,
    report: &mut Report,
    budget: u32,
    add: &AddRow,
    r: Option<&[[f64; 3]]>,
) -> Result<(), SweepError> {
    // The third knob, the resolution the ghosts are added up at (the
    // divisor of the view's side), with the default grids (16² on average,
    // shared by power), and the defaults' cost when the camera turns,
    // against the 3-wavelength reference.
    for resolution in ctx.pick(
        vec![GhostResolution::Full, GhostResolution::Quarter],
        vec![
            GhostResolution::Full,
            GhostResolution::Half,
            GhostResolution::Quarter,
        ],
    ) {
        let setup = Setup {
            resolution,
            ..Setup::double_gauss(DEFAULT_GRID, budget)
        };
        let knob = f64::from(resolution.divisor());
        add(report, "ghost resolution (defaults)", setup, r, knob)?;
    }
    // The fourth knob, the image spread below which a ghost's wavelengths
    // are drawn as one (0: never), with the defaults.
    for merge_px in ctx.pick(vec![0.0, 2.0], vec![0.0, 0.5, 1.0, 2.0]) {
        let setup = Setup {
            merge_px,
            ..Setup::double_gauss(DEFAULT_GRID, budget)
        };
        add(
            report,
            "merged wavelengths (defaults)",
            setup,
            r,
            f64::from(merge_px),
        )?;
    }
    // The fifth knob, the image size above which a ghost is added up at
    // half the ghosts' resolution, with the defaults; and with none so.
    let coarse_knobs = ctx.pick(
        vec![None, Some(16.0)],
        vec![None, Some(32.0), Some(64.0), Some(128.0), Some(192.0)],
    );
    for coarse_px in coarse_knobs {
        let setup = Setup {
            coarse_px,
            ..Setup::double_gauss(DEFAULT_GRID, budget)
        };
        let (series, knob) = match coarse_px {
            Some(px) => ("coarse ghosts (defaults)", f64::from(px)),
            None => ("no coarse ghosts (defaults)", f64::from(DEFAULT_GRID)),
        };
        add(report, series, setup, r, knob)?;
    }
    // The sixth knob, the irradiance spread below which a large ghost's
    // 2 × 2 cells are drawn as one (0: never), with the defaults.
    for merge_cells in ctx.pick(vec![0.0, 0.5], vec![0.0, 0.25, 0.5, 1.0]) {
        let setup = Setup {
            merge_cells,
            ..Setup::double_gauss(DEFAULT_GRID, budget)
        };
        let knob = f64::from(merge_cells);
        add(report, "merged cells (defaults)", setup, r, knob)?;
    }
    let turning = Setup {
        turning: true,
        ..Setup::double_gauss(DEFAULT_GRID, budget)
    };
    add(
        report,
        "turning camera (defaults)",
        turning,
        None,
        f64::from(DEFAULT_GRID),
    )?;
    Ok(())
}

/// The zoom's scale case, timed only: every unblocked ghost of 528 with the
/// default settings at 1280×720, then with every wavelength drawn, then
/// with no ghost added up at half resolution.
fn zoom_rows(ctx: &SweepContext, report: &mut Report) -> Result<(), SweepError> {
    ctx.progress(1, 1, "zoom, every unblocked ghost, 16² on average");
    let (w, h) = (1280, 720);
    let zoom_setup = zoom_setup()?;
    let log = Arc::new(Mutex::new(None));
    ctx.headless(64, 64).frames(8).render(scene(
        Some(zoom_setup.clone()),
        false,
        Some(log.clone()),
    ))?;
    let zoom_ghosts = log
        .lock()
        .map_err(|_| SweepError::Setup("log".into()))?
        .clone()
        .ok_or_else(|| SweepError::Setup("the zoom chose no ghosts".into()))?;
    let drawn = zoom_ghosts.drawn().count();
    let (passing_ms, spectrum_ms) = fit_cost(&zoom_ghosts)?;
    // The defaults, then every wavelength of every ghost drawn, then
    // every ghost added up at the ghosts' resolution.
    for (series, merge_px, coarse_px) in [
        ("zoom 1280x720", zoom_setup.merge_px, zoom_setup.coarse_px),
        (
            "zoom 1280x720, every wavelength drawn",
            0.0,
            zoom_setup.coarse_px,
        ),
        ("zoom 1280x720, no coarse ghosts", zoom_setup.merge_px, None),
    ] {
        let setup = Setup {
            merge_px,
            coarse_px,
            ..zoom_setup.clone()
        };
        let (blocks, per_block) = ctx.blocks();
        let paired = ctx.headless(w, h).hdr(true).time_paired(
            3,
            blocks,
            per_block,
            scene(Some(setup), true, None),
            scene(None, true, None),
        )?;
        let timed = &paired.effect;
        let flare = timed.pass("optica/lens_flare");
        let mut row = Row::paired(16.0, &paired);
        if let Some(px) = coarse_px {
            row = row.work("coarse_ghost_px", f64::from(px));
        }
        report.rows.push(counted(
            row.series(series)
                .work("ghosts", drawn as f64)
                .work("wavelengths", 3.0)
                .work("merge_wavelengths_px", f64::from(merge_px))
                .work("fit_passing_ms_per_degree", passing_ms)
                .work("fit_spectrum_ms_per_degree", spectrum_ms)
                .work("spectrum_budget_ms_per_frame", SPECTRUM_BUDGET_MS)
                .work("size_px", f64::from(w))
                .work("flare_ms", flare.map_or(f64::NAN, |p| p.ms.median)),
            timed,
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_rendered_rows_converge_to_the_reference() {
        let ctx = SweepContext::new("lens_flare", true, true);
        let mut report = Report::cpu("lens_flare", "grid_rays_per_side");
        rendered_rows(&ctx, &mut report).expect("the rendered rows run on lavapipe");
        let rows = &report.rows;
        for r in rows {
            eprintln!(
                "{} grid {}: {:?}, {:.1} ms vs {:.1} ms, {:?}",
                r.series, r.knob, r.error, r.time_ms, r.baseline_time_ms, r.work
            );
            assert!(r.error.values().all(|v| v.is_finite()), "{r:?}");
        }
        let find = |series: &str, grid: f64| {
            rows.iter()
                .find(|r| r.series == series && r.knob == grid)
                .unwrap_or_else(|| panic!("no {series} row at {grid}"))
        };
        assert_eq!(rows.len(), 16, "{rows:?}");
        for series in ["rendered", "fixed grid"] {
            let (coarse, fine) = (find(series, 8.0), find(series, 32.0));
            // A finer grid follows the reference more closely.
            assert!(
                fine.error["rel_l1"] < coarse.error["rel_l1"],
                "{series}: {rows:?}"
            );
            // (At the quick run's 128² the ghosts are added up at 32², where
            // the default merge of a ghost's wavelengths, 2 of its pixels,
            // loses fringes 8 pixels wide: 0.54 here, 0.14 at 512².)
            assert!(fine.error["rel_l1"] < 0.6, "{series}: {rows:?}");
            assert!(fine.error["rel_energy"].abs() < 0.1, "{series}: {rows:?}");
            assert!(fine.error["psnr_db"] > 30.0, "{series}: {rows:?}");
        }
        // More wavelengths follow a finely sampled spectrum more closely,
        // and any count carries the band's light (the spectral gains;
        // without them one sample gives −39 % and three +46 %).
        let (one, three) = (
            find("wavelengths (32² fixed)", 1.0),
            find("wavelengths (32² fixed)", 3.0),
        );
        assert!(
            three.error["rel_l1"] < one.error["rel_l1"],
            "{one:?} vs {three:?}"
        );
        for r in [one, three] {
            assert!(r.error["rel_energy"].abs() < 0.05, "{r:?}");
        }
        // Drawing a ghost's wavelengths as one where they nearly coincide
        // draws fewer rays and costs only their fringes: +0.017 relative L1
        // at 512², +0.12 here, where 2 pixels of the ghosts' 32² target
        // are 8 of the view's (a merged ghost in the wrong colour or place
        // would be off by most of its light).
        let (every, merged) = (
            find("merged wavelengths (defaults)", 0.0),
            find(
                "merged wavelengths (defaults)",
                f64::from(DEFAULT_MERGE_WAVELENGTHS_PX),
            ),
        );
        assert!(
            merged.work["draw_vertices"] < every.work["draw_vertices"],
            "{every:?} vs {merged:?}"
        );
        assert!(
            merged.error["rel_l1"] < every.error["rel_l1"] + 0.15,
            "{every:?} vs {merged:?}"
        );
        // Large ghosts added up at half the resolution shade fewer
        // fragments and keep their light (the quick run's small grids
        // themselves miss it by several per cent); their edges soften (at
        // 128² the coarse target is 16²: more than at full size).
        let (fine, coarse) = (
            find("no coarse ghosts (defaults)", 16.0),
            find("coarse ghosts (defaults)", 16.0),
        );
        // (The ghosts' own fragments: the coarse target's scaling up adds
        // one per pixel of the ghosts' reduced-resolution target to the
        // draw's count, 1,024 here against about 1,400 ghost fragments.)
        let divisor = f64::from(GhostResolution::default().divisor());
        let shaded = |r: &Row| {
            let coarse = r.work.get("coarse_fragments").copied();
            let upsampled = coarse.map_or(0.0, |_| (r.work["size_px"] / divisor).powi(2));
            r.work["draw_fragments"] + coarse.unwrap_or(0.0) - upsampled
        };
        assert!(coarse.work["coarse_fragments"] > 0.0, "{coarse:?}");
        assert!(shaded(coarse) < shaded(fine), "{fine:?} vs {coarse:?}");
        assert!(
            coarse.error["rel_energy"].abs() < fine.error["rel_energy"].abs() + 0.03,
            "{fine:?} vs {coarse:?}"
        );
        assert!(
            coarse.error["rel_l1"] < fine.error["rel_l1"] + 0.25,
            "{fine:?} vs {coarse:?}"
        );
        for r in rows.iter().filter(|r| r.error.contains_key("flip_mean")) {
            assert!((0.0..1.0).contains(&r.error["flip_mean"]), "{r:?}");
        }
        // Symmetry changes where the rays fall, not what they add up to.
        let (sym, whole) = (find("rendered", 32.0), find("no symmetry", 32.0));
        assert!(
            (sym.error["rel_l1"] - whole.error["rel_l1"]).abs() < 0.5 * whole.error["rel_l1"],
            "{sym:?} vs {whole:?}"
        );
        // lavapipe counts the passes' work: a finer grid draws more
        // vertices; the scene's main pass is counted too.
        for r in rows {
            for key in ["draw_vertices", "draw_fragments", "main_fragments"] {
                assert!(r.work.get(key).is_some_and(|&v| v > 0.0), "no {key}: {r:?}");
            }
        }
        // (Not 16× as many: at 128² the ghosts' quarter-resolution target
        // is 32², and cells of at least 1.5 of its pixels cut the finer
        // grids of the small ghosts.)
        let (coarse, fine) = (find("fixed grid", 8.0), find("fixed grid", 32.0));
        assert!(
            fine.work["draw_vertices"] > 2.0 * coarse.work["draw_vertices"],
            "{coarse:?} vs {fine:?}"
        );
        // A still camera traces its rays and colours their cells once,
        // before the timed frames; a turning one every frame.
        let turning = find("turning camera (defaults)", 16.0);
        assert!(!fine.work.contains_key("cells_invocations"), "{fine:?}");
        assert!(turning.work["cells_invocations"] > 0.0, "{turning:?}");
        assert!(
            fine.work["trace_frames"] < turning.work["trace_frames"],
            "{fine:?} vs {turning:?}"
        );
        assert!(turning.work["trace_frames"] >= 3.0, "{turning:?}");
        assert!(turning.work["trace_invocations"] > 0.0, "{turning:?}");
        // Ghosts added up at a quarter of the resolution shade fewer
        // fragments and keep the light they add at full resolution (the
        // quarter's grids are cut to its pixels, so not exactly).
        let (full, quarter) = (
            find("ghost resolution (defaults)", 1.0),
            find("ghost resolution (defaults)", 4.0),
        );
        assert!(
            quarter.work["draw_fragments"] < full.work["draw_fragments"],
            "{full:?} vs {quarter:?}"
        );
        let kept = (1.0 + quarter.error["rel_energy"]) / (1.0 + full.error["rel_energy"]);
        assert!((kept - 1.0).abs() < 0.1, "{full:?} vs {quarter:?}");
    }
}
