//! The lens-flare plugin on lavapipe: the trace shader against its CPU
//! twin, lens assets and the choice of ghosts.

mod aperture;
mod frame;
mod ghosts;
mod goldens;
mod parity;
mod passes;
mod stability;
mod trace;

use bevy::prelude::*;
use optica_lens_flare::FlareSource;

/// A flaring sun of `lux` whose light travels along `travel` (the view
/// space of a camera at the origin looking along −Z).
pub fn sun(travel: Vec3, lux: f32) -> impl Bundle {
    (
        DirectionalLight {
            illuminance: lux,
            ..default()
        },
        Transform::IDENTITY.looking_to(travel, Vec3::Y),
        FlareSource::default(),
    )
}
