//! Compound eye (Sagawa, thesis ch. 6), rendered: the thesis's slice count
//! `K` against the exact lattice tracer, with the thesis's one-lens model and
//! with rays followed into neighbouring lenses; and the material's default
//! exact path (series `exact path`, its knob the lens cap), with its
//! agreement by incidence band.
//!
//! Scene: a flat eye (a square of the compound-eye material) seen from above
//! at an angle by a perspective camera, so one frame holds every incidence
//! from 0° (the foot of the camera's perpendicular, where the principal
//! pseudopupil is) to about 66°.
//!
//! - Reference: `optica_optics::compound_eye::trace_exact` for the ray through
//!   every pixel's centre (the same lattice, lenses, pigment and Fresnel),
//!   as the factor `c_t·T` on the surface colour.
//! - Error: PSNR, 1 − SSIM and ꟻLIP of the material's `PigmentOnly` output
//!   (the same factor, read back as linear floats) against the reference,
//!   both encoded as sRGB greys; the distance between the dark patches'
//!   centroids (`dark_patch_centroid`) in facets.
//! - Time: the lit frame's median wall time and its main pass's GPU time,
//!   against the same square with a plain `StandardMaterial` (same coverage)
//!   in the same run.

use bevy::prelude::*;
use image::RgbaImage;
use optica_compound_eye::{
    CompoundEye, EyeLattice, EyeOutput,
};
use optica_harness::{FrameTimings, TimeSource};
use optica_optics::compound_eye::{
    CompoundEyeError, DarkCentre, Lattice, LensParams, MAX_EXACT_LENSES, MAX_LENSES, Ray, Shade,
    ShadeFallback, TextureAxes, dark_patch_centroid, shade, trace_exact,
};
use optica_optics::glam::{DVec2, DVec3};

use super::SweepError;
use super::render::OPAQUE_PASS;
use crate::{Report, Row, SweepContext};

/// Vertical field of view of the sweep's camera, radians.
const FOV: f32 = 1.6;
/// Side of the flat eye, world units.
const EYE_SIDE: f32 = 8.0;

fn camera() -> Transform {
    // Looking 20° from straight down: the foot of the perpendicular (the
    // pseudopupil) sits below the image centre with its patch whole, and the
    // top of the image sees the eye at about 66°.
    Transform::from_xyz(0.0, -1.0, 1.4).looking_at(
        Vec3::new(0.0, -1.0 + 1.4 * 20f32.to_radians().tan(), 0.0),
        Vec3::Z,
    )
}

/// The point on the eye where the surface normal faces the camera.
fn foot() -> DVec3 {
    let c = camera().translation.as_dvec3();
    DVec3::new(c.x, c.y, 0.0)
}

fn eye_settings(
    facets_per_uv: f32,
    slices: u32,
    neighbours: bool,
    output: EyeOutput,
) -> CompoundEye {
    CompoundEye {
        facets_per_uv,
        lattice: EyeLattice::Hexagonal,
        exact: false,
        slices,
        follow_neighbours: neighbours,
        prefilter: false,
        output,
        ..default()
    }
}

/// The scene: the flat eye with `eye` (or a plain `StandardMaterial`), lit,
/// no shadows, MSAA off (one fragment per pixel, at its centre).
pub(super) fn scene(eye: Option<CompoundEye>) -> impl FnOnce(&mut App) {
    crate::fixtures::compound_eye_scene(
        Mesh::from(Rectangle::new(EYE_SIDE, EYE_SIDE)),
        Transform::IDENTITY,
        eye,
        camera(),
        Projection::Perspective(PerspectiveProjection {
            fov: FOV,
            ..default()
        }),
        None,
    )
}

/// The CPU side of the flat eye: its lattice and pigment for `eye`.
struct Cpu {
    lattice: Lattice,
    pigment: DarkCentre,
}

fn cpu_eye(eye: &CompoundEye) -> Result<Cpu, CompoundEyeError> {
    // Bevy's Rectangle: u along +x, v along −y, one UV unit over the side.
    let facet = (EYE_SIDE / eye.facets_per_uv) as f64;
    let h = 0.5 * EYE_SIDE as f64;
    let axes = TextureAxes::from_axes(
        DVec3::new(-h, h, 0.0),
        DVec3::X * facet,
        -DVec3::Y * facet,
        DVec3::Z,
    )?;
    let kind = eye.lattice_kind();
    let r = eye.lens_radius as f64 * kind.cell_inradius(axes.u(), axes.v());
    let lens = LensParams::new(r, eye.lens_index as f64, eye.pigment_depth as f64 * r)?;
    let pigment = DarkCentre::new(
        eye.pigment.radius as f64,
        eye.pigment.softness as f64,
        eye.pigment.darkness as f64,
    )?;
    Ok(Cpu {
        lattice: Lattice::with_kind(axes, lens, kind)?,
        pigment,
    })
}

/// The ray through the centre of pixel (x, y) of a `size`² frame.
fn pixel_ray(x: u32, y: u32, size: u32) -> Ray {
    let cam = camera();
    let t = (FOV / 2.0).tan();
    let ndc = Vec2::new(
        (x as f32 + 0.5) / size as f32 * 2.0 - 1.0,
        1.0 - (y as f32 + 0.5) / size as f32 * 2.0,
    );
    let dir = cam.rotation * Vec3::new(ndc.x * t, ndc.y * t, -1.0);
    Ray::new(cam.translation.as_dvec3(), dir.as_dvec3()).expect("a finite camera ray")
}

/// The factor on the surface colour for one traced ray (`c_t·T`; 1 for a
/// ray that reaches no pigment), as the material computes it.
fn factor(cpu: &Cpu, s: Shade) -> f64 {
    match s {
        Shade::Pigment(hit) => cpu.pigment.transmission(&cpu.lattice, hit.uv) * hit.transmittance,
        Shade::Fallback(ShadeFallback::Escaped { .. }) | Shade::Fallback(_) => 1.0,
    }
}

/// The reference image: the exact tracer through every pixel.
fn reference(cpu: &Cpu, size: u32, max_lenses: u32) -> Vec<f64> {
    use rayon::prelude::*;
    (0..size * size)
        .into_par_iter()
        .map(|k| {
            factor(
                cpu,
                trace_exact(
                    &cpu.lattice,
                    &pixel_ray(k % size, k / size, size),
                    max_lenses,
                ),
            )
        })
        .collect()
}

/// A linear factor image as an 8-bit sRGB grey image.
fn grey(values: &[f64], size: u32) -> RgbaImage {
    RgbaImage::from_fn(size, size, |x, y| {
        let v = values[(y * size + x) as usize].clamp(0.0, 1.0) as f32;
        let [r, g, b, _] = Srgba::from(LinearRgba::rgb(v, v, v)).to_u8_array();
        image::Rgba([r, g, b, 255])
    })
}

/// Pixels per facet at the pseudopupil (where the camera looks straight down).
fn pixels_per_facet(eye: &CompoundEye, size: u32) -> f64 {
    let height = camera().translation.z as f64;
    let pixel = 2.0 * height * (FOV as f64 / 2.0).tan() / size as f64;
    (EYE_SIDE / eye.facets_per_uv) as f64 / pixel
}

/// The centroid of the dark patch of a factor image.
fn centroid(values: &[f64], size: u32, facet_px: f64) -> Option<DVec2> {
    let darkness: Vec<f64> = values.iter().map(|v| 1.0 - v.clamp(0.0, 1.0)).collect();
    dark_patch_centroid(
        &darkness,
        size as usize,
        size as usize,
        (facet_px / 2.0).round() as usize,
    )
}

/// Where the foot of the perpendicular lands in the image, pixels.
fn foot_pixel(size: u32) -> DVec2 {
    let cam = camera();
    let v = cam
        .compute_affine()
        .inverse()
        .transform_point3(foot().as_vec3());
    let t = (FOV / 2.0).tan();
    let ndc = Vec2::new(v.x / (-v.z * t), v.y / (-v.z * t));
    DVec2::new(
        ((ndc.x + 1.0) / 2.0 * size as f32) as f64,
        ((1.0 - ndc.y) / 2.0 * size as f32) as f64,
    )
}

/// Runs the sweep.
pub fn run(ctx: &SweepContext) -> Result<Report, SweepError> {
    let size = ctx.pick(96, 256);
    let facets_per_uv = ctx.pick(50.0, 128.0);
    let slices: Vec<u32> = ctx.pick(vec![0, 2, 8, 32], vec![0, 1, 2, 4, 8, 16, 32, 64]);
    let warmup = ctx.pick(1, 4);
    let facet_px = pixels_per_facet(
        &eye_settings(facets_per_uv, 8, false, EyeOutput::Shaded),
        size,
    );

    ctx.progress(0, 2 * slices.len() + 1, "plain StandardMaterial");
    let headless = ctx.headless(size, size);
    let base = headless.render(scene(None))?;
    let mut report = Report::rendered("compound_eye", "slices", base.adapter.clone());
    report.reference = format!(
        "optica_optics::compound_eye::trace_exact through every pixel centre ({size}², the same hexagonal lattice of \
         touching lenses, n = 1.5, pigment at d = 2r (the thesis's depth and the material's default), dark-centre pigment, Fresnel), one lens for the \
         `one lens` series and up to {MAX_LENSES} for `neighbours`; a flat eye seen at 0–66° incidence, facets \
         {facet_px:.1} px wide at the pseudopupil"
    );
    report.baseline = format!(
        "the same square with a plain StandardMaterial, {}; \
         `opaque_gpu_ms` is the main pass's GPU time (timestamp queries)",
        ctx.paired_words(warmup)
    );

    let expected_foot = foot_pixel(size);
    let mut step = 0;
    for (series, neighbours) in [("one lens", false), ("neighbours", true)] {
        let cpu = cpu_eye(&eye_settings(
            facets_per_uv,
            0,
            neighbours,
            EyeOutput::PigmentOnly,
        ))
        .map_err(|e| SweepError::Setup(e.to_string()))?;
        let reference = reference(&cpu, size, if neighbours { MAX_LENSES } else { 1 });
        let reference_grey = grey(&reference, size);
        let reference_centroid = centroid(&reference, size, facet_px);
        for &k in &slices {
            step += 1;
            ctx.progress(step, 2 * slices.len() + 1, &format!("{series}, K = {k}"));
            let frame = headless.clone().hdr(true).render(scene(Some(eye_settings(
                facets_per_uv,
                k,
                neighbours,
                EyeOutput::PigmentOnly,
            ))))?;
            let img = frame
                .hdr()
                .ok_or(SweepError::Setup("no HDR frame".into()))?;
            let gpu: Vec<f64> = img.pixels().map(|p| p.0[0] as f64).collect();
            let m = optica_harness::metrics::compare(&reference_grey, &grey(&gpu, size))
                .map_err(|e| SweepError::Setup(e.to_string()))?;
            // Against the plain frame in alternating blocks: lavapipe frame
            // times drift by 20 % over a run and more with other work.
            let (blocks, per_block) = ctx.blocks();
            let paired = headless.time_paired(
                warmup,
                blocks,
                per_block,
                scene(Some(eye_settings(
                    facets_per_uv,
                    k,
                    neighbours,
                    EyeOutput::Shaded,
                ))),
                scene(None),
            )?;
            let (timings, plain) = (&paired.effect, &paired.baseline);
            let gpu_centroid = centroid(&gpu, size, facet_px);
            let centroid_facets = match (gpu_centroid, reference_centroid) {
                (Some(g), Some(r)) => (g - r).length() / facet_px,
                _ => f64::NAN,
            };
            let foot_facets =
                gpu_centroid.map_or(f64::NAN, |g| (g - expected_foot).length() / facet_px);
            let mut row = Row::paired(f64::from(k), &paired)
                .series(series)
                .err("psnr_db", m.psnr_db)
                .err("flip_mean", m.flip_mean)
                .err("one_minus_ssim", 1.0 - m.ssim)
                .err("centroid_facets", centroid_facets)
                .work("centroid_to_normal_facets", foot_facets)
                .timing("frame_iqr_ms", timings.frame_ms.iqr());
            row = with_pass_times(row, timings, plain);
            report.rows.push(row);
        }
    }
    exact_path(ctx, &mut report, size, facets_per_uv, warmup)?;
    costs(ctx, &mut report, size, facets_per_uv, warmup)?;
    stability(ctx, &mut report, size)?;
    Ok(report)
}

/// Incidence bands (degrees from the normal) the exact path's agreement is
/// counted in; the sweep's frame reaches about 66°.
const BANDS: [(f64, f64); 3] = [(0.0, 30.0), (30.0, 60.0), (60.0, 90.0)];

/// The exact path (the material's default), through one lens and through
/// up to `MAX_EXACT_LENSES`: its output against `trace_exact` with as many
/// lenses, pixel by pixel, by incidence band: the share of pixels whose
/// outcome (escape or not) agrees and whose factor is within 0.02. The
/// knob (the table's `slices` column) is the lens cap.
fn exact_path(
    ctx: &SweepContext,
    report: &mut Report,
    size: u32,
    facets_per_uv: f32,
    warmup: u32,
) -> Result<(), SweepError> {
    use rayon::prelude::*;
    let headless = ctx.headless(size, size);
    for lenses in [1, MAX_EXACT_LENSES] {
        ctx.progress(0, 1, &format!("exact path, up to {lenses} lenses"));
        let eye = |output| CompoundEye {
            exact: true,
            ..eye_settings(facets_per_uv, 0, lenses > 1, output)
        };
        let cpu =
            cpu_eye(&eye(EyeOutput::PigmentOnly)).map_err(|e| SweepError::Setup(e.to_string()))?;
        let shades: Vec<Shade> = (0..size * size)
            .into_par_iter()
            .map(|k| trace_exact(&cpu.lattice, &pixel_ray(k % size, k / size, size), lenses))
            .collect();
        let reference: Vec<f64> = shades.iter().map(|&s| factor(&cpu, s)).collect();
        let frame = headless
            .clone()
            .hdr(true)
            .render(scene(Some(eye(EyeOutput::PigmentOnly))))?;
        let img = frame
            .hdr()
            .ok_or(SweepError::Setup("no HDR frame".into()))?;
        let gpu: Vec<[f32; 4]> = img.pixels().map(|p| p.0).collect();
        let gpu_factor: Vec<f64> = gpu.iter().map(|p| f64::from(p[0])).collect();
        let m = optica_harness::metrics::compare(&grey(&reference, size), &grey(&gpu_factor, size))
            .map_err(|e| SweepError::Setup(e.to_string()))?;
        let (blocks, per_block) = ctx.blocks();
        let paired = headless.time_paired(
            warmup,
            blocks,
            per_block,
            scene(Some(eye(EyeOutput::Shaded))),
            scene(None),
        )?;
        let (timings, plain) = (&paired.effect, &paired.baseline);
        let mut row = Row::paired(f64::from(lenses), &paired)
        .series("exact path")
        .err("psnr_db", m.psnr_db)
        .err("flip_mean", m.flip_mean)
        .err("one_minus_ssim", 1.0 - m.ssim)
        .timing("frame_iqr_ms", timings.frame_ms.iqr());
        for (lo, hi) in BANDS {
            let (mut n, mut same, mut within) = (0usize, 0usize, 0usize);
            for k in 0..(size * size) as usize {
                let ray = pixel_ray(k as u32 % size, k as u32 / size, size);
                let cos = -ray.dir().z;
                let incidence = cos.clamp(-1.0, 1.0).acos().to_degrees();
                // Pixels that see the eye (the ray reaches z = 0 inside it).
                let t = -ray.origin().z / ray.dir().z;
                let p = ray.at(t);
                let inside = t > 0.0
                    && p.x.abs() < 0.5 * EYE_SIDE as f64
                    && p.y.abs() < 0.5 * EYE_SIDE as f64;
                if !inside || incidence < lo || incidence >= hi {
                    continue;
                }
                let escaped = matches!(shades[k], Shade::Fallback(ShadeFallback::Escaped { .. }));
                n += 1;
                same += usize::from(escaped == (gpu[k][1] > 0.5));
                within += usize::from((gpu_factor[k] - reference[k]).abs() <= 0.02);
            }
            let share = |x: usize| if n > 0 { x as f64 / n as f64 } else { f64::NAN };
            let name = format!("{lo:.0}_{hi:.0}");
            row = row
                .err(&format!("outcome_agrees_{name}"), share(same))
                .err(&format!("within_0_02_{name}"), share(within))
                .work(&format!("pixels_{name}"), n as f64);
        }
        row = with_pass_times(row, timings, plain);
        report.rows.push(row);
    }
    Ok(())
}

/// Adds the main pass's GPU time of both frames, where the adapter has
/// timestamp queries.
fn with_pass_times(row: Row, eye: &FrameTimings, plain: &FrameTimings) -> Row {
    let gpu = |t: &FrameTimings| {
        t.pass(OPAQUE_PASS)
            .filter(|p| p.source == TimeSource::GpuTimestamps)
            .map(|p| p.ms.median)
    };
    match (gpu(eye), gpu(plain)) {
        (Some(e), Some(p)) => row
            .timing("opaque_gpu_ms", e)
            .timing("baseline_opaque_gpu_ms", p),
        _ => row,
    }
}

/// Samples per axis of the supersampled renders the prefilter is measured
/// against (64 a pixel).
const SUPERSAMPLE: u32 = 8;

/// The most ꟻLIP against the supersampled render the prefilter may leave
/// where facets are a pixel or smaller (the goal at 0.5 px).
const MAX_SUB_PIXEL_FLIP: f64 = 0.08;

/// The prefilter's error at one facet size.
struct PrefilterError {
    /// Pixels per facet at the pseudopupil.
    facet_px: f64,
    /// ꟻLIP and PSNR of the prefiltered render against the supersampled one.
    prefiltered: (f64, f64),
    /// The same without the prefilter.
    unfiltered: (f64, f64),
}

/// The material's defaults (the exact path, the prefilter's table) at
/// `facets_per_uv`, optics only, against an [`SUPERSAMPLE`]× supersampled
/// render without the prefilter, box-filtered in linear light.
fn prefilter_flip(
    ctx: &SweepContext,
    size: u32,
    facets_per_uv: f32,
) -> Result<PrefilterError, SweepError> {
    let ss = SUPERSAMPLE;
    let eye = |prefilter: bool| CompoundEye {
        prefilter,
        exact: true,
        ..eye_settings(facets_per_uv, 0, true, EyeOutput::PigmentOnly)
    };
    let factor_image = |frame: &optica_harness::RenderedFrame| -> Vec<f64> {
        frame
            .hdr()
            .map(|img| img.pixels().map(|p| p.0[0] as f64).collect())
            .unwrap_or_default()
    };
    let fine = ctx
        .headless(size * ss, size * ss)
        .hdr(true)
        .render(scene(Some(eye(false))))?;
    let fine = fine.hdr().ok_or(SweepError::Setup("no HDR frame".into()))?;
    let supersampled: Vec<f64> = box_down(fine, size).iter().map(|p| p[0]).collect();
    let target = grey(&supersampled, size);
    let mut flips = Vec::new();
    for prefilter in [true, false] {
        let frame = ctx
            .headless(size, size)
            .hdr(true)
            .render(scene(Some(eye(prefilter))))?;
        let m = optica_harness::metrics::compare(&target, &grey(&factor_image(&frame), size))
            .map_err(|e| SweepError::Setup(e.to_string()))?;
        flips.push((m.flip_mean, m.psnr_db));
    }
    Ok(PrefilterError {
        facet_px: pixels_per_facet(&eye(true), size),
        prefiltered: flips[0],
        unfiltered: flips[1],
    })
}

/// The lit eye with the prefilter against the unfiltered lit eye
/// supersampled (box-filtered in linear light): where the prefilter leaves
/// a share of escaping rays, each pixel shows the escape mirror with that
/// probability (a fixed dither) rather than the mean of the two lit colours
/// the supersampled reference holds. Returns the errors and the escaping
/// share of the supersampled pixels.
fn shaded_prefilter_flip(
    ctx: &SweepContext,
    size: u32,
    facets_per_uv: f32,
) -> Result<(PrefilterError, f64), SweepError> {
    let ss = SUPERSAMPLE;
    let eye = |prefilter: bool, output| CompoundEye {
        prefilter,
        exact: true,
        ..eye_settings(facets_per_uv, 0, true, output)
    };
    let render = |side: u32, eye: CompoundEye| -> Result<image::Rgba32FImage, SweepError> {
        let frame = ctx
            .headless(side, side)
            .hdr(true)
            .render(scene(Some(eye)))?;
        frame
            .hdr()
            .cloned()
            .ok_or(SweepError::Setup("no HDR frame".into()))
    };
    let srgb = |px: &[[f64; 4]]| {
        RgbaImage::from_fn(size, size, |x, y| {
            let [r, g, b, _] = px[(y * size + x) as usize].map(|v| v as f32);
            let [r, g, b, _] = Srgba::from(LinearRgba::rgb(r, g, b)).to_u8_array();
            image::Rgba([r, g, b, 255])
        })
    };
    let escaping = box_down(
        &render(size * ss, eye(false, EyeOutput::PigmentOnly))?,
        size,
    );
    let escape_share = escaping.iter().map(|p| p[1]).sum::<f64>() / f64::from(size * size);
    let target = srgb(&box_down(
        &render(size * ss, eye(false, EyeOutput::Shaded))?,
        size,
    ));
    let mut out = Vec::new();
    for prefilter in [true, false] {
        let test = srgb(&box_down(
            &render(size, eye(prefilter, EyeOutput::Shaded))?,
            size,
        ));
        let m = optica_harness::metrics::compare(&target, &test)
            .map_err(|e| SweepError::Setup(e.to_string()))?;
        out.push((m.flip_mean, m.psnr_db));
    }
    let errors = PrefilterError {
        facet_px: pixels_per_facet(&eye(true, EyeOutput::Shaded), size),
        prefiltered: out[0],
        unfiltered: out[1],
    };
    Ok((errors, escape_share))
}

/// `fine`, a render of a `size`² view at a whole multiple of its side,
/// box-filtered down to `size`² in linear light (in f64): RGBA per pixel,
/// row by row. At the same side it is the render itself.
fn box_down(fine: &image::Rgba32FImage, size: u32) -> Vec<[f64; 4]> {
    let ss = fine.width() / size;
    (0..size * size)
        .map(|k| {
            let (x, y) = (k % size, k / size);
            let mut sum = [0.0f64; 4];
            for dy in 0..ss {
                for dx in 0..ss {
                    let p = fine.get_pixel(x * ss + dx, y * ss + dy).0;
                    for (s, v) in sum.iter_mut().zip(p) {
                        *s += f64::from(v);
                    }
                }
            }
            sum.map(|v| v / f64::from(ss * ss))
        })
        .collect()
}

/// Facets per UV unit that make facets ~0.5 px wide at the pseudopupil.
fn sub_pixel_facets_per_uv(ctx: &SweepContext) -> f32 {
    ctx.pick(533.0, 1365.0)
}

/// What the settings the table leaves out cost: the material's defaults
/// (prefilter on, 8 slices, neighbours, Fresnel) at the sweep's facet size,
/// and the prefilter where facets are ~0.5 px (all of the eye read from the
/// prefilter's table), each as a ratio to the plain material.
fn costs(
    ctx: &SweepContext,
    report: &mut Report,
    size: u32,
    facets_per_uv: f32,
    warmup: u32,
) -> Result<(), SweepError> {
    let headless = ctx.headless(size, size);
    let (blocks, per_block) = ctx.blocks();
    // Each against the plain material in alternating blocks.
    let time = |eye: CompoundEye| -> Result<optica_harness::PairedTimings, SweepError> {
        Ok(headless.time_paired(warmup, blocks, per_block, scene(Some(eye)), scene(None))?)
    };
    let interval = |p: &optica_harness::PairedTimings| {
        format!(
            "{:.2}× [{:.2}, {:.2}] the plain material ({:.2} ms)",
            p.ratio.median, p.ratio.low, p.ratio.high, p.baseline.frame_ms.median
        )
    };
    let defaults = time(CompoundEye {
        facets_per_uv,
        ..default()
    })?;
    report.case(
        "cost at the material's defaults",
        defaults.ratio.high.is_finite(),
        format!(
            "exact path, neighbours (up to {MAX_EXACT_LENSES} lenses), prefilter on, Fresnel, {facets_per_uv} facets \
             per UV: frame {:.2} ms, {} ({blocks} alternating blocks of {per_block} frames, 95 % interval)",
            defaults.effect.frame_ms.median,
            interval(&defaults)
        ),
    );
    let tiny = sub_pixel_facets_per_uv(ctx);
    let sub_pixel = |prefilter| CompoundEye {
        prefilter,
        exact: true,
        ..eye_settings(tiny, 0, true, EyeOutput::Shaded)
    };
    let (on, off) = (time(sub_pixel(true))?, time(sub_pixel(false))?);
    report.case(
        "cost of the prefilter at sub-pixel facets",
        on.ratio.high.is_finite() && off.ratio.high.is_finite(),
        format!(
            "~0.5 px per facet, exact path, neighbours: prefiltered {:.2} ms ({}), unfiltered \
             {:.2} ms ({})",
            on.effect.frame_ms.median,
            interval(&on),
            off.effect.frame_ms.median,
            interval(&off)
        ),
    );
    Ok(())
}

/// Stiff cases through the whole path: sub-pixel facets (moiré, with and
/// without the prefilter, against a supersampled render), a degenerate UV
/// triangle, grazing and skimming rays on the CPU twin.
fn stability(ctx: &SweepContext, report: &mut Report, size: u32) -> Result<(), SweepError> {
    // Facets of ~0.5 px at the pseudopupil: the prefiltered render against
    // an 8× supersampled one (prefilter off, box-filtered in linear light;
    // 64 samples a pixel, about 16 a facet).
    let tiny = sub_pixel_facets_per_uv(ctx);
    let at_half = prefilter_flip(ctx, size, tiny)?;
    let (lit, escape_share) = shaded_prefilter_flip(ctx, size, tiny)?;
    let (lit, lit_unfiltered) = (lit.prefiltered, lit.unfiltered);
    report.case(
        "facets below a pixel, lit (a partial escape share dithered)",
        lit.0 < lit_unfiltered.0,
        format!(
            "the same eye lit ({:.1} % of the supersampled rays escape): prefiltered ꟻLIP {:.4} (PSNR {:.1} dB), \
             unfiltered ꟻLIP {:.4} (PSNR {:.1} dB)",
            100.0 * escape_share,
            lit.0,
            lit.1,
            lit_unfiltered.0,
            lit_unfiltered.1
        ),
    );
    report.case(
        "facets below a pixel (moiré)",
        at_half.prefiltered.0 < at_half.unfiltered.0,
        format!(
            "{:.2} px per facet at the pseudopupil; against an {SUPERSAMPLE}× supersampled render: prefiltered ꟻLIP {:.4} \
             (PSNR {:.1} dB), unfiltered ꟻLIP {:.4} (PSNR {:.1} dB)",
            at_half.facet_px,
            at_half.prefiltered.0,
            at_half.prefiltered.1,
            at_half.unfiltered.0,
            at_half.unfiltered.1
        ),
    );
    // A zoom-out: the same eye from 4 px per facet to a quarter of a
    // pixel. Moiré shows as error against the supersampled render that the
    // prefilter does not remove: the measure is the largest ꟻLIP over the
    // sequence.
    let mut steps = Vec::new();
    let mut no_moire = true;
    for px in [4.0, 2.0, 1.0, 0.5, 0.25] {
        let facets = tiny * (at_half.facet_px / px) as f32;
        let f = prefilter_flip(ctx, size, facets)?;
        // Moiré arises once facets shrink below a pixel; larger facets
        // show their own edges, aliased as any sharp detail is.
        no_moire &= f.prefiltered.0 <= f.unfiltered.0
            && (f.facet_px > 1.5 || f.prefiltered.0 <= MAX_SUB_PIXEL_FLIP);
        steps.push(format!(
            "{:.2} px: {:.4} (unfiltered {:.4})",
            f.facet_px, f.prefiltered.0, f.unfiltered.0
        ));
        // The lit eye at the material's defaults, against the plain square.
        let warmup = ctx.pick(1, 4);
        let (blocks, per_block) = ctx.blocks();
        let headless = ctx.headless(size, size);
        let paired = headless.time_paired(
            warmup,
            blocks,
            per_block,
            scene(Some(CompoundEye {
                facets_per_uv: facets,
                ..default()
            })),
            scene(None),
        )?;
        report.rows.push(
            Row::paired(f.facet_px, &paired)
                .series("zoom-out (prefilter)")
                .err("flip_mean", f.prefiltered.0)
                .err("psnr_db", f.prefiltered.1)
                .err("unfiltered_flip_mean", f.unfiltered.0),
        );
    }
    report.case(
        "zoom-out without moiré",
        no_moire,
        format!(
            "defaults (exact path, prefilter table), ꟻLIP against an {SUPERSAMPLE}× supersampled render at each \
             size of facet (ok: never above the unfiltered render's, and at most {MAX_SUB_PIXEL_FLIP} from a pixel \
             per facet down): {}",
            steps.join(", ")
        ),
    );

    // Degenerate UV triangle: a typed error, and the fallback frame traces finitely.
    let lens = LensParams::thesis(0.4, 1.5).map_err(|e| SweepError::Setup(e.to_string()))?;
    let p = [
        DVec3::ZERO,
        DVec3::new(2.0, 0.0, 0.0),
        DVec3::new(0.0, 1.0, 0.0),
    ];
    let t = [DVec2::ZERO, DVec2::new(1.0, 1.0), DVec2::new(2.0, 2.0)];
    let err = TextureAxes::from_triangle(p, t);
    let axes = TextureAxes::from_triangle_or_fallback(p, t, 1.0);
    let probe: Vec<Ray> = (0..64)
        .map(|k| {
            let (a, b) = ((k as f64 * 0.37).sin() * 1.4, k as f64 * 0.41);
            Ray::new(
                DVec3::new(0.3 * (k % 8) as f64, 0.2 * (k / 8) as f64, 1.0),
                DVec3::new(a.sin() * b.cos(), a.sin() * b.sin(), -a.cos()),
            )
            .expect("finite probe rays")
        })
        .collect();
    let finite = |s: &Shade| {
        s.hit()
            .is_none_or(|h| h.uv.is_finite() && h.point.is_finite())
    };
    let all_finite = Lattice::new(axes, lens).is_ok_and(|l| {
        probe
            .iter()
            .all(|r| finite(&shade(&l, r, 8)) && finite(&trace_exact(&l, r, MAX_LENSES)))
    });
    report.case(
        "degenerate UV triangle",
        matches!(err, Err(CompoundEyeError::DegenerateUv { .. })) && all_finite,
        format!(
            "from_triangle: {err:?}; the fallback frame traces 64 probe rays finitely: {all_finite}"
        ),
    );

    // A ray skimming the surface along a cell edge: the exact tracer's walk
    // reaches its cap, the shading path finds the lens it grazes far away;
    // both finite.
    let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z)
        .map_err(|e| SweepError::Setup(e.to_string()))?;
    let l = Lattice::new(
        axes,
        LensParams::thesis(0.5, 1.5).map_err(|e| SweepError::Setup(e.to_string()))?,
    )
    .map_err(|e| SweepError::Setup(e.to_string()))?;
    let skim =
        Ray::new(DVec3::new(0.3, 0.0, 0.0), DVec3::new(1.0, 0.0, -1e-9)).expect("a finite ray");
    let (a, b) = (shade(&l, &skim, 8), trace_exact(&l, &skim, 1));
    report.case(
        "skimming ray",
        finite(&a) && finite(&b),
        format!("cos 1e-9 to the surface, along a cell edge: shading {a:?}, exact {b:?}"),
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quick_sweep_renders_converges_and_finds_the_pseudopupil() {
        let r = run(&SweepContext::new("compound_eye", true, true))
            .expect("compound-eye sweep on lavapipe");
        assert!(
            r.adapter
                .as_ref()
                .is_some_and(|a| a.name.contains("llvmpipe"))
        );
        let problems = r.problems();
        assert!(problems.is_empty(), "{problems:#?}");
        for series in ["one lens", "neighbours"] {
            let rows: Vec<&Row> = r.rows.iter().filter(|row| row.series == series).collect();
            let (first, last) = (&rows[0].error, &rows[rows.len() - 1].error);
            assert!(
                last["flip_mean"] < first["flip_mean"],
                "{series}: {first:?} -> {last:?}"
            );
            assert!(
                last["psnr_db"] > 28.0,
                "{series}: K = 32 only {} dB from the exact tracer",
                last["psnr_db"]
            );
            assert!(
                last["centroid_facets"] <= 0.25,
                "{series}: pseudopupil {} facets off",
                last["centroid_facets"]
            );
        }
        // The exact path agrees with the exact tracer in every band the
        // frame holds.
        let exact: Vec<&Row> = r
            .rows
            .iter()
            .filter(|row| row.series == "exact path")
            .collect();
        assert_eq!(exact.len(), 2);
        for row in exact {
            for (lo, hi) in BANDS {
                let name = format!("{lo:.0}_{hi:.0}");
                if row.work[&format!("pixels_{name}")] < 100.0 {
                    continue;
                }
                let (same, within) = (
                    row.error[&format!("outcome_agrees_{name}")],
                    row.error[&format!("within_0_02_{name}")],
                );
                assert!(
                    same >= 0.995 && within >= 0.99,
                    "exact path, {} lenses, {name}°: outcome {same}, within {within}",
                    row.knob
                );
            }
        }
    }
}
