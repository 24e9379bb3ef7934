//! The dome camera on lavapipe: the WGSL projection against its CPU twin,
//! a scene seen through the dome, and nothing built without a dome camera.

mod cameras;
mod classify;
mod cube;
mod export;
mod goldens;
mod line;
mod meshes;
mod pipelines;
mod projection;
mod scene;
mod stability;
mod texture;

use bevy::prelude::*;
use bevy::render::view::Msaa;
use optica_dome::DomeCamera;
use optica_report::fixtures::{black_untonemapped, unlit};

/// A dome camera's mount looking at the zenith (+Y), the back of the
/// theatre towards +Z: the audience front (bottom of the domemaster) is −Z.
pub use optica_report::fixtures::zenith;

/// `dome` at `transform`, drawing on black, untonemapped (colours come out
/// as given), one sample per pixel.
pub fn dome_camera(dome: DomeCamera, transform: Transform) -> impl Bundle {
    (dome, black_untonemapped(Msaa::Off), transform)
}

/// An unlit material of `colour`, both sides drawn.
pub fn flat(
    materials: &mut Assets<StandardMaterial>,
    colour: Color,
) -> MeshMaterial3d<StandardMaterial> {
    MeshMaterial3d(materials.add(unlit(colour)))
}
