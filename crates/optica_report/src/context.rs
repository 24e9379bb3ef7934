//! What a sweep gets from the runner: the quick flag, the adapter, progress, timing.

use std::io::Write;
use std::time::Instant;

use optica_harness::{Adapter, Headless};

/// Passed to every sweep.
pub struct SweepContext {
    /// Run a reduced sweep (used by the test suite): fewer knob values, smaller
    /// references. The full sweep is the default of the command line.
    pub quick: bool,
    /// The adapter that rendering sweeps draw on (`--adapter`).
    pub adapter: Adapter,
    /// A sweep of absolute GPU figures may run on a CPU device
    /// (`--allow-cpu`).
    pub allow_cpu: bool,
    label: String,
    started: Instant,
    quiet: bool,
}

impl SweepContext {
    /// A context for the sweep named `label`, rendering on lavapipe.
    pub fn new(label: &str, quick: bool, quiet: bool) -> Self {
        Self {
            quick,
            adapter: Adapter::Software,
            allow_cpu: false,
            label: label.into(),
            started: Instant::now(),
            quiet,
        }
    }

    /// Renders on `adapter` instead.
    pub fn with_adapter(mut self, adapter: Adapter) -> Self {
        self.adapter = adapter;
        self
    }

    /// Lets a sweep of absolute GPU figures run on a CPU device.
    pub fn allowing_cpu(mut self) -> Self {
        self.allow_cpu = true;
        self
    }

    /// A headless run of `width`×`height` on the chosen adapter: what every
    /// rendering sweep starts from, so `--adapter` reaches all of them.
    pub fn headless(&self, width: u32, height: u32) -> Headless {
        Headless::new(width, height).adapter(self.adapter.clone())
    }

    /// Reports progress on stderr: `step` of `total`, with a short note.
    pub fn progress(&self, step: usize, total: usize, note: &str) {
        if self.quiet {
            return;
        }
        let secs = self.started.elapsed().as_secs_f64();
        eprintln!(
            "[{}] {}/{} {} ({:.1} s)",
            self.label, step, total, note, secs
        );
        let _ = std::io::stderr().flush();
    }

    /// Picks the quick or the full variant of a setting.
    pub fn pick<T>(&self, quick: T, full: T) -> T {
        if self.quick { quick } else { full }
    }

    /// How a ratio's effect and baseline are timed against each other
    /// (`Headless::time_paired`): the number of alternating blocks and the
    /// frames in each; 4 blocks of 2 frames quick, 12 of 4 in full.
    pub fn blocks(&self) -> (u32, u32) {
        self.pick((4, 2), (12, 4))
    }

    /// Words for a report's baseline text: how its ratios were timed.
    pub fn paired_words(&self, warmup: u32) -> String {
        let (blocks, frames) = self.blocks();
        format!(
            "timed against each row in {blocks} alternating blocks of {frames} frames after {warmup} \
             warm-up (two apps side by side); the ratio is the median of the blocks' ratios with its \
             95 % bootstrap interval"
        )
    }
}

/// The CPU in words: its model name (from `/proc/cpuinfo` on Linux) and the
/// number of threads this process may use.
pub fn cpu_description() -> String {
    let model = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|info| {
            info.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string());
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{model} ({threads} threads)")
}
