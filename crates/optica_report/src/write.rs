//! Writing a report: JSON (the data), Markdown (the table) and a PNG plot.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use plotters::prelude::*;

use crate::Report;

/// Errors while writing a report.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// A file could not be written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The plot could not be drawn.
    #[error("plot {path}: {message}")]
    Plot {
        /// The file.
        path: PathBuf,
        /// The cause.
        message: String,
    },
}

/// Writes `DIR/<plugin>.json`, `.md` and `.png` (and the plot as `.svg`
/// beside it); returns the JSON, Markdown and PNG paths.
pub fn write_all(report: &Report, dir: &Path) -> Result<[PathBuf; 3], WriteError> {
    std::fs::create_dir_all(dir).map_err(|source| WriteError::Io {
        path: dir.into(),
        source,
    })?;
    let json = dir.join(format!("{}.json", report.plugin));
    let md = dir.join(format!("{}.md", report.plugin));
    let png = dir.join(format!("{}.png", report.plugin));
    let svg = dir.join(format!("{}.svg", report.plugin));
    let text = serde_json::to_string_pretty(report).expect("a report serialises");
    write_file(&json, text)?;
    write_file(&md, markdown(report))?;
    plot(report, &png, &svg).map_err(|message| WriteError::Plot {
        path: png.clone(),
        message,
    })?;
    Ok([json, md, png])
}

fn write_file(path: &Path, text: String) -> Result<(), WriteError> {
    std::fs::write(path, text).map_err(|source| WriteError::Io {
        path: path.into(),
        source,
    })
}

/// Columns of a detail table besides the series and the knob.
const DETAIL_COLUMNS: usize = 6;

/// The Markdown page: what was measured; the main table (the knob, the
/// headline errors, the time against the baseline: at most 8 columns);
/// the other errors, named times and work counters in detail tables of at
/// most 8 columns each; the stability cases.
pub fn markdown(report: &Report) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# {} — error against run time\n", report.plugin);
    let _ = writeln!(s, "- adapter: {}", report.adapter_summary());
    let _ = writeln!(s, "- cpu: {}", report.cpu);
    let _ = writeln!(s, "- knob: `{}`", report.knob);
    if !report.reference.is_empty() {
        let _ = writeln!(s, "- reference: {}", report.reference);
    }
    if !report.baseline.is_empty() {
        let _ = writeln!(s, "- baseline: {}", report.baseline);
    }
    if let Some(r) = report.rows.iter().find_map(|r| r.ratio) {
        let _ = writeln!(
            s,
            "- ratios with an interval: the row's effect and its baseline timed in {} alternating \
             blocks (frames of two apps side by side; calls of the two functions where both run on \
             the CPU); the median of the blocks' ratios and its {:.0} % bootstrap interval (a goal \
             on a ratio is met when the interval's upper bound meets it)",
            r.blocks,
            100.0 * r.confidence
        );
    }
    s.push('\n');
    s.push_str(&main_table(report, usize::MAX));
    let headline = report.headline_errors();
    let details: Vec<(String, Column)> = names(report.rows.iter().flat_map(|r| r.error.keys()))
        .into_iter()
        .filter(|e| !headline.contains(e))
        .map(|e| (e.clone(), Column::ErrorNamed(e)))
        .chain(
            names(report.rows.iter().flat_map(|r| r.timings.keys()))
                .into_iter()
                .map(|t| (format!("{t} (ms)"), Column::Timing(t))),
        )
        .chain(
            names(report.rows.iter().flat_map(|r| r.work.keys()))
                .into_iter()
                .map(|w| (w.clone(), Column::Work(w))),
        )
        .collect();
    if !details.is_empty() {
        let _ = writeln!(
            s,
            "\n## Details\n\nSecondary errors, named times (ms) and work counters of the same rows."
        );
        for chunk in details.chunks(DETAIL_COLUMNS) {
            s.push('\n');
            s.push_str(&table(report, chunk));
        }
    }
    let _ = writeln!(s, "\n## Stability\n\n| case | ok | detail |\n|---|---|---|");
    for c in &report.stability {
        let _ = writeln!(
            s,
            "| {} | {} | {} |",
            c.case,
            if c.ok { "yes" } else { "**NO**" },
            c.detail.replace('|', "\\|")
        );
    }
    s
}

/// A column of a detail table.
#[derive(Clone, Debug)]
enum Column {
    /// An error, by name.
    ErrorNamed(String),
    /// A named time.
    Timing(String),
    /// A work counter.
    Work(String),
}

/// The main table: `[series] | knob | headline errors | time | baseline |
/// ratio`, the first `max_rows` rows.
fn main_table(report: &Report, max_rows: usize) -> String {
    let mut s = String::new();
    let errors = report.headline_errors();
    let has_series = report.rows.iter().any(|r| !r.series.is_empty());
    let _ = write!(
        s,
        "|{} {} |",
        if has_series { " series |" } else { "" },
        report.knob
    );
    for e in &errors {
        let _ = write!(s, " {e} |");
    }
    let _ = writeln!(s, " time ms | baseline ms | ratio [95 % interval] |");
    let _ = writeln!(
        s,
        "|{}",
        "---|".repeat(errors.len() + 4 + usize::from(has_series))
    );
    for row in report.rows.iter().take(max_rows) {
        if has_series {
            let _ = write!(s, "| {} ", row.series);
        }
        let _ = write!(s, "| {} |", num(row.knob));
        for e in &errors {
            let _ = write!(s, " {} |", row.error.get(e).map_or("–".into(), |v| num(*v)));
        }
        let ratio = match row.ratio {
            Some(r) => format!("{} [{}, {}]", num(r.median), num(r.low), num(r.high)),
            None => num(row.ratio()),
        };
        let _ = writeln!(
            s,
            " {} | {} | {ratio} |",
            num(row.time_ms),
            num(row.baseline_time_ms),
        );
    }
    if report.rows.len() > max_rows {
        let _ = writeln!(
            s,
            "\n({} more rows in the full table.)",
            report.rows.len() - max_rows
        );
    }
    s
}

/// A detail table: `[series] | knob | columns`.
fn table(report: &Report, columns: &[(String, Column)]) -> String {
    let mut s = String::new();
    let has_series = report.rows.iter().any(|r| !r.series.is_empty());
    let _ = write!(
        s,
        "|{} {} |",
        if has_series { " series |" } else { "" },
        report.knob
    );
    for (title, _) in columns {
        let _ = write!(s, " {title} |");
    }
    let _ = writeln!(
        s,
        "\n|{}",
        "---|".repeat(columns.len() + 1 + usize::from(has_series))
    );
    for row in &report.rows {
        if has_series {
            let _ = write!(s, "| {} ", row.series);
        }
        let _ = write!(s, "| {} |", num(row.knob));
        for (_, c) in columns {
            let v = match c {
                Column::ErrorNamed(n) => row.error.get(n),
                Column::Timing(n) => row.timings.get(n),
                Column::Work(n) => row.work.get(n),
            };
            let _ = write!(s, " {} |", v.map_or("–".into(), |v| num(*v)));
        }
        s.push('\n');
    }
    s
}

/// What a reader should take from each report's table and plot, in a
/// sentence (the summary page's).
fn reading(plugin: &str) -> &'static str {
    match plugin {
        "optics" => {
            "The CPU reference's own accuracy and cost: each knob row's error against a finer run of the same routine."
        }
        "render" => {
            "The harness itself: what a headless frame costs at each size on this adapter, the floor every plugin's ratio sits on."
        }
        "foveated_lod" => {
            "Frame time as a share of full quality (left of the baseline line saves) against the image error beyond the central field, for the mesh path and the paper's ray tracer in its four scenes and two gazes."
        }
        "compound_eye" => {
            "Error against the exact per-pixel ray trace of the eye, and the frame time as a multiple of a plain material: how many neighbouring lenses buy how much."
        }
        "lens_flare" => {
            "Error of the flare against a dense CPU trace of the same ghosts, and its cost as a multiple of the frame without a flare, by grid size and resolution."
        }
        "spectacles" => {
            "Blur and correction error against the ray-traced eye (mrad, px) and the frame as a multiple of the sharp view, by clone count S and voxel density."
        }
        "dome" => {
            "Edge error in pixels of the dome's image against the exact curve (it stays under the tolerance knob) and the cost against a perspective view; the cube mode by face size beside it."
        }
        _ => "Error against the plugin's reference, time against its baseline.",
    }
}

/// The commit the report was made from (`git rev-parse --short HEAD`),
/// with "+ uncommitted changes" when a tracked file other than those in
/// `out` (the report being written) differs from it, if there is a
/// repository to ask.
pub fn commit(out: &Path) -> Option<String> {
    let git = |args: &[&str]| {
        let out = std::process::Command::new("git").args(args).output().ok()?;
        out.status
            .success()
            .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
    };
    let head = git(&["rev-parse", "--short", "HEAD"]).filter(|c| !c.is_empty())?;
    // Tracked files only, and not the report being written.
    let exclude = format!(":(exclude){}", out.display());
    let dirty = git(&[
        "status",
        "--porcelain",
        "--untracked-files=no",
        "--",
        ".",
        &exclude,
    ])
    .is_some_and(|s| !s.is_empty());
    Some(if dirty {
        format!("{head} + uncommitted changes")
    } else {
        head
    })
}

/// Rows of a plugin's main table the summary shows.
const SUMMARY_ROWS: usize = 8;

/// `REPORT.md`: one page a reader takes in at a glance. The machine, the
/// adapter and the commit; per plugin, a sentence on what to read, the
/// first rows of its main table, its plot and a link to its full table.
pub fn summary(reports: &[Report], commit: Option<&str>, quick: bool) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# optica — error against run time\n");
    let cpu = reports.first().map_or("unknown".into(), |r| r.cpu.clone());
    let adapter = reports
        .iter()
        .find_map(|r| r.adapter.as_ref().map(|a| a.summary()))
        .unwrap_or_else(|| "none (CPU-only sweeps)".into());
    let _ = writeln!(s, "- machine: {cpu}");
    let _ = writeln!(s, "- adapter: {adapter}");
    let _ = writeln!(s, "- commit: {}", commit.unwrap_or("unknown"));
    let _ = writeln!(
        s,
        "- run: {}",
        if quick {
            "`--quick` (reduced sweeps)"
        } else {
            "full sweeps"
        }
    );
    let cpu_device = reports
        .iter()
        .filter_map(|r| r.adapter.as_ref())
        .any(|a| a.device_type.eq_ignore_ascii_case("cpu"));
    if cpu_device {
        let _ = writeln!(
            s,
            "\nThe adapter is a CPU rasteriser: times are CPU-bound and only their ratios to the baseline measured in the same run mean anything (they compare methods, not GPUs). Absolute GPU times come from `optica_report gpu` on a machine with a GPU."
        );
    }
    for r in reports {
        let _ = writeln!(s, "\n## {}\n", r.plugin);
        let _ = writeln!(s, "{}", reading(&r.plugin));
        if !r.baseline.is_empty() {
            let _ = writeln!(s, "Baseline: {}.", r.baseline.trim_end_matches('.'));
        }
        s.push('\n');
        s.push_str(&main_table(r, SUMMARY_ROWS));
        let bad = r.stability.iter().filter(|c| !c.ok).count();
        let _ = writeln!(
            s,
            "\n{} stability cases, {}.\n",
            r.stability.len(),
            if bad == 0 {
                "all ok".to_string()
            } else {
                format!("**{bad} not ok**")
            }
        );
        let _ = writeln!(
            s,
            "![{0}]({0}.png)\n\nFull table, details and stability cases: [{0}.md]({0}.md) (data: [{0}.json]({0}.json), plot as [SVG]({0}.svg)).",
            r.plugin
        );
    }
    s
}

/// Writes `DIR/REPORT.md` for `reports`.
pub fn write_summary(reports: &[Report], dir: &Path, quick: bool) -> Result<PathBuf, WriteError> {
    let path = dir.join("REPORT.md");
    write_file(&path, summary(reports, commit(dir).as_deref(), quick))?;
    Ok(path)
}

fn names<'a>(keys: impl Iterator<Item = &'a String>) -> Vec<String> {
    let mut v: Vec<String> = keys.cloned().collect();
    v.sort();
    v.dedup();
    v
}

/// Numbers as a person reads them: 4 significant digits.
fn num(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    if v.fract() == 0.0 && v.abs() < 1e9 {
        // Counts and integral knobs read best without decimals.
        return format!("{v:.0}");
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let digits = (3 - a.log10().floor() as i32).max(0) as usize;
        format!("{v:.digits$}")
    } else {
        format!("{v:.3e}")
    }
}

static FONT: &[u8] = include_bytes!("../fonts/DejaVuSans.ttf");

/// Whether an error is plotted: every error is lower-is-better except the
/// ones in decibels (PSNR), which the table shows and the plot leaves out.
fn plotted(name: &str) -> bool {
    !name.ends_with("_db")
}

/// The plot's size in pixels.
const PLOT_SIZE: (u32, u32) = (1200, 800);
/// Panels at most: the headline errors first, then the others by name.
const MAX_PANELS: usize = 6;

/// One panel per error (a metric family: PSNR-like `_db` ones are left
/// out) of up to six, each error (log) against the time as a multiple of
/// the baseline (log), with the baseline drawn at 1: left of the line is
/// cheaper than the baseline, right of it dearer. A sweep without a
/// baseline time is drawn against its time in ms. Written as PNG and SVG.
fn plot(report: &Report, png: &Path, svg: &Path) -> Result<(), String> {
    static REGISTER: std::sync::Once = std::sync::Once::new();
    REGISTER.call_once(|| {
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
    draw(
        report,
        BitMapBackend::new(png, PLOT_SIZE).into_drawing_area(),
    )?;
    draw(report, SVGBackend::new(svg, PLOT_SIZE).into_drawing_area())
}

/// What a panel plots: per series, (x, error, knob).
type Points = Vec<(String, Vec<(f64, f64, f64)>)>;

fn panel_points(report: &Report, error: &str, by_ratio: bool) -> Points {
    let positive = |v: f64| v.is_finite() && v > 0.0;
    names(report.rows.iter().map(|r| &r.series))
        .into_iter()
        .map(|series| {
            let pts = report
                .rows
                .iter()
                .filter(|r| r.series == series)
                .filter_map(|r| {
                    let x = if by_ratio { r.ratio() } else { r.time_ms };
                    r.error.get(error).map(|e| (x, *e, r.knob))
                })
                .filter(|(x, e, _)| positive(*x) && positive(*e))
                .collect();
            (series, pts)
        })
        .filter(|(_, pts): &(String, Vec<_>)| !pts.is_empty())
        .collect()
}

fn draw<DB: DrawingBackend>(
    report: &Report,
    root: DrawingArea<DB, plotters::coord::Shift>,
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let device = match &report.adapter {
        Some(a) => a.name.clone(),
        None => "CPU".into(),
    };
    let by_ratio = report
        .rows
        .iter()
        .any(|r| r.ratio().is_finite() && r.ratio() > 0.0);
    // Errors with something to draw on a log axis (one that is 0 in every
    // row, e.g. the foveated central field's, gets no panel).
    let errors: Vec<String> = report
        .headline_errors()
        .into_iter()
        .chain(names(report.rows.iter().flat_map(|r| r.error.keys())))
        .filter(|n| plotted(n) && !panel_points(report, n, by_ratio).is_empty())
        .fold(Vec::new(), |mut v, n| {
            if !v.contains(&n) {
                v.push(n);
            }
            v
        })
        .into_iter()
        .take(MAX_PANELS)
        .collect();
    let title = format!(
        "{}: error against {} ({device})",
        report.plugin,
        if by_ratio { "time / baseline" } else { "time" }
    );
    let root = root.titled(&title, ("sans-serif", 26)).map_err(err)?;
    if errors.is_empty() {
        return root.present().map_err(err);
    }
    // One colour per series across every panel, named once in a legend
    // column at the right (legends inside the panels hid the points).
    let all_series = names(report.rows.iter().map(|r| &r.series));
    let colour = |name: &str| {
        let i = all_series.iter().position(|s| s == name).unwrap_or(0);
        Palette99::pick(i).to_rgba()
    };
    let (plots, legend) = root.split_horizontally((78).percent_width());
    let mut entries: Vec<(String, RGBAColor)> = Vec::new();
    if by_ratio {
        entries.push(("baseline (ratio 1)".into(), BLACK.mix(0.6)));
    }
    for name in &all_series {
        let label = if name.is_empty() { "all rows" } else { name };
        entries.push((label.to_string(), colour(name)));
    }
    for (i, (label, c)) in entries.iter().enumerate() {
        let y = 40 + 22 * i as i32;
        legend
            .draw(&PathElement::new(vec![(6, y), (30, y)], c.stroke_width(3)))
            .map_err(err)?;
        legend
            .draw(&Text::new(label.clone(), (36, y - 7), ("sans-serif", 13)))
            .map_err(err)?;
    }
    let cols = errors.len().min(3);
    let rows = errors.len().div_ceil(cols);
    let panels = plots.split_evenly((rows, cols));
    for (error, area) in errors.iter().zip(panels.iter()) {
        let series = panel_points(report, error, by_ratio);
        let all: Vec<&(f64, f64, f64)> = series.iter().flat_map(|(_, p)| p).collect();
        if all.is_empty() {
            area.titled(error, ("sans-serif", 18)).map_err(err)?;
            continue;
        }
        let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for (x, y, _) in &all {
            x0 = x0.min(*x);
            x1 = x1.max(*x);
            y0 = y0.min(*y);
            y1 = y1.max(*y);
        }
        if by_ratio {
            // The baseline's line is always in view.
            x0 = x0.min(1.0);
            x1 = x1.max(1.0);
        }
        let pad = |lo: f64, hi: f64| (lo / 1.4, if hi > lo { hi * 1.4 } else { lo * 2.0 });
        let (x0, x1) = pad(x0, x1);
        let (y0, y1) = pad(y0, y1);
        let mut chart = ChartBuilder::on(area)
            .caption(error, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(40)
            .y_label_area_size(72)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
            .map_err(err)?;
        chart
            .configure_mesh()
            .x_desc(if by_ratio {
                "time / baseline"
            } else {
                "time (ms)"
            })
            .label_style(("sans-serif", 14))
            .axis_desc_style(("sans-serif", 15))
            .x_labels(6)
            .y_labels(6)
            .x_label_formatter(&|v| num(*v))
            .y_label_formatter(&|v| num(*v))
            .draw()
            .map_err(err)?;
        if by_ratio {
            chart
                .draw_series(LineSeries::new(
                    [(1.0, y0), (1.0, y1)],
                    BLACK.mix(0.6).stroke_width(2),
                ))
                .map_err(err)?;
        }
        for (name, pts) in &series {
            let color = colour(name);
            chart
                .draw_series(LineSeries::new(
                    pts.iter().map(|(x, e, _)| (*x, *e)),
                    color.stroke_width(2),
                ))
                .map_err(err)?;
            chart
                .draw_series(pts.iter().map(|(x, e, k)| {
                    EmptyElement::at((*x, *e))
                        + Circle::new((0, 0), 3, color.filled())
                        + Text::new(num(*k), (5, -13), ("sans-serif", 11))
                }))
                .map_err(err)?;
        }
    }
    root.present().map_err(err)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Row;

    /// A ratio timed in alternating blocks is printed with its interval,
    /// and the page says how it was timed.
    #[test]
    fn a_paired_ratio_is_printed_with_its_interval() {
        let mut r = Report::cpu("demo", "n");
        let mut row = Row::new(4.0, 6.0, 3.0).err("rel", 0.25);
        row.ratio = Some(optica_harness::RatioInterval {
            median: 1.9,
            low: 1.75,
            high: 2.25,
            confidence: 0.95,
            blocks: 12,
        });
        r.rows.push(row);
        assert_eq!(r.rows[0].ratio(), 1.9);
        assert_eq!(r.rows[0].ratio_high(), 2.25);
        let md = markdown(&r);
        assert!(
            md.contains("| 4 | 0.2500 | 6 | 3 | 1.900 [1.750, 2.250] |"),
            "{md}"
        );
        assert!(md.contains("12 alternating blocks"), "{md}");
        let json = serde_json::to_value(&r.rows[0]).unwrap();
        assert_eq!(json["ratio"]["high"], 2.25);
    }

    #[test]
    fn numbers_read_well() {
        assert_eq!(num(0.0), "0");
        assert_eq!(num(1.23456), "1.235");
        assert_eq!(num(123.456), "123.5");
        assert_eq!(num(1.5e-6), "1.500e-6");
        assert_eq!(num(4096.0), "4096");
    }

    #[test]
    fn writes_three_files_with_the_shape() {
        let mut r = Report::cpu("demo", "n");
        for n in [1.0, 2.0, 4.0] {
            r.rows.push(
                Row::new(n, n * 1.5, 1.0)
                    .err("rel", 1.0 / n)
                    .work("rays", n * 100.0),
            );
        }
        r.case("zero", true, "finite");
        let dir = std::env::temp_dir().join(format!("optica-report-{}", std::process::id()));
        let [json, md, png] = write_all(&r, &dir).unwrap();
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
        for key in ["plugin", "cpu", "adapter", "knob", "rows", "stability"] {
            assert!(v.get(key).is_some(), "missing {key}");
        }
        let row = &v["rows"][0];
        for key in ["knob", "error", "time_ms", "baseline_time_ms"] {
            assert!(row.get(key).is_some(), "row missing {key}");
        }
        let md = std::fs::read_to_string(md).unwrap();
        // The main table leads with the knob, the error and the ratio; the
        // work counter is in the details.
        assert!(
            md.contains("| n | rel | time ms | baseline ms | ratio [95 % interval] |"),
            "{md}"
        );
        assert!(md.contains("| 4 | 0.2500 | 6 | 1 | 6 |"), "{md}");
        assert!(
            md.contains("| n | rays |") && md.contains("| 4 | 400 |"),
            "{md}"
        );
        let img = image_size(&png);
        assert_eq!(img, PLOT_SIZE);
        assert!(
            std::fs::read_to_string(png.with_extension("svg"))
                .unwrap()
                .contains("<svg")
        );
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn the_summary_leads_with_the_machine_and_shows_each_plugin_briefly() {
        let mut a = Report::cpu("dome", "tolerance_px");
        for k in 0..20 {
            a.rows.push(
                Row::new(k as f64, 2.0, 1.0)
                    .err("max_px", 0.5)
                    .work("segments", 9.0),
            );
        }
        a.case("antipode", true, "finite");
        let mut b = Report::cpu("optics", "n");
        b.rows.push(Row::new(1.0, 1.0, 0.0).err("rel", 0.1));
        b.case("tir", false, "NaN");
        let page = summary(&[a, b], Some("abc1234"), true);
        assert!(
            page.contains("- commit: abc1234") && page.contains("- machine: "),
            "{page}"
        );
        assert!(
            page.contains("## dome") && page.contains("## optics"),
            "{page}"
        );
        assert!(page.contains("![dome](dome.png)") && page.contains("[dome.md](dome.md)"));
        assert!(page.contains("(12 more rows in the full table.)"), "{page}");
        assert!(page.contains("**1 not ok**"), "{page}");
        // No work counters on the summary.
        assert!(!page.contains("segments"), "{page}");
    }

    /// Width and height from a PNG's IHDR chunk.
    fn image_size(path: &Path) -> (u32, u32) {
        let b = std::fs::read(path).unwrap();
        assert_eq!(&b[1..4], b"PNG");
        (
            u32::from_be_bytes(b[16..20].try_into().unwrap()),
            u32::from_be_bytes(b[20..24].try_into().unwrap()),
        )
    }
}
