//! What a headless render returns.

use bevy::color::{ColorToPacked, LinearRgba, Srgba};
use image::{Rgba32FImage, RgbaImage};

use crate::AdapterInfo;

/// The pixels of a frame: 8-bit sRGB, or linear HDR floats.
#[derive(Clone, Debug)]
pub enum Pixels {
    /// 8-bit sRGB with alpha, as the default (tonemapped) camera writes it.
    Rgba8(RgbaImage),
    /// Linear RGBA floats from an `Rgba16Float` target, no tonemapping.
    Hdr(Rgba32FImage),
}

/// One rendered frame and where it came from.
#[derive(Clone, Debug)]
pub struct RenderedFrame {
    /// The adapter that rendered it.
    pub adapter: AdapterInfo,
    /// The pixels, 8-bit or HDR as [`Headless::hdr`](crate::Headless::hdr) asked.
    pub pixels: Pixels,
    /// Number of render and compute pipelines that compiled during the run.
    pub pipelines: usize,
}

impl RenderedFrame {
    /// Width in pixels.
    pub fn width(&self) -> u32 {
        match &self.pixels {
            Pixels::Rgba8(img) => img.width(),
            Pixels::Hdr(img) => img.width(),
        }
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        match &self.pixels {
            Pixels::Rgba8(img) => img.height(),
            Pixels::Hdr(img) => img.height(),
        }
    }

    /// The HDR pixels, if this is an HDR frame.
    pub fn hdr(&self) -> Option<&Rgba32FImage> {
        match &self.pixels {
            Pixels::Hdr(img) => Some(img),
            Pixels::Rgba8(_) => None,
        }
    }

    /// The 8-bit image; for an HDR frame, its linear values clamped to
    /// [0, 1] and encoded as sRGB (no tonemapping curve).
    pub fn to_rgba8(&self) -> RgbaImage {
        match &self.pixels {
            Pixels::Rgba8(img) => img.clone(),
            Pixels::Hdr(img) => RgbaImage::from_fn(img.width(), img.height(), |x, y| {
                let [r, g, b, a] = img.get_pixel(x, y).0;
                // NaN would clamp to 0 silently; make it visible as magenta.
                if [r, g, b, a].iter().any(|v| v.is_nan()) {
                    return image::Rgba([255, 0, 255, 255]);
                }
                image::Rgba(Srgba::from(LinearRgba::new(r, g, b, a)).to_u8_array())
            }),
        }
    }
}
