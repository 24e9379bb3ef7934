//! Eq. 9 and 10: what a ray's level buys — its reflection depth and the
//! polygon count of every object it is tested against.

/// Tolerance for products such as (2/3)·3 that are integers mathematically but
/// round to 1.9999999999999998; without it a quantised level would lose a
/// whole reflection (or a whole hysteresis step) to rounding. Rounding leaves
/// such products a few 1e-16 short; 1e-9 is far above that and far below the
/// smallest level step anyone quantises to.
pub(crate) const ROUND_SLACK: f64 = 1e-9;

/// Clamps a level to [0, 1]; NaN becomes 1 (documented fallback: full quality).
#[inline]
pub(crate) fn sanitize_level(level: f64) -> f64 {
    if level.is_nan() {
        1.0
    } else {
        level.clamp(0.0, 1.0)
    }
}

/// Eq. 9: the largest number of reflections a ray of this level may make,
/// ⌊level × Reflect_max⌋.
///
/// The paper's eq. 9 is Reflect_i = level_i × Reflect_max, and Step 6 of its
/// §3.3.3 stops tracing when the count *exceeds* Reflect_i, so an integer
/// count n is allowed iff n ≤ Reflect_i, i.e. n ≤ ⌊Reflect_i⌋. A level
/// outside [0, 1] is clamped; NaN counts as 1 (full quality).
#[inline]
pub fn reflect_limit(level: f64, reflect_max: u32) -> u32 {
    let r = sanitize_level(level) * reflect_max as f64;
    ((r + ROUND_SLACK).floor() as u32).min(reflect_max)
}

/// Eq. 10: the polygon count N_j = level (N_max − N_min) + N_min of an
/// object for a ray of this level (a real number; the paper's progressive
/// meshes realise it to the nearest polygon). `n_min > n_max` is treated as
/// the two swapped; the level is clamped as in [`reflect_limit`].
#[inline]
pub fn polygon_budget(level: f64, n_min: usize, n_max: usize) -> f64 {
    let (lo, hi) = if n_min <= n_max {
        (n_min, n_max)
    } else {
        (n_max, n_min)
    };
    sanitize_level(level) * (hi - lo) as f64 + lo as f64
}

/// The index, in a chain of meshes sorted by ascending triangle count, of the
/// coarsest mesh with at least `budget` triangles; the finest if none has.
/// An empty chain returns 0.
///
/// The paper uses progressive meshes (any count); with a discrete chain this
/// takes the coarsest mesh that meets eq. 10, so a ray never gets fewer
/// polygons than eq. 10 asks.
pub fn choose_lod(triangle_counts: &[usize], budget: f64) -> usize {
    let need = budget - ROUND_SLACK;
    triangle_counts
        .iter()
        .position(|&n| n as f64 >= need)
        .unwrap_or(triangle_counts.len().saturating_sub(1))
}

/// Eq. 10 then [`choose_lod`] for a chain sorted by ascending triangle count:
/// N_min is the first count, N_max the last, and the result the index of the
/// mesh an object uses for a ray (or an object) of this level. An empty chain
/// returns 0.
pub fn lod_for_level(triangle_counts: &[usize], level: f64) -> usize {
    match (triangle_counts.first(), triangle_counts.last()) {
        (Some(&lo), Some(&hi)) => choose_lod(triangle_counts, polygon_budget(level, lo, hi)),
        _ => 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn eq9_with_the_papers_reflect_max() {
        // §4.2: Reflect_max = 3. Levels 1, 2/3, 1/3 give 3, 2, 1 reflections;
        // anything below a whole reflection is floored (Step 6: stop when the
        // count exceeds Reflect_i).
        assert_eq!(reflect_limit(1.0, 3), 3);
        assert_eq!(reflect_limit(2.0 / 3.0, 3), 2);
        assert_eq!(reflect_limit(1.0 / 3.0, 3), 1);
        assert_eq!(reflect_limit(0.66, 3), 1);
        assert_eq!(reflect_limit(0.0, 3), 0);
        assert_eq!(reflect_limit(f64::NAN, 3), 3);
        assert_eq!(reflect_limit(7.0, 3), 3);
        for k in 0..=10u32 {
            assert_eq!(reflect_limit(k as f64 / 10.0, 10), k);
        }
    }

    #[test]
    fn eq10_with_the_papers_counts() {
        // §4.2: N_max = 5804 (the cow), N_min = 500.
        assert_eq!(polygon_budget(1.0, 500, 5804), 5804.0);
        assert_eq!(polygon_budget(0.0, 500, 5804), 500.0);
        assert_eq!(polygon_budget(0.5, 500, 5804), 3152.0);
        assert_eq!(polygon_budget(0.5, 5804, 500), 3152.0);
    }

    #[test]
    fn lod_choice_never_undercuts_the_budget() {
        let chain = [528, 1224, 2600, 5624];
        assert_eq!(choose_lod(&chain, 528.0), 0);
        assert_eq!(choose_lod(&chain, 529.0), 1);
        assert_eq!(choose_lod(&chain, 2600.0), 2);
        assert_eq!(choose_lod(&chain, 5624.0), 3);
        assert_eq!(choose_lod(&chain, 9999.0), 3);
        assert_eq!(choose_lod(&[], 10.0), 0);
    }

    #[test]
    fn lod_for_level_is_eq10_over_the_chain() {
        // N_min = 528, N_max = 5624: level 0.5 → 3076 → 5624 (index 3);
        // 0.2 → 1547.2 → 2600; 0.1 → 1037.6 → 1224; 0 → 528.
        let chain = [528, 1224, 2600, 5624];
        let got: Vec<usize> = [1.0, 0.5, 0.2, 0.1, 0.0]
            .iter()
            .map(|&l| lod_for_level(&chain, l))
            .collect();
        assert_eq!(got, vec![3, 3, 2, 1, 0]);
        assert_eq!(lod_for_level(&chain, f64::NAN), 3, "NaN is full quality");
        assert_eq!(lod_for_level(&[], 0.5), 0);
        assert_eq!(lod_for_level(&[7], 0.0), 0);
    }

    proptest! {
        #[test]
        fn budgets_are_monotone_in_level(a in 0.0f64..1.0, b in 0.0f64..1.0, rmax in 0u32..10) {
            let (lo, hi) = if a < b { (a, b) } else { (b, a) };
            prop_assert!(reflect_limit(lo, rmax) <= reflect_limit(hi, rmax));
            prop_assert!(polygon_budget(lo, 500, 5804) <= polygon_budget(hi, 500, 5804));
            let chain = [100, 400, 1600];
            let (i, j) = (choose_lod(&chain, polygon_budget(lo, 100, 1600)),
                          choose_lod(&chain, polygon_budget(hi, 100, 1600)));
            prop_assert!(i <= j);
            prop_assert!(chain[j] as f64 >= polygon_budget(hi, 100, 1600) - 1e-6);
        }
    }
}
