//! The golden update workflow, mode by mode, on hand-made images (no
//! rendering needed): what each mode writes, what it leaves alone, pending
//! files and their acceptance, per-adapter goldens, the lock.

use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

use image::RgbaImage;
use optica_harness::golden::recorded_adapter;
use optica_harness::{
    AdapterInfo, Golden, GoldenOutcome, Tolerance, UpdateMode, WriteReason, golden_name,
};

fn checker(offset: u32) -> RgbaImage {
    RgbaImage::from_fn(48, 48, |x, y| {
        let on = ((x + offset) / 8 + y / 8).is_multiple_of(2);
        image::Rgba(if on {
            [230, 200, 40, 255]
        } else {
            [20, 40, 90, 255]
        })
    })
}

fn adapter(name: &str, device_type: &str) -> AdapterInfo {
    AdapterInfo {
        name: name.into(),
        backend: "Vulkan".into(),
        device_type: device_type.into(),
        driver: String::new(),
        driver_info: "test driver 1.0".into(),
    }
}

fn lavapipe() -> AdapterInfo {
    adapter("llvmpipe (LLVM 15.0.6, 256 bits)", "Cpu")
}

/// A fresh folder per test, so tests run in parallel.
fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("optica-golden-{}-{test}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn pngs(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|it| {
            it.filter_map(|e| e.ok()?.file_name().into_string().ok())
                .filter(|n| n.ends_with(".png"))
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

fn tol() -> Tolerance {
    Tolerance::default()
}

#[test]
fn pending_mode_writes_a_render_to_review_and_fails_until_accepted() {
    let dir = scratch("pending");
    let golden = Golden::new(&dir).mode(UpdateMode::Pending);
    let first = golden
        .compare_image("c", &checker(0), &lavapipe(), tol())
        .unwrap();
    match &first {
        GoldenOutcome::Pending {
            new,
            diff: None,
            metrics: None,
        } => assert!(new.ends_with("c.new.png")),
        other => panic!("a missing golden must give a pending file, got {other:?}"),
    }
    assert!(!first.passed());
    assert_eq!(pngs(&dir), ["c.new.png"]);

    let accepted = golden.accept_pending().unwrap();
    assert_eq!(accepted, [dir.join("c.png")]);
    assert_eq!(pngs(&dir), ["c.png"]);
    assert_eq!(
        recorded_adapter(&dir.join("c.png")).unwrap(),
        Some(lavapipe())
    );
    assert!(matches!(
        golden
            .compare_image("c", &checker(0), &lavapipe(), tol())
            .unwrap(),
        GoldenOutcome::Matches { .. }
    ));

    // A change: a pending file and a difference map; the golden stays.
    match golden
        .compare_image("c", &checker(3), &lavapipe(), tol())
        .unwrap()
    {
        GoldenOutcome::Pending {
            diff: Some(_),
            metrics: Some(m),
            ..
        } => assert!(!tol().accepts(&m)),
        other => panic!("a shifted checker must be pending, got {other:?}"),
    }
    assert_eq!(pngs(&dir), ["c.diff.png", "c.new.png", "c.png"]);
    // Matching again removes the stale review files.
    assert!(
        golden
            .compare_image("c", &checker(0), &lavapipe(), tol())
            .unwrap()
            .passed()
    );
    assert_eq!(pngs(&dir), ["c.png"]);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn never_mode_writes_nothing() {
    let dir = scratch("never");
    let never = Golden::new(&dir).mode(UpdateMode::Never);
    match never
        .compare_image("c", &checker(0), &lavapipe(), tol())
        .unwrap()
    {
        GoldenOutcome::Missing { other_families, .. } => assert!(other_families.is_empty()),
        other => panic!("expected Missing, got {other:?}"),
    }
    assert!(!dir.exists(), "never mode created the folder");
    Golden::new(&dir)
        .mode(UpdateMode::Missing)
        .compare_image("c", &checker(0), &lavapipe(), tol())
        .unwrap();
    match never
        .compare_image("c", &checker(3), &lavapipe(), tol())
        .unwrap()
    {
        GoldenOutcome::Differs { golden_adapter, .. } => {
            assert_eq!(golden_adapter, Some(lavapipe()))
        }
        other => panic!("expected Differs, got {other:?}"),
    }
    assert_eq!(pngs(&dir), ["c.png"]);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn missing_mode_writes_new_goldens_but_not_changed_ones() {
    let dir = scratch("missing");
    let golden = Golden::new(&dir).mode(UpdateMode::Missing);
    match golden
        .compare_image("c", &checker(0), &lavapipe(), tol())
        .unwrap()
    {
        GoldenOutcome::Written {
            reason: WriteReason::Missing,
            path,
        } => assert_eq!(path, dir.join("c.png")),
        other => panic!("expected Written, got {other:?}"),
    }
    let changed = golden
        .compare_image("c", &checker(3), &lavapipe(), tol())
        .unwrap();
    assert!(
        matches!(
            changed,
            GoldenOutcome::Pending {
                metrics: Some(_),
                ..
            }
        ),
        "{changed:?}"
    );
    let original = optica_harness::metrics::psnr(
        &image::open(dir.join("c.png")).unwrap().to_rgba8(),
        &checker(0),
    )
    .unwrap();
    assert!(original.is_infinite(), "the golden was changed");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn overwrite_mode_replaces_changed_goldens_and_leaves_matching_ones_alone() {
    let dir = scratch("overwrite");
    let golden = Golden::new(&dir).mode(UpdateMode::Overwrite);
    golden
        .compare_image("c", &checker(0), &lavapipe(), tol())
        .unwrap();
    let path = dir.join("c.png");
    // Date the file back, then compare the same image: it must not be rewritten.
    let old = SystemTime::UNIX_EPOCH + Duration::from_secs(1_000_000_000);
    std::fs::File::options()
        .write(true)
        .open(&path)
        .unwrap()
        .set_modified(old)
        .unwrap();
    assert!(matches!(
        golden
            .compare_image("c", &checker(0), &lavapipe(), tol())
            .unwrap(),
        GoldenOutcome::Matches { .. }
    ));
    assert_eq!(
        std::fs::metadata(&path).unwrap().modified().unwrap(),
        old,
        "a matching golden was rewritten"
    );
    match golden
        .compare_image("c", &checker(3), &lavapipe(), tol())
        .unwrap()
    {
        GoldenOutcome::Written {
            reason: WriteReason::Replaced(m),
            ..
        } => assert!(!tol().accepts(&m)),
        other => panic!("expected Written(Replaced), got {other:?}"),
    }
    assert_ne!(std::fs::metadata(&path).unwrap().modified().unwrap(), old);
    assert_eq!(pngs(&dir), ["c.png"]);
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn goldens_are_per_adapter_family() {
    let dir = scratch("families");
    Golden::new(&dir)
        .mode(UpdateMode::Missing)
        .compare_image("c", &checker(0), &lavapipe(), tol())
        .unwrap();
    let gpu = adapter("NVIDIA H200", "DiscreteGpu");
    assert_eq!(gpu.family(), "nvidia-h200");
    let never = Golden::new(&dir).mode(UpdateMode::Never);
    // The GPU render is not judged against the lavapipe golden, even when identical.
    match never.compare_image("c", &checker(0), &gpu, tol()).unwrap() {
        GoldenOutcome::Missing {
            path,
            other_families,
        } => {
            assert_eq!(path, dir.join("c@nvidia-h200.png"));
            assert_eq!(other_families, ["llvmpipe"]);
        }
        other => panic!("expected Missing for another family, got {other:?}"),
    }
    // A different lavapipe build (LLVM version, vector width) is the same family.
    let other_build = adapter("llvmpipe (LLVM 19.1.7, 128 bits)", "Cpu");
    assert!(matches!(
        never
            .compare_image("c", &checker(0), &other_build, tol())
            .unwrap(),
        GoldenOutcome::Matches { .. }
    ));
    Golden::new(&dir)
        .mode(UpdateMode::Missing)
        .compare_image("c", &checker(1), &gpu, tol())
        .unwrap();
    assert_eq!(pngs(&dir), ["c.png", "c@nvidia-h200.png"]);
    assert_eq!(
        recorded_adapter(&dir.join("c@nvidia-h200.png")).unwrap(),
        Some(gpu)
    );
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn a_size_change_is_pending_without_a_diff_map() {
    let dir = scratch("size");
    let golden = Golden::new(&dir).mode(UpdateMode::Missing);
    golden
        .compare_image("c", &checker(0), &lavapipe(), tol())
        .unwrap();
    let small = RgbaImage::from_pixel(16, 16, image::Rgba([0, 0, 0, 255]));
    match golden
        .compare_image("c", &small, &lavapipe(), tol())
        .unwrap()
    {
        GoldenOutcome::Pending {
            diff: None,
            metrics: Some(m),
            ..
        } => assert_eq!(m.differing_fraction, 1.0),
        other => panic!("expected Pending without diff, got {other:?}"),
    }
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn writers_racing_on_one_golden_leave_a_whole_file() {
    let dir = scratch("race");
    let threads: Vec<_> = (0..6)
        .map(|i| {
            let dir = dir.clone();
            std::thread::spawn(move || {
                Golden::new(&dir)
                    .mode(UpdateMode::Overwrite)
                    .compare_image("c", &checker(i), &lavapipe(), tol())
                    .unwrap()
            })
        })
        .collect();
    for t in threads {
        assert!(t.join().unwrap().passed());
    }
    let last = image::open(dir.join("c.png"))
        .expect("a readable golden")
        .to_rgba8();
    assert!(
        (0..6).any(|i| last == checker(i)),
        "the golden is none of the images written"
    );
    assert_eq!(pngs(&dir), ["c.png"], "a temporary file was left behind");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn golden_names_come_from_the_test_function() {
    assert_eq!(
        golden_name!(),
        "golden_workflow__golden_names_come_from_the_test_function"
    );
    assert_eq!(UpdateMode::parse("overwrite"), Some(UpdateMode::Overwrite));
    assert_eq!(UpdateMode::parse("always"), Some(UpdateMode::Overwrite));
    assert_eq!(UpdateMode::parse("sometimes"), None);
    let dir = scratch("names");
    let golden = Golden::new(&dir).mode(UpdateMode::Missing);
    for bad in ["", "../escape", "a@b", ".hidden", "x.new"] {
        assert!(
            golden
                .compare_image(bad, &checker(0), &lavapipe(), tol())
                .is_err(),
            "`{bad}` accepted"
        );
    }
    assert!(!dir.exists());
}
