//! Golden-image tests: compare a render with a checked-in PNG.
//!
//! Goldens live in a folder of the test crate (optica keeps them in
//! `tests/golden/`). Set `OPTICA_UPDATE_GOLDEN=1` to write the current render
//! as the new golden instead of comparing. On failure the render and a diff
//! image (ꟻLIP error, magma colour map) are written beside the golden as
//! `<name>.actual.png` and `<name>.diff.png`.
//!
//! ```no_run
//! use optica_harness::{Golden, Tolerance};
//! # let image = image::RgbaImage::new(1, 1);
//! let golden = Golden::new(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden"));
//! golden.assert_matches("lit_cube", &image, Tolerance::default());
//! ```

use std::path::{Path, PathBuf};

use image::RgbaImage;

use crate::{HarnessError, metrics};

/// The environment variable that turns comparisons into updates.
pub const UPDATE_ENV: &str = "OPTICA_UPDATE_GOLDEN";

/// How close a render must be to its golden.
#[derive(Clone, Copy, Debug)]
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
    /// fails; loose enough for rasteriser noise between Mesa versions.
    fn default() -> Self {
        Self { min_psnr_db: 38.0, max_flip_mean: 0.01, max_differing_fraction: 0.005 }
    }
}

/// The outcome of a comparison.
#[derive(Clone, Debug)]
pub enum GoldenOutcome {
    /// Within tolerance.
    Matches(metrics::ImageMetrics),
    /// The golden was (re)written because [`UPDATE_ENV`] was set or no golden existed and updating was asked.
    Updated(PathBuf),
    /// Out of tolerance; the render and a diff image were written.
    Differs {
        /// The metrics that failed.
        metrics: metrics::ImageMetrics,
        /// Where the render was written.
        actual: PathBuf,
        /// Where the diff image was written.
        diff: PathBuf,
    },
}

/// A folder of golden images.
#[derive(Clone, Debug)]
pub struct Golden {
    dir: PathBuf,
    update: bool,
}

impl Golden {
    /// Goldens in `dir`; updating when [`UPDATE_ENV`] is set to anything but `0`.
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        let update = std::env::var(UPDATE_ENV).map(|v| v != "0" && !v.is_empty()).unwrap_or(false);
        Self { dir: dir.into(), update }
    }

    /// Forces update mode on or off (tests of the harness itself use this).
    pub fn updating(mut self, update: bool) -> Self {
        self.update = update;
        self
    }

    /// The path of golden `name`.
    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(format!("{name}.png"))
    }

    /// Compares `image` with golden `name`, or writes it in update mode.
    pub fn compare(&self, name: &str, image: &RgbaImage, tolerance: Tolerance) -> Result<GoldenOutcome, HarnessError> {
        let path = self.path(name);
        let err = |message: String| HarnessError::Golden { path: path.display().to_string(), message };
        if self.update {
            std::fs::create_dir_all(&self.dir).map_err(|e| err(e.to_string()))?;
            image.save(&path).map_err(|e| err(e.to_string()))?;
            return Ok(GoldenOutcome::Updated(path));
        }
        let golden = image::open(&path)
            .map_err(|e| err(format!("{e} (run with {UPDATE_ENV}=1 to create it)")))?
            .to_rgba8();
        let m = metrics::compare(&golden, image).map_err(|e| err(e.to_string()))?;
        let ok = m.psnr_db >= tolerance.min_psnr_db
            && m.flip_mean <= tolerance.max_flip_mean
            && m.differing_fraction <= tolerance.max_differing_fraction;
        if ok {
            return Ok(GoldenOutcome::Matches(m));
        }
        let actual = self.dir.join(format!("{name}.actual.png"));
        let diff = self.dir.join(format!("{name}.diff.png"));
        image.save(&actual).map_err(|e| err(e.to_string()))?;
        write_diff(&golden, image, &diff).map_err(|e| err(e.to_string()))?;
        Ok(GoldenOutcome::Differs { metrics: m, actual, diff })
    }

    /// Like [`Golden::compare`], panicking with the metrics and file paths on
    /// a mismatch: for use in `#[test]`s.
    #[track_caller]
    pub fn assert_matches(&self, name: &str, image: &RgbaImage, tolerance: Tolerance) -> GoldenOutcome {
        match self.compare(name, image, tolerance) {
            Ok(GoldenOutcome::Differs { metrics, actual, diff }) => panic!(
                "golden `{name}` differs: {metrics:?} (tolerance {tolerance:?}); render {}, diff {}",
                actual.display(),
                diff.display()
            ),
            Ok(outcome) => outcome,
            Err(e) => panic!("{e}"),
        }
    }
}

fn write_diff(golden: &RgbaImage, image: &RgbaImage, path: &Path) -> Result<(), String> {
    let map = metrics::flip_map(golden, image).map_err(|e| e.to_string())?;
    let (w, h) = golden.dimensions();
    let float = nv_flip::FlipImageFloat::with_data(w, h, &map);
    let colored = float.apply_color_lut(&nv_flip::magma_lut());
    image::RgbImage::from_raw(w, h, colored.to_vec()).ok_or("diff buffer size")?.save(path).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(offset: u32) -> RgbaImage {
        RgbaImage::from_fn(48, 48, |x, y| {
            let on = ((x + offset) / 8 + y / 8).is_multiple_of(2);
            image::Rgba(if on { [230, 200, 40, 255] } else { [20, 40, 90, 255] })
        })
    }

    #[test]
    fn update_then_match_then_differ() {
        let dir = std::env::temp_dir().join(format!("optica-golden-{}", std::process::id()));
        let writer = Golden::new(&dir).updating(true);
        assert!(matches!(writer.compare("c", &checker(0), Tolerance::default()).unwrap(), GoldenOutcome::Updated(_)));
        let reader = Golden::new(&dir).updating(false);
        assert!(matches!(reader.compare("c", &checker(0), Tolerance::default()).unwrap(), GoldenOutcome::Matches(_)));
        match reader.compare("c", &checker(3), Tolerance::default()).unwrap() {
            GoldenOutcome::Differs { actual, diff, .. } => assert!(actual.exists() && diff.exists()),
            other => panic!("a shifted checker must differ, got {other:?}"),
        }
        let black = RgbaImage::from_pixel(48, 48, image::Rgba([0, 0, 0, 255]));
        assert!(matches!(reader.compare("c", &black, Tolerance::default()).unwrap(), GoldenOutcome::Differs { .. }));
        assert!(reader.compare("missing", &black, Tolerance::default()).is_err());
        let _ = std::fs::remove_dir_all(dir);
    }
}
