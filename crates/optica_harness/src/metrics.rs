//! Image metrics: PSNR, SSIM (image-compare) and FLIP (NVIDIA's ꟻLIP via nv-flip).
//!
//! All take two 8-bit sRGB images of the same size; alpha is ignored.

use image::{RgbImage, RgbaImage};

/// The three metrics of one comparison.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageMetrics {
    /// Peak signal-to-noise ratio over RGB in dB (`f64::INFINITY` for identical images).
    pub psnr_db: f64,
    /// Mean structural similarity (8×8 windows, the lowest of the three channels), 1 = identical.
    pub ssim: f64,
    /// Mean ꟻLIP error in [0, 1] at the default 67 pixels per degree, 0 = identical.
    pub flip_mean: f64,
    /// Largest per-pixel ꟻLIP error.
    pub flip_max: f64,
    /// Fraction of pixels whose largest channel difference exceeds 8/255.
    pub differing_fraction: f64,
}

impl ImageMetrics {
    /// The metrics of two images that cannot be compared (different sizes):
    /// NaN PSNR, SSIM and ꟻLIP, every pixel differing. No tolerance accepts them.
    pub fn incomparable() -> Self {
        Self {
            psnr_db: f64::NAN,
            ssim: f64::NAN,
            flip_mean: f64::NAN,
            flip_max: f64::NAN,
            differing_fraction: 1.0,
        }
    }
}

/// Why two images cannot be compared.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("images differ in size: {0:?} vs {1:?}")]
pub struct SizeMismatch(pub (u32, u32), pub (u32, u32));

fn rgb(img: &RgbaImage) -> RgbImage {
    image::DynamicImage::ImageRgba8(img.clone()).to_rgb8()
}

/// PSNR in dB over the RGB channels.
pub fn psnr(reference: &RgbaImage, test: &RgbaImage) -> Result<f64, SizeMismatch> {
    check(reference, test)?;
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (a, b) in reference.pixels().zip(test.pixels()) {
        for c in 0..3 {
            let d = a[c] as f64 - b[c] as f64;
            sum += d * d;
            n += 1;
        }
    }
    let mse = sum / n.max(1) as f64;
    Ok(if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    })
}

/// Mean SSIM (the lowest of the three channels).
pub fn ssim(reference: &RgbaImage, test: &RgbaImage) -> Result<f64, SizeMismatch> {
    check(reference, test)?;
    image_compare::rgb_similarity_structure(
        &image_compare::Algorithm::MSSIMSimple,
        &rgb(reference),
        &rgb(test),
    )
    .map(|s| s.score)
    .map_err(|_| SizeMismatch(reference.dimensions(), test.dimensions()))
}

/// The ꟻLIP error map (values in [0, 1], one per pixel) at the default viewing
/// condition.
pub fn flip_map(reference: &RgbaImage, test: &RgbaImage) -> Result<Vec<f32>, SizeMismatch> {
    check(reference, test)?;
    let (w, h) = reference.dimensions();
    let a = nv_flip::FlipImageRgb8::with_data(w, h, rgb(reference).as_raw());
    let b = nv_flip::FlipImageRgb8::with_data(w, h, rgb(test).as_raw());
    Ok(nv_flip::flip(a, b, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec())
}

/// All metrics at once.
pub fn compare(reference: &RgbaImage, test: &RgbaImage) -> Result<ImageMetrics, SizeMismatch> {
    let map = flip_map(reference, test)?;
    let flip_mean = map.iter().map(|&v| v as f64).sum::<f64>() / map.len().max(1) as f64;
    let flip_max = map.iter().fold(0.0f32, |m, &v| m.max(v)) as f64;
    let differing = reference
        .pixels()
        .zip(test.pixels())
        .filter(|(a, b)| (0..3).any(|c| a[c].abs_diff(b[c]) > 8))
        .count();
    Ok(ImageMetrics {
        psnr_db: psnr(reference, test)?,
        ssim: ssim(reference, test)?,
        flip_mean,
        flip_max,
        differing_fraction: differing as f64
            / (reference.width() * reference.height()).max(1) as f64,
    })
}

fn check(a: &RgbaImage, b: &RgbaImage) -> Result<(), SizeMismatch> {
    if a.dimensions() != b.dimensions() {
        return Err(SizeMismatch(a.dimensions(), b.dimensions()));
    }
    Ok(())
}
