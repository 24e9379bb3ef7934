//! The diffraction textures of a [`LensFlare`] camera, made on the CPU
//! (`optica_optics::lens_flare`'s FFTs) when the iris or their settings
//! change, and kept as images the draw pass reads: the starburst (RGB,
//! summed over the flare's wavelengths) and the ringing (the iris's
//! propagated intensity at 650, 550 and 450 nm in R, G and B).

use bevy::asset::RenderAssetUsages;
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use optica_optics::lens_flare::{
    Aperture, LensDirt, pupil_image, ringing, spectral_weight, starburst,
};

use crate::{Error, LensFlare};

/// The wavelengths of the ringing texture's R, G and B, nm.
pub const RINGING_NM: [f64; 3] = [650.0, 550.0, 450.0];

/// An RGBA float image of `side`² texels.
fn float_image(side: usize, rgb: impl Iterator<Item = [f32; 3]>) -> Image {
    let data = rgb
        .flat_map(|[r, g, b]| [r, g, b, 1.0])
        .flat_map(f32::to_le_bytes)
        .collect();
    Image::new(
        Extent3d {
            width: side as u32,
            height: side as u32,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        data,
        TextureFormat::Rgba32Float,
        RenderAssetUsages::RENDER_WORLD,
    )
}

/// The starburst image of `flare` through `aperture`, or `None` when it is
/// off.
pub fn starburst_image(
    flare: &LensFlare,
    aperture: &Aperture,
) -> Result<Option<Image>, Error> {
    let Some(settings) = flare.starburst else {
        return Ok(None);
    };
    let side = settings.resolution as usize;
    let dirt = LensDirt {
        specks: settings.specks,
        scratches: settings.scratches,
        seed: settings.seed,
    };
    let pupil = pupil_image(aperture, side, &dirt)?;
    let wavelengths = flare.wavelengths_nm();
    let samples: Vec<(f64, [f64; 3])> = wavelengths
        .iter()
        .map(|&wl| (wl, spectral_weight(wl, &wavelengths).to_array()))
        .collect();
    let shortest = wavelengths.iter().copied().fold(f64::INFINITY, f64::min);
    let burst = starburst(&pupil, &samples, shortest)?;
    Ok(Some(float_image(side, burst.rgb.into_iter())))
}

/// The ringing image of `flare` through `aperture`, or `None` when it is
/// off.
pub fn ringing_image(
    flare: &LensFlare,
    aperture: &Aperture,
) -> Result<Option<Image>, Error> {
    let Some(settings) = flare.ringing else {
        return Ok(None);
    };
    let side = settings.resolution as usize;
    let pupil = pupil_image(aperture, side, &LensDirt::default())?;
    let channels: Vec<Vec<f64>> = RINGING_NM
        .iter()
        .map(|&wl| ringing(&pupil, wl, f64::from(settings.fresnel_number) * 550.0 / wl))
        .collect::<Result<_, _>>()?;
    let texels = (0..side * side).map(|k| {
        [
            channels[0][k] as f32,
            channels[1][k] as f32,
            channels[2][k] as f32,
        ]
    });
    Ok(Some(float_image(side, texels)))
}
