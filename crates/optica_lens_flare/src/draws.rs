//! Each frame, on the main world: the ghost grids a [`LensFlare`] camera
//! traces — one per drawn ghost, wavelength and [`FlareSource`] light whose
//! light enters the lens — with their beams, the lens per wavelength and
//! the colour each grid adds. Extracted to the render world as
//! [`FlareDraws`].

use bevy::camera::Exposure;
use bevy::math::{DVec3, Mat4, Vec2, Vec3, Vec4};
use bevy::prelude::*;
use bevy::render::extract_component::ExtractComponent;
use bevy::render::render_resource::ShaderType;
use optica_optics::glass::LAMBDA_D_NM;
use optica_optics::lens::{LensPrescription, PreparedLens, TracePath};
use optica_optics::lens_flare::{Aperture, Beam, DEFAULT_MAX_GAIN, spectral_weight};

use crate::fit::{Fits, PassingFits, fit_for, screen_grid};
use crate::frame::{SensorMapping, light_in_lens};
use crate::gpu_lens::{GpuSurface, aperture_params, gpu_surfaces};
use crate::{FlareGhosts, FlareSource, LensFlare};

/// Cells of a row one invocation of the cell pass colours
/// (`ghost_cells.wgsl`'s `SPAN_CELLS`).
const SPAN_CELLS: u32 = 4;

/// One grid of rays (`GridJob`): the ray at pupil `(u, v)` starts at
/// `origin + u·du + v·dv`.
#[derive(ShaderType, Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct GridJob {
    origin: Vec3,
    first: u32,
    du: Vec3,
    second: u32,
    dv: Vec3,
    lens_base: u32,
    dir: Vec3,
    cell_pupil_area: f32,
    /// Linear RGB added per unit irradiance; w: the wavelength, nm.
    color: Vec4,
    /// The light's index in [`FlareDraws::lights`].
    light: u32,
    /// Rays per side.
    n: u32,
    /// Where its rays start in the ray buffer.
    ray_base: u32,
    /// Where its rays start among the trace's threads.
    thread_base: u32,
    /// (cos, sin) of the azimuth its traced rays are turned by.
    rotation: Vec2,
    /// Rows traced: all `n`, or with symmetry the first `⌈n/2⌉`, whose
    /// mirror images are the rest.
    rows: u32,
    /// Where its cells start among all grids' cells.
    cell_base: u32,
    /// Where its row spans start among the cell pass's threads.
    span_base: u32,
    /// The cell pass draws a smooth 2 × 2 block of its cells as one where
    /// their irradiances are within this share of each other (0: never;
    /// [`LensFlare::merge_cells`] for the coarse grids).
    merge: f32,
}

impl GridJob {
    /// One past its last ray in the ray buffer.
    pub(crate) fn ray_end(&self) -> u32 {
        self.ray_base + self.n * self.n
    }

    /// Its first cell among all grids' cells.
    pub(crate) fn cell_start(&self) -> u32 {
        self.cell_base
    }

    /// One past its last cell among all grids' cells.
    pub(crate) fn cell_end(&self) -> u32 {
        self.cell_base + (self.n - 1) * (self.n - 1)
    }

    /// Row spans of [`SPAN_CELLS`] cells (the last one shorter) in its grid.
    fn spans(&self) -> u32 {
        (self.n - 1) * (self.n - 1).div_ceil(SPAN_CELLS)
    }

    /// One past its last span among the cell pass's threads.
    pub(crate) fn span_end(&self) -> u32 {
        self.span_base + self.spans()
    }

    /// One past its last thread of the trace.
    pub(crate) fn thread_end(&self) -> u32 {
        self.thread_base + self.n * self.rows
    }
}

/// Where a light's occlusion is read (`LightProbe`): its image in NDC and
/// the largest depth (reverse Z) that does not hide it.
#[derive(ShaderType, Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct LightProbe {
    /// The light's image, NDC.
    pub ndc: Vec2,
    /// Scene depths above this (nearer) hide the light.
    pub depth_limit: f32,
    /// 0 when the light has no image to read depth round (it flares fully).
    pub read_depth: u32,
    /// The light's linear RGB at the camera (irradiance × exposure ×
    /// strength × the flare's intensity), for its starburst.
    pub color: Vec4,
}

impl LightProbe {
    /// The probe of a light seen along `towards` in view space — a
    /// direction (`w = 0`, a sun) or a position (`w = 1`) — through
    /// `clip_from_view`. A position is moved `light_radius` towards the
    /// camera first, so that the light's own bulb does not hide it.
    pub fn new(clip_from_view: Mat4, towards: Vec4, light_radius: f32) -> Self {
        let unreadable = Self::default();
        let mut p = towards;
        if p.w != 0.0 {
            let distance = p.xyz().length();
            if distance <= light_radius {
                // The camera is inside the bulb: nothing hides the light.
                return unreadable;
            }
            p = (p.xyz() * (1.0 - light_radius / distance)).extend(1.0);
        }
        let clip = clip_from_view * p;
        if !clip.is_finite() || clip.w <= 0.0 {
            return unreadable;
        }
        Self {
            ndc: clip.xy() / clip.w,
            depth_limit: clip.z / clip.w,
            read_depth: 1,
            color: Vec4::ZERO,
        }
    }
}

/// The uniform of both passes (`FlareParams`).
#[derive(ShaderType, Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct FlareParams {
    /// Rays in all the grids.
    pub rays: u32,
    /// Grids.
    pub jobs: u32,
    /// Surfaces per lens.
    pub surfaces: u32,
    sensor_z: f32,
    half_height_mm: f32,
    aspect: f32,
    max_gain: f32,
    intensity: f32,
    /// The iris (`aperture_contains`'s parameters).
    pub(crate) blades: u32,
    rotation: f32,
    radius: f32,
    arc_w: f32,
    /// Lights in [`FlareDraws::lights`].
    pub lights: u32,
    /// Radius of the occlusion disk, pixels; 0 with occlusion off.
    pub occlusion_radius_px: f32,
    /// Weight of the last frame's visibility.
    pub occlusion_history: f32,
    /// 1 when the visibility's history is to be dropped.
    pub reset_history: u32,
    /// Half the starburst's height, NDC; 0 with the starburst off.
    pub starburst_half_ndc: f32,
    /// The starburst's texel value to pixel value (energy per pixel).
    pub starburst_scale: f32,
    /// 1 when the ghosts read the ringing texture.
    pub ringing: u32,
    /// Rays traced (fewer than `rays` with symmetry: mirrored rows are
    /// not traced).
    pub threads: u32,
    /// Where this frame's TAA jitter moved the depth buffer against the
    /// light's unjittered image, NDC (set by the render world).
    pub jitter_ndc: Vec2,
    /// Frames in the view's jitter sequence whose raw visibilities are
    /// averaged (0: no jitter).
    pub jitter_cycle: u32,
    /// The frame's slot in that sequence.
    pub jitter_slot: u32,
    /// Cells in all the grids.
    pub cells: u32,
    /// Row spans in all the grids (the cell pass's threads).
    pub spans: u32,
}

impl FlareParams {
    /// What of the uniform the trace and the cell pass read: grids,
    /// threads, surfaces per lens, the sensor plane, the gain bound, the
    /// cell pass's spans and the iris it merges cells inside (floats as
    /// bits).
    pub(crate) fn trace_inputs(&self) -> [u32; 10] {
        [
            self.jobs,
            self.threads,
            self.surfaces,
            self.sensor_z.to_bits(),
            self.max_gain.to_bits(),
            self.spans,
            self.blades,
            self.rotation.to_bits(),
            self.radius.to_bits(),
            self.arc_w.to_bits(),
        ]
    }
}

/// What a flare camera's passes trace and draw this frame; no grids when
/// no light enters the lens.
#[derive(Component, Clone, Debug, Default, ExtractComponent)]
pub(crate) struct FlareDraws {
    /// The lens at each wavelength, one after the other.
    pub surfaces: Vec<GpuSurface>,
    /// The grids.
    pub jobs: Vec<GridJob>,
    /// Where each light's occlusion is read (indexed by the grids).
    pub lights: Vec<LightProbe>,
    /// The lights, in the order of `lights` (a change resets the
    /// visibility's history).
    pub light_entities: Vec<Entity>,
    /// The starburst texture, when on.
    pub starburst: Option<AssetId<Image>>,
    /// The ringing texture, when on.
    pub ringing: Option<AssetId<Image>>,
    /// The view's size over the size the ghosts are added up at, per side
    /// ([`crate::GhostResolution::divisor`]).
    pub ghost_divisor: u32,
    /// The first of the grids added up at half the ghosts' resolution
    /// ([`LensFlare::coarse_ghost_px`]); they come after the others.
    pub coarse_from: usize,
    /// Sizes and the sensor-to-screen mapping.
    pub params: FlareParams,
}

/// A starburst texel's value to a pixel's: the light the lens focuses from
/// a light (its irradiance times the entrance pupil's area) spread over the
/// pattern's texels, per sensor pixel. For a pattern `side` texels across
/// spanning `2 · size` of the view's height and a sensor `2 · hh` mm high,
/// a pixel holds `(side / (2 size H))²` texels and has `(2 hh / H)²` mm²,
/// so the view's height `H` cancels: `side² · A_pupil / (16 size² hh²)`.
pub fn starburst_scale(
    flare: &LensFlare,
    ghosts: &FlareGhosts,
    paraxial: &optica_optics::lens::ParaxialProperties,
    mapping: &SensorMapping,
) -> f32 {
    let (Some(settings), Some(_)) = (flare.starburst, ghosts.starburst.as_ref()) else {
        return 0.0;
    };
    let side = f64::from(settings.resolution);
    let pupil_mm2 = std::f64::consts::PI * paraxial.entrance_pupil_radius_mm.powi(2);
    let size = f64::from(settings.size);
    let value = f64::from(settings.intensity) * side * side * pupil_mm2
        / (16.0 * size * size * mapping.half_height_mm.powi(2));
    if value.is_finite() { value as f32 } else { 0.0 }
}

/// A light that may flare: where it is, its [`FlareSource`] and which kind
/// of light it is.
type FlareLight = (
    Entity,
    &'static GlobalTransform,
    &'static FlareSource,
    Option<&'static DirectionalLight>,
    Option<&'static PointLight>,
    Option<&'static SpotLight>,
);

/// Builds [`FlareDraws`] for every [`LensFlare`] camera.
#[allow(clippy::type_complexity)]
pub(crate) fn prepare_draws(
    mut commands: Commands,
    mut fits: Local<PassingFits>,
    cameras: Query<(
        Entity,
        &LensFlare,
        Ref<FlareGhosts>,
        &Camera,
        &Projection,
        &GlobalTransform,
        Option<&Exposure>,
    )>,
    lights: Query<FlareLight>,
) {
    fits.cameras.retain(|e, _| cameras.contains(*e));
    for (entity, flare, ghosts, camera, projection, transform, exposure) in &cameras {
        let camera_fits = fits.cameras.entry(entity).or_default();
        if ghosts.is_changed() {
            camera_fits.clear();
        }
        camera_fits.start_frame();
        let draws = build(
            flare,
            &ghosts,
            camera,
            projection,
            transform,
            exposure,
            &lights,
            camera_fits,
        )
        .unwrap_or_default();
        commands.entity(entity).insert(draws);
    }
}
/// What every ghost of a flare shares while its grids are laid out.
struct GhostSetup<'a> {
    flare: &'a LensFlare,
    ghosts: &'a FlareGhosts,
    lens: &'a LensPrescription,
    aperture: &'a Aperture,
    /// The lens prepared at each traced wavelength.
    prepared: &'a [PreparedLens],
    wavelengths: &'a [f64],
    /// Surfaces per wavelength in the lens table.
    count: u32,
    /// Pixels per sensor mm where the ghosts are added up.
    ghost_px_per_mm: f64,
}

/// One light as its ghosts see it.
struct GhostLight {
    /// Its slot among the flare's lights.
    index: u32,
    /// Its colour at the camera (exposed, linear).
    rgb: Vec3,
    /// Its direction of travel in the lens's frame.
    d: DVec3,
}

/// A light's direction of travel (world), irradiance at the camera (lux)
/// and colour; `None` for a light that is neither directional, point nor
/// spot.
fn irradiance(
    camera_position: Vec3,
    light_transform: &GlobalTransform,
    directional: Option<&DirectionalLight>,
    point: Option<&PointLight>,
    spot: Option<&SpotLight>,
) -> Option<(Vec3, f32, Color)> {
    if let Some(d) = directional {
        return Some((light_transform.forward().as_vec3(), d.illuminance, d.color));
    }
    let to_camera = camera_position - light_transform.translation();
    let d2 = to_camera.length_squared().max(1e-6);
    let (lumens, colour) = match (point, spot) {
        (Some(p), _) => (p.intensity, p.color),
        (_, Some(s)) => (s.intensity, s.color),
        _ => return None,
    };
    Some((
        to_camera,
        lumens / (4.0 * std::f32::consts::PI * d2),
        colour,
    ))
}

/// The grid jobs of every drawn ghost of one light: one per drawn
/// wavelength, into `coarse_jobs` when the ghost is large enough to be
/// added up at half the resolution.
fn push_ghost_jobs(
    setup: &GhostSetup,
    light: &GhostLight,
    fits: &mut Fits,
    jobs: &mut Vec<GridJob>,
    coarse_jobs: &mut Vec<GridJob>,
) {
    let GhostSetup {
        flare,
        ghosts,
        lens,
        aperture,
        prepared,
        wavelengths,
        count,
        ghost_px_per_mm,
    } = *setup;
    let (d, rgb, light) = (light.d, light.rgb, light.index);
    for ((first, second), mut n) in ghosts.drawn_grids() {
        let path = TracePath::ghost(first, second);
        // With symmetry, where the ghost's light gets through (none:
        // the ghost is not drawn at this angle), and no more cells
        // than pixels it covers where the ghosts are added up.
        let middle = &prepared[prepared.len() / 2];
        let (passing, spectrum) = fit_for(fits, lens, middle, (first, second), aperture, d);
        // A large ghost is added up at half the resolution: its pixels
        // are twice as wide (its grid is not cut to them: cells that
        // coarse made the double Gauss's bright large ghosts 10 %
        // worse against the reference for little time).
        let coarse = passing.is_some_and(|p| {
            let image_px = (p.sensor.max - p.sensor.min).max_element() * ghost_px_per_mm;
            flare
                .coarse_ghost_px
                .is_some_and(|limit| image_px > f64::from(limit))
        });
        let px_per_mm = if coarse {
            ghost_px_per_mm / 2.0
        } else {
            ghost_px_per_mm
        };
        // A ghost whose wavelengths draw one image (it moves by less
        // than `merge_wavelengths_px` across the band) is drawn once,
        // at the middle wavelength: a third of the cells at three.
        let merged = spectrum.is_some_and(|s| {
            wavelengths.len() > 1
                && s.spread_mm() * px_per_mm < f64::from(flare.merge_wavelengths_px)
        });
        let drawn: &[f64] = if merged {
            std::slice::from_ref(&wavelengths[wavelengths.len() / 2])
        } else {
            wavelengths
        };
        // The ghost's colour over the whole band, carried by the
        // drawn wavelengths.
        let gains = spectrum.map_or(Vec3::ONE, |s| s.gains(drawn).as_vec3());
        let passing = if flare.symmetry {
            let Some(passing) = passing else {
                continue;
            };
            n = screen_grid(n, &passing, ghost_px_per_mm);
            Some(passing.pupil)
        } else {
            None
        };
        let cells = f64::from((n - 1) * (n - 1));
        for (w, &wl) in wavelengths.iter().enumerate() {
            if merged && w != wavelengths.len() / 2 {
                continue;
            }
            // With symmetry: the light turned into the x–z plane, half
            // the rows traced and mirrored, the result turned back.
            let beam = if flare.symmetry {
                Beam::meridional(lens, path, d, wl)
            } else {
                Beam::for_path(lens, path, d, wl).map(|b| (b, 0.0))
            };
            let Ok((mut beam, azimuth)) = beam else {
                continue;
            };
            if let Some(rect) = passing {
                beam = beam.within(rect, true);
            }
            let at = |u: f64, v: f64| beam.ray_at(u, v).map(|r| r.origin());
            let (Ok(o), Ok(ou), Ok(ov)) = (at(0.0, 0.0), at(1.0, 0.0), at(0.0, 1.0)) else {
                continue;
            };
            let weight = spectral_weight(wl, drawn).as_vec3() * gains;
            let jobs = if coarse { &mut *coarse_jobs } else { &mut *jobs };
            jobs.push(GridJob {
                origin: o.as_vec3(),
                first: first as u32,
                du: (ou - o).as_vec3(),
                second: second as u32,
                dv: (ov - o).as_vec3(),
                lens_base: w as u32 * count,
                dir: DVec3::as_vec3(beam.direction()),
                cell_pupil_area: (beam.cross_section_mm2() / cells) as f32,
                color: (rgb * weight).extend(wl as f32),
                light,
                n,
                ray_base: 0,
                thread_base: 0,
                rotation: Vec2::from_angle(azimuth as f32),
                rows: if flare.symmetry { n.div_ceil(2) } else { n },
                cell_base: 0,
                span_base: 0,
                merge: if coarse { flare.merge_cells } else { 0.0 },
            });
        }
    }
}

/// Gives each job its first ray, thread, cell and span; the totals.
fn lay_out(jobs: &mut [GridJob]) -> (u32, u32, u32, u32) {
    let (mut rays, mut threads, mut cells, mut spans) = (0u32, 0u32, 0u32, 0u32);
    for job in jobs {
        job.ray_base = rays;
        job.thread_base = threads;
        job.cell_base = cells;
        job.span_base = spans;
        cells = cells.saturating_add((job.n - 1) * (job.n - 1));
        spans = spans.saturating_add(job.spans());
        rays = rays.saturating_add(job.n * job.n);
        threads = threads.saturating_add(job.n * job.rows);
    }
    (rays, threads, cells, spans)
}


#[allow(clippy::too_many_arguments)]
fn build(
    flare: &LensFlare,
    ghosts: &FlareGhosts,
    camera: &Camera,
    projection: &Projection,
    transform: &GlobalTransform,
    exposure: Option<&Exposure>,
    lights: &Query<FlareLight>,
    fits: &mut Fits,
) -> Option<FlareDraws> {
    flare.validate().ok()?;
    let lens = ghosts.lens.as_ref()?;
    let aperture = ghosts.aperture.as_ref()?;
    let (blades, rotation, radius, arc_w) = aperture_params(aperture);
    let Projection::Perspective(perspective) = projection else {
        return None;
    };
    let size = camera.physical_target_size()?;
    let aspect = f64::from(size.x) / f64::from(size.y.max(1));
    let paraxial = lens.paraxial(LAMBDA_D_NM).ok()?;
    let efl = paraxial.efl_mm;
    let mapping = SensorMapping::new(efl, f64::from(perspective.fov), aspect)?;
    let wavelengths = flare.wavelengths_nm();
    let prepared: Vec<PreparedLens> = wavelengths
        .iter()
        .map(|&wl| PreparedLens::new(lens, wl).ok())
        .collect::<Option<_>>()?;
    let surfaces: Vec<GpuSurface> = prepared.iter().flat_map(gpu_surfaces).collect();
    let count = lens.surfaces().len() as u32;
    let exposure = exposure.copied().unwrap_or_default().exposure();
    let view_from_world = transform.affine().inverse();
    let camera_position = transform.translation();
    let mut jobs = Vec::new();
    let mut coarse_jobs = Vec::new();
    let mut probes = Vec::new();
    let mut light_entities = Vec::new();
    let clip_from_view = camera.clip_from_view();
    // Pixels per sensor mm where the ghosts are added up.
    let ghost_px_per_mm = f64::from(size.y)
        / f64::from(flare.ghost_resolution.divisor())
        / (2.0 * mapping.half_height_mm);
    let light_radius = flare.occlusion.map_or(0.0, |o| o.light_radius);
    let ghost_setup = GhostSetup {
        flare,
        ghosts,
        lens,
        aperture,
        prepared: &prepared,
        wavelengths: &wavelengths,
        count,
        ghost_px_per_mm,
    };
    // In entity order, so that a light keeps its visibility's slot.
    let mut lights: Vec<_> = lights.iter().collect();
    lights.sort_by_key(|l| l.0);
    for (light_entity, light_transform, source, directional, point, spot) in lights {
        let Some((travel, lux, colour)) =
            irradiance(camera_position, light_transform, directional, point, spot)
        else {
            continue;
        };
        let travel_view = view_from_world.transform_vector3(travel);
        let Some(d) = light_in_lens(travel_view) else {
            continue;
        };
        let towards = if directional.is_some() {
            (-travel_view).extend(0.0)
        } else {
            view_from_world
                .transform_point3(light_transform.translation())
                .extend(1.0)
        };
        let rgb = Vec3::from_array(LinearRgba::from(colour).to_f32_array_no_alpha())
            * lux
            * exposure
            * source.strength;
        let light = probes.len() as u32;
        probes.push(LightProbe {
            color: (rgb * flare.intensity).extend(1.0),
            ..LightProbe::new(clip_from_view, towards, light_radius)
        });
        light_entities.push(light_entity);
        let light = GhostLight {
            index: light,
            rgb,
            d,
        };
        push_ghost_jobs(&ghost_setup, &light, fits, &mut jobs, &mut coarse_jobs);
    }
    // The grids added up at the ghosts' resolution, then the coarse ones,
    // so that each set's cells are one range of the index buffer; each in
    // light and brightness order, so that grids left out past the device's
    // limit are the dimmest coarse ones of the last light.
    let coarse_from = jobs.len();
    jobs.append(&mut coarse_jobs);
    let (rays, threads, cells, spans) = lay_out(&mut jobs);
    Some(FlareDraws {
        params: FlareParams {
            rays,
            jobs: jobs.len() as u32,
            surfaces: count,
            sensor_z: prepared[0].table_sensor_z() as f32,
            half_height_mm: mapping.half_height_mm as f32,
            aspect: aspect as f32,
            max_gain: DEFAULT_MAX_GAIN as f32,
            intensity: flare.intensity,
            blades,
            rotation,
            radius,
            arc_w,
            lights: probes.len() as u32,
            occlusion_radius_px: flare.occlusion.map_or(0.0, |o| o.radius * size.y as f32),
            occlusion_history: flare.occlusion.map_or(0.0, |o| o.history),
            reset_history: 0,
            starburst_half_ndc: flare.starburst.map_or(0.0, |b| 2.0 * b.size),
            starburst_scale: starburst_scale(flare, ghosts, &paraxial, &mapping),
            ringing: u32::from(ghosts.ringing.is_some()),
            threads,
            jitter_ndc: Vec2::ZERO,
            jitter_cycle: 0,
            jitter_slot: 0,
            cells,
            spans,
        },
        starburst: ghosts.starburst.as_ref().map(Handle::id),
        ringing: ghosts.ringing.as_ref().map(Handle::id),
        ghost_divisor: flare.ghost_resolution.divisor(),
        coarse_from,
        surfaces,
        jobs,
        lights: probes,
        light_entities,
    })
}
