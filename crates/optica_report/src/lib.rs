//! # optica_report — error against run time, for every plugin
//!
//! ```text
//! cargo run --release -p optica_report -- <sweep>|all [--out DIR] [--quick] [--adapter software|auto|<name>]
//! ```
//!
//! writes `DIR/<sweep>.json`, `DIR/<sweep>.md` and `DIR/<sweep>.png` (and
//! `.svg`; default `DIR` = `report/`), and with `all` also `DIR/REPORT.md`,
//! a one-page summary: per plugin a sentence on what to read, the first
//! rows of its table, its plot and a link to the rest. `replot --out DIR`
//! writes the Markdown, the plots and `REPORT.md` again from `DIR`'s JSON.
//! `gpu` (not part of `all`) measures the absolute GPU figures beside
//! their goals ([`sweeps::gpu`]). Each sweep turns one quality knob of a plugin over its
//! range, measures the error against the plugin's reference and the run time
//! against a baseline timed in the same run, and runs the plugin's stiff and
//! extreme cases. The JSON shape is the same for every sweep ([`Report`]),
//! and every report records the CPU and the GPU adapter it ran on.
//!
//! Rendering sweeps draw through `optica_harness` on the adapter
//! `--adapter` names: `software` (lavapipe, the default: ratios comparable
//! across CI machines), `auto` (the GPU wgpu picks first) or any part of an
//! adapter's name (`--adapter H200`). A run on a missing adapter fails
//! rather than fall back to another one. GPU times come from timestamp
//! queries around each pass where the adapter has them
//! ([`optica_harness::Headless::time_frames`]).
//!
//! To add a sweep: a module in `sweeps/` with `pub fn run(&SweepContext) ->
//! Result<Report, SweepError>` and a line in [`sweeps::SWEEPS`].

#![warn(missing_docs)]

mod context;
mod cpu_timing;
pub mod fixtures;
mod report;
pub mod sweeps;
mod write;

pub use context::{SweepContext, cpu_description};
pub use cpu_timing::{PairedCpu, time_ms, time_paired_ms};
pub use report::{Report, Row, StabilityCase};
pub use write::{WriteError, commit, markdown, summary, write_all, write_summary};

/// How a run of the report runner is set up.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Where the files go.
    pub out: std::path::PathBuf,
    /// Reduced sweeps (the test suite's).
    pub quick: bool,
    /// No progress on stderr.
    pub quiet: bool,
    /// The adapter rendering sweeps draw on.
    pub adapter: optica_harness::Adapter,
    /// `gpu` may run on a CPU device (`--allow-cpu`).
    pub allow_cpu: bool,
}

/// Writes the Markdown, plots and `REPORT.md` again from the `*.json`
/// reports in `dir` (after a change to how reports are written, without
/// running the sweeps again). Returns the reports, in `all`'s order.
pub fn replot(dir: &std::path::Path, quick: bool) -> Result<Vec<Report>, String> {
    let order: Vec<&str> = sweeps::SWEEPS.iter().map(|(n, _)| *n).collect();
    let mut reports = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))? {
        let path = entry.map_err(|e| e.to_string())?.path();
        if path.extension().is_some_and(|e| e == "json") {
            let text =
                std::fs::read_to_string(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            let report: Report =
                serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
            reports.push(report);
        }
    }
    reports.sort_by_key(|r| {
        order
            .iter()
            .position(|n| *n == r.plugin)
            .unwrap_or(usize::MAX)
    });
    for r in &reports {
        write_all(r, dir).map_err(|e| e.to_string())?;
    }
    let in_all: Vec<Report> = reports
        .iter()
        .filter(|r| order.contains(&r.plugin.as_str()))
        .cloned()
        .collect();
    write_summary(&in_all, dir, quick).map_err(|e| e.to_string())?;
    Ok(reports)
}

/// Runs the sweep called `name` (or every sweep for `all`) and writes its
/// files into `options.out`. Returns the reports.
pub fn run(name: &str, options: &RunOptions) -> Result<Vec<Report>, String> {
    let chosen: Vec<_> = sweeps::SWEEPS
        .iter()
        .filter(|(n, _)| name == "all" || *n == name)
        .chain(sweeps::PARTS.iter().filter(|(n, _)| *n == name))
        .collect();
    if chosen.is_empty() {
        let known: Vec<_> = sweeps::SWEEPS
            .iter()
            .chain(sweeps::PARTS)
            .map(|(n, _)| *n)
            .collect();
        return Err(format!(
            "unknown sweep `{name}`; known: all, {}",
            known.join(", ")
        ));
    }
    let mut reports = Vec::new();
    for (n, f) in chosen {
        let mut ctx = SweepContext::new(n, options.quick, options.quiet)
            .with_adapter(options.adapter.clone());
        ctx.allow_cpu = options.allow_cpu;
        let report = f(&ctx).map_err(|e| format!("sweep `{n}`: {e}"))?;
        write_all(&report, &options.out).map_err(|e| e.to_string())?;
        reports.push(report);
    }
    if name == "all" {
        write_summary(&reports, &options.out, options.quick).map_err(|e| e.to_string())?;
    }
    Ok(reports)
}
