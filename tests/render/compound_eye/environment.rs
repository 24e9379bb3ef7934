//! A ray that leaves the lattice after its lenses shows the view's
//! environment map, not a fixed colour.

use bevy::prelude::*;
use optica_compound_eye::{CompoundEye, EyeOutput};
use optica_harness::{Headless, RenderedFrame};

use super::{ortho, scene};

const SIZE: u32 = 96;

/// Lenses of index 0.8 bend rays away from their axis; seen 35° off the
/// normal, many leave the eye again (the parity test counts them).
fn eye(output: EyeOutput) -> CompoundEye {
    CompoundEye {
        lens_index: 0.8,
        output,
        ..CompoundEye::thesis(8.0, 0.8, 16)
    }
}

fn camera() -> Transform {
    let dir = Vec3::new(-0.6, -0.35, -1.0).normalize();
    Transform::from_translation(-5.0 * dir).looking_to(dir, Vec3::Y)
}

/// The eye lit by a uniform environment map of `sky` on the camera.
fn render(output: EyeOutput, sky: Option<Color>) -> RenderedFrame {
    Headless::new(SIZE, SIZE)
        .hdr(true)
        .render(move |app: &mut App| {
            scene(
                Mesh::from(Rectangle::new(2.0, 2.0)),
                Transform::IDENTITY,
                Some(eye(output)),
                camera(),
                ortho(2.4),
            )(app);
            if let Some(sky) = sky {
                app.add_systems(
                    PostStartup,
                    move |mut commands: Commands,
                          mut images: ResMut<Assets<Image>>,
                          cameras: Query<Entity, With<Camera3d>>| {
                        let light = EnvironmentMapLight {
                            intensity: 400.0,
                            ..EnvironmentMapLight::solid_color(&mut images, sky)
                        };
                        for camera in &cameras {
                            commands.entity(camera).insert(light.clone());
                        }
                    },
                );
            }
        })
        .expect("render")
}

#[test]
fn escaping_rays_show_the_environment() {
    // Where the rays escape: the optics-only output's green channel.
    let optics = render(EyeOutput::PigmentOnly, None);
    let optics = optics.hdr().expect("an HDR frame");
    let escaped: Vec<(u32, u32)> = optics
        .enumerate_pixels()
        .filter(|(_, _, p)| p.0[1] > 0.99)
        .map(|(x, y, _)| (x, y))
        .collect();
    let absorbed: Vec<(u32, u32)> = optics
        .enumerate_pixels()
        .filter(|(_, _, p)| p.0[1] == 0.0 && p.0[0] < 0.99)
        .map(|(x, y, _)| (x, y))
        .collect();
    assert!(
        escaped.len() > 20 && absorbed.len() > 20,
        "{} escaped, {} absorbed pixels",
        escaped.len(),
        absorbed.len()
    );
    // Under a green sky and a blue sky: the escaping pixels take the sky's
    // colour (a mirror-like view along the escaping ray), far more than the
    // red-brown surface's pixels, which only get its diffuse light.
    for (sky, channel) in [
        (Color::srgb(0.0, 1.0, 0.0), 1usize),
        (Color::srgb(0.0, 0.0, 1.0), 2),
    ] {
        let frame = render(EyeOutput::Shaded, Some(sky));
        let img = frame.hdr().expect("an HDR frame");
        assert!(
            img.as_raw().iter().all(|v| v.is_finite()),
            "a non-finite pixel"
        );
        let mean = |px: &[(u32, u32)]| {
            px.iter()
                .map(|&(x, y)| img.get_pixel(x, y).0[channel])
                .sum::<f32>()
                / px.len() as f32
        };
        let (sky_seen, surface) = (mean(&escaped), mean(&absorbed));
        assert!(
            sky_seen > 3.0 * surface,
            "sky channel {channel}: escaped {sky_seen}, absorbed {surface}"
        );
    }
}
