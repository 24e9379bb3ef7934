//! A straight 3D line on the dome: a segment 20 units long, passing 3 units
//! above and 2 in front of the viewer, covers 160° of the sky and projects to
//! a curved arc. Drawn as a thin bar (triangles) or as a line mesh (the
//! GPU's one-pixel lines), every pixel it lights must lie within the
//! tolerance (plus the bar's own half-width and pixel sampling) of the
//! analytic image of the 3D segment — and, refined at a loose tolerance, it
//! visibly does not.

use bevy::asset::RenderAssetUsages;
use bevy::mesh::PrimitiveTopology;
use bevy::prelude::*;
use optica_dome::{DomeCamera, DomeLens, DomePlugin};
use optica_harness::Headless;
use optica_optics::glam::DVec2;

use super::{dome_camera, flat, zenith};

const SIZE: u32 = 256;
/// The bar's cross-section, world units.
const THICKNESS: f32 = 0.05;
const CENTRE: Vec3 = Vec3::new(0.0, 3.0, -2.0);

/// How the segment is drawn.
#[derive(Clone, Copy)]
enum Drawn {
    /// A box of cross-section `THICKNESS`.
    Bar,
    /// A line-list mesh of one segment, or the same as a two-point strip.
    Line(PrimitiveTopology),
}

/// The largest distance, in px, from a lit pixel centre to the analytic
/// arc, and the number of lit pixels.
fn farthest_lit_pixel(tolerance_px: f32, drawn: Drawn) -> (f64, usize) {
    farthest_lit_pixel_through(DomeLens::Equidistant, tolerance_px, drawn)
}

/// [`farthest_lit_pixel`] through a dome camera with `lens`. The
/// equirectangular panorama (256 × 128) looks along +X at the horizon and
/// the segment runs along Z, 3 up and 2 behind, so that its image crosses
/// the ±180° seam at 56° of latitude.
fn farthest_lit_pixel_through(lens: DomeLens, tolerance_px: f32, drawn: Drawn) -> (f64, usize) {
    let camera = DomeCamera {
        tolerance_px,
        lens,
        ..default()
    };
    let (mount, place, (width, height)) = if lens == DomeLens::Equirectangular {
        (
            Transform::IDENTITY.looking_to(Vec3::X, Vec3::Y),
            Transform::from_xyz(-2.0, 3.0, 0.0)
                .with_rotation(Quat::from_rotation_y(std::f32::consts::FRAC_PI_2)),
            (SIZE, SIZE / 2),
        )
    } else {
        (zenith(), Transform::from_translation(CENTRE), (SIZE, SIZE))
    };
    let frame = Headless::new(width, height)
        .render(move |app: &mut App| {
            app.add_plugins(DomePlugin);
            app.add_systems(
                Startup,
                move |mut commands: Commands,
                      mut meshes: ResMut<Assets<Mesh>>,
                      mut materials: ResMut<Assets<StandardMaterial>>| {
                    let mesh = match drawn {
                        Drawn::Bar => Cuboid::new(20.0, THICKNESS, THICKNESS).into(),
                        Drawn::Line(topology) => Mesh::new(topology, RenderAssetUsages::default())
                            .with_inserted_attribute(
                                Mesh::ATTRIBUTE_POSITION,
                                vec![[-10.0f32, 0.0, 0.0], [10.0, 0.0, 0.0]],
                            ),
                    };
                    commands.spawn((
                        Mesh3d(meshes.add(mesh)),
                        flat(&mut materials, Color::WHITE),
                        place,
                    ));
                    commands.spawn(dome_camera(camera, mount));
                },
            );
        })
        .expect("render");
    let dome = camera.panorama(width, height).expect("a valid dome");
    // The analytic image: the segment's axis, finely sampled, projected.
    let view_from_world = mount.compute_affine().inverse();
    let arc: Vec<DVec2> = (0..=20_000)
        .filter_map(|k| {
            let x = -10.0 + 20.0 * k as f32 / 20_000.0;
            let p = view_from_world.transform_point3(place.transform_point(Vec3::X * x));
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
    let (refined, lit) = farthest_lit_pixel(0.5, Drawn::Bar);
    eprintln!("tolerance 0.5 px: {lit} lit pixels, farthest {refined:.2} px from the arc");
    // The bar is < 0.3 px thick here; a lit pixel centre may lie up to
    // ~0.75 px from the line it covers.
    assert!(lit > 150, "the line is missing: {lit} px");
    assert!(
        refined <= 0.5 + 0.3 + 0.75,
        "a lit pixel {refined:.2} px off the arc"
    );
    let (loose, _) = farthest_lit_pixel(30.0, Drawn::Bar);
    eprintln!("tolerance 30 px: farthest {loose:.2} px from the arc");
    assert!(
        loose > 3.0,
        "a 30 px tolerance drew the line within {loose:.2} px: the test cannot tell"
    );
}

/// The same segment as a line mesh (list and strip): refined like a
/// triangle's edge, its one-pixel line lies on the arc; unrefined (a loose
/// tolerance) it does not.
#[test]
fn a_line_mesh_lies_on_its_analytic_arc() {
    for topology in [PrimitiveTopology::LineList, PrimitiveTopology::LineStrip] {
        let (refined, lit) = farthest_lit_pixel(0.5, Drawn::Line(topology));
        eprintln!(
            "{topology:?} at 0.5 px: {lit} lit pixels, farthest {refined:.2} px from the arc"
        );
        // The arc is ~190 px long; a one-pixel line lights about as many.
        assert!(lit > 150, "the line is missing: {lit} px");
        // A lit pixel centre lies within ~0.75 px of the line it covers.
        assert!(
            refined <= 0.5 + 0.75,
            "a lit pixel {refined:.2} px off the arc"
        );
    }
    let (loose, _) = farthest_lit_pixel(30.0, Drawn::Line(PrimitiveTopology::LineList));
    eprintln!("line at 30 px: farthest {loose:.2} px from the arc");
    assert!(loose > 3.0, "30 px drew the line within {loose:.2} px");
}

/// Every lens and the panorama: the segment drawn as a line mesh at 0.5 px
/// lies on its analytic curve in that projection's image (a lit pixel
/// centre within the tolerance plus ~0.75 px of sampling), and at 30 px it
/// does not.
#[test]
fn a_straight_line_lies_on_its_analytic_curve_through_every_lens() {
    for lens in DomeLens::ALL {
        let line = Drawn::Line(PrimitiveTopology::LineList);
        let (refined, lit) = farthest_lit_pixel_through(lens, 0.5, line);
        let (loose, _) = farthest_lit_pixel_through(lens, 30.0, line);
        eprintln!(
            "{}: {lit} lit pixels, farthest {refined:.2} px from the curve at 0.5 px, {loose:.2} px at 30 px",
            lens.name()
        );
        assert!(lit > 100, "{}: the line is missing ({lit} px)", lens.name());
        assert!(
            refined <= 0.5 + 0.75,
            "{}: a lit pixel {refined:.2} px off the curve",
            lens.name()
        );
        assert!(
            loose > 2.0,
            "{}: 30 px drew the line within {loose:.2} px",
            lens.name()
        );
    }
}

/// The panorama's triangles: the segment as a thin bar (a box whose faces
/// cross the seam) lies on its curve at 0.5 px, and is not lost at the seam.
#[test]
fn a_bar_across_the_panorama_seam_lies_on_its_curve() {
    let (refined, lit) = farthest_lit_pixel_through(DomeLens::Equirectangular, 0.5, Drawn::Bar);
    eprintln!("panorama bar at 0.5 px: {lit} lit pixels, farthest {refined:.2} px from the curve");
    // ~150 px of curve; a bar thinner than a pixel lights about two thirds.
    assert!(lit > 60, "the bar is missing: {lit} px");
    // The bar is ~0.6 px thick here; a lit pixel centre may lie up to
    // ~0.75 px from the line it covers.
    assert!(
        refined <= 0.5 + 0.3 + 0.75,
        "a lit pixel {refined:.2} px off the curve"
    );
}
