//! The brightest any pixel of a flare can be, from the CPU twins: the
//! bound the stability and passes tests hold the drawn flare to in place
//! of a fixed number.
//!
//! The twins rebuild each drawn ghost's grids as the plugin does (the
//! passing light fitted at the two steps round the light's angle, the
//! grid cut to the ghost's pixels, the meridional beam within the passing
//! light, at every drawn wavelength) and take the brightest cell
//! (`optica_optics::lens_flare::cell_intensity`, the GPU's formula). Each
//! drawn sample of channel `c` carries a band weight (they sum to 1 over
//! the samples) times the ghost's spectral gain, so a ghost adds at most
//! its brightest cell times `gain_c` to a pixel, times the ringing's
//! largest texel. The ghosts overlap at worst everywhere: their bounds
//! add, and the starburst's largest texel (times its texel-to-pixel
//! scale) adds to that. All in units of the light's exposed irradiance.

use bevy::camera::Exposure;
use bevy::image::Image;
use bevy::prelude::*;
use optica_lens_flare::twins::{
    SensorMapping, fit_steps, light_in_lens, passing_at_step, ringing_image, screen_grid,
    spectral_gains, starburst_image, starburst_scale,
};
use optica_lens_flare::{FlareGhosts, LensFlare};
use optica_optics::glam::DVec3;
use optica_optics::glass::LAMBDA_D_NM;
use optica_optics::lens::{PreparedLens, TracePath};
use optica_optics::lens_flare::{Beam, GridOptions, Passing, trace_grid};

/// The GPU computes the cells in `f32`, the twins in `f64`.
const ROUNDING: f64 = 1.01;

/// Per channel, the largest value of `image`'s texels (RGBA32F).
fn largest_texel(image: &Image) -> DVec3 {
    let data = image.data.as_ref().expect("texels");
    data.chunks(16).fold(DVec3::ZERO, |m, t| {
        let c = |k: usize| f64::from(f32::from_le_bytes(t[4 * k..4 * k + 4].try_into().unwrap()));
        m.max(DVec3::new(c(0), c(1), c(2)))
    })
}

/// The bound on any channel of any pixel for a white directional light of
/// `lux` travelling along `travel_view` (the view space of the camera,
/// whose vertical field of view is `fov`, `size`² pixels), default
/// exposure.
pub fn brightest_pixel(
    flare: &LensFlare,
    ghosts: &FlareGhosts,
    travel_view: Vec3,
    lux: f32,
    fov: f32,
    size: u32,
) -> f32 {
    let lens = ghosts.lens.as_ref().expect("the flare's lens");
    let aperture = ghosts.aperture.as_ref().expect("the flare's iris");
    let Some(d) = light_in_lens(travel_view) else {
        // Light from behind the camera draws nothing.
        return 0.0;
    };
    let samples = flare.wavelengths_nm();
    let middle = [samples[samples.len() / 2]];
    let prepared: Vec<PreparedLens> = samples
        .iter()
        .map(|&wl| PreparedLens::new(lens, wl).expect("prepared"))
        .collect();
    let paraxial = lens.paraxial(LAMBDA_D_NM).expect("paraxial");
    let mapping = SensorMapping::new(paraxial.efl_mm, f64::from(fov), 1.0).expect("mapping");
    let ghost_px_per_mm = f64::from(size)
        / f64::from(flare.ghost_resolution.divisor())
        / (2.0 * mapping.half_height_mm);
    let middle_lens = &prepared[prepared.len() / 2];
    let mut ghost_sum = DVec3::ZERO;
    for ((first, second), n) in ghosts.drawn_grids() {
        let path = TracePath::ghost(first, second);
        let Some(passing) = fit_steps(d)
            .into_iter()
            .filter_map(|step| passing_at_step(lens, middle_lens, (first, second), aperture, step))
            .reduce(Passing::union)
        else {
            // Not drawn at this angle.
            continue;
        };
        let n = screen_grid(n, &passing, ghost_px_per_mm) as usize;
        let mut brightest = 0f64;
        for (&wl, prepared) in samples.iter().zip(&prepared) {
            let Ok((beam, azimuth)) = Beam::meridional(lens, path, d, wl) else {
                continue;
            };
            let beam = beam.within(passing.pupil, true);
            let grid = trace_grid(prepared, path, &beam, n, &GridOptions::default())
                .expect("grid")
                .turned(azimuth)
                .extrapolated(lens.stop_semi_aperture_mm());
            let cell = grid.cells().iter().map(|c| c.intensity).fold(0.0, f64::max);
            brightest = brightest.max(cell);
        }
        // Drawn at every sample, or merged at the middle one.
        let gains = spectral_gains(lens, (first, second), aperture, d, &samples)
            .max(spectral_gains(lens, (first, second), aperture, d, &middle));
        ghost_sum += brightest * ROUNDING * gains;
    }
    let ringing = ringing_image(flare, aperture)
        .expect("ringing")
        .map_or(DVec3::ONE, |image| largest_texel(&image));
    let starburst = match starburst_image(flare, aperture).expect("starburst") {
        Some(image) => {
            f64::from(starburst_scale(flare, ghosts, &paraxial, &mapping)) * largest_texel(&image)
        }
        None => DVec3::ZERO,
    };
    let exposed = f64::from(lux * Exposure::default().exposure() * flare.intensity);
    // The ringing's channels are wavelengths, not colours: its largest
    // over all three bounds every sample's.
    let per_channel = exposed * (ghost_sum * ringing.max_element() + starburst);
    per_channel.max_element() as f32
}
