//! GPU and frame timing of headless runs, from Bevy's render diagnostics.

use std::collections::BTreeMap;

use bevy::diagnostic::DiagnosticsStore;
use bevy::prelude::World;
use serde::{Deserialize, Serialize};

use crate::AdapterInfo;

/// How many untimed frames [`Headless::time_frames`](crate::Headless::time_frames)
/// runs after the timed ones for late diagnostics: timestamp results are
/// mapped asynchronously and reach the `DiagnosticsStore` one to three frames
/// after their frame; eight leaves room for a slow driver.
pub const MAX_DIAGNOSTIC_LAG_FRAMES: u32 = 8;

/// Median and spread of a set of times in milliseconds.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Number of samples.
    pub n: usize,
    /// Median.
    pub median: f64,
    /// 25th percentile.
    pub p25: f64,
    /// 75th percentile.
    pub p75: f64,
    /// Smallest sample.
    pub min: f64,
    /// Largest sample.
    pub max: f64,
    /// Arithmetic mean.
    pub mean: f64,
}

impl Stats {
    /// Statistics of `samples` (non-finite ones are dropped); `None` when
    /// nothing finite is left.
    ///
    /// ```
    /// use optica_harness::Stats;
    /// let s = Stats::of(&[4.0, 1.0, 3.0, 2.0, 100.0]).unwrap();
    /// assert_eq!((s.n, s.median, s.min, s.max), (5, 3.0, 1.0, 100.0));
    /// assert_eq!((s.p25, s.p75), (2.0, 4.0));
    /// ```
    pub fn of(samples: &[f64]) -> Option<Self> {
        let mut v: Vec<f64> = samples.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return None;
        }
        v.sort_by(f64::total_cmp);
        // Linear interpolation between order statistics (the "R-7" rule of
        // Hyndman & Fan 1996, NumPy's default).
        let q = |p: f64| {
            let h = p * (v.len() - 1) as f64;
            let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
            v[lo] + (h - lo as f64) * (v[hi] - v[lo])
        };
        Some(Self {
            n: v.len(),
            median: q(0.5),
            p25: q(0.25),
            p75: q(0.75),
            min: v[0],
            max: v[v.len() - 1],
            mean: v.iter().sum::<f64>() / v.len() as f64,
        })
    }

    /// The interquartile range `p75 − p25`: the spread the reports quote.
    pub fn iqr(&self) -> f64 {
        self.p75 - self.p25
    }
}

/// The times of one render span (a pass, or a group of passes).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpanTiming {
    /// The span's path as the pass named it, e.g. `main_opaque_pass_3d` or
    /// `optica/lens_flare` (Bevy prefixes `render/` in its diagnostics; not here).
    pub name: String,
    /// GPU time from timestamp queries; `None` where the adapter has none.
    pub gpu_ms: Option<Stats>,
    /// CPU time spent encoding the span.
    pub cpu_ms: Option<Stats>,
    /// The work the device counted in the span, per frame, by Bevy's name
    /// (`vertex_shader_invocations`, `fragment_shader_invocations`,
    /// `compute_shader_invocations`, `clipper_invocations`,
    /// `clipper_primitives_out`): from pipeline-statistics queries, where
    /// the adapter has them and the pass records its span with
    /// `pass_span` (a `time_span` counts nothing). lavapipe has them, and
    /// counts fragments in whole 4×4 blocks per triangle: a measure of its
    /// rasteriser's work, not of covered pixels.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub counts: BTreeMap<String, Stats>,
}

/// Where a [`PassTime`] comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum TimeSource {
    /// GPU timestamp queries around the pass.
    GpuTimestamps,
    /// The adapter has no timestamp queries: the whole frame's wall time.
    FrameWallTime,
}

/// The time of one pass, and how it was measured.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PassTime {
    /// The time in milliseconds.
    pub ms: Stats,
    /// How it was measured.
    pub source: TimeSource,
}

/// The timings of a [`Headless::time_frames`](crate::Headless::time_frames) run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameTimings {
    /// The adapter that ran the frames.
    pub adapter: AdapterInfo,
    /// Wall time of each whole frame: the app's update plus the wait for the
    /// GPU to finish it (pipelined rendering is off in the harness).
    pub frame_ms: Stats,
    /// Every span the passes recorded, by name.
    pub spans: Vec<SpanTiming>,
}

impl FrameTimings {
    pub(crate) fn new(adapter: AdapterInfo, frame_ms: Vec<f64>, spans: Vec<SpanTiming>) -> Self {
        // `time_frames` refuses zero frames, so there is at least one sample;
        // a frame time is never NaN.
        let frame_ms = Stats::of(&frame_ms).unwrap_or(Stats {
            n: 0,
            median: 0.0,
            p25: 0.0,
            p75: 0.0,
            min: 0.0,
            max: 0.0,
            mean: 0.0,
        });
        Self {
            adapter,
            frame_ms,
            spans,
        }
    }

    /// Whether any span has GPU times, i.e. the adapter has timestamp queries.
    pub fn has_gpu_timestamps(&self) -> bool {
        self.spans.iter().any(|s| s.gpu_ms.is_some())
    }

    /// The span called `name`, if a pass recorded it.
    pub fn span(&self, name: &str) -> Option<&SpanTiming> {
        self.spans.iter().find(|s| s.name == name)
    }

    /// The time of the pass that records span `name`: its GPU time where
    /// the adapter has timestamp queries, else the whole frame's wall time.
    /// `None` when no pass recorded the span at all (the pass did not run).
    pub fn pass(&self, name: &str) -> Option<PassTime> {
        let span = self.span(name)?;
        Some(match (span.gpu_ms, self.has_gpu_timestamps()) {
            (Some(ms), _) => PassTime {
                ms,
                source: TimeSource::GpuTimestamps,
            },
            _ => PassTime {
                ms: self.frame_ms,
                source: TimeSource::FrameWallTime,
            },
        })
    }
}

const PREFIX: &str = "render/";
const GPU_SUFFIX: &str = "/elapsed_gpu";
const CPU_SUFFIX: &str = "/elapsed_cpu";
/// The pipeline statistics Bevy records per `pass_span`.
const COUNTS: [&str; 5] = [
    "vertex_shader_invocations",
    "clipper_invocations",
    "clipper_primitives_out",
    "fragment_shader_invocations",
    "compute_shader_invocations",
];

/// What a render diagnostic path measures.
enum Measure<'a> {
    Gpu,
    Cpu,
    Count(&'a str),
}

/// A render diagnostic's span name (without `render/`) and what it
/// measures; `None` for any other diagnostic.
fn parse_path(path: &str) -> Option<(&str, Measure<'_>)> {
    let rest = path.strip_prefix(PREFIX)?;
    if let Some(name) = rest.strip_suffix(GPU_SUFFIX) {
        return Some((name, Measure::Gpu));
    }
    if let Some(name) = rest.strip_suffix(CPU_SUFFIX) {
        return Some((name, Measure::Cpu));
    }
    COUNTS.iter().find_map(|count| {
        let name = rest.strip_suffix(count)?.strip_suffix('/')?;
        Some((name, Measure::Count(count)))
    })
}

/// Gathers each render span's newest measurement after every frame.
#[derive(Default)]
pub(crate) struct SpanCollector {
    /// Per diagnostic path: the time of the last measurement taken, and the values.
    seen: BTreeMap<String, (Option<std::time::Instant>, Vec<f64>)>,
}

impl SpanCollector {
    /// Each render span's newest frame: its time, and the sum of what it
    /// measured in that frame. A pass that runs once per view (three CAVE
    /// walls, six cube faces) records its span once per view, and Bevy
    /// stores those measurements under one path with one time; the span's
    /// cost in the frame is their sum, not the last view's.
    fn render_paths(world: &World) -> impl Iterator<Item = (String, std::time::Instant, f64)> + '_ {
        let store = world.get_resource::<DiagnosticsStore>();
        store.into_iter().flat_map(|s| s.iter()).filter_map(|d| {
            let path = d.path().as_str();
            parse_path(path)?;
            let newest = d.measurement()?.time;
            let sum = d
                .measurements()
                .filter(|m| m.time == newest)
                .map(|m| m.value)
                .sum();
            Some((path.to_string(), newest, sum))
        })
    }

    /// Marks what the store holds now as already seen.
    pub(crate) fn skip_seen(&mut self, world: &World) {
        for (path, time, _) in Self::render_paths(world) {
            self.seen.insert(path, (Some(time), Vec::new()));
        }
    }

    /// Takes every measurement newer than the last one taken.
    pub(crate) fn collect(&mut self, world: &World) {
        for (path, time, value) in Self::render_paths(world) {
            let entry = self.seen.entry(path).or_default();
            if entry.0 != Some(time) {
                entry.0 = Some(time);
                entry.1.push(value);
            }
        }
    }

    /// Whether every span has at least `frames` measurements.
    pub(crate) fn complete(&self, frames: usize) -> bool {
        !self.seen.is_empty() && self.seen.values().all(|(_, v)| v.len() >= frames)
    }

    /// The spans, each from its first `frames` measurements.
    pub(crate) fn finish(self, frames: usize) -> Vec<SpanTiming> {
        let mut spans: BTreeMap<String, SpanTiming> = BTreeMap::new();
        for (path, (_, values)) in self.seen {
            let values = &values[..values.len().min(frames)];
            let Some((name, measure)) = parse_path(&path) else {
                continue;
            };
            let span = spans.entry(name.to_string()).or_insert(SpanTiming {
                name: name.to_string(),
                gpu_ms: None,
                cpu_ms: None,
                counts: BTreeMap::new(),
            });
            let stats = Stats::of(values);
            match measure {
                Measure::Gpu => span.gpu_ms = stats,
                Measure::Cpu => span.cpu_ms = stats,
                Measure::Count(count) => {
                    if let Some(stats) = stats {
                        span.counts.insert(count.to_string(), stats);
                    }
                }
            }
        }
        spans.into_values().collect()
    }
}

/// A ratio of two frame times with its confidence interval, from blocks of
/// frames timed alternately (see [`Headless::time_paired`](crate::Headless::time_paired)).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RatioInterval {
    /// The median over blocks of each block's ratio (the effect's median
    /// frame time in the block over its baseline's in the adjacent block).
    pub median: f64,
    /// The interval's lower bound.
    pub low: f64,
    /// The interval's upper bound: the figure a "no more than" goal is
    /// judged by.
    pub high: f64,
    /// The interval's confidence (0.95).
    pub confidence: f64,
    /// How many block ratios it comes from.
    pub blocks: usize,
}

/// Bootstrap resamples behind a [`RatioInterval`].
pub const BOOTSTRAP_RESAMPLES: usize = 2000;

impl RatioInterval {
    /// The median of `ratios` and its 95 % percentile-bootstrap interval
    /// ([`BOOTSTRAP_RESAMPLES`] resamples with replacement, a fixed seed, so
    /// the same ratios give the same interval). `None` without a finite,
    /// positive ratio.
    ///
    /// ```
    /// use optica_harness::RatioInterval;
    /// let r = RatioInterval::bootstrap(&[1.9, 2.0, 2.1, 2.0, 1.95, 2.05]).unwrap();
    /// assert!((r.median - 2.0).abs() < 1e-12);
    /// assert!(r.low <= r.median && r.median <= r.high);
    /// assert!(r.low >= 1.9 && r.high <= 2.1);
    /// // One block: no spread to go by, the interval is the point.
    /// let one = RatioInterval::bootstrap(&[1.5]).unwrap();
    /// assert_eq!((one.low, one.high), (1.5, 1.5));
    /// ```
    pub fn bootstrap(ratios: &[f64]) -> Option<Self> {
        use rand::{RngExt, SeedableRng};
        let ratios: Vec<f64> = ratios
            .iter()
            .copied()
            .filter(|r| r.is_finite() && *r > 0.0)
            .collect();
        let median = Stats::of(&ratios)?.median;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(0x0971_CA);
        let n = ratios.len();
        let mut medians: Vec<f64> = (0..BOOTSTRAP_RESAMPLES)
            .map(|_| {
                let resample: Vec<f64> = (0..n).map(|_| ratios[rng.random_range(0..n)]).collect();
                Stats::of(&resample).map_or(median, |s| s.median)
            })
            .collect();
        medians.sort_by(f64::total_cmp);
        let at = |q: f64| medians[((BOOTSTRAP_RESAMPLES - 1) as f64 * q).round() as usize];
        Some(Self {
            median,
            low: at(0.025).min(median),
            high: at(0.975).max(median),
            confidence: 0.95,
            blocks: n,
        })
    }
}

/// An effect timed against its baseline by [`Headless::time_paired`](crate::Headless::time_paired).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PairedTimings {
    /// Every timed frame of the effect's app, over all blocks.
    pub effect: FrameTimings,
    /// Every timed frame of the baseline's app, over all blocks.
    pub baseline: FrameTimings,
    /// Effect over baseline, by block, with its interval.
    pub ratio: RatioInterval,
    /// Wall time of the whole measurement, the two apps' start included (s).
    pub elapsed_s: f64,
}
