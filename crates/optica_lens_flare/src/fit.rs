//! Where each ghost's light gets through, so that its grid of rays covers
//! only that part of the pupil plane (the blog's *Bundle bounding*,
//! measured instead of bounded), and a grid no finer than the pixels the
//! ghost covers.
//!
//! Wide open, only about 15 % of the square the pupil bounds give a double
//! Gauss ghost passes the lens (measured at dae9e45, 2026-12-02): 85 % of
//! its rays were traced and its cells drawn for nothing, and the cells
//! that drew it were few. With the grid fitted to the passing light, the
//! same 32² grid follows the reference more closely (relative L1 0.148 →
//! 0.117 on the double Gauss at 512², measured at dae9e45, 2026-12-02; the
//! `lens_flare` report's `fixed grid` series measures the current
//! settings).
//!
//! The same fits measure each ghost's throughput over the band
//! ([`GhostSpectrum`]), from which its spectral gains follow.

use bevy::math::DVec3;
use std::time::Duration;

use bevy::platform::collections::HashMap;
use bevy::platform::time::Instant;
use bevy::prelude::Entity;
use optica_optics::lens::{LensPrescription, PreparedLens, TracePath};
use optica_optics::lens_flare::{
    Aperture, Beam, GhostSpectrum, Passing, SINGLE_SAMPLE_NM, passing_rect, spectrum_lenses,
};

/// Field angles, degrees, at which the passing light is measured; a light
/// between two steps is given the union of both.
pub const FIT_STEP_DEG: f64 = 1.0;
/// Rays per side of the grid a fit traces (at the middle wavelength; the
/// fit grows by one of its steps on each side, which also covers the
/// other wavelengths' small shifts).
pub const FIT_RAYS: usize = 13;
/// A ghost's cells are at least this many pixels across (of the target the
/// ghosts are added up in): a finer grid only adds triangles, each of
/// which costs a rasteriser at least a block of pixels.
pub const CELL_PX: f64 = 1.5;
/// Fewest rays per side a ghost's grid is cut to for its size on screen.
pub const MIN_SCREEN_GRID: u32 = 8;

/// The two fit steps round the field angle of light travelling along `d`
/// (lens frame).
pub fn fit_steps(d: DVec3) -> [i32; 2] {
    let below = (field_deg(d) / FIT_STEP_DEG).floor() as i32;
    [below, below + 1]
}

/// The field angle of light travelling along `d` (lens frame), degrees.
fn field_deg(d: DVec3) -> f64 {
    d.z.clamp(-1.0, 1.0).acos().to_degrees()
}

/// Light `step · FIT_STEP_DEG` off axis, in the x–z plane.
fn step_light(step: i32) -> DVec3 {
    let t = (f64::from(step) * FIT_STEP_DEG).to_radians();
    DVec3::new(t.sin(), 0.0, t.cos())
}

/// Where the light of the ghost `(first, second)` passes at fit step
/// `step` (light `step · FIT_STEP_DEG` off axis, in the x–z plane: with
/// symmetry every azimuth is this one turned), traced at `middle`'s
/// wavelength through the iris `aperture`; `None` when none passes.
pub fn passing_at_step(
    lens: &LensPrescription,
    middle: &PreparedLens,
    (first, second): (usize, usize),
    aperture: &Aperture,
    step: i32,
) -> Option<Passing> {
    let path = TracePath::ghost(first, second);
    let (beam, _) = Beam::meridional(lens, path, step_light(step), middle.wavelength_nm()).ok()?;
    passing_rect(middle, path, &beam, aperture, FIT_RAYS)
        .ok()
        .flatten()
}

/// Rays per side for a ghost drawn with at most `n`, whose light lands on
/// `passing.sensor`, where the ghosts are added up at `px_per_mm` pixels
/// per sensor mm: cells of at least [`CELL_PX`], never fewer than
/// [`MIN_SCREEN_GRID`] rays (nor more than `n`).
pub fn screen_grid(n: u32, passing: &Passing, px_per_mm: f64) -> u32 {
    let extent = passing.sensor.max - passing.sensor.min;
    let px = extent.max_element() * px_per_mm;
    let cells = if px.is_finite() {
        (px / CELL_PX).ceil().clamp(0.0, f64::from(u32::MAX - 1)) as u32
    } else {
        u32::MAX - 1
    };
    n.min((cells + 1).max(MIN_SCREEN_GRID))
}

/// Main-thread time a frame may spend measuring ghost spectra at new fit
/// steps. A spectrum costs far more than the passing light (17 traces of
/// 5² rays: 880 ms for the zoom's 311 ghosts per degree, against 142 ms
/// for where they pass; the `lens_flare` report's `zoom 1280x720` series,
/// full run), and changes little over a degree, so a turning camera
/// measures the new steps a few ghosts a frame and meanwhile draws each
/// ghost with its last measured spectrum. A ghost with none yet is
/// measured at once, whatever the budget, so a still view's first frame
/// is complete and the same on every run.
pub const SPECTRUM_BUDGET_MS: f64 = 2.0;

/// What is measured of one ghost at one fit step: where its light passes
/// (`None`: nowhere) and its throughput over the band (for the spectral
/// gains; `None` until measured, `Some(None)` where no light passes).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct StepFit {
    passing: Option<Passing>,
    spectrum: Option<Option<GhostSpectrum>>,
}

/// One camera's fits: per ghost `(first, second)` and fit step, and the
/// lens at the spectrum's wavelengths they are traced with.
#[derive(Default)]
pub(crate) struct Fits {
    steps: HashMap<((usize, usize), i32), StepFit>,
    spectrum_lenses: Option<Vec<PreparedLens>>,
    /// Per ghost, the spectrum measured last: drawn while a new step's
    /// waits for the budget.
    latest: HashMap<(usize, usize), Option<GhostSpectrum>>,
    /// Until when this frame may measure spectra; `None`: no limit.
    deadline: Option<Instant>,
}

impl Fits {
    /// Forgets every fit (the ghosts or the lens changed).
    pub(crate) fn clear(&mut self) {
        self.steps.clear();
        self.latest.clear();
        self.spectrum_lenses = None;
    }

    /// Starts a frame's budget for measuring spectra
    /// ([`SPECTRUM_BUDGET_MS`]).
    pub(crate) fn start_frame(&mut self) {
        self.deadline = Some(Instant::now() + Duration::from_secs_f64(SPECTRUM_BUDGET_MS * 1e-3));
    }
}

/// Per flare camera, the fits of each drawn ghost at each step, kept until
/// its ghosts change: a camera that turns measures each degree once.
#[derive(Default)]
pub(crate) struct PassingFits {
    pub(crate) cameras: HashMap<Entity, Fits>,
}

/// A ghost's fit for light travelling along `d` (lens frame), from a
/// camera's `fits` (made on first use at the two steps round its angle):
/// where its light passes, the union of both steps (`None` when it passes
/// at neither), and its throughput over the band, linear in the angle
/// between them.
pub(crate) fn fit_for(
    fits: &mut Fits,
    lens: &LensPrescription,
    middle: &PreparedLens,
    ghost: (usize, usize),
    aperture: &Aperture,
    d: DVec3,
) -> (Option<Passing>, Option<GhostSpectrum>) {
    let lenses = fits
        .spectrum_lenses
        .get_or_insert_with(|| spectrum_lenses(lens).unwrap_or_default());
    let steps = fit_steps(d);
    // A ghost never measured is measured at both steps now.
    let first_time = !fits.latest.contains_key(&ghost);
    let [below, above] = steps.map(|step| {
        let fit = fits.steps.entry((ghost, step)).or_insert_with(|| StepFit {
            passing: passing_at_step(lens, middle, ghost, aperture, step),
            spectrum: None,
        });
        let in_budget = fits.deadline.is_none_or(|end| Instant::now() < end);
        if fit.spectrum.is_none() && (first_time || in_budget) {
            let spectrum = spectrum_at_step(lens, lenses, ghost, aperture, step, fit.passing);
            fit.spectrum = Some(spectrum);
            fits.latest.insert(ghost, spectrum);
        }
        *fit
    });
    let passing = match (below.passing, above.passing) {
        (Some(a), Some(b)) => Some(a.union(b)),
        (a, b) => a.or(b),
    };
    let t = field_deg(d) / FIT_STEP_DEG - f64::from(steps[0]);
    let spectrum = match (below.spectrum, above.spectrum) {
        (Some(Some(a)), Some(Some(b))) => Some(a.lerp(&b, t)),
        (Some(Some(a)), _) | (_, Some(Some(a))) => Some(a),
        (Some(None), Some(None)) => None,
        // Not measured yet at this angle: the last measured.
        _ => fits.latest.get(&ghost).copied().flatten(),
    };
    (passing, spectrum)
}

/// The spectral gains the plugin gives the ghost `(first, second)` of
/// `lens` drawn at `samples` nm for light travelling along `d` (lens
/// frame), as its drawing multiplies them into the samples' colours: the
/// ghost's throughput over the band measured at the two fit steps round
/// the light's angle, linear between them
/// ([`GhostSpectrum::gains`](optica_optics::lens_flare::GhostSpectrum::gains));
/// (1, 1, 1) where its light passes at neither. For CPU twins of the
/// drawn flare; the plugin keeps these fits per camera.
pub fn spectral_gains(
    lens: &LensPrescription,
    ghost: (usize, usize),
    aperture: &Aperture,
    d: DVec3,
    samples: &[f64],
) -> DVec3 {
    // The passing light is fitted at the middle sample, as drawn.
    let wl = samples
        .get(samples.len() / 2)
        .copied()
        .unwrap_or(SINGLE_SAMPLE_NM);
    let Ok(middle) = PreparedLens::new(lens, wl) else {
        return DVec3::ONE;
    };
    let (_, spectrum) = fit_for(&mut Fits::default(), lens, &middle, ghost, aperture, d);
    spectrum.map_or(DVec3::ONE, |s| s.gains(samples))
}

/// The ghost `(first, second)`'s throughput over the band at fit step
/// `step` (as [`passing_at_step`]'s light), traced with `lenses` (from
/// [`spectrum_lenses`]) over where its light passes (`passing`, from
/// [`passing_at_step`]; `None`: nowhere, so no spectrum).
pub fn spectrum_at_step(
    lens: &LensPrescription,
    lenses: &[PreparedLens],
    (first, second): (usize, usize),
    aperture: &Aperture,
    step: i32,
    passing: Option<Passing>,
) -> Option<GhostSpectrum> {
    let path = TracePath::ghost(first, second);
    let (beam, _) = Beam::meridional(lens, path, step_light(step), SINGLE_SAMPLE_NM).ok()?;
    let beam = beam.within(passing?.pupil, true);
    GhostSpectrum::trace(lenses, path, &beam, aperture)
        .ok()
        .flatten()
}
