//! Occlusion by the scene's depth on lavapipe: a sun or a point light
//! behind a wall gives no flare, moved out it flares fully, half behind an
//! edge it flares in part; the light's own bulb does not hide it; MSAA
//! depth is read as well; and the visibility's history makes a change
//! fade in over frames instead of popping.

use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_harness::Headless;
use optica_lens_flare::{
    DEFAULT_COARSE_GHOST_PX, FlareOcclusion, FlareSource, LensFlare, LensFlarePlugin,
};

const SIZE: u32 = 128;
const TESSAR: &str = "lenses/tessar-us2854889.lens";

/// The sun's light travels along this (12° off the axis, from the upper
/// right of the view).
fn travel() -> Vec3 {
    Vec3::new(-0.15, -0.15, 1.0).normalize()
}

/// Where the sun's image is, 6 units in front of the camera.
fn towards_sun() -> Vec3 {
    -travel() * 6.0
}

#[derive(Clone, Copy)]
enum Light {
    Sun,
    /// A point light with a small bulb round it, 6 units out towards the
    /// sun's image.
    Bulb,
}

#[derive(Component)]
struct Wall;

struct Case {
    light: Light,
    /// The wall's offset from the line of sight to the light (it is 1.5
    /// units wide, 4 units from the camera); `None` for no wall.
    wall: Option<Vec2>,
    msaa: Msaa,
    occlusion: Option<FlareOcclusion>,
    /// At this frame the wall is moved out of the way.
    move_out_at: Option<u32>,
    /// `LensFlare::coarse_ghost_px`.
    coarse_ghost_px: Option<f32>,
}

impl Default for Case {
    fn default() -> Self {
        Self {
            light: Light::Sun,
            wall: None,
            msaa: Msaa::Off,
            occlusion: Some(FlareOcclusion::default()),
            move_out_at: None,
            coarse_ghost_px: Some(DEFAULT_COARSE_GHOST_PX),
        }
    }
}

/// The flare's total light (sum of all channels; walls are black and
/// unlit, so the frame is the flare).
fn total(case: Case) -> f64 {
    let frame = Headless::new(SIZE, SIZE)
        .hdr(true)
        .frames(14)
        .render(scene(case))
        .expect("render");
    let img = frame.hdr().expect("HDR");
    assert!(
        img.as_raw().iter().all(|v| v.is_finite()),
        "a non-finite pixel"
    );
    img.as_raw()
        .chunks(4)
        .map(|p| f64::from(p[0] + p[1] + p[2]))
        .sum()
}

/// The scene of `case`: its light, its wall, the Tessar's flare.
fn scene(case: Case) -> impl FnOnce(&mut App) {
    let Case {
        light,
        wall,
        msaa,
        occlusion,
        move_out_at,
        coarse_ghost_px,
    } = case;
    move |app: &mut App| {
        app.add_plugins(LensFlarePlugin);
        app.add_systems(
            Startup,
            move |mut commands: Commands,
                  assets: Res<AssetServer>,
                  mut meshes: ResMut<Assets<Mesh>>,
                  mut materials: ResMut<Assets<StandardMaterial>>| {
                let black = materials.add(super::black_wall());
                match light {
                    Light::Sun => {
                        commands.spawn(super::sun(travel(), 100_000.0));
                    }
                    Light::Bulb => {
                        commands.spawn((
                            PointLight {
                                intensity: 4.0e8,
                                range: 100.0,
                                ..default()
                            },
                            Transform::from_translation(towards_sun()),
                            FlareSource::default(),
                            Mesh3d(meshes.add(Sphere::new(0.05))),
                            MeshMaterial3d(black.clone()),
                        ));
                    }
                }
                if let Some(offset) = wall {
                    // Facing the camera, 4 units out along the line of
                    // sight to the light, shifted by `offset`.
                    let centre = towards_sun().normalize() * 4.0;
                    let rotation = Transform::IDENTITY.looking_to(centre, Vec3::Y).rotation;
                    let shifted = centre + rotation * offset.extend(0.0);
                    commands.spawn((
                        Mesh3d(meshes.add(Cuboid::new(1.5, 1.5, 0.1))),
                        MeshMaterial3d(black.clone()),
                        Transform::from_translation(shifted).with_rotation(rotation),
                        Wall,
                    ));
                }
                commands
                    .spawn((
                        super::black_hdr_camera(),
                        Transform::IDENTITY,
                        LensFlare {
                            grid: 16,
                            occlusion,
                            coarse_ghost_px,
                            ..LensFlare::new(assets.load(TESSAR))
                        },
                    ))
                    .insert(msaa);
            },
        );
        if let Some(at) = move_out_at {
            app.add_systems(
                Update,
                move |mut frame: Local<u32>, mut walls: Query<&mut Transform, With<Wall>>| {
                    *frame += 1;
                    if *frame == at {
                        for mut t in &mut walls {
                            t.translation += Vec3::new(-20.0, 0.0, 0.0);
                        }
                    }
                },
            );
        }
    }
}

/// A hidden light's ghosts cost no pixels: the draw collapses its rays
/// (each carries its light) to one point outside the view, so its
/// triangles are culled before shading. Read from the fragments lavapipe
/// counts in the ghosts' pass (every ghost in it: no coarse ghosts, whose
/// scaling up would be counted there too): some in the open, none behind
/// the wall.
#[test]
fn a_hidden_lights_ghosts_shade_no_pixel() {
    let fragments = |wall: Option<Vec2>| {
        let timed = Headless::new(SIZE, SIZE)
            .hdr(true)
            .time_frames(
                10,
                2,
                scene(Case {
                    wall,
                    coarse_ghost_px: None,
                    ..Case::default()
                }),
            )
            .expect("timed");
        timed
            .span("optica/lens_flare/draw")
            .and_then(|s| s.counts.get("fragment_shader_invocations"))
            .map_or(0.0, |c| c.median)
    };
    let open = fragments(None);
    let hidden = fragments(Some(Vec2::ZERO));
    eprintln!("ghost fragments: open {open}, behind the wall {hidden}");
    assert!(open > 0.0, "the open light drew nothing");
    assert_eq!(hidden, 0.0, "a hidden light's ghosts were shaded");
}

#[test]
fn a_light_behind_a_wall_does_not_flare() {
    let open = total(Case::default());
    let hidden = total(Case {
        wall: Some(Vec2::ZERO),
        ..default()
    });
    // Beside the light: the wall is in the picture but not over the sun.
    let beside = total(Case {
        wall: Some(Vec2::new(-1.6, 0.0)),
        ..default()
    });
    // The wall's edge through the sun's image: in part.
    let half = total(Case {
        wall: Some(Vec2::new(-0.75, 0.0)),
        ..default()
    });
    let msaa = total(Case {
        wall: Some(Vec2::ZERO),
        msaa: Msaa::Sample4,
        ..default()
    });
    let msaa_open = total(Case {
        wall: Some(Vec2::new(-1.6, 0.0)),
        msaa: Msaa::Sample4,
        ..default()
    });
    let ignored = total(Case {
        wall: Some(Vec2::ZERO),
        occlusion: None,
        ..default()
    });
    eprintln!(
        "flare light: open {open:.2}, hidden {hidden:.4}, beside {beside:.2}, \
         half {half:.2}, MSAA hidden {msaa:.4} and beside {msaa_open:.2}, occlusion off {ignored:.2}"
    );
    assert!(open > 1.0, "no flare in the open: {open}");
    assert!(hidden < 1e-3 * open, "{hidden} behind the wall");
    assert!(msaa < 1e-3 * open, "{msaa} behind the wall with MSAA");
    assert!(
        (msaa_open - open).abs() < 1e-3 * open,
        "{msaa_open} beside the wall with MSAA"
    );
    assert!(
        (beside - open).abs() < 1e-3 * open,
        "{beside} beside the wall"
    );
    assert!(half > 0.2 * open && half < 0.8 * open, "{half} at the edge");
    assert!(
        (ignored - open).abs() < 1e-3 * open,
        "{ignored} with occlusion off"
    );
}

#[test]
fn a_bulb_does_not_hide_its_own_light_but_a_wall_does() {
    let open = total(Case {
        light: Light::Bulb,
        ..default()
    });
    let hidden = total(Case {
        light: Light::Bulb,
        wall: Some(Vec2::ZERO),
        ..default()
    });
    eprintln!("point light in a bulb: open {open:.2}, behind a wall {hidden:.4}");
    assert!(open > 1.0, "the bulb hides its light: {open}");
    assert!(hidden < 1e-3 * open, "{hidden} behind the wall");
}

/// The wall moves away at frame 8 of 14. Without history the flare is
/// fully back by the last frame; with a history of 0.9 it has come back
/// only in part (1 − 0.9⁶ ≈ 47 % in six frames), without a jump.
#[test]
fn visibility_fades_in_over_frames() {
    let open = total(Case::default());
    let moved = |history: f32| {
        total(Case {
            wall: Some(Vec2::ZERO),
            occlusion: Some(FlareOcclusion {
                history,
                ..default()
            }),
            move_out_at: Some(8),
            ..default()
        })
    };
    let sharp = moved(0.0);
    let smooth = moved(0.9);
    eprintln!(
        "wall moved away 6 frames ago: {:.0} % of the open flare without history, {:.0} % with 0.9",
        100.0 * sharp / open,
        100.0 * smooth / open
    );
    assert!((sharp - open).abs() < 1e-3 * open, "{sharp} vs {open}");
    assert!(
        smooth > 0.2 * open && smooth < 0.8 * open,
        "{smooth} of {open}"
    );
}
