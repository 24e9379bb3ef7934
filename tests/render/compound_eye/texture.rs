//! The pigment texture: its red channel is `c_t`, sampled in its own UV
//! space (scale and offset per facet), in place of the procedural disc.

use bevy::asset::RenderAssetUsages;
use bevy::image::{ImageAddressMode, ImageSampler, ImageSamplerDescriptor};
use bevy::prelude::*;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use optica_compound_eye::{CompoundEye, EyeLattice, EyeOutput};
use optica_harness::{Headless, RenderedFrame};

use super::{ortho, scene};

const SIZE: u32 = 64;

/// Two texels, 0.2 and 0.8, sampled without filtering, tiled.
fn two_texels() -> Image {
    let mut image = Image::new(
        Extent3d {
            width: 2,
            height: 1,
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        vec![51, 204],
        TextureFormat::R8Unorm,
        RenderAssetUsages::RENDER_WORLD,
    );
    image.sampler = ImageSampler::Descriptor(ImageSamplerDescriptor {
        address_mode_u: ImageAddressMode::Repeat,
        address_mode_v: ImageAddressMode::Repeat,
        ..ImageSamplerDescriptor::nearest()
    });
    image
}

/// The optics-only output of a front view of a quad covered by the eye;
/// `texture` (with its UV scale and offset) replaces the procedural pigment.
fn render(texture: Option<(Vec2, Vec2)>) -> RenderedFrame {
    let eye = CompoundEye {
        facets_per_uv: 6.0,
        lattice: EyeLattice::Hexagonal,
        slices: 16,
        fresnel: false,
        prefilter: false,
        output: EyeOutput::PigmentOnly,
        ..default()
    };
    let camera = Transform::from_xyz(0.0, 0.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y);
    Headless::new(SIZE, SIZE)
        .hdr(true)
        .render(move |app: &mut App| {
            let eye = match texture {
                Some((scale, offset)) => {
                    let handle = app
                        .world_mut()
                        .resource_mut::<Assets<Image>>()
                        .add(two_texels());
                    CompoundEye {
                        pigment_texture: Some(handle),
                        pigment_uv_scale: scale,
                        pigment_uv_offset: offset,
                        ..eye
                    }
                }
                None => eye,
            };
            scene(
                Mesh::from(Rectangle::new(2.0, 2.0)),
                Transform::IDENTITY,
                Some(eye),
                camera,
                ortho(2.4),
            )(app)
        })
        .expect("render")
}

/// `c_t·T` (red) of the pixels in the quad's inner part whose ray reached
/// the pigment (green, the environment weight, is 0).
fn pigment_values(frame: &RenderedFrame) -> Vec<f32> {
    let img = frame.hdr().expect("an HDR frame");
    let (lo, hi) = (SIZE / 5, SIZE - SIZE / 5);
    let mut out = Vec::new();
    for y in lo..hi {
        for x in lo..hi {
            let [r, g, _, _] = img.get_pixel(x, y).0;
            if g == 0.0 {
                out.push(r);
            }
        }
    }
    out
}

#[test]
fn the_texture_replaces_the_procedural_pigment_in_its_own_uv_space() {
    let inner = ((SIZE - 2 * (SIZE / 5)) * (SIZE - 2 * (SIZE / 5))) as usize;
    // The procedural disc: dark centres and clear rims, many values.
    let disc = pigment_values(&render(None));
    assert!(
        disc.len() > inner / 2,
        "only {} of {inner} rays reached the pigment",
        disc.len()
    );
    let (min, max) = disc
        .iter()
        .fold((f32::MAX, f32::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    assert!(
        max - min > 0.5,
        "the procedural pigment is flat: {min}..{max}"
    );
    // A zero scale pins every pigment point to one texture coordinate: the
    // offset alone picks the texel, whatever the lattice does.
    for (offset, texel) in [(Vec2::new(0.25, 0.5), 0.2f32), (Vec2::new(0.75, 0.5), 0.8)] {
        let values = pigment_values(&render(Some((Vec2::ZERO, offset))));
        assert!(
            values.len() > inner / 2,
            "offset {offset}: only {} rays reached the pigment",
            values.len()
        );
        let worst = values
            .iter()
            .map(|v| (v - texel).abs())
            .fold(0.0f32, f32::max);
        assert!(
            worst < 2e-3,
            "offset {offset}: c_t off the texel {texel} by up to {worst}"
        );
    }
    // Half a texel per facet: the pigment coordinate, in facets, now walks
    // over both texels, and both show up.
    let values = pigment_values(&render(Some((Vec2::new(0.5, 0.0), Vec2::new(0.0, 0.5)))));
    let near = |t: f32| values.iter().filter(|v| (*v - t).abs() < 2e-3).count();
    assert_eq!(
        near(0.2) + near(0.8),
        values.len(),
        "a value that is neither texel"
    );
    assert!(
        near(0.2) > values.len() / 5 && near(0.8) > values.len() / 5,
        "0.2: {}, 0.8: {}",
        near(0.2),
        near(0.8)
    );
}
