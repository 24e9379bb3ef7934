//! The blog's *Adaptive resolution*: a grid size per ghost from how much
//! the ghost deforms. A ghost whose rays land on the sensor as an affine
//! image of the pupil is drawn exactly by any grid; one that bends and
//! folds needs more rays for the same error.
//!
//! The measure: trace a grid of odd size `2m + 1` and predict every ray at
//! an odd index from its even-indexed neighbours (the grid of `m + 1`
//! rays, interpolated bilinearly, as the draw pass does); the RMS miss on
//! the sensor is the interpolation error at that spacing. Linear
//! interpolation errs as the square of the spacing, so a ghost drawn with
//! `N` rays per side errs by about `e · (m / N)²`: equal error over the
//! ghosts asks `N_g ∝ √e_g`.

use super::RayGrid;

/// The RMS distance, mm, between the rays of `grid` at odd indices and
/// their prediction from the even-indexed rays (mid-edge: the mean of two,
/// mid-cell: of four), over the rays whose neighbours are alive and inside
/// every aperture (`r_rel ≤ 1`); `None` for a grid of even size or with no
/// such ray.
pub fn interpolation_error_mm(grid: &RayGrid) -> Option<f64> {
    let n = grid.n();
    if n < 3 || n.is_multiple_of(2) {
        return None;
    }
    let seen = |i: usize, j: usize| {
        grid.ray(i, j)
            .filter(|r| r.alive && r.r_rel <= 1.0)
            .map(|r| r.sensor)
    };
    let (mut sum, mut count) = (0.0, 0usize);
    for j in 0..n {
        for i in 0..n {
            let neighbours: &[(usize, usize)] = match (i % 2, j % 2) {
                (0, 0) => continue,
                (1, 0) => &[(i - 1, j), (i + 1, j)],
                (0, 1) => &[(i, j - 1), (i, j + 1)],
                _ => &[
                    (i - 1, j - 1),
                    (i + 1, j - 1),
                    (i - 1, j + 1),
                    (i + 1, j + 1),
                ],
            };
            let Some(actual) = seen(i, j) else { continue };
            let points: Option<Vec<_>> = neighbours.iter().map(|&(a, b)| seen(a, b)).collect();
            let Some(points) = points else { continue };
            let predicted = points.iter().sum::<glam::DVec2>() / points.len() as f64;
            let miss = (actual - predicted).length_squared();
            if miss.is_finite() {
                sum += miss;
                count += 1;
            }
        }
    }
    (count > 0).then(|| (sum / count as f64).sqrt())
}

/// Grid sizes, rays per side, for ghosts whose interpolation errors are
/// `errors` (any unit; `None` or not finite: the median's): `N_g ∝ √e_g`,
/// scaled so that the ghosts trace as many rays in all as `base²` each
/// would, then rounded to `base · 2^k` (so that ghosts of a size draw
/// together) within `[min, max]`.
pub fn grid_sizes(errors: &[Option<f64>], base: u32, min: u32, max: u32) -> Vec<u32> {
    let known: Vec<f64> = errors
        .iter()
        .flatten()
        .copied()
        .filter(|e| e.is_finite() && *e >= 0.0)
        .collect();
    let median = if known.is_empty() {
        1.0
    } else {
        let mut sorted = known.clone();
        sorted.sort_by(f64::total_cmp);
        sorted[sorted.len() / 2]
    };
    let errors: Vec<f64> = errors
        .iter()
        .map(|e| e.filter(|e| e.is_finite() && *e >= 0.0).unwrap_or(median))
        .collect();
    let total: f64 = errors.iter().sum();
    let (min, max) = (min.max(2), max.max(min.max(2)));
    errors
        .iter()
        .map(|&e| {
            let ideal = if total > 0.0 {
                f64::from(base) * (errors.len() as f64 * e / total).sqrt()
            } else {
                f64::from(base)
            };
            // Nearest base · 2^k in log scale.
            let k = (ideal.max(1e-9) / f64::from(base))
                .log2()
                .round()
                .clamp(-8.0, 8.0);
            let n = (f64::from(base) * 2f64.powf(k)).round() as u32;
            n.clamp(min, max)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::builtin;
    use crate::lens_flare::{
        Aperture, Beam, EstimateOptions, GridOptions, PreparedLens, estimate_ghosts,
        light_from_field, trace_grid,
    };

    #[test]
    fn interpolation_error_falls_as_the_square_of_the_spacing() {
        let lens = builtin::double_gauss();
        let light = light_from_field(10.0, 0.0);
        let aperture = Aperture::circle(lens.stop_semi_aperture_mm()).unwrap();
        let ranked =
            estimate_ghosts(&lens, light, 550.0, &aperture, &EstimateOptions::default()).unwrap();
        let prepared = PreparedLens::new(&lens, 550.0).unwrap();
        let mut errors = Vec::new();
        for g in ranked.iter().take(12) {
            let beam = Beam::for_path(&lens, g.path, light, 550.0).unwrap();
            let at = |n| {
                let grid =
                    trace_grid(&prepared, g.path, &beam, n, &GridOptions::default()).unwrap();
                interpolation_error_mm(&grid)
            };
            if let (Some(coarse), Some(fine)) = (at(17), at(33)) {
                errors.push(coarse);
                // Halving the spacing: about a quarter of the error.
                let ratio = fine / coarse;
                assert!(
                    coarse < 1e-9 || (0.1..0.5).contains(&ratio),
                    "{:?}: {coarse} → {fine}",
                    g.path
                );
            }
        }
        assert!(errors.len() >= 8);
        // Ghosts differ: the most deformed errs far more than the least.
        let (lo, hi) = errors
            .iter()
            .fold((f64::INFINITY, 0f64), |(lo, hi), &e| (lo.min(e), hi.max(e)));
        assert!(hi > 10.0 * lo, "{lo} … {hi}");
        assert_eq!(
            interpolation_error_mm(&{
                let beam = Beam::for_path(&lens, ranked[0].path, light, 550.0).unwrap();
                trace_grid(
                    &prepared,
                    ranked[0].path,
                    &beam,
                    16,
                    &GridOptions::default(),
                )
                .unwrap()
            }),
            None,
            "an even grid has no midpoints"
        );
    }

    #[test]
    fn sizes_follow_the_square_root_of_the_error_within_the_budget() {
        let sizes = grid_sizes(
            &[Some(1.0), Some(4.0), Some(16.0), None, Some(f64::NAN)],
            32,
            16,
            512,
        );
        // Median of the known errors is 4: the last two count as 4.
        assert_eq!(sizes[1], sizes[3]);
        assert_eq!(sizes[3], sizes[4]);
        assert!(sizes[0] < sizes[1] && sizes[1] < sizes[2], "{sizes:?}");
        for s in &sizes {
            assert!(
                (16..=512).contains(s) && (s / 16).is_power_of_two(),
                "{sizes:?}"
            );
        }
        // The budget: about as many rays as 32² each.
        let rays: u32 = sizes.iter().map(|s| s * s).sum();
        let want = 5 * 32 * 32;
        assert!(rays > want / 2 && rays < want * 2, "{rays} vs {want}");
        // All equal: all base; all zero: all base.
        assert_eq!(grid_sizes(&[Some(2.0); 3], 24, 4, 512), vec![24; 3]);
        assert_eq!(grid_sizes(&[Some(0.0); 3], 24, 4, 512), vec![24; 3]);
        assert!(grid_sizes(&[], 24, 4, 512).is_empty());
        // A huge spread is held to the bounds.
        let wide = grid_sizes(&[Some(1e-12), Some(1e6)], 32, 16, 128);
        assert_eq!(wide, vec![16, 64]);
    }
}
