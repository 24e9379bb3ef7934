//! The brute-force reference of one ghost's image, and image errors.
//!
//! Many rays, stratified-jittered over the same pupil square as the grid (one
//! uniform random point in each of K×K strata: unbiased, and far less noisy
//! than independent samples), each traced along the ghost path and clipped
//! exactly — every surface's semi-aperture (`r_rel <= 1`, the stop included
//! at each crossing) and the aperture shape at every stop-plane crossing
//! (three for a ghost `(i, j)` with `j < stop < i`, see
//! [`crate::lens::TraceResult::stop_xy_all`]) — then
//! splatted into the sensor histogram with its power
//! `cross_section / K² × throughput`. Nothing is interpolated, so this is what
//! the grid method approximates; its own error is Monte-Carlo noise, which
//! falls as 1/K per pixel for a smooth image.

use rayon::prelude::*;

use super::FlareError;
use super::aperture::Aperture;
use super::grid_trace::{GridOptions, check_setup, trace_one};
use super::pupil::Beam;
use super::raster::{SensorImage, SensorWindow};
use crate::lens::{PreparedLens, TracePath};

/// Most strata per side of a reference (4096² ≈ 1.7·10⁷ rays).
pub const MAX_REFERENCE_SIDE: usize = 4096;

/// A brute-force image and its ray counts.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceImage {
    /// Power per pixel.
    pub image: SensorImage,
    /// Rays traced.
    pub rays: usize,
    /// Rays that reached the sensor unclipped (inside the window or not).
    pub passed: usize,
    /// Power of the unclipped rays, inside the window or not, mm².
    pub power: f64,
}

/// SplitMix64 (Steele et al. 2014): a tiny, well-mixed generator, enough
/// for jitter; seeded per row so the reference is the same however rayon
/// splits the work.
#[derive(Clone, Copy, Debug)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1) with 53 random bits.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// The brute-force image of `path` for `beam`: `rays_per_side²` jittered
/// rays, clipped by `r_rel <= 1` and `aperture`, binned over `window`.
/// `options.sensor_z` places the sensor (`max_gain` is unused here).
#[allow(clippy::too_many_arguments)]
pub fn reference_image(
    lens: &PreparedLens,
    path: TracePath,
    beam: &Beam,
    aperture: &Aperture,
    window: SensorWindow,
    rays_per_side: usize,
    seed: u64,
    options: &GridOptions,
) -> Result<ReferenceImage, FlareError> {
    if rays_per_side == 0 {
        return Err(FlareError::NoRays);
    }
    if rays_per_side > MAX_REFERENCE_SIDE {
        return Err(FlareError::InvalidGridSize { got: rays_per_side, max: MAX_REFERENCE_SIDE });
    }
    let sensor_z = check_setup(lens, path, options)?;
    let k = rays_per_side;
    let w = beam.cross_section_mm2() / (k * k) as f64;
    let npix = window.width * window.height;
    let inv = 1.0 / k as f64;
    let (power, passed, total) = (0..k)
        .into_par_iter()
        .fold(
            || (vec![0.0; npix], 0usize, 0.0f64),
            |(mut img, mut passed, mut total), j| {
                let mut rng = SplitMix64(seed ^ (j as u64).wrapping_mul(0xD134_2543_DE82_EF95));
                for i in 0..k {
                    let u = (i as f64 + rng.next_f64()) * inv;
                    let v = (j as f64 + rng.next_f64()) * inv;
                    let r = trace_one(lens, path, beam, u, v, sensor_z);
                    if !r.passes(aperture) {
                        continue;
                    }
                    passed += 1;
                    total += w * r.throughput;
                    if let Some((ix, iy)) = window.pixel_of(r.sensor) {
                        img[iy * window.width + ix] += w * r.throughput;
                    }
                }
                (img, passed, total)
            },
        )
        .reduce(
            || (vec![0.0; npix], 0usize, 0.0f64),
            |(mut a, pa, ta), (b, pb, tb)| {
                for (x, y) in a.iter_mut().zip(&b) {
                    *x += y;
                }
                (a, pa + pb, ta + tb)
            },
        );
    Ok(ReferenceImage { image: SensorImage { window, power }, rays: k * k, passed, power: total })
}

/// Errors of an image against a reference over the same window.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageError {
    /// `Σ|test − ref| / Σ ref`.
    pub rel_l1: f64,
    /// `‖test − ref‖₂ / ‖ref‖₂`.
    pub rel_l2: f64,
    /// `(Σ test − Σ ref) / Σ ref` (signed).
    pub rel_energy: f64,
}

/// Compares `test` with `reference`; `None` when the windows differ or the
/// reference holds no power (nothing to be relative to).
pub fn compare(test: &SensorImage, reference: &SensorImage) -> Option<ImageError> {
    if test.window != reference.window {
        return None;
    }
    let (mut l1, mut l2, mut r1, mut r2, mut t1) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (t, r) in test.power.iter().zip(&reference.power) {
        l1 += (t - r).abs();
        l2 += (t - r) * (t - r);
        r1 += r.abs();
        r2 += r * r;
        t1 += t;
    }
    if !(r1 > 0.0 && r2 > 0.0 && l1.is_finite() && l2.is_finite()) {
        return None;
    }
    Some(ImageError { rel_l1: l1 / r1, rel_l2: (l2 / r2).sqrt(), rel_energy: (t1 - r1) / r1 })
}

/// The same image on a coarser window: `factor × factor` pixels summed into one
/// (`factor` must divide both sides; else `None`). Comparing at a coarser
/// scale separates the grid's error from the reference's per-pixel noise.
pub fn downsample(image: &SensorImage, factor: usize) -> Option<SensorImage> {
    let w = image.window;
    if factor == 0 || !w.width.is_multiple_of(factor) || !w.height.is_multiple_of(factor) {
        return None;
    }
    let win = SensorWindow::new(w.min, w.pixel_mm * factor as f64, w.width / factor, w.height / factor).ok()?;
    let mut out = SensorImage::new(win);
    for iy in 0..w.height {
        for ix in 0..w.width {
            out.power[(iy / factor) * win.width + ix / factor] += image.power[iy * w.width + ix];
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fresnel::Coating;
    use crate::lens::{LensPrescription, builtin};
    use crate::lens_flare::grid_trace::trace_grid;
    use crate::lens_flare::pupil::light_from_field;
    use crate::lens_flare::raster::rasterise;

    fn coated_tessar() -> LensPrescription {
        crate::lens_flare::coat_air_interfaces(&builtin::tessar(), Coating::quarter_wave(1.38, 550.0))
    }

    #[test]
    fn splitmix_is_uniform_enough() {
        // Mean of 10⁴ draws of U[0,1): 0.5 ± 3σ, σ = √(1/12/10⁴) = 0.0029.
        let mut r = SplitMix64(7);
        let m: f64 = (0..10_000).map(|_| r.next_f64()).sum::<f64>() / 1e4;
        assert!((m - 0.5).abs() < 0.009, "{m}");
    }

    #[test]
    fn compare_by_hand() {
        let w = SensorWindow::new(glam::DVec2::ZERO, 1.0, 2, 1).unwrap();
        let r = SensorImage { window: w, power: vec![1.0, 3.0] };
        let t = SensorImage { window: w, power: vec![2.0, 3.0] };
        let e = compare(&t, &r).unwrap();
        assert!((e.rel_l1 - 0.25).abs() < 1e-15);
        assert!((e.rel_l2 - (1.0f64 / 10.0).sqrt()).abs() < 1e-15);
        assert!((e.rel_energy - 0.25).abs() < 1e-15);
        assert!(compare(&t, &SensorImage::new(w)).is_none());
        let d = downsample(&r, 1).unwrap();
        assert_eq!(d, r);
        assert!(downsample(&r, 2).is_none());
    }

    #[test]
    fn grid_converges_to_the_reference() {
        // Coated Tessar ghost (5, 4) (reflections behind the stop), 8° off
        // axis: the rasterised grid's relative L1 error against a 400²-ray
        // reference must fall from N = 5 to N = 33, and end below 0.15.
        let p = coated_tessar();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let path = TracePath::ghost(5, 4);
        let beam = Beam::for_path(&p, path, light_from_field(8.0, 0.0), 550.0).unwrap();
        let opts = GridOptions::default();
        let ap = Aperture::of_stop(&p);
        let fine = trace_grid(&lens, path, &beam, 65, &opts).unwrap();
        let window =
            SensorWindow::around(fine.rays.iter().filter(|r| r.alive && r.r_rel <= 1.0).map(|r| r.sensor), 0.05, 24)
                .unwrap();
        let reference = reference_image(&lens, path, &beam, &ap, window, 400, 1, &opts).unwrap();
        let errs: Vec<ImageError> = [5, 9, 17, 33]
            .iter()
            .map(|&n| {
                let g = trace_grid(&lens, path, &beam, n, &opts).unwrap();
                compare(&rasterise(&g, &ap, window), &reference.image).unwrap()
            })
            .collect();
        assert!(errs[3].rel_l1 < errs[0].rel_l1, "{errs:?}");
        assert!(errs[3].rel_l1 < 0.15, "{errs:?}");
        assert!(errs[3].rel_energy.abs() < 0.05, "{errs:?}");
    }

    #[test]
    fn bladed_stop_clips_a_ghost_at_all_three_stop_crossings() {
        // Coated Tessar ghost (5, 0), 10° off axis: reflects behind the stop
        // (surface 3), then in front of it, so it crosses the stop plane
        // three times. With a triangular stop (3 blades inscribed in the stop
        // circle) about a quarter of the light that passes the triangle at
        // the first crossing is cut at the second or third: the reference
        // and the rasteriser must test all three (clipping at the first
        // only would keep ~1.3× the power).
        let p = coated_tessar();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let path = TracePath::ghost(5, 0);
        let beam = Beam::for_path(&p, path, light_from_field(10.0, 0.0), 550.0).unwrap();
        let opts = GridOptions::default();
        let stop_r = p.surfaces[p.stop_index().unwrap()].semi_aperture_mm;
        let ap = Aperture::polygon(3, 0.5, stop_r);
        // Power on a regular 200² grid, clipped at every crossing and at the first only.
        let (n, sensor_z) = (200, lens.table_sensor_z());
        let w = beam.cross_section_mm2() / (n * n) as f64;
        let (mut all, mut first) = (0.0, 0.0);
        for k in 0..n * n {
            let r = trace_one(&lens, path, &beam, ((k % n) as f64 + 0.5) / n as f64, ((k / n) as f64 + 0.5) / n as f64, sensor_z);
            if r.alive && r.r_rel <= 1.0 && ap.contains(r.stop_xy[0]) {
                first += w * r.throughput;
                if r.passes(&ap) {
                    all += w * r.throughput;
                }
            }
        }
        assert!(all < 0.9 * first, "later crossings cut little here: {all} vs {first}");
        let g = trace_grid(&lens, path, &beam, 65, &opts).unwrap();
        let window =
            SensorWindow::around(g.rays.iter().filter(|r| r.alive && r.r_rel <= 1.0).map(|r| r.sensor), 0.05, 24)
                .unwrap();
        let reference = reference_image(&lens, path, &beam, &ap, window, 300, 9, &opts).unwrap();
        assert!((reference.power / all - 1.0).abs() < 0.02, "reference {} vs every-crossing {all} (first only {first})", reference.power);
        let e = compare(&rasterise(&g, &ap, window), &reference.image).unwrap();
        assert!(e.rel_l1 < 0.2 && e.rel_energy.abs() < 0.03, "{e:?}");
    }

    #[test]
    fn flat_surface_ghost_with_bladed_aperture_matches_the_reference() {
        // Heliar (US 2,645,156) surface 6 is plano (c = 0) and not the stop:
        // ghost (8, 6) reflects on it, behind the stop, so it crosses the stop
        // once (where the blade shape is tested). With a 6-blade stop the per-pixel clip
        // by the interpolated stop position must agree with the exact per-ray
        // clip: N = 33 within 20 % L1 and 3 % energy of a 300² reference.
        let p = crate::lens_flare::coat_air_interfaces(&builtin::heliar(), Coating::quarter_wave(1.38, 550.0));
        assert!(p.surfaces[6].is_flat() && !p.surfaces[6].is_stop);
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let path = TracePath::ghost(8, 6);
        let beam = Beam::for_path(&p, path, light_from_field(5.0, 0.0), 550.0).unwrap();
        let opts = GridOptions::default();
        let stop_r = p.surfaces[p.stop_index().unwrap()].semi_aperture_mm;
        let ap = Aperture::polygon(6, 0.3, stop_r);
        let g = trace_grid(&lens, path, &beam, 33, &opts).unwrap();
        let window =
            SensorWindow::around(g.rays.iter().filter(|r| r.alive && r.r_rel <= 1.0).map(|r| r.sensor), 0.05, 24)
                .unwrap();
        let reference = reference_image(&lens, path, &beam, &ap, window, 300, 5, &opts).unwrap();
        let img = rasterise(&g, &ap, window);
        assert!(img.power.iter().all(|p| p.is_finite() && *p >= 0.0));
        let e = compare(&img, &reference.image).unwrap();
        assert!(e.rel_l1 < 0.2 && e.rel_energy.abs() < 0.03, "{e:?}");
        // The bladed stop passes less than the round one it is inscribed in.
        let round = rasterise(&g, &Aperture::circle(stop_r), window);
        assert!(img.total() < round.total(), "{} vs {} ref {}", img.total(), round.total(), reference.image.total());
    }
}

