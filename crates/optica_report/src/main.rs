//! `cargo run -p optica_report -- <sweep>|all [--out DIR] [--quick]`

use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let (mut name, mut out, mut quick) = (None, PathBuf::from("report"), false);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--out" => match args.next() {
                Some(d) => out = d.into(),
                None => return usage("--out needs a directory"),
            },
            "--quick" => quick = true,
            "-h" | "--help" => return usage(""),
            _ if name.is_none() && !a.starts_with('-') => name = Some(a),
            _ => return usage(&format!("unexpected argument `{a}`")),
        }
    }
    let Some(name) = name else { return usage("name a sweep or `all`") };
    match optica_report::run(&name, &out, quick, false) {
        Ok(reports) => {
            for r in reports {
                let bad = r.stability.iter().filter(|c| !c.ok).count();
                println!(
                    "{}: {} rows, {} stability cases ({} not ok) -> {}/{}.{{json,md,png}}",
                    r.plugin,
                    r.rows.len(),
                    r.stability.len(),
                    bad,
                    out.display(),
                    r.plugin
                );
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}

fn usage(problem: &str) -> ExitCode {
    if !problem.is_empty() {
        eprintln!("error: {problem}");
    }
    let names: Vec<_> = optica_report::sweeps::SWEEPS.iter().map(|(n, _)| *n).collect();
    eprintln!("usage: optica_report <{}|all> [--out DIR] [--quick]", names.join("|"));
    if problem.is_empty() { ExitCode::SUCCESS } else { ExitCode::FAILURE }
}
