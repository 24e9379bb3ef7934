//! The report data: one shape for every plugin.
//!
//! ```json
//! {"plugin": "dome", "cpu": "AMD EPYC 7B13 (2 threads)",
//!  "adapter": {"name": "llvmpipe (LLVM 15.0.6, 256 bits)", "backend": "Vulkan",
//!              "device_type": "Cpu", "driver": "llvmpipe", "driver_info": "Mesa 22.3.6 (LLVM 15.0.6)"},
//!  "knob": "tolerance_px",
//!  "rows": [{"knob": 0.5, "error": {"max_px": 0.41}, "time_ms": 1.2,
//!            "baseline_time_ms": 0.3, "timings": {"pass_gpu_ms": 0.2}, "work": {"segments": 1234}}],
//!  "stability": [{"case": "antipode", "ok": true, "detail": "..."}]}
//! ```
//!
//! `adapter` is the GPU adapter a rendering sweep ran on, `null` for a sweep
//! that only runs CPU code; `cpu` is always there. `timings` (named times in
//! ms besides `time_ms`: GPU time per pass, spreads) and `work` (cost
//! counters that are not times: segments emitted, rays traced) are omitted
//! when empty.

use std::collections::BTreeMap;

use optica_harness::{AdapterInfo, PairedTimings, RatioInterval};
use serde::{Deserialize, Serialize};

use crate::PairedCpu;

/// A plugin's error-against-run-time sweep and its stability cases.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Report {
    /// Plugin name as given on the command line (`optics`, `dome`, ...).
    pub plugin: String,
    /// The machine's CPU, which ran the CPU parts of the sweep.
    pub cpu: String,
    /// The GPU adapter the sweep rendered on; `None` for a CPU-only sweep.
    pub adapter: Option<AdapterInfo>,
    /// Name of the quality knob, with its unit (`"rays_per_side"`, `"tolerance_px"`).
    pub knob: String,
    /// What `baseline_time_ms` measures, in words (shown in the Markdown).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub baseline: String,
    /// What the reference is, in words (shown in the Markdown).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub reference: String,
    /// The errors the main table and the summary lead with (at most
    /// three); empty: the first three by name. The rest go to the detail
    /// tables.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub main_errors: Vec<String>,
    /// One row per knob value, in the order swept.
    pub rows: Vec<Row>,
    /// Stiff and extreme cases.
    pub stability: Vec<StabilityCase>,
}

/// One knob setting.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Row {
    /// Which series the row belongs to when a sweep turns the knob under
    /// more than one setting (e.g. `"one lens"` and `"neighbours"`); empty
    /// for a single series. The plot draws one line per series and error.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub series: String,
    /// The knob's value.
    pub knob: f64,
    /// Named errors against the reference (`"rel_rms"`, `"max_px"`, `"psnr_db"`).
    pub error: BTreeMap<String, f64>,
    /// Time of the method at this knob, in milliseconds.
    pub time_ms: f64,
    /// Time of the baseline measured in the same run, in milliseconds.
    pub baseline_time_ms: f64,
    /// Named times in milliseconds besides `time_ms` (optional addition to the shape).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub timings: BTreeMap<String, f64>,
    /// Cost counters that are not times (optional addition to the shape).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub work: BTreeMap<String, f64>,
    /// Where the method and its baseline were timed in alternating blocks
    /// (`Headless::time_paired`): the ratio's median over blocks and its
    /// 95 % interval. Goals on the ratio are judged by its upper bound.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ratio: Option<RatioInterval>,
}

/// One stiff or extreme case and whether the method handled it.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct StabilityCase {
    /// Short name of the case (`"total internal reflection"`).
    pub case: String,
    /// `true` when the result was finite, the fallback was the documented one
    /// and, where the case is inside the model's range, the error within bound.
    pub ok: bool,
    /// What was observed, in words and numbers.
    pub detail: String,
}

impl Report {
    /// An empty report of a CPU-only sweep for `plugin`, sweeping `knob`.
    pub fn cpu(plugin: &str, knob: &str) -> Self {
        Self {
            plugin: plugin.into(),
            cpu: crate::context::cpu_description(),
            adapter: None,
            knob: knob.into(),
            baseline: String::new(),
            reference: String::new(),
            main_errors: Vec::new(),
            rows: Vec::new(),
            stability: Vec::new(),
        }
    }

    /// An empty report of a sweep that rendered on `adapter`.
    pub fn rendered(plugin: &str, knob: &str, adapter: AdapterInfo) -> Self {
        Self {
            adapter: Some(adapter),
            ..Self::cpu(plugin, knob)
        }
    }

    /// The adapter in words: its summary, or that the sweep ran on the CPU only.
    pub fn adapter_summary(&self) -> String {
        match &self.adapter {
            Some(a) => a.summary(),
            None => "none (CPU-only sweep)".into(),
        }
    }

    /// The errors the main table shows: [`Report::main_errors`] that some
    /// row has, else the first three error names.
    pub fn headline_errors(&self) -> Vec<String> {
        let all: Vec<String> = {
            let mut v: Vec<String> = self
                .rows
                .iter()
                .flat_map(|r| r.error.keys().cloned())
                .collect();
            v.sort();
            v.dedup();
            v
        };
        let chosen: Vec<String> = self
            .main_errors
            .iter()
            .filter(|e| all.contains(e))
            .take(3)
            .cloned()
            .collect();
        if chosen.is_empty() {
            all.into_iter().take(3).collect()
        } else {
            chosen
        }
    }

    /// Adds a stability case.
    pub fn case(&mut self, case: &str, ok: bool, detail: impl Into<String>) {
        self.stability.push(StabilityCase {
            case: case.into(),
            ok,
            detail: detail.into(),
        });
    }

    /// A goal on the time ratio of the rows `which` picks, judged by each
    /// ratio's upper bound (`Row::ratio_high`), recorded as a stability
    /// case: ok when every ratio was measured (a goal not met is said in
    /// the detail, not failed: performance goals are figures of the report,
    /// not assertions of its tests). Returns whether every row met it.
    pub fn ratio_goal(&mut self, case: &str, goal: f64, which: impl Fn(&Row) -> bool) -> bool {
        let rows: Vec<&Row> = self.rows.iter().filter(|r| which(r)).collect();
        let measured = !rows.is_empty() && rows.iter().all(|r| r.ratio_high().is_finite());
        let met = rows.iter().filter(|r| r.ratio_high() <= goal).count();
        let worst = rows
            .iter()
            .max_by(|a, b| a.ratio_high().total_cmp(&b.ratio_high()))
            .map(|r| {
                format!(
                    "; worst `{}` at {}: {:.2} (upper bound {:.2})",
                    r.series,
                    r.knob,
                    r.ratio(),
                    r.ratio_high()
                )
            })
            .unwrap_or_default();
        let all = met == rows.len() && measured;
        let detail = format!(
            "goal: at most {goal}× at the 95 % interval's upper bound, {}: {met} of {} rows within it{worst}",
            if all { "met" } else { "not met" },
            rows.len()
        );
        self.case(case, measured, detail);
        all
    }

    /// What a sweep's own test must fail on, in words: a non-finite time,
    /// error or work counter in any row, and any stability case that is not ok.
    /// Empty for a sane report.
    pub fn problems(&self) -> Vec<String> {
        let mut out = Vec::new();
        for row in &self.rows {
            let numbers = [
                ("time_ms", &row.time_ms),
                ("baseline_time_ms", &row.baseline_time_ms),
            ];
            let named = row
                .error
                .iter()
                .chain(row.work.iter())
                .chain(row.timings.iter())
                .map(|(k, v)| (k.as_str(), v));
            for (name, v) in numbers.into_iter().chain(named) {
                if !v.is_finite() {
                    out.push(format!("{} = {}: {name} is {v}", self.knob, row.knob));
                }
            }
        }
        // Every ratio comes with its interval: a ratio of two times taken
        // one after the other is what a load that comes and goes can fake.
        for row in self
            .rows
            .iter()
            .filter(|r| r.baseline_time_ms > 0.0 && r.ratio.is_none())
        {
            out.push(format!(
                "{} = {}{}: a ratio without its interval (time it with `Headless::time_paired` \
                 or `time_paired_ms`)",
                self.knob,
                row.knob,
                if row.series.is_empty() {
                    String::new()
                } else {
                    format!(" ({})", row.series)
                }
            ));
        }
        for c in self.stability.iter().filter(|c| !c.ok) {
            out.push(format!("stability case `{}` failed: {}", c.case, c.detail));
        }
        out
    }
}

impl Row {
    /// A row with the given knob and times; add errors with [`Row::err`].
    pub fn new(knob: f64, time_ms: f64, baseline_time_ms: f64) -> Self {
        Self {
            series: String::new(),
            knob,
            error: BTreeMap::new(),
            time_ms,
            baseline_time_ms,
            timings: BTreeMap::new(),
            work: BTreeMap::new(),
            ratio: None,
        }
    }

    /// A row whose times come from an effect and its baseline timed in
    /// alternating blocks: their median frames, and the ratio's interval.
    /// The blocks and the time the measurement took are in its work
    /// counters (`timing_blocks`, `timing_s`).
    pub fn paired(knob: f64, timed: &PairedTimings) -> Self {
        Self {
            ratio: Some(timed.ratio),
            ..Self::new(
                knob,
                timed.effect.frame_ms.median,
                timed.baseline.frame_ms.median,
            )
        }
        .work("timing_blocks", timed.ratio.blocks as f64)
        .work("timing_s", timed.elapsed_s)
    }

    /// A row whose times come from CPU work and its baseline timed in
    /// alternating blocks ([`time_paired_ms`](crate::time_paired_ms)):
    /// their median calls and the ratio's interval, with the blocks and
    /// the time the measurement took as work counters, as in
    /// [`Row::paired`].
    pub fn paired_cpu(knob: f64, timed: &PairedCpu) -> Self {
        let blocks = timed.ratio.map_or(0, |r| r.blocks);
        Self {
            ratio: timed.ratio,
            ..Self::new(knob, timed.effect_ms, timed.baseline_ms)
        }
        .work("timing_blocks", blocks as f64)
        .work("timing_s", timed.elapsed_s)
    }

    /// The ratio's upper bound where the row has an interval, else the
    /// plain ratio: what a "no more than" goal is judged by.
    pub fn ratio_high(&self) -> f64 {
        self.ratio.map_or_else(|| self.ratio(), |r| r.high)
    }

    /// Puts the row in series `name`.
    pub fn series(mut self, name: &str) -> Self {
        self.series = name.into();
        self
    }

    /// Adds a named error.
    pub fn err(mut self, name: &str, value: f64) -> Self {
        self.error.insert(name.into(), value);
        self
    }

    /// Adds a named time in milliseconds.
    pub fn timing(mut self, name: &str, ms: f64) -> Self {
        self.timings.insert(name.into(), ms);
        self
    }

    /// Time over the baseline's: the median of the block ratios where the
    /// two were timed in alternating blocks, else the two medians' ratio
    /// (NaN without a baseline).
    pub fn ratio(&self) -> f64 {
        if let Some(r) = self.ratio {
            r.median
        } else if self.baseline_time_ms > 0.0 {
            self.time_ms / self.baseline_time_ms
        } else {
            f64::NAN
        }
    }

    /// Adds a named cost counter.
    pub fn work(mut self, name: &str, value: f64) -> Self {
        self.work.insert(name.into(), value);
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A goal on ratios is judged by each interval's upper bound, and a
    /// goal not met is said, not failed.
    #[test]
    fn ratio_goals_go_by_the_upper_bound() {
        let interval = |median, high| RatioInterval {
            median,
            low: median * 0.9,
            high,
            confidence: 0.95,
            blocks: 12,
        };
        let mut r = Report::cpu("demo", "n");
        for (knob, median, high) in [(1.0, 0.8, 0.95), (2.0, 0.9, 1.1)] {
            let mut row = Row::new(knob, median, 1.0).series("mesh: case");
            row.ratio = Some(interval(median, high));
            r.rows.push(row);
        }
        assert!(!r.ratio_goal("never slower", 1.0, |row| row.series.starts_with("mesh:")));
        assert!(r.ratio_goal("at most 1.2", 1.2, |row| row.series.starts_with("mesh:")));
        assert!(r.stability.iter().all(|c| c.ok), "measured: ok");
        let detail = &r.stability[0].detail;
        assert!(
            detail.contains("not met: 1 of 2 rows within it"),
            "{detail}"
        );
        assert!(detail.contains("upper bound 1.10"), "{detail}");
        assert!(r.problems().is_empty());
    }

    #[test]
    fn problems_name_non_finite_numbers_bare_ratios_and_failed_cases() {
        let interval = RatioInterval {
            median: 2.0,
            low: 1.9,
            high: 2.1,
            confidence: 0.95,
            blocks: 4,
        };
        let mut r = Report::cpu("demo", "n");
        let mut row = Row::new(1.0, 2.0, 1.0).err("rel", 0.1).work("rays", 10.0);
        row.ratio = Some(interval);
        r.rows.push(row);
        // A row without a baseline gives no ratio, so it needs no interval.
        r.rows.push(Row::new(3.0, 2.0, 0.0).err("rel", 0.1));
        r.case("fine", true, "ok");
        assert!(r.problems().is_empty(), "{:?}", r.problems());
        let mut nan = Row::new(2.0, f64::NAN, 1.0).err("rel", f64::INFINITY);
        nan.ratio = Some(interval);
        r.rows.push(nan);
        r.rows
            .push(Row::new(4.0, 2.0, 1.0).series("timed one after the other"));
        r.case("broken", false, "NaN pixel");
        let p = r.problems();
        assert_eq!(p.len(), 4, "{p:?}");
        assert!(p[0].contains("time_ms") && p[1].contains("rel"), "{p:?}");
        assert!(
            p[2].contains("n = 4 (timed one after the other): a ratio without its interval"),
            "{p:?}"
        );
        assert!(p[3].contains("broken"), "{p:?}");
    }
}
