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

/// Writes `DIR/<plugin>.json`, `.md` and `.png`; returns the three paths.
pub fn write_all(report: &Report, dir: &Path) -> Result<[PathBuf; 3], WriteError> {
    std::fs::create_dir_all(dir).map_err(|source| WriteError::Io {
        path: dir.into(),
        source,
    })?;
    let json = dir.join(format!("{}.json", report.plugin));
    let md = dir.join(format!("{}.md", report.plugin));
    let png = dir.join(format!("{}.png", report.plugin));
    let text = serde_json::to_string_pretty(report).expect("a report serialises");
    std::fs::write(&json, text).map_err(|source| WriteError::Io {
        path: json.clone(),
        source,
    })?;
    std::fs::write(&md, markdown(report)).map_err(|source| WriteError::Io {
        path: md.clone(),
        source,
    })?;
    plot(report, &png).map_err(|message| WriteError::Plot {
        path: png.clone(),
        message,
    })?;
    Ok([json, md, png])
}

/// The Markdown page: what was measured, the table, the stability cases.
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
    let errors = names(report.rows.iter().flat_map(|r| r.error.keys()));
    let timings = names(report.rows.iter().flat_map(|r| r.timings.keys()));
    let work = names(report.rows.iter().flat_map(|r| r.work.keys()));
    let has_series = report.rows.iter().any(|r| !r.series.is_empty());
    let _ = write!(
        s,
        "\n|{} {} |",
        if has_series { " series |" } else { "" },
        report.knob
    );
    for e in &errors {
        let _ = write!(s, " {e} |");
    }
    let _ = write!(s, " time ms | baseline ms | ratio |");
    for t in &timings {
        let _ = write!(s, " {t} |");
    }
    for w in &work {
        let _ = write!(s, " {w} |");
    }
    let _ = write!(s, "\n|---|");
    for _ in 0..errors.len() + timings.len() + work.len() + 3 + usize::from(has_series) {
        let _ = write!(s, "---|");
    }
    s.push('\n');
    for row in &report.rows {
        if has_series {
            let _ = write!(s, "| {} ", row.series);
        }
        let _ = write!(s, "| {} |", num(row.knob));
        for e in &errors {
            let _ = write!(s, " {} |", row.error.get(e).map_or("–".into(), |v| num(*v)));
        }
        let ratio = if row.baseline_time_ms > 0.0 {
            row.time_ms / row.baseline_time_ms
        } else {
            f64::NAN
        };
        let _ = write!(
            s,
            " {} | {} | {} |",
            num(row.time_ms),
            num(row.baseline_time_ms),
            num(ratio)
        );
        for t in &timings {
            let _ = write!(
                s,
                " {} |",
                row.timings.get(t).map_or("–".into(), |v| num(*v))
            );
        }
        for w in &work {
            let _ = write!(s, " {} |", row.work.get(w).map_or("–".into(), |v| num(*v)));
        }
        s.push('\n');
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

/// Error (log) against time in ms (log), one series per error name (but
/// PSNR-like `_db` ones), each point labelled with its knob value.
fn plot(report: &Report, path: &Path) -> Result<(), String> {
    static REGISTER: std::sync::Once = std::sync::Once::new();
    REGISTER.call_once(|| {
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
    let errors: Vec<String> = names(report.rows.iter().flat_map(|r| r.error.keys()))
        .into_iter()
        .filter(|n| plotted(n))
        .collect();
    let positive = |v: f64| v.is_finite() && v > 0.0;
    let pts: Vec<(f64, f64)> = report
        .rows
        .iter()
        .flat_map(|r| {
            r.error
                .iter()
                .filter(|(n, _)| plotted(n))
                .map(move |(_, e)| (r.time_ms, *e))
        })
        .filter(|(t, e)| positive(*t) && positive(*e))
        .collect();
    let root = BitMapBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let device = match &report.adapter {
        Some(a) => a.name.clone(),
        None => "CPU".into(),
    };
    let title = format!("{}: error vs time ({device})", report.plugin);
    if pts.is_empty() {
        root.titled(&title, ("sans-serif", 22))
            .map_err(|e| e.to_string())?;
        return root.present().map_err(|e| e.to_string());
    }
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for (x, y) in &pts {
        x0 = x0.min(*x);
        x1 = x1.max(*x);
        y0 = y0.min(*y);
        y1 = y1.max(*y);
    }
    let pad = |lo: f64, hi: f64| (lo / 1.5, if hi > lo { hi * 1.5 } else { lo * 2.0 });
    let (x0, x1) = pad(x0, x1);
    let (y0, y1) = pad(y0, y1);
    let mut chart = ChartBuilder::on(&root)
        .caption(&title, ("sans-serif", 22))
        .margin(15)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc("time per run (ms)")
        .y_desc("error")
        .x_label_formatter(&|v| num(*v))
        .y_label_formatter(&|v| num(*v))
        .draw()
        .map_err(|e| e.to_string())?;
    let series_names = names(report.rows.iter().map(|r| &r.series));
    let lines: Vec<(String, String)> = series_names
        .iter()
        .flat_map(|sn| errors.iter().map(move |e| (sn.clone(), e.clone())))
        .collect();
    for (i, (series_name, name)) in lines.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let series: Vec<(f64, f64, f64)> = report
            .rows
            .iter()
            .filter(|r| &r.series == series_name)
            .filter_map(|r| r.error.get(name).map(|e| (r.time_ms, *e, r.knob)))
            .filter(|(t, e, _)| positive(*t) && positive(*e))
            .collect();
        if series.is_empty() {
            continue;
        }
        let label = if series_name.is_empty() {
            name.clone()
        } else {
            format!("{name} ({series_name})")
        };
        chart
            .draw_series(LineSeries::new(
                series.iter().map(|(t, e, _)| (*t, *e)),
                color.stroke_width(2),
            ))
            .map_err(|e| e.to_string())?
            .label(label)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], color.stroke_width(2))
            });
        chart
            .draw_series(series.iter().map(|(t, e, k)| {
                EmptyElement::at((*t, *e))
                    + Circle::new((0, 0), 4, color.filled())
                    + Text::new(num(*k), (6, -14), ("sans-serif", 13))
            }))
            .map_err(|e| e.to_string())?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.8))
        .border_style(BLACK)
        .draw()
        .map_err(|e| e.to_string())?;
    root.present().map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Row;

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
        assert!(
            std::fs::read_to_string(md)
                .unwrap()
                .contains("| 4 | 0.2500 | 6 | 1 | 6 | 400 |")
        );
        let img = image_size(&png);
        assert_eq!(img, (900, 600));
        let _ = std::fs::remove_dir_all(dir);
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
