//! Golden images on lavapipe: a compound eye with the square and the
//! hexagonal lattice, lit, from the same viewpoint.

use bevy::prelude::*;
use optica_compound_eye::{CompoundEye, EyeLattice};
use optica_harness::{Headless, assert_golden};

use super::pseudopupil::{eye_sphere, upright};
use super::scene;

fn eye_frame(lattice: EyeLattice) -> optica_harness::RenderedFrame {
    let eye = CompoundEye {
        facets_per_uv: 24.0,
        lattice,
        slices: 12,
        ..default()
    };
    let camera = Transform::from_xyz(0.4, 0.3, 1.6).looking_at(Vec3::ZERO, Vec3::Y);
    let projection = Projection::Perspective(PerspectiveProjection {
        fov: 0.6,
        ..default()
    });
    Headless::new(128, 128)
        .render(scene(
            eye_sphere(),
            upright(),
            Some(eye),
            camera,
            projection,
        ))
        .expect("render")
}

#[test]
fn square_lattice_eye() {
    assert_golden!(&eye_frame(EyeLattice::Square));
}

#[test]
fn hexagonal_lattice_eye() {
    assert_golden!(&eye_frame(EyeLattice::Hexagonal));
}
