//! `cargo run --release -p optica_report -- <sweep>|all|gpu [--out DIR] [--quick] [--adapter software|auto|<name>] [--allow-cpu]`

use std::path::PathBuf;
use std::process::ExitCode;

use optica_harness::Adapter;
use optica_report::RunOptions;

fn main() -> ExitCode {
    let mut args = std::env::args().skip(1);
    let mut name = None;
    let mut options = RunOptions {
        out: PathBuf::from("report"),
        quick: false,
        quiet: false,
        adapter: Adapter::Software,
        allow_cpu: false,
    };
    while let Some(a) = args.next() {
        match a.as_str() {
            "--out" => match args.next() {
                Some(d) => options.out = d.into(),
                None => return usage("--out needs a directory"),
            },
            "--adapter" => match args.next() {
                Some(choice) if choice.eq_ignore_ascii_case("noop") => {
                    return usage(
                        "--adapter noop draws nothing: use software, auto or an adapter name",
                    );
                }
                Some(choice) => options.adapter = Adapter::parse(&choice),
                None => return usage("--adapter needs software, auto or part of an adapter name"),
            },
            "--quick" => options.quick = true,
            "--allow-cpu" => options.allow_cpu = true,
            "-h" | "--help" => return usage(""),
            _ if name.is_none() && !a.starts_with('-') => name = Some(a),
            _ => return usage(&format!("unexpected argument `{a}`")),
        }
    }
    let Some(name) = name else {
        return usage("name a sweep or `all`");
    };
    if name == "replot" {
        return match optica_report::replot(&options.out, options.quick) {
            Ok(reports) => {
                println!(
                    "{} reports written again in {}",
                    reports.len(),
                    options.out.display()
                );
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                ExitCode::FAILURE
            }
        };
    }
    match optica_report::run(&name, &options) {
        Ok(reports) => {
            for r in reports {
                let bad = r.stability.iter().filter(|c| !c.ok).count();
                println!(
                    "{}: {} rows, {} stability cases ({} not ok), adapter {} -> {}/{}.{{json,md,png}}",
                    r.plugin,
                    r.rows.len(),
                    r.stability.len(),
                    bad,
                    r.adapter_summary(),
                    options.out.display(),
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
    let names: Vec<_> = optica_report::sweeps::SWEEPS
        .iter()
        .map(|(n, _)| *n)
        .collect();
    eprintln!(
        "usage: optica_report <{}|all|gpu|dome_scale|replot> [--out DIR] [--quick] [--adapter software|auto|<name>] [--allow-cpu]",
        names.join("|")
    );
    if problem.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}
