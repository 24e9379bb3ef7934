//! A straight 3D line on the dome: a thin bar 20 units long, passing 3 units
//! above and 2 in front of the viewer, covers 160° of the sky and projects to
//! a curved arc. Every pixel it lights must lie within the tolerance (plus
//! the bar's own half-width and pixel sampling) of the analytic image of the
//! 3D segment — and, refined at a loose tolerance, it visibly does not.

use bevy::prelude::*;
use optica_dome::{DomeCamera, DomePlugin};
use optica_harness::Headless;
use optica_optics::glam::DVec2;

use super::{dome_camera, flat, zenith};

const SIZE: u32 = 256;
/// The bar's cross-section, world units.
const THICKNESS: f32 = 0.05;
const CENTRE: Vec3 = Vec3::new(0.0, 3.0, -2.0);

/// The largest distance, in px, from a lit pixel centre to the analytic
/// arc, and the number of lit pixels.
fn farthest_lit_pixel(tolerance_px: f32) -> (f64, usize) {
    let frame = Headless::new(SIZE, SIZE)
        .render(move |app: &mut App| {
            app.add_plugins(DomePlugin);
            app.add_systems(
                Startup,
                move |mut commands: Commands,
                      mut meshes: ResMut<Assets<Mesh>>,
                      mut materials: ResMut<Assets<StandardMaterial>>| {
                    commands.spawn((
                        Mesh3d(meshes.add(Cuboid::new(20.0, THICKNESS, THICKNESS))),
                        flat(&mut materials, Color::WHITE),
                        Transform::from_translation(CENTRE),
                    ));
                    commands.spawn(dome_camera(
                        DomeCamera {
                            tolerance_px,
                            ..default()
                        },
                        zenith(),
                    ));
                },
            );
        })
        .expect("render");
    let dome = DomeCamera::default()
        .projection(SIZE)
        .expect("a valid dome");
    // The analytic image: the segment's axis, finely sampled, projected.
    let view_from_world = zenith().compute_affine().inverse();
    let arc: Vec<DVec2> = (0..=20_000)
        .filter_map(|k| {
            let x = -10.0 + 20.0 * k as f32 / 20_000.0;
            let p = view_from_world.transform_point3(CENTRE + Vec3::X * x);
            dome.project(p.as_dvec3()).visible_pixel()
        })
        .collect();
    let img = frame.to_rgba8();
    let (mut worst, mut lit) = (0f64, 0usize);
    for (x, y, p) in img.enumerate_pixels() {
        if p.0[0] < 128 {
            continue;
        }
        lit += 1;
        let c = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
        let d = arc
            .iter()
            .map(|a| (*a - c).length())
            .fold(f64::INFINITY, f64::min);
        worst = worst.max(d);
    }
    (worst, lit)
}

#[test]
fn a_straight_line_lies_on_its_analytic_arc() {
    let (refined, lit) = farthest_lit_pixel(0.5);
    eprintln!("tolerance 0.5 px: {lit} lit pixels, farthest {refined:.2} px from the arc");
    // The bar is < 0.3 px thick here; a lit pixel centre may lie up to
    // ~0.75 px from the line it covers.
    assert!(lit > 150, "the line is missing: {lit} px");
    assert!(
        refined <= 0.5 + 0.3 + 0.75,
        "a lit pixel {refined:.2} px off the arc"
    );
    let (loose, _) = farthest_lit_pixel(30.0);
    eprintln!("tolerance 30 px: farthest {loose:.2} px from the arc");
    assert!(
        loose > 3.0,
        "a 30 px tolerance drew the line within {loose:.2} px: the test cannot tell"
    );
}
