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
    render_base(output, sky, false)
}

/// As [`render`], the eye's base material `unlit` if asked.
fn render_base(output: EyeOutput, sky: Option<Color>, unlit: bool) -> RenderedFrame {
    Headless::new(SIZE, SIZE)
        .hdr(true)
        .render(move |app: &mut App| {
            if unlit {
                app.add_systems(
                    PostStartup,
                    |mut eyes: ResMut<Assets<optica_compound_eye::CompoundEyeMaterial>>| {
                        for (_, material) in eyes.iter_mut() {
                            material.base.unlit = true;
                        }
                    },
                );
            }
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
    escaping_rays_show_the_sky(false);
}

/// An unlit eye as the lit one: where a ray escapes it shows what lies
/// beyond the eye (before, the unlit branch showed the base colour there).
#[test]
fn escaping_rays_of_an_unlit_eye_show_the_environment() {
    escaping_rays_show_the_sky(true);
}

fn escaping_rays_show_the_sky(unlit: bool) {
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
    // red-brown surface's pixels, which only get its diffuse light (or,
    // unlit, show their base colour), and far more than under the other sky.
    let skies = [
        (Color::srgb(0.0, 1.0, 0.0), 1usize),
        (Color::srgb(0.0, 0.0, 1.0), 2),
    ];
    let frames: Vec<RenderedFrame> = skies
        .iter()
        .map(|&(sky, _)| render_base(EyeOutput::Shaded, Some(sky), unlit))
        .collect();
    for (k, &(_, channel)) in skies.iter().enumerate() {
        let mean = |frame: &RenderedFrame, px: &[(u32, u32)]| {
            let img = frame.hdr().expect("an HDR frame");
            assert!(
                img.as_raw().iter().all(|v| v.is_finite()),
                "a non-finite pixel"
            );
            px.iter()
                .map(|&(x, y)| img.get_pixel(x, y).0[channel])
                .sum::<f32>()
                / px.len() as f32
        };
        let (sky_seen, surface) = (mean(&frames[k], &escaped), mean(&frames[k], &absorbed));
        let other_sky = mean(&frames[1 - k], &escaped);
        eprintln!(
            "unlit {unlit}, sky channel {channel}: escaped {sky_seen} (under the other sky \
             {other_sky}), absorbed {surface}"
        );
        assert!(
            sky_seen > 3.0 * surface && sky_seen > 3.0 * other_sky,
            "unlit {unlit}, sky channel {channel}: escaped {sky_seen} (other sky {other_sky}), \
             absorbed {surface}"
        );
    }
}

/// Facets of ~0.4 px seen 60° off the normal: the prefilter's table leaves
/// a share of escaping rays (0.13) in every pixel, and each pixel shows the
/// mirror with that probability (a fixed dither, so that it is lit once).
#[test]
fn a_share_of_escaping_rays_shows_the_mirror_in_that_share_of_pixels() {
    let tiny = |output| CompoundEye {
        facets_per_uv: 200.0,
        lens_index: 0.8,
        output,
        ..default()
    };
    let share = Headless::new(SIZE, SIZE)
        .hdr(true)
        .render(scene(
            Mesh::from(Rectangle::new(2.0, 2.0)),
            Transform::IDENTITY,
            Some(CompoundEye {
                prefilter: true,
                ..tiny(EyeOutput::PigmentOnly)
            }),
            oblique(),
            ortho(2.4),
        ))
        .expect("render");
    let share = share.hdr().expect("an HDR frame");
    // The eye's pixels with a partial escape share.
    let partial: Vec<(u32, u32, f32)> = share
        .enumerate_pixels()
        .filter(|(_, _, p)| p.0[1] > 0.05 && p.0[1] < 0.95)
        .map(|(x, y, p)| (x, y, p.0[1]))
        .collect();
    assert!(
        partial.len() > 500,
        "{} pixels with a partial escape share",
        partial.len()
    );
    let mean_share = partial.iter().map(|p| f64::from(p.2)).sum::<f64>() / partial.len() as f64;

    // Under a green sky a mirror pixel is far greener than a pigment one.
    let lit = Headless::new(SIZE, SIZE)
        .hdr(true)
        .render(move |app: &mut App| {
            scene(
                Mesh::from(Rectangle::new(2.0, 2.0)),
                Transform::IDENTITY,
                Some(CompoundEye {
                    prefilter: true,
                    ..tiny(EyeOutput::Shaded)
                }),
                oblique(),
                ortho(2.4),
            )(app);
            app.add_systems(
                PostStartup,
                |mut commands: Commands,
                 mut images: ResMut<Assets<Image>>,
                 cameras: Query<Entity, With<Camera3d>>| {
                    let light = EnvironmentMapLight {
                        intensity: 400.0,
                        ..EnvironmentMapLight::solid_color(&mut images, Color::srgb(0.0, 1.0, 0.0))
                    };
                    for camera in &cameras {
                        commands.entity(camera).insert(light.clone());
                    }
                },
            );
        })
        .expect("render");
    let lit = lit.hdr().expect("an HDR frame");
    assert!(
        lit.as_raw().iter().all(|v| v.is_finite()),
        "a non-finite pixel"
    );
    let greens: Vec<f32> = partial
        .iter()
        .map(|&(x, y, _)| lit.get_pixel(x, y).0[1])
        .collect();
    let (lo, hi) = greens
        .iter()
        .fold((f32::MAX, f32::MIN), |(lo, hi), &g| (lo.min(g), hi.max(g)));
    assert!(
        hi > 3.0 * lo,
        "no mirror pixels stand out: green {lo}..{hi}"
    );
    let threshold = 0.5 * (lo + hi);
    let mirrors = greens.iter().filter(|&&g| g > threshold).count() as f64 / greens.len() as f64;
    assert!(
        (mirrors - mean_share).abs() < 0.02,
        "{:.3} of the pixels show the mirror, the mean escape share is {mean_share:.3}",
        mirrors
    );
}

/// 60° off the normal.
fn oblique() -> Transform {
    let dir = Vec3::new(-60f32.to_radians().sin(), 0.0, -60f32.to_radians().cos());
    Transform::from_translation(-5.0 * dir).looking_to(dir, Vec3::Y)
}
