//! The fuzz corpus replayed on stable: every input under `fuzz/corpus/` and
//! `fuzz/regressions/` (a crash the fuzzer found, kept after its fix) goes
//! through the same checks as the cargo-fuzz targets (`fuzz/src/lib.rs`):
//! a typed error or a value that passes the plugin's checks, never a panic,
//! and within the per-input time cap of the fuzz run. The fuzzing itself
//! (millions of executions, nightly) is `fuzz/README.md`'s command.

use std::path::Path;
use std::time::{Duration, Instant};

#[allow(dead_code)]
#[path = "../../fuzz/src/lib.rs"]
mod targets;

/// The fuzz run's `-timeout`, with room for this unoptimised build.
const TIME_CAP: Duration = Duration::from_secs(2);

/// Replays every file under `fuzz/{corpus,regressions}/<target>`; the
/// number replayed.
fn replay(target: &str, check: fn(&[u8])) -> usize {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz");
    let mut count = 0;
    for dir in ["corpus", "regressions"] {
        let Ok(entries) = std::fs::read_dir(root.join(dir).join(target)) else {
            continue;
        };
        let mut files: Vec<_> = entries.map(|e| e.expect("corpus entry").path()).collect();
        files.sort();
        for file in files {
            let data = std::fs::read(&file).expect("corpus file");
            let start = Instant::now();
            let outcome = std::panic::catch_unwind(|| check(&data));
            let took = start.elapsed();
            assert!(outcome.is_ok(), "{}: the check panicked", file.display());
            assert!(
                took < TIME_CAP,
                "{}: {took:?}, over the cap",
                file.display()
            );
            count += 1;
        }
    }
    count
}

#[test]
fn every_fuzz_corpus_input_gives_an_error_or_a_checked_value() {
    for (target, check, at_least) in [
        ("lens", targets::lens as fn(&[u8]), 50),
        ("head_trace", targets::head_trace, 50),
        ("dtrack", targets::dtrack, 50),
        ("frame_range", targets::frame_range, 20),
        ("cave_datagram", targets::cave_datagram, 50),
    ] {
        let n = replay(target, check);
        eprintln!("{target}: {n} inputs replayed");
        assert!(n >= at_least, "{target}: only {n} inputs in the corpus");
    }
}
