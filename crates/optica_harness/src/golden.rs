//! Golden-image tests: compare a render with a checked-in PNG.
//!
//! Goldens are PNGs in a folder of the test crate (optica keeps them in
//! `tests/golden/`). Each records, in a PNG text chunk, the adapter that made
//! it. Goldens are **per adapter family**: the reference family (lavapipe,
//! `llvmpipe`, unless [`Golden::reference_family`] says otherwise) owns
//! `<name>.png`, any other family its own `<name>@<family>.png` (e.g.
//! `lit_cube@nvidia-h200.png`). A render from a GPU is therefore never
//! judged against a lavapipe golden; without a golden of its own family the
//! comparison says so plainly ([`GoldenOutcome::Missing`] names the families
//! that do have one).
//!
//! ## Update modes
//!
//! The environment variable [`MODE_ENV`] (`OPTICA_GOLDEN`) chooses what a
//! comparison may write, as `INSTA_UPDATE` does for insta snapshots:
//!
//! | `OPTICA_GOLDEN` | missing golden | differing golden | matching golden |
//! |---|---|---|---|
//! | `never` (default when `CI` is set) | fail | fail | pass |
//! | `pending` (default otherwise) | write `<name>.new.png`, fail | write `.new.png` and `.diff.png`, fail | pass |
//! | `missing` | write the golden, pass | write `.new.png` and `.diff.png`, fail | pass |
//! | `overwrite` | write the golden, pass | overwrite the golden, pass | pass, file untouched |
//!
//! Review pending files by looking at `<name>.new.png` next to `<name>.png`
//! and the ꟻLIP map `<name>.diff.png`; accept them all with
//! [`Golden::accept_pending`] (or rename `.new.png` to `.png` by hand: the
//! adapter record travels inside the PNG). A golden that still matches is
//! never rewritten, so an `overwrite` run changes only what changed. A lock
//! file in the golden folder is held while comparing and writing, so test
//! threads and parallel test binaries never read a half-written golden.
//!
//! ## Naming
//!
//! [`golden_name!`](crate::golden_name) names a golden after the test
//! function it is called in, and [`assert_golden!`](crate::assert_golden)
//! compares a frame with it in the calling crate's `tests/golden/`.

use std::fs::File;
use std::io::{BufReader, BufWriter};
use std::path::{Path, PathBuf};

use image::RgbaImage;

use crate::{AdapterInfo, HarnessError, RenderedFrame, metrics};

/// The environment variable that chooses the [`UpdateMode`].
pub const MODE_ENV: &str = "OPTICA_GOLDEN";

/// The adapter family whose goldens carry no suffix: Mesa's lavapipe, the
/// device every CI machine has.
pub const REFERENCE_FAMILY: &str = "llvmpipe";

/// The PNG text chunk (iTXt keyword) holding the adapter record.
const ADAPTER_KEYWORD: &str = "optica-adapter";

/// The lock file in a golden folder.
const LOCK_FILE: &str = ".optica-golden.lock";

/// What a comparison may write. See the [module docs](self) for the table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UpdateMode {
    /// Compare only; write nothing.
    Never,
    /// Write `<name>.new.png` for a missing or differing golden, and fail.
    Pending,
    /// Write missing goldens; a differing one gets a `.new.png` and fails.
    Missing,
    /// Write missing and differing goldens; leave matching ones untouched.
    Overwrite,
}

impl UpdateMode {
    /// Parses `never`, `pending`, `missing` or `overwrite` (insta's `no`,
    /// `new`, `unseen` and `always` are accepted as synonyms).
    pub fn parse(text: &str) -> Option<Self> {
        match text.trim().to_ascii_lowercase().as_str() {
            "never" | "no" => Some(UpdateMode::Never),
            "pending" | "new" => Some(UpdateMode::Pending),
            "missing" | "unseen" => Some(UpdateMode::Missing),
            "overwrite" | "always" => Some(UpdateMode::Overwrite),
            _ => None,
        }
    }

    /// The mode [`MODE_ENV`] asks for; without it, `never` on CI (when `CI`
    /// is set, as GitHub Actions, GitLab and most CI systems do) and
    /// `pending` elsewhere.
    ///
    /// An unknown value is an error, not a silent default.
    pub fn from_env() -> Result<Self, HarnessError> {
        match std::env::var(MODE_ENV) {
            Ok(v) if !v.is_empty() => UpdateMode::parse(&v).ok_or_else(|| HarnessError::Golden {
                path: MODE_ENV.into(),
                message: format!("unknown mode `{v}`: use never, pending, missing or overwrite"),
            }),
            _ if std::env::var_os("CI")
                .is_some_and(|v| !v.is_empty() && v != "false" && v != "0") =>
            {
                Ok(UpdateMode::Never)
            }
            _ => Ok(UpdateMode::Pending),
        }
    }
}

/// How close a render must be to its golden.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerance {
    /// Lowest acceptable PSNR in dB.
    pub min_psnr_db: f64,
    /// Highest acceptable mean ꟻLIP error.
    pub max_flip_mean: f64,
    /// Highest acceptable fraction of pixels differing by more than 8/255.
    pub max_differing_fraction: f64,
}

impl Default for Tolerance {
    /// Tight enough that a moved object, a changed colour or a black frame
    /// fails (a cube turned by 0.15 rad gives PSNR 22.6 dB, ꟻLIP 0.063 and
    /// 3.4 % differing pixels at 128², measured at 18544de, 2026-11-30);
    /// loose enough for rasteriser noise between Mesa versions.
    fn default() -> Self {
        Self {
            min_psnr_db: 38.0,
            max_flip_mean: 0.01,
            max_differing_fraction: 0.005,
        }
    }
}

impl Tolerance {
    /// Whether `m` is within this tolerance.
    pub fn accepts(&self, m: &metrics::ImageMetrics) -> bool {
        m.psnr_db >= self.min_psnr_db
            && m.flip_mean <= self.max_flip_mean
            && m.differing_fraction <= self.max_differing_fraction
    }
}

/// Why a golden was written.
#[derive(Clone, Debug, PartialEq)]
pub enum WriteReason {
    /// There was none for this adapter family.
    Missing,
    /// The old one differed by these metrics.
    Replaced(metrics::ImageMetrics),
}

/// The outcome of a comparison.
#[derive(Clone, Debug)]
pub enum GoldenOutcome {
    /// Within tolerance. Nothing was written.
    Matches {
        /// The metrics against the golden.
        metrics: metrics::ImageMetrics,
        /// The golden.
        path: PathBuf,
    },
    /// The golden was written ([`UpdateMode::Missing`] or [`UpdateMode::Overwrite`]).
    Written {
        /// The golden.
        path: PathBuf,
        /// Why.
        reason: WriteReason,
    },
    /// A render to review was written as `<name>.new.png` ([`UpdateMode::Pending`],
    /// or a differing golden under [`UpdateMode::Missing`]). A test fails on it.
    Pending {
        /// The pending file.
        new: PathBuf,
        /// The ꟻLIP difference map, when there was a golden of the same size.
        diff: Option<PathBuf>,
        /// The metrics against the golden; `None` when there was no golden.
        metrics: Option<metrics::ImageMetrics>,
    },
    /// Out of tolerance under [`UpdateMode::Never`]. Nothing was written.
    Differs {
        /// The metrics that failed.
        metrics: metrics::ImageMetrics,
        /// The golden.
        path: PathBuf,
        /// The adapter recorded in the golden, when it has a record.
        golden_adapter: Option<AdapterInfo>,
    },
    /// No golden for this adapter family under [`UpdateMode::Never`].
    Missing {
        /// Where it would be.
        path: PathBuf,
        /// The adapter families that do have a golden of this name.
        other_families: Vec<String>,
    },
}

impl GoldenOutcome {
    /// Whether a test should pass: the render matched, or the golden was written.
    pub fn passed(&self) -> bool {
        matches!(
            self,
            GoldenOutcome::Matches { .. } | GoldenOutcome::Written { .. }
        )
    }
}

/// A folder of golden images.
#[derive(Clone, Debug)]
pub struct Golden {
    dir: PathBuf,
    mode: UpdateMode,
    reference_family: String,
}

impl Golden {
    /// Goldens in `dir`, in the mode [`UpdateMode::from_env`] gives.
    ///
    /// Panics when [`MODE_ENV`] holds an unknown mode: a typo there must not
    /// quietly run a test suite in the wrong mode.
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        let mode = UpdateMode::from_env().unwrap_or_else(|e| panic!("{e}"));
        Self {
            dir: dir.into(),
            mode,
            reference_family: REFERENCE_FAMILY.into(),
        }
    }

    /// Sets the update mode, whatever the environment says.
    pub fn mode(mut self, mode: UpdateMode) -> Self {
        self.mode = mode;
        self
    }

    /// The update mode in force.
    pub fn update_mode(&self) -> UpdateMode {
        self.mode
    }

    /// Makes `family` (see [`AdapterInfo::family`]) the one whose goldens
    /// carry no suffix. The default is [`REFERENCE_FAMILY`].
    pub fn reference_family(mut self, family: &str) -> Self {
        self.reference_family = family.into();
        self
    }

    /// The golden folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// The path of golden `name` for renders by `adapter`.
    pub fn path(&self, name: &str, adapter: &AdapterInfo) -> PathBuf {
        self.dir.join(format!("{}.png", self.stem(name, adapter)))
    }

    fn stem(&self, name: &str, adapter: &AdapterInfo) -> String {
        let family = adapter.family();
        if family == self.reference_family {
            name.to_string()
        } else {
            format!("{name}@{family}")
        }
    }

    /// Compares `frame` with golden `name` of its adapter family, writing
    /// what the [`UpdateMode`] allows.
    pub fn compare(
        &self,
        name: &str,
        frame: &RenderedFrame,
        tolerance: Tolerance,
    ) -> Result<GoldenOutcome, HarnessError> {
        self.compare_image(name, &frame.to_rgba8(), &frame.adapter, tolerance)
    }

    /// [`Golden::compare`] for an image that `adapter` rendered.
    pub fn compare_image(
        &self,
        name: &str,
        image: &RgbaImage,
        adapter: &AdapterInfo,
        tolerance: Tolerance,
    ) -> Result<GoldenOutcome, HarnessError> {
        check_name(name)?;
        let path = self.path(name, adapter);
        let stem = self.stem(name, adapter);
        let err = |p: &Path, message: String| HarnessError::Golden {
            path: p.display().to_string(),
            message,
        };
        if self.mode == UpdateMode::Never && !path.exists() {
            return Ok(GoldenOutcome::Missing {
                path,
                other_families: self.families_of(name),
            });
        }
        std::fs::create_dir_all(&self.dir).map_err(|e| err(&self.dir, e.to_string()))?;
        let _lock = FolderLock::acquire(&self.dir)?;
        let new = self.dir.join(format!("{stem}.new.png"));
        let diff_path = self.dir.join(format!("{stem}.diff.png"));

        if !path.exists() {
            return match self.mode {
                UpdateMode::Never => Ok(GoldenOutcome::Missing {
                    path,
                    other_families: self.families_of(name),
                }),
                UpdateMode::Pending => {
                    write_png(&new, image, adapter)?;
                    Ok(GoldenOutcome::Pending {
                        new,
                        diff: None,
                        metrics: None,
                    })
                }
                UpdateMode::Missing | UpdateMode::Overwrite => {
                    write_png(&path, image, adapter)?;
                    remove_stale(&[&new, &diff_path]);
                    Ok(GoldenOutcome::Written {
                        path,
                        reason: WriteReason::Missing,
                    })
                }
            };
        }

        let (golden, golden_adapter) = read_png(&path)?;
        let m = if golden.dimensions() == image.dimensions() {
            metrics::compare(&golden, image).map_err(|e| err(&path, e.to_string()))?
        } else {
            metrics::ImageMetrics::incomparable()
        };
        if tolerance.accepts(&m) {
            // Never rewritten: an overwrite run changes only what changed.
            remove_stale(&[&new, &diff_path]);
            return Ok(GoldenOutcome::Matches { metrics: m, path });
        }
        match self.mode {
            UpdateMode::Never => Ok(GoldenOutcome::Differs {
                metrics: m,
                path,
                golden_adapter,
            }),
            UpdateMode::Overwrite => {
                write_png(&path, image, adapter)?;
                remove_stale(&[&new, &diff_path]);
                Ok(GoldenOutcome::Written {
                    path,
                    reason: WriteReason::Replaced(m),
                })
            }
            UpdateMode::Pending | UpdateMode::Missing => {
                write_png(&new, image, adapter)?;
                let diff = if golden.dimensions() == image.dimensions() {
                    write_diff(&golden, image, &diff_path).map_err(|e| err(&diff_path, e))?;
                    Some(diff_path)
                } else {
                    None
                };
                Ok(GoldenOutcome::Pending {
                    new,
                    diff,
                    metrics: Some(m),
                })
            }
        }
    }

    /// Like [`Golden::compare`], panicking with a message that says what to
    /// do when the outcome is not a pass: for use in `#[test]`s.
    #[track_caller]
    pub fn assert_matches(
        &self,
        name: &str,
        frame: &RenderedFrame,
        tolerance: Tolerance,
    ) -> GoldenOutcome {
        let outcome = self
            .compare(name, frame, tolerance)
            .unwrap_or_else(|e| panic!("{e}"));
        if let Some(message) = failure_message(name, &frame.adapter, &outcome, tolerance) {
            panic!("{message}");
        }
        outcome
    }

    /// Accepts every pending render in the folder: `<x>.new.png` replaces
    /// `<x>.png`, and `<x>.diff.png` is removed. Returns the goldens written.
    pub fn accept_pending(&self) -> Result<Vec<PathBuf>, HarnessError> {
        let err = |p: &Path, e: std::io::Error| HarnessError::Golden {
            path: p.display().to_string(),
            message: e.to_string(),
        };
        if !self.dir.exists() {
            return Ok(Vec::new());
        }
        let _lock = FolderLock::acquire(&self.dir)?;
        let mut accepted = Vec::new();
        for entry in std::fs::read_dir(&self.dir).map_err(|e| err(&self.dir, e))? {
            let path = entry.map_err(|e| err(&self.dir, e))?.path();
            let Some(stem) = path
                .file_name()
                .and_then(|n| n.to_str())
                .and_then(|n| n.strip_suffix(".new.png"))
            else {
                continue;
            };
            let golden = self.dir.join(format!("{stem}.png"));
            std::fs::rename(&path, &golden).map_err(|e| err(&path, e))?;
            remove_stale(&[&self.dir.join(format!("{stem}.diff.png"))]);
            accepted.push(golden);
        }
        accepted.sort();
        Ok(accepted)
    }

    /// The adapter families that have a golden called `name`.
    fn families_of(&self, name: &str) -> Vec<String> {
        let Ok(entries) = std::fs::read_dir(&self.dir) else {
            return Vec::new();
        };
        let mut families: Vec<String> = entries
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter_map(|f| {
                let stem = f.strip_suffix(".png")?;
                if stem.ends_with(".new") || stem.ends_with(".diff") {
                    return None;
                }
                if stem == name {
                    Some(self.reference_family.clone())
                } else {
                    stem.strip_prefix(name)?
                        .strip_prefix('@')
                        .map(str::to_string)
                }
            })
            .collect();
        families.sort();
        families
    }
}

/// What a failed outcome means, in words; `None` for a pass.
fn failure_message(
    name: &str,
    adapter: &AdapterInfo,
    outcome: &GoldenOutcome,
    tolerance: Tolerance,
) -> Option<String> {
    let modes = format!(
        "set {MODE_ENV}=pending to write a render to review, or missing/overwrite to write goldens"
    );
    match outcome {
        GoldenOutcome::Matches { .. } | GoldenOutcome::Written { .. } => None,
        GoldenOutcome::Pending { new, diff, metrics } => Some(format!(
            "golden `{name}`: {}; review {}{} and accept it (Golden::accept_pending, or rename it to .png)",
            match metrics {
                Some(m) => format!("render differs ({}; tolerance {tolerance:?})", describe(m)),
                None => format!(
                    "no golden yet for adapter {} (family `{}`)",
                    adapter.summary(),
                    adapter.family()
                ),
            },
            new.display(),
            diff.as_ref()
                .map(|d| format!(" (difference map {})", d.display()))
                .unwrap_or_default()
        )),
        GoldenOutcome::Differs {
            metrics,
            path,
            golden_adapter,
        } => Some(format!(
            "golden `{name}` differs: {} (tolerance {tolerance:?}); golden {} made on {}, this render on {}; {modes}",
            describe(metrics),
            path.display(),
            golden_adapter
                .as_ref()
                .map_or("an unrecorded adapter".into(), AdapterInfo::summary),
            adapter.summary()
        )),
        GoldenOutcome::Missing {
            path,
            other_families,
        } => Some(format!(
            "golden `{name}`: none for adapter {} (family `{}`) at {}; {}; goldens are per adapter family; {modes}",
            adapter.summary(),
            adapter.family(),
            path.display(),
            if other_families.is_empty() {
                "no adapter has one".to_string()
            } else {
                format!("there are goldens for {}", other_families.join(", "))
            }
        )),
    }
}

fn describe(m: &metrics::ImageMetrics) -> String {
    if m.psnr_db.is_nan() {
        return "the sizes differ".into();
    }
    format!(
        "PSNR {:.1} dB, ꟻLIP mean {:.4}, {:.2} % of pixels off by more than 8/255",
        m.psnr_db,
        m.flip_mean,
        100.0 * m.differing_fraction
    )
}

/// A golden name becomes a file name: no separators, no leading dot.
fn check_name(name: &str) -> Result<(), HarnessError> {
    let bad = name.is_empty()
        || name.starts_with('.')
        || name.contains(['/', '\\', '@'])
        || name.ends_with(".new");
    if bad {
        return Err(HarnessError::Golden {
            path: name.into(),
            message: "a golden name must be non-empty, without `/`, `\\` or `@`, not start with `.`, not end in `.new`".into(),
        });
    }
    Ok(())
}

/// An exclusive lock on a golden folder, released on drop.
struct FolderLock(File);

impl FolderLock {
    fn acquire(dir: &Path) -> Result<Self, HarnessError> {
        let path = dir.join(LOCK_FILE);
        let err = |e: std::io::Error| HarnessError::Golden {
            path: path.display().to_string(),
            message: e.to_string(),
        };
        let file = File::options()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&path)
            .map_err(err)?;
        file.lock().map_err(err)?;
        Ok(Self(file))
    }
}

impl Drop for FolderLock {
    fn drop(&mut self) {
        let _ = self.0.unlock();
    }
}

fn remove_stale(paths: &[&Path]) {
    for p in paths {
        let _ = std::fs::remove_file(p);
    }
}

/// Writes an RGBA PNG with the adapter record, atomically (a temporary file,
/// then a rename), so a reader never sees half a file.
fn write_png(path: &Path, image: &RgbaImage, adapter: &AdapterInfo) -> Result<(), HarnessError> {
    let err = |message: String| HarnessError::Golden {
        path: path.display().to_string(),
        message,
    };
    let tmp = path.with_extension("png.tmp");
    let record = serde_json::to_string(adapter).map_err(|e| err(e.to_string()))?;
    {
        let file = File::create(&tmp).map_err(|e| err(e.to_string()))?;
        let mut encoder = png::Encoder::new(BufWriter::new(file), image.width(), image.height());
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        encoder
            .add_itxt_chunk(ADAPTER_KEYWORD.into(), record)
            .map_err(|e| err(e.to_string()))?;
        let mut writer = encoder.write_header().map_err(|e| err(e.to_string()))?;
        writer
            .write_image_data(image.as_raw())
            .map_err(|e| err(e.to_string()))?;
        writer.finish().map_err(|e| err(e.to_string()))?;
    }
    std::fs::rename(&tmp, path).map_err(|e| err(e.to_string()))
}

/// Reads a golden and its adapter record (`None` for a PNG without one).
fn read_png(path: &Path) -> Result<(RgbaImage, Option<AdapterInfo>), HarnessError> {
    let err = |message: String| HarnessError::Golden {
        path: path.display().to_string(),
        message,
    };
    let image = image::open(path)
        .map_err(|e| err(e.to_string()))?
        .to_rgba8();
    let file = File::open(path).map_err(|e| err(e.to_string()))?;
    let reader = png::Decoder::new(BufReader::new(file))
        .read_info()
        .map_err(|e| err(e.to_string()))?;
    let adapter = reader
        .info()
        .utf8_text
        .iter()
        .find(|t| t.keyword == ADAPTER_KEYWORD)
        .and_then(|t| t.get_text().ok())
        .and_then(|text| serde_json::from_str(&text).ok());
    Ok((image, adapter))
}

/// The adapter recorded in a golden PNG, if any.
pub fn recorded_adapter(path: &Path) -> Result<Option<AdapterInfo>, HarnessError> {
    read_png(path).map(|(_, adapter)| adapter)
}

fn write_diff(golden: &RgbaImage, image: &RgbaImage, path: &Path) -> Result<(), String> {
    let map = metrics::flip_map(golden, image).map_err(|e| e.to_string())?;
    let (w, h) = golden.dimensions();
    let float = nv_flip::FlipImageFloat::with_data(w, h, &map);
    let colored = float.apply_color_lut(&nv_flip::magma_lut());
    image::RgbImage::from_raw(w, h, colored.to_vec())
        .ok_or("diff buffer size")?
        .save(path)
        .map_err(|e| e.to_string())
}

/// A golden name from a function's type path (what
/// [`golden_name!`](crate::golden_name) passes in): the crate name and the
/// helper function's own name are dropped, closures are skipped, and the
/// remaining module path and test name are joined by `__`, as insta names
/// its snapshots.
///
/// ```
/// use optica_harness::golden::name_from_type_path;
/// assert_eq!(name_from_type_path("harness::scenes::lit_cube::here"), "scenes__lit_cube");
/// assert_eq!(name_from_type_path("render::flare::{{closure}}::here"), "flare");
/// ```
pub fn name_from_type_path(path: &str) -> String {
    let parts: Vec<&str> = path.split("::").filter(|p| !p.starts_with('{')).collect();
    // [crate, modules.., test, here]
    let inner = if parts.len() > 2 {
        &parts[1..parts.len() - 1]
    } else {
        &parts[..parts.len().saturating_sub(1)]
    };
    inner.join("__")
}

/// The name of the test function this is called in, for a golden:
/// `module__test_name`, without the crate name.
///
/// ```
/// fn lit_cube_matches() -> String {
///     optica_harness::golden_name!()
/// }
/// // In a test crate `render`, module `scenes`: "scenes__lit_cube_matches".
/// assert!(lit_cube_matches().ends_with("lit_cube_matches"));
/// ```
#[macro_export]
macro_rules! golden_name {
    () => {{
        fn here() {}
        $crate::golden::name_from_type_path(::std::any::type_name_of_val(&here))
    }};
}

/// Compares a [`RenderedFrame`](crate::RenderedFrame) with the golden named
/// after the calling test ([`golden_name!`](crate::golden_name)) in the
/// calling crate's `tests/golden/`, and panics with instructions unless it
/// matches (see [`Golden::assert_matches`]). An optional second argument is
/// the [`Tolerance`].
///
/// ```no_run
/// # let frame: optica_harness::RenderedFrame = unimplemented!();
/// optica_harness::assert_golden!(&frame);
/// optica_harness::assert_golden!(&frame, optica_harness::Tolerance { min_psnr_db: 30.0, ..Default::default() });
/// ```
#[macro_export]
macro_rules! assert_golden {
    ($frame:expr) => {
        $crate::assert_golden!($frame, $crate::Tolerance::default())
    };
    ($frame:expr, $tolerance:expr) => {
        $crate::Golden::new(::std::concat!(
            ::std::env!("CARGO_MANIFEST_DIR"),
            "/tests/golden"
        ))
        .assert_matches(&$crate::golden_name!(), $frame, $tolerance)
    };
}
