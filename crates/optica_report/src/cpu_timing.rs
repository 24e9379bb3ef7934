//! Timing CPU work: one function alone ([`time_ms`]), or a function
//! against its baseline in alternating blocks ([`time_paired_ms`]), the CPU
//! counterpart of `Headless::time_paired`, so that a CPU row's ratio comes
//! with an interval that the machine's other work cannot fake.

use std::time::Instant;

use optica_harness::{RatioInterval, Stats};

/// Runs `f` repeatedly and returns the median wall time of one call in
/// milliseconds, with the last result. Runs at least `min_runs` times and
/// keeps going until about `budget_ms` has passed (at most 101 runs), so
/// that fast calls are timed over many runs and slow ones only a few.
pub fn time_ms<R>(min_runs: usize, budget_ms: f64, mut f: impl FnMut() -> R) -> (f64, R) {
    let min = min_runs.max(1);
    let (mut times, last) = calls(min, min.max(101), budget_ms, &mut f);
    times.sort_by(|a, b| a.total_cmp(b));
    (times[times.len() / 2], last)
}

/// Calls `f` at least `min` times and on until about `budget_ms` have
/// passed or `max` calls are made: each call's wall time (ms) and the last
/// result.
fn calls<T>(min: usize, max: usize, budget_ms: f64, f: &mut impl FnMut() -> T) -> (Vec<f64>, T) {
    let start = Instant::now();
    let mut times = Vec::new();
    loop {
        let t = Instant::now();
        let out = std::hint::black_box(f());
        times.push(t.elapsed().as_secs_f64() * 1e3);
        let spent = start.elapsed().as_secs_f64() * 1e3;
        if times.len() >= min && (spent >= budget_ms || times.len() >= max) {
            return (times, out);
        }
    }
}

/// A function and its baseline timed in alternating blocks
/// ([`time_paired_ms`]).
#[derive(Clone, Copy, Debug)]
pub struct PairedCpu {
    /// The median wall time of one call of the function, ms, over all blocks.
    pub effect_ms: f64,
    /// The same for the baseline.
    pub baseline_ms: f64,
    /// The median of the blocks' ratios (the function's median call in the
    /// block over the baseline's) and its 95 % bootstrap interval; `None`
    /// when no block gave a finite, positive ratio.
    pub ratio: Option<RatioInterval>,
    /// How long the measurement took, s.
    pub elapsed_s: f64,
}

/// Times `effect` against `baseline` in `blocks` alternating blocks (effect
/// first in even blocks, baseline first in odd ones), as
/// `Headless::time_paired` times frames: a load that comes and goes then
/// slows both sides of a block alike instead of one side of the ratio.
/// Each side runs at least `min_runs` calls in all and keeps going until
/// about `budget_ms` of its own calls have passed (at most 101 calls, or
/// `min_runs` where that is more), both spread evenly over the blocks, and
/// at least one call a block. Returns the times and the effect's last
/// result.
pub fn time_paired_ms<R, B>(
    blocks: u32,
    min_runs: usize,
    budget_ms: f64,
    mut effect: impl FnMut() -> R,
    mut baseline: impl FnMut() -> B,
) -> (PairedCpu, R) {
    let started = Instant::now();
    let blocks = blocks.max(1) as usize;
    let min_per_block = min_runs.div_ceil(blocks).max(1);
    let max_per_block = (101 / blocks).max(min_per_block);
    let budget_per_block = budget_ms / blocks as f64;
    let median = |t: &[f64]| Stats::of(t).map_or(f64::NAN, |s| s.median);
    let (mut all_effect, mut all_baseline, mut ratios) = (Vec::new(), Vec::new(), Vec::new());
    let mut last = None;
    let (min, max, budget) = (min_per_block, max_per_block, budget_per_block);
    for b in 0..blocks {
        let ((effect_times, out), base) = if b % 2 == 0 {
            let e = calls(min, max, budget, &mut effect);
            (e, calls(min, max, budget, &mut baseline).0)
        } else {
            let base = calls(min, max, budget, &mut baseline).0;
            (calls(min, max, budget, &mut effect), base)
        };
        last = Some(out);
        ratios.push(median(&effect_times) / median(&base));
        all_effect.extend(effect_times);
        all_baseline.extend(base);
    }
    let timed = PairedCpu {
        effect_ms: median(&all_effect),
        baseline_ms: median(&all_baseline),
        ratio: RatioInterval::bootstrap(&ratios),
        elapsed_s: started.elapsed().as_secs_f64(),
    };
    (timed, last.expect("at least one block runs the effect"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ratio comes from the blocks: a function that does twice its
    /// baseline's work measures about 2 with an interval around it, and
    /// each side ran in every block.
    #[test]
    fn a_function_twice_its_baseline_measures_about_two() {
        let work = |n: u64| (0..n).fold(0u64, |a, i| a.wrapping_mul(31).wrapping_add(i));
        let (mut calls_e, mut calls_b) = (0, 0);
        let (timed, out) = time_paired_ms(
            6,
            12,
            60.0,
            || {
                calls_e += 1;
                work(std::hint::black_box(400_000))
            },
            || {
                calls_b += 1;
                work(std::hint::black_box(200_000))
            },
        );
        assert_eq!(out, work(400_000));
        assert!(calls_e >= 12 && calls_b >= 12, "{calls_e} {calls_b}");
        let r = timed.ratio.expect("finite ratios");
        assert_eq!(r.blocks, 6);
        assert!(r.low <= r.median && r.median <= r.high, "{r:?}");
        assert!((1.3..3.0).contains(&r.median), "{r:?}");
        assert!(timed.effect_ms > timed.baseline_ms, "{timed:?}");
    }
}
