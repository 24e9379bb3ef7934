//! Image metrics on hand-made images.

use image::RgbaImage;
use optica_harness::metrics::{SizeMismatch, compare, psnr};

fn gradient(shift: u8) -> RgbaImage {
    RgbaImage::from_fn(64, 64, |x, y| {
        image::Rgba([(x * 4) as u8, (y * 4) as u8, shift, 255])
    })
}

#[test]
fn identical_images_are_perfect() {
    let m = compare(&gradient(0), &gradient(0)).unwrap();
    assert!(m.psnr_db.is_infinite());
    assert!((m.ssim - 1.0).abs() < 1e-9, "ssim {}", m.ssim);
    assert_eq!(m.flip_mean, 0.0);
    assert_eq!(m.differing_fraction, 0.0);
}

#[test]
fn psnr_of_a_uniform_offset_is_analytic() {
    // Blue differs by 10 on every pixel, red and green are equal:
    // MSE = 100 / 3, PSNR = 10 log10(255² · 3 / 100) = 32.9020 dB.
    let p = psnr(&gradient(0), &gradient(10)).unwrap();
    assert!((p - 32.9020).abs() < 1e-3, "{p}");
}

#[test]
fn metrics_grow_with_the_difference() {
    let small = compare(&gradient(0), &gradient(10)).unwrap();
    let large = compare(&gradient(0), &gradient(120)).unwrap();
    assert!(large.psnr_db < small.psnr_db);
    assert!(large.flip_mean > small.flip_mean && small.flip_mean > 0.0);
    assert!(large.ssim <= small.ssim);
    assert_eq!(large.differing_fraction, 1.0);
}

#[test]
fn sizes_must_match() {
    let other = RgbaImage::new(32, 64);
    assert_eq!(
        psnr(&gradient(0), &other),
        Err(SizeMismatch((64, 64), (32, 64)))
    );
}
