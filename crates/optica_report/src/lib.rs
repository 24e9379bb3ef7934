//! # optica_report — error against run time, for every plugin
//!
//! ```text
//! cargo run -p optica_report -- <sweep>|all [--out DIR] [--quick]
//! ```
//!
//! writes `DIR/<sweep>.json`, `DIR/<sweep>.md` and `DIR/<sweep>.png` (default
//! `DIR` = `report/`). Each sweep turns one quality knob of a plugin over its
//! range, measures the error against the plugin's reference and the run time
//! against a baseline timed in the same run, and runs the plugin's stiff and
//! extreme cases. The JSON shape is the same for every sweep ([`Report`]).
//!
//! To add a sweep: a module in `sweeps/` with `pub fn run(&SweepContext) -> Report`
//! and a line in [`sweeps::SWEEPS`].

#![warn(missing_docs)]

mod context;
mod report;
pub mod sweeps;
mod write;

pub use context::{SweepContext, time_ms};
pub use report::{Report, Row, StabilityCase};
pub use write::{WriteError, markdown, write_all};

/// Runs the sweep called `name` (or every sweep for `all`) and writes its
/// files into `out`. Returns the reports.
pub fn run(name: &str, out: &std::path::Path, quick: bool, quiet: bool) -> Result<Vec<Report>, String> {
    let chosen: Vec<_> = sweeps::SWEEPS.iter().filter(|(n, _)| name == "all" || *n == name).collect();
    if chosen.is_empty() {
        let known: Vec<_> = sweeps::SWEEPS.iter().map(|(n, _)| *n).collect();
        return Err(format!("unknown sweep `{name}`; known: all, {}", known.join(", ")));
    }
    let mut reports = Vec::new();
    for (n, f) in chosen {
        let ctx = SweepContext::new(n, quick, quiet);
        let report = f(&ctx);
        write_all(&report, out).map_err(|e| e.to_string())?;
        reports.push(report);
    }
    Ok(reports)
}
