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
//! `N` rays per side errs by about `e · (m / N)²`.
//!
//! What the image's error follows, though, is the power a ghost carries:
//! sizing grids by deformation gave the double Gauss's smooth bright
//! ghosts too few rays. [`grid_sizes_by_power`] sizes them by power.

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

/// Grid sizes, rays per side, that spend the rays of `base²` per ghost
/// where they lower the flare's error most, for ghosts carrying `powers`
/// (any unit; not finite or negative counts as 0).
///
/// A ghost drawn with `N` rays per side errs by about `P · c / N` in the
/// image (its power misplaced along its edges and folds, a band one cell
/// wide), so the sum `Σ P_g / N_g` under the budget `Σ N_g² = G · base²`
/// is least for `N_g ∝ P_g^(1/3)`. Sizes are whole numbers within
/// `[min, max]` (`min` at least 2), scaled to spend at most the budget
/// (all `min` when even that is over it).
///
/// Measured on the double Gauss at 512² (83 ghosts, 10° off axis, one of
/// which carries half the flare's power and 84 % of a fixed grid's error):
/// at the rays of 16² each, the summed error of the ghosts falls from 0.48
/// of the flare's power (every ghost at 16²) to 0.15; every ghost at 32²
/// errs by 0.20.
pub fn grid_sizes_by_power(powers: &[f64], base: u32, min: u32, max: u32) -> Vec<u32> {
    let (min, max) = (min.max(2), max.max(min.max(2)));
    let weights: Vec<f64> = powers
        .iter()
        .map(|p| {
            if p.is_finite() && *p > 0.0 {
                p.cbrt()
            } else {
                0.0
            }
        })
        .collect();
    let budget = powers.len() as f64 * f64::from(base) * f64::from(base);
    let sizes = |scale: f64| -> Vec<u32> {
        weights
            .iter()
            .map(|w| (scale * w).round().clamp(f64::from(min), f64::from(max)) as u32)
            .collect()
    };
    let spent = |sizes: &[u32]| {
        sizes
            .iter()
            .map(|&n| f64::from(n) * f64::from(n))
            .sum::<f64>()
    };
    // The largest scale within the budget, by bisection
    // (the spend only grows with the scale).
    let top = weights.iter().copied().fold(0.0, f64::max);
    if top <= 0.0 {
        return vec![base.clamp(min, max); powers.len()];
    }
    let (mut lo, mut hi) = (0.0, f64::from(max) / top);
    if spent(&sizes(hi)) <= budget {
        return sizes(hi);
    }
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if spent(&sizes(mid)) <= budget {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    sizes(lo)
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
    fn sizes_follow_the_cube_root_of_the_power_within_the_budget() {
        let sizes = grid_sizes_by_power(&[1.0, 8.0, 64.0, f64::NAN, -1.0], 32, 8, 512);
        // Twice the size for 8× the power; no power: the least.
        assert_eq!(sizes[3], 8);
        assert_eq!(sizes[4], 8);
        for pair in [(sizes[0], sizes[1]), (sizes[1], sizes[2])] {
            let ratio = f64::from(pair.1) / f64::from(pair.0);
            assert!((ratio - 2.0).abs() < 0.1, "{sizes:?}");
        }
        // The budget: at most the rays of 32² each, and nearly all of it.
        let rays: u32 = sizes.iter().map(|s| s * s).sum();
        let want = 5 * 32 * 32;
        assert!(rays <= want && rays > want * 9 / 10, "{rays} vs {want}");
        // All equal: all base; all zero: all base; none: none.
        assert_eq!(grid_sizes_by_power(&[2.0; 3], 24, 4, 512), vec![24; 3]);
        assert_eq!(grid_sizes_by_power(&[0.0; 3], 24, 4, 512), vec![24; 3]);
        assert!(grid_sizes_by_power(&[], 24, 4, 512).is_empty());
        // A huge spread is held to the bounds.
        let wide = grid_sizes_by_power(&[1e-12, 1e6], 32, 16, 40);
        assert_eq!(wide, vec![16, 40]);
        // A budget below the least size: all the least.
        assert_eq!(grid_sizes_by_power(&[1.0, 2.0], 4, 8, 512), vec![8, 8]);
    }
}
