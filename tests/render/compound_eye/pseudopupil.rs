//! The moving pseudopupil: on an eye-shaped sphere, the dark patch sits where
//! the surface normal points at the camera (the facets whose axes look at
//! the viewer show their dark pigment), within one facet, and moves with
//! the viewpoint.

use bevy::mesh::VertexAttributeValues;
use bevy::prelude::*;
use optica_compound_eye::{CompoundEye, EyeLattice, EyeOutput};
use optica_harness::Headless;
use optica_optics::compound_eye::dark_patch_centroid;

use super::scene;

const SIZE: u32 = 128;
const RADIUS: f32 = 0.5;
const FACETS_PER_UV: f32 = 40.0;
const FOV: f32 = 0.7;

/// Where the pseudopupil shows from `eye_pos` (camera at `eye_pos` looking
/// at the centre): its centroid in pixels, and where the sphere's normal
/// points at the camera, in pixels, plus the facet pitch there (world units
/// along the meridian and the parallel).
struct Seen {
    centroid: Vec2,
    expected: Vec2,
    dark_pixels: usize,
}

fn look(camera: Transform, facet_px: f32) -> Seen {
    let eye = CompoundEye {
        facets_per_uv: FACETS_PER_UV,
        lattice: EyeLattice::Hexagonal,
        output: EyeOutput::PigmentOnly,
        slices: 16,
        ..default()
    };
    let projection = Projection::Perspective(PerspectiveProjection {
        fov: FOV,
        ..default()
    });
    let frame = Headless::new(SIZE, SIZE)
        .hdr(true)
        .render(scene(
            eye_sphere(),
            upright(),
            Some(eye),
            camera,
            projection,
        ))
        .expect("render");
    let img = frame.hdr().unwrap();
    // Darkness on the sphere, 0 off it; the patch is found by averaging over
    // about a facet (optica_optics::compound_eye::dark_patch_centroid).
    let darkness: Vec<f64> = img
        .enumerate_pixels()
        .map(|(x, y, p)| {
            if on_sphere(camera, x, y) {
                1.0 - p.0[0].clamp(0.0, 1.0) as f64
            } else {
                0.0
            }
        })
        .collect();
    let half = (facet_px / 2.0).round() as usize;
    let centroid = dark_patch_centroid(&darkness, SIZE as usize, SIZE as usize, half)
        .expect("no dark pixel on the eye");
    let n = darkness.iter().filter(|&&d| d > 0.5).count();
    Seen {
        centroid: centroid.as_vec2(),
        expected: project(camera, camera.translation.normalize() * RADIUS),
        dark_pixels: n,
    }
}

/// Bevy's UV sphere has its poles on ±Z; turned so that they are on ±Y, the
/// cameras (looking along −Z) face its equator, where the facets are even.
pub fn upright() -> Transform {
    Transform::from_rotation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2))
}

/// A UV sphere whose facets are square at the equator: Bevy's UV sphere
/// maps u to the longitude (2πR) and v to the latitude (πR), so v is halved.
pub fn eye_sphere() -> Mesh {
    let mut mesh = Sphere::new(RADIUS).mesh().uv(96, 48);
    if let Some(VertexAttributeValues::Float32x2(uv)) = mesh.attribute_mut(Mesh::ATTRIBUTE_UV_0) {
        for t in uv.iter_mut() {
            t[1] *= 0.5;
        }
    }
    mesh
}

/// Whether the ray through the centre of pixel (x, y) meets the sphere at
/// least a pixel inside its silhouette.
fn on_sphere(camera: Transform, x: u32, y: u32) -> bool {
    let t = (FOV / 2.0).tan();
    let ndc = Vec2::new(
        (x as f32 + 0.5) / SIZE as f32 * 2.0 - 1.0,
        1.0 - (y as f32 + 0.5) / SIZE as f32 * 2.0,
    );
    let dir = camera.rotation * Vec3::new(ndc.x * t, ndc.y * t, -1.0).normalize();
    let o = camera.translation;
    // Distance of the line from the centre, against the radius less a pixel.
    let closest = (o - dir * o.dot(dir)).length();
    let pixel = 2.0 * t * o.length() / SIZE as f32;
    closest < RADIUS - pixel
}

/// Pixel position of world point `p` for the test camera.
fn project(camera: Transform, p: Vec3) -> Vec2 {
    let view = camera.compute_affine().inverse().transform_point3(p);
    let t = (FOV / 2.0).tan();
    let ndc = Vec2::new(view.x / (-view.z * t), view.y / (-view.z * t));
    Vec2::new(
        (ndc.x + 1.0) / 2.0 * SIZE as f32,
        (1.0 - ndc.y) / 2.0 * SIZE as f32,
    )
}

/// Pixels per world unit near the sphere's front for a camera at `distance`.
fn pixels_per_unit(distance: f32) -> f32 {
    SIZE as f32 / (2.0 * (distance - RADIUS) * (FOV / 2.0).tan())
}

#[test]
fn the_dark_patch_faces_the_camera_and_moves_with_it() {
    let distance = 1.8;
    // Two viewpoints side by side, both looking along −Z: the point whose
    // normal faces the camera lands at different places of the image.
    let at = |x: f32, y: f32| Transform::from_xyz(x, y, distance).looking_to(Vec3::NEG_Z, Vec3::Y);
    // The facet pitch at the equator, 2πR / R_t world units along both axes.
    let facet_px = std::f32::consts::TAU * RADIUS / FACETS_PER_UV * pixels_per_unit(distance);
    let mut seen_at = Vec::new();
    for (x, y) in [(-0.45, 0.1), (0.5, -0.15)] {
        let seen = look(at(x, y), facet_px);
        let miss = (seen.centroid - seen.expected).length();
        eprintln!(
            "camera at x = {x}, y = {y}: {} dark px, centroid {:?}, normal-facing point {:?}: {:.2} px = {:.2} facets",
            seen.dark_pixels,
            seen.centroid,
            seen.expected,
            miss,
            miss / facet_px
        );
        assert!(seen.dark_pixels > 5, "no pseudopupil from x = {x}");
        assert!(
            miss <= facet_px,
            "the pseudopupil is {:.2} facets from where the normal faces the camera",
            miss / facet_px
        );
        seen_at.push(seen);
    }
    // It moved with the viewpoint, by what the geometry says.
    let moved = seen_at[1].centroid - seen_at[0].centroid;
    let expected = seen_at[1].expected - seen_at[0].expected;
    assert!(
        expected.length() > 4.0 * facet_px,
        "the two viewpoints are too close to tell"
    );
    assert!(
        (moved - expected).length() <= 2.0 * facet_px,
        "moved {moved:?}, expected {expected:?}"
    );
}
