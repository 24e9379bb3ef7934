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

use rand::{RngExt, SeedableRng};
use rand_xoshiro::SplitMix64;
use rayon::prelude::*;

use super::FlareError;
use super::aperture::Aperture;
use super::grid_trace::{GridOptions, check_setup, count_in, trace_one};
use super::pupil::Beam;
use super::raster::{SensorImage, SensorWindow};
use crate::lens::{PreparedLens, TracePath};

/// Most strata per side of a reference: 4096² ≈ 1.7·10⁷ rays, a few minutes
/// on a laptop; the plugin's error measure uses 512² rays per ghost.
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

/// Rows of a reference are traced in this many blocks, in parallel: enough
/// to keep 16 cores busy, and few enough that the blocks' partial images
/// (one per block, added in order so that the result is deterministic) stay
/// small next to the rays traced.
const ROW_BLOCKS: usize = 16;

/// The generator of row `row` of a reference seeded with `seed`: SplitMix64
/// (Steele, Lea and Flood, "Fast splittable pseudorandom number generators",
/// OOPSLA 2014), a small, well-mixed generator, enough for jitter. Each row
/// gets its own so that the image is the same however rayon splits the rows.
/// Seeds go through SplitMix64's output mixing twice — `base` = first output
/// for `seed`, the row's seed = first output for `base + row` — which spreads
/// neighbouring values over the whole 64-bit state, so neither the rows of
/// one reference nor those of references with neighbouring seeds share a
/// stream (a plain `seed + row` would give seed 2's row j to seed 1's row
/// j + 1).
fn row_rng(seed: u64, row: usize) -> SplitMix64 {
    let base: u64 = SplitMix64::seed_from_u64(seed).random();
    SplitMix64::seed_from_u64(SplitMix64::seed_from_u64(base.wrapping_add(row as u64)).random())
}

/// The brute-force image of `path` for `beam`: `rays_per_side²` (1 to
/// [`MAX_REFERENCE_SIDE`] per side) jittered rays, clipped by `r_rel <= 1`
/// and `aperture`, binned over `window`. `options.sensor_z` places the
/// sensor (`max_gain` is checked but unused here). The same arguments give
/// the same image bit for bit, whatever the number of threads.
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
    let k = count_in(
        "reference rays per side",
        rays_per_side,
        1,
        MAX_REFERENCE_SIDE,
    )?;
    let sensor_z = check_setup(lens, path, options)?;
    let w = beam.cross_section_mm2() / (k * k) as f64;
    let npix = window.width() * window.height();
    let inv = 1.0 / k as f64;
    // Rows go in ROW_BLOCKS contiguous blocks, each summed in row order and
    // the blocks then added in block order: the floating-point sums, and so
    // the image, do not depend on how rayon schedules the work.
    let blocks = ROW_BLOCKS.min(k);
    let per_block: Vec<(Vec<f64>, usize, f64)> = (0..blocks)
        .into_par_iter()
        .map(|b| {
            let (mut img, mut passed, mut total) = (vec![0.0; npix], 0usize, 0.0f64);
            for j in b * k / blocks..(b + 1) * k / blocks {
                let mut rng = row_rng(seed, j);
                for i in 0..k {
                    let u = (i as f64 + rng.random::<f64>()) * inv;
                    let v = (j as f64 + rng.random::<f64>()) * inv;
                    let r = trace_one(lens, path, beam, u, v, sensor_z);
                    if !r.passes(aperture) {
                        continue;
                    }
                    passed += 1;
                    total += w * r.throughput;
                    if let Some((ix, iy)) = window.pixel_of(r.sensor) {
                        img[iy * window.width() + ix] += w * r.throughput;
                    }
                }
            }
            (img, passed, total)
        })
        .collect();
    let (mut power, mut passed, mut total) = (vec![0.0; npix], 0usize, 0.0f64);
    for (img, p, t) in per_block {
        for (x, y) in power.iter_mut().zip(&img) {
            *x += y;
        }
        passed += p;
        total += t;
    }
    Ok(ReferenceImage {
        image: SensorImage::from_power(window, power),
        rays: k * k,
        passed,
        power: total,
    })
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
    if test.window() != reference.window() {
        return None;
    }
    let (mut l1, mut l2, mut r1, mut r2, mut t1) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (t, r) in test.power().iter().zip(reference.power()) {
        l1 += (t - r).abs();
        l2 += (t - r) * (t - r);
        r1 += r.abs();
        r2 += r * r;
        t1 += t;
    }
    if !(r1 > 0.0 && r2 > 0.0 && l1.is_finite() && l2.is_finite()) {
        return None;
    }
    Some(ImageError {
        rel_l1: l1 / r1,
        rel_l2: (l2 / r2).sqrt(),
        rel_energy: (t1 - r1) / r1,
    })
}

/// The same image on a coarser window: `factor × factor` pixels summed into one
/// (`factor` must divide both sides; else `None`). Comparing at a coarser
/// scale separates the grid's error from the reference's per-pixel noise.
pub fn downsample(image: &SensorImage, factor: usize) -> Option<SensorImage> {
    let w = image.window();
    let (width, height) = (w.width(), w.height());
    if factor == 0 || !width.is_multiple_of(factor) || !height.is_multiple_of(factor) {
        return None;
    }
    let win = SensorWindow::new(
        w.min(),
        w.pixel_mm() * factor as f64,
        width / factor,
        height / factor,
    )
    .ok()?;
    let mut out = SensorImage::new(win);
    for iy in 0..height {
        for ix in 0..width {
            out.power_mut()[(iy / factor) * win.width() + ix / factor] +=
                image.power()[iy * width + ix];
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
        crate::lens_flare::coat_air_interfaces(
            &builtin::tessar(),
            Coating::quarter_wave(1.38, 550.0).unwrap(),
        )
        .unwrap()
    }

    #[test]
    fn rows_draw_different_jitter_and_the_image_depends_only_on_the_seed() {
        // Neighbouring rows and seeds start far apart: no two of the first
        // draws of 64 rows × 2 seeds coincide.
        let mut firsts: Vec<u64> = (0..64)
            .flat_map(|j| [row_rng(1, j), row_rng(2, j)])
            .map(|mut r| r.random())
            .collect();
        firsts.sort_unstable();
        firsts.dedup();
        assert_eq!(firsts.len(), 128);
        // Same seed, same image (whatever rayon did); another seed, another.
        let p = coated_tessar();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let path = TracePath::ghost(5, 4);
        let beam = Beam::for_path(&p, path, light_from_field(8.0, 0.0), 550.0).unwrap();
        let (ap, o) = (Aperture::of_stop(&p), GridOptions::default());
        let w = SensorWindow::new(glam::DVec2::splat(-20.0), 2.0, 20, 20).unwrap();
        let a = reference_image(&lens, path, &beam, &ap, w, 40, 3, &o).unwrap();
        assert_eq!(
            a,
            reference_image(&lens, path, &beam, &ap, w, 40, 3, &o).unwrap()
        );
        assert_ne!(
            a.image,
            reference_image(&lens, path, &beam, &ap, w, 40, 4, &o)
                .unwrap()
                .image
        );
        for n in [0, MAX_REFERENCE_SIDE + 1] {
            let e = reference_image(&lens, path, &beam, &ap, w, n, 3, &o).unwrap_err();
            assert!(
                matches!(e, FlareError::Input(i) if i.what == "reference rays per side"),
                "{n}: {e}"
            );
        }
    }

    #[test]
    fn compare_by_hand() {
        let w = SensorWindow::new(glam::DVec2::ZERO, 1.0, 2, 1).unwrap();
        let r = SensorImage::from_power(w, vec![1.0, 3.0]);
        let t = SensorImage::from_power(w, vec![2.0, 3.0]);
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
        let window = SensorWindow::around(
            fine.rays()
                .iter()
                .filter(|r| r.alive && r.r_rel <= 1.0)
                .map(|r| r.sensor),
            0.05,
            24,
        )
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
        let ap = Aperture::polygon(3, 0.5, p.stop_semi_aperture_mm()).unwrap();
        // Power on a regular 200² grid, clipped at every crossing and at the first only.
        let (n, sensor_z) = (200, lens.table_sensor_z());
        let w = beam.cross_section_mm2() / (n * n) as f64;
        let (mut all, mut first) = (0.0, 0.0);
        for k in 0..n * n {
            let r = trace_one(
                &lens,
                path,
                &beam,
                ((k % n) as f64 + 0.5) / n as f64,
                ((k / n) as f64 + 0.5) / n as f64,
                sensor_z,
            );
            if r.alive && r.r_rel <= 1.0 && ap.contains(r.stop_xy[0]) {
                first += w * r.throughput;
                if r.passes(&ap) {
                    all += w * r.throughput;
                }
            }
        }
        assert!(
            all < 0.9 * first,
            "later crossings cut little here: {all} vs {first}"
        );
        let g = trace_grid(&lens, path, &beam, 65, &opts).unwrap();
        let window = SensorWindow::around(
            g.rays()
                .iter()
                .filter(|r| r.alive && r.r_rel <= 1.0)
                .map(|r| r.sensor),
            0.05,
            24,
        )
        .unwrap();
        let reference = reference_image(&lens, path, &beam, &ap, window, 300, 9, &opts).unwrap();
        assert!(
            (reference.power / all - 1.0).abs() < 0.02,
            "reference {} vs every-crossing {all} (first only {first})",
            reference.power
        );
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
        let p = crate::lens_flare::coat_air_interfaces(
            &builtin::heliar(),
            Coating::quarter_wave(1.38, 550.0).unwrap(),
        )
        .unwrap();
        assert!(p.surfaces()[6].is_flat() && !p.surfaces()[6].is_stop);
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let path = TracePath::ghost(8, 6);
        let beam = Beam::for_path(&p, path, light_from_field(5.0, 0.0), 550.0).unwrap();
        let opts = GridOptions::default();
        let stop_r = p.stop_semi_aperture_mm();
        let ap = Aperture::polygon(6, 0.3, stop_r).unwrap();
        let g = trace_grid(&lens, path, &beam, 33, &opts).unwrap();
        let window = SensorWindow::around(
            g.rays()
                .iter()
                .filter(|r| r.alive && r.r_rel <= 1.0)
                .map(|r| r.sensor),
            0.05,
            24,
        )
        .unwrap();
        let reference = reference_image(&lens, path, &beam, &ap, window, 300, 5, &opts).unwrap();
        let img = rasterise(&g, &ap, window);
        assert!(img.power().iter().all(|p| p.is_finite() && *p >= 0.0));
        let e = compare(&img, &reference.image).unwrap();
        assert!(e.rel_l1 < 0.2 && e.rel_energy.abs() < 0.03, "{e:?}");
        // The bladed stop passes less than the round one it is inscribed in.
        let round = rasterise(&g, &Aperture::circle(stop_r).unwrap(), window);
        assert!(
            img.total() < round.total(),
            "{} vs {} ref {}",
            img.total(),
            round.total(),
            reference.image.total()
        );
    }
}
