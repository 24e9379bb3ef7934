//! Golden images of the coated Tessar's flare on lavapipe with the default
//! settings (ghosts with ringing, the starburst with its dust and
//! scratches): a sun 6° and 15° off the axis (up and to the right), 128²,
//! 24² rays per ghost, three wavelengths, six blades, untonemapped on
//! black.

use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_harness::{Headless, RenderedFrame, assert_golden};
use optica_lens_flare::{LensFlare, LensFlarePlugin};

fn flare_at(field_deg: f32) -> RenderedFrame {
    let t = field_deg.to_radians();
    // Travelling into the camera from up and to the right.
    let travel = Vec3::new(-t.sin() * 0.6, -t.sin() * 0.8, t.cos());
    Headless::new(128, 128)
        .frames(12)
        .render(move |app: &mut App| {
            app.add_plugins(LensFlarePlugin);
            app.add_systems(
                Startup,
                move |mut commands: Commands, assets: Res<AssetServer>| {
                    commands.spawn(super::sun(travel, 100_000.0));
                    commands.spawn((
                        Camera3d::default(),
                        Camera {
                            clear_color: ClearColorConfig::Custom(Color::BLACK),
                            ..default()
                        },
                        Tonemapping::None,
                        Msaa::Off,
                        LensFlare {
                            grid: 24,
                            intensity: 4.0,
                            ..LensFlare::new(assets.load("lenses/tessar-us2854889.lens"))
                        },
                    ));
                },
            );
        })
        .expect("render")
}

#[test]
fn tessar_sun_6_degrees_off_axis() {
    assert_golden!(&flare_at(6.0));
}

#[test]
fn tessar_sun_15_degrees_off_axis() {
    assert_golden!(&flare_at(15.0));
}
