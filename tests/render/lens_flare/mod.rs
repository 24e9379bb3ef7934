//! The lens-flare plugin on lavapipe: the trace shader against its CPU
//! twin, lens assets and the choice of ghosts.

mod aperture;
mod bound;
mod frame;
mod ghosts;
mod goldens;
mod lenses;
mod occlusion;
mod parity;
mod passes;
mod stability;
mod taa;
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

/// The walls' material: black and unlit, so that a frame with walls in it
/// is still only the flare's light.
pub fn black_wall() -> StandardMaterial {
    StandardMaterial {
        base_color: Color::BLACK,
        unlit: true,
        ..default()
    }
}

/// A camera at the origin looking along −Z, clearing to black, HDR,
/// untonemapped, one sample per pixel: its image is the flare's light.
pub use optica_report::fixtures::black_hdr_camera;

/// A shader library as plain WGSL, for a readback kernel to paste in: its
/// `#define_import_path` line and its `virtual fn` defaults (each up to the
/// first line that is a lone `}`; the kernel defines them instead) left
/// out.
fn pasted(library: &str) -> String {
    let mut kept = Vec::new();
    let mut in_virtual = false;
    for line in library.lines() {
        if line.starts_with("virtual fn") {
            in_virtual = true;
        }
        if !in_virtual && !line.starts_with("#define_import_path") {
            kept.push(line);
        }
        if in_virtual && line == "}" {
            in_virtual = false;
        }
    }
    kept.join("\n")
}
