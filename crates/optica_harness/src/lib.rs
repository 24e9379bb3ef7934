//! # optica_harness — headless Bevy render tests
//!
//! Everything a Bevy developer needs to test a scene without a window or a GPU:
//!
//! - [`Headless`] runs an app for a few frames on Mesa's lavapipe (or any
//!   adapter) and returns the image, 8-bit or linear HDR, and the adapter name;
//! - [`Headless::check_pipelines`] proves every pipeline compiles, also on
//!   wgpu's noop backend where no driver exists;
//! - [`metrics`] computes PSNR, SSIM and ꟻLIP;
//! - [`Golden`] compares a render with a checked-in PNG, writes a diff on
//!   failure and regenerates goldens when `OPTICA_UPDATE_GOLDEN=1`.
//!
//! A golden test of your own scene:
//!
//! ```no_run
//! use bevy::prelude::*;
//! use optica_harness::{Golden, Headless, Tolerance};
//!
//! fn scene(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>, mut materials: ResMut<Assets<StandardMaterial>>) {
//!     commands.spawn((Mesh3d(meshes.add(Cuboid::default())), MeshMaterial3d(materials.add(Color::WHITE))));
//!     commands.spawn((DirectionalLight::default(), Transform::from_xyz(1.0, 2.0, 3.0).looking_at(Vec3::ZERO, Vec3::Y)));
//!     commands.spawn((Camera3d::default(), Transform::from_xyz(2.0, 2.0, 2.0).looking_at(Vec3::ZERO, Vec3::Y)));
//! }
//!
//! let frame = Headless::new(96, 96).render(|app| { app.add_systems(Startup, scene); }).unwrap();
//! Golden::new(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/golden"))
//!     .assert_matches("my_scene", &frame.to_rgba8(), Tolerance::default());
//! ```
//!
//! With the `winit` feature the harness removes Bevy's `WinitPlugin` from
//! `DefaultPlugins`: enable it when your build enables Bevy's `bevy_winit`.

#![warn(missing_docs)]

mod error;
pub mod golden;
mod headless;
pub mod metrics;
mod noop;

pub use error::HarnessError;
pub use golden::{Golden, GoldenOutcome, Tolerance};
pub use headless::{Adapter, Headless, HarnessTarget, PipelineReport, RenderedFrame, linear_to_srgb};
