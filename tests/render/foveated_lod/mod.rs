//! The foveated-LOD plugin: the tracked head and its dropouts, LOD chains
//! and their switching under gaze traces, CAVE wall projections on
//! lavapipe, and nothing run for a scene without a consumer.

mod cave;
mod cluster;
mod lod;
mod raytrace;
mod tracking;

use std::time::Duration;

use bevy::prelude::*;
use bevy::time::TimeUpdateStrategy;
use optica_foveated_lod::{FoveatedLodPlugin, HeadSource, SimulatedGaze};

/// Frames per second of the CPU-only apps.
pub const FPS: f64 = 60.0;

/// An app without rendering: the plugin, meshes as assets, transforms and
/// a clock that advances 1/60 s per update.
pub fn cpu_app() -> App {
    let mut app = App::new();
    app.add_plugins((
        MinimalPlugins,
        TransformPlugin,
        AssetPlugin::default(),
        FoveatedLodPlugin,
    ))
    .init_asset::<Mesh>()
    .insert_resource(TimeUpdateStrategy::ManualDuration(Duration::from_secs_f64(
        1.0 / FPS,
    )))
    .insert_resource(HeadSource::Simulated(SimulatedGaze::default()));
    app
}

/// Sets the simulated gaze's yaw (degrees, positive right).
pub fn set_gaze_yaw(app: &mut App, yaw_deg: f32) {
    if let HeadSource::Simulated(sim) = &mut *app.world_mut().resource_mut::<HeadSource>() {
        sim.gaze_yaw_deg = yaw_deg;
    }
}
