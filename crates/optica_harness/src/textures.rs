//! Test patterns as Bevy images: what a render test puts in front of a
//! camera to measure what an effect does to it.
//!
//! - [`checker`]: a checkerboard, for blur and sharpness;
//! - [`coordinates`]: a texture whose texels hold their own place on the
//!   surface, so that every pixel of a render says which point of the
//!   surface it shows: distortion and displacement in pixels;
//! - [`gaussian_spot`]: a soft spot, whose image moments do not depend on
//!   how the pixel grid falls on it: blur sizes from moments.

use bevy::asset::RenderAssetUsages;
use bevy::image::{Image, ImageSampler, ImageSamplerDescriptor};
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};

/// A square `n`×`n` sRGB checkerboard of `cells` cells a side, `dark` and
/// `light` grey levels (0–255), sampled nearest (hard edges).
pub fn checker(n: u32, cells: u32, dark: u8, light: u8) -> Image {
    let mut data = Vec::with_capacity((n * n * 4) as usize);
    for y in 0..n {
        for x in 0..n {
            let v = if ((x * cells / n) + (y * cells / n)).is_multiple_of(2) {
                light
            } else {
                dark
            };
            data.extend_from_slice(&[v, v, v, 255]);
        }
    }
    let mut image = square(n, data, TextureFormat::Rgba8UnormSrgb);
    image.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor::nearest());
    image
}

/// A square `n`×`n` float texture over a surface spanning `±half` on both
/// axes: red and green hold the texel's centre `(x, y)` (x to the right,
/// y up, in the surface's units), blue holds 1 (so a render read back in
/// HDR tells the surface from the background), sampled linearly (the
/// coordinates are continuous between texels). Use it unlit; `Rgba16Float`
/// readbacks hold `±2` to about a thousandth.
pub fn coordinates(n: u32, half: f32) -> Image {
    coordinates_in(n, half, [0, 1, 2])
}

/// [`coordinates`] with x, y and the 1 in the channels `[x, y, one]`
/// (0 red, 1 green, 2 blue; alpha holds 1): `[2, 1, 0]` puts x in blue, to
/// read where a colour-dependent view (chromatic aberration) takes blue
/// from.
pub fn coordinates_in(n: u32, half: f32, channels: [usize; 3]) -> Image {
    let mut data = Vec::with_capacity((n * n * 16) as usize);
    for j in 0..n {
        for i in 0..n {
            let x = ((i as f32 + 0.5) / n as f32 - 0.5) * 2.0 * half;
            let y = (0.5 - (j as f32 + 0.5) / n as f32) * 2.0 * half;
            let mut texel = [1.0f32; 4];
            texel[channels[0]] = x;
            texel[channels[1]] = y;
            texel[channels[2]] = 1.0;
            for c in texel {
                data.extend_from_slice(&c.to_le_bytes());
            }
        }
    }
    let mut image = square(n, data, TextureFormat::Rgba32Float);
    image.sampler = ImageSampler::linear();
    image
}

/// [`coordinates`] scaled by `tag`: red, green and blue hold `(x, y, 1)·tag`,
/// so that a pixel says which of several surfaces it shows (`round(blue)`)
/// and where on it (`red / blue`, `green / blue`), even when the view
/// scales the colour (a mirror's reflectance, a lit reflection).
pub fn coordinates_tagged(n: u32, half: f32, tag: f32) -> Image {
    let mut image = coordinates(n, half);
    if let Some(data) = image.data.as_mut() {
        for texel in data.chunks_exact_mut(16) {
            for c in texel[..12].chunks_exact_mut(4) {
                let v = f32::from_le_bytes([c[0], c[1], c[2], c[3]]) * tag;
                c.copy_from_slice(&v.to_le_bytes());
            }
        }
    }
    image
}

/// A soft white spot on black: a Gaussian of standard deviation `sigma`
/// (a fraction of the texture's side) in the middle of an `n`×`n` linear
/// texture, sampled linearly.
pub fn gaussian_spot(n: u32, sigma: f32) -> Image {
    let mut data = Vec::with_capacity((n * n * 4) as usize);
    for y in 0..n {
        for x in 0..n {
            let u = (x as f32 + 0.5) / n as f32 - 0.5;
            let v = (y as f32 + 0.5) / n as f32 - 0.5;
            let g = (-(u * u + v * v) / (2.0 * sigma * sigma)).exp();
            let c = (g * 255.0).round() as u8;
            data.extend_from_slice(&[c, c, c, 255]);
        }
    }
    let mut image = square(n, data, TextureFormat::Rgba8Unorm);
    image.sampler = ImageSampler::linear();
    image
}

fn square(n: u32, data: Vec<u8>, format: TextureFormat) -> Image {
    Image::new(
        Extent3d {
            width: n,
            height: n,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        data,
        format,
        RenderAssetUsages::RENDER_WORLD,
    )
}
