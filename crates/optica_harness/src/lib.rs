//! # optica_harness — headless Bevy render tests
//!
//! Golden-image tests and GPU timings of your own Bevy scenes, with no
//! window and no GPU:
//!
//! - [`Headless`] runs an app for a few frames on Mesa's lavapipe (or any
//!   adapter) with deterministic time, and returns the frame (8-bit or linear
//!   HDR) with the [`AdapterInfo`] that rendered it;
//! - [`Golden`] and [`assert_golden!`] compare a frame with a checked-in PNG
//!   of the same adapter family, with insta-style update modes and pending
//!   files to review;
//! - [`Headless::time_frames`] measures frame times and every render pass's
//!   GPU time (timestamp queries through Bevy's `RenderDiagnosticsPlugin`),
//!   median and spread over N frames after a warm-up;
//! - [`Headless::check_pipelines`] proves every pipeline compiles, also on
//!   wgpu's noop backend where no driver exists;
//! - [`metrics`] computes PSNR, SSIM and ꟻLIP;
//! - [`randomise`] draws a settings component's every field over its whole
//!   type range (NaN and infinities included), for property tests;
//! - [`textures`] makes test patterns (a checkerboard, a texture of its own
//!   coordinates, a soft spot) to put in front of the camera.
//!
//! **Prerequisite:** a Vulkan driver. On a headless Linux machine or CI,
//! `apt-get install mesa-vulkan-drivers` gives lavapipe, the CPU device the
//! default [`Adapter::Software`] asks for. Without it a run fails with
//! [`HarnessError::NoAdapter`]; it never skips.
//!
//! ## A golden test of your own scene
//!
//! This is `tests/harness/user_scene.rs` of this crate, run by its tests:
//!
//! ```ignore
#![doc = include_str!("../tests/harness/user_scene.rs")]
//! ```
//!
//! The first run writes `tests/golden/user_scene__lit_cube_matches_its_golden.new.png`
//! and fails, asking you to review it; accept it and commit the PNG.
//!
//! ## The update workflow
//!
//! `OPTICA_GOLDEN` chooses what a comparison may write (see [`golden`] for
//! the full table): `never` on CI (when `CI` is set), `pending` elsewhere
//! (a missing or changed render is written as `<name>.new.png` with a
//! ꟻLIP difference map `<name>.diff.png`, and the test fails), `missing`
//! (write new goldens), `overwrite` (rewrite changed goldens; unchanged ones
//! are left alone). After an intended change of a scene:
//!
//! ```sh
//! cargo test                              # fails, writes .new.png files
//! # look at tests/golden/*.new.png and *.diff.png, then accept them:
//! OPTICA_GOLDEN=overwrite cargo test      # or Golden::accept_pending()
//! ```
//!
//! Goldens record the adapter that made them inside the PNG and are kept per
//! adapter family: a render on a GPU is compared with a GPU golden
//! (`<name>@nvidia-h200.png`), never with the lavapipe one, and without one
//! the failure says which families do have a golden. `tests/harness/golden_workflow.rs`
//! exercises every mode.
//!
//! A headless app runs without Bevy's `LogPlugin` (a test process holds
//! several apps, and only one may own the global logger); set
//! `OPTICA_HARNESS_LOG` (to anything) to keep it in a process that runs one
//! app, e.g. an example's headless run, with `RUST_LOG` as usual.
//!
//! ## GPU timing of a pass
//!
//! This is `tests/harness/timing.rs`: a render pass that records its own time
//! span, timed with Bevy's own passes:
//!
//! ```ignore
#![doc = include_str!("../tests/harness/timing.rs")]
//! ```
//!
//! With the `winit` feature the harness removes Bevy's `WinitPlugin` from
//! `DefaultPlugins`: enable it when your build enables Bevy's `bevy_winit`.

#![warn(missing_docs)]

mod adapter;
mod error;
mod frame;
pub mod golden;
mod headless;
mod kernel;
pub mod metrics;
mod noop;
pub mod randomise;
pub mod textures;
mod timing;

pub use adapter::{Adapter, AdapterInfo};
pub use error::HarnessError;
pub use frame::{Pixels, RenderedFrame};
pub use golden::{Golden, GoldenOutcome, Tolerance, UpdateMode, WriteReason};
pub use headless::{
    DEFAULT_TIME_STEP, HarnessTarget, Headless, HeadlessRun, MAX_SETTLE_FRAMES, MAX_SIDE,
    PipelineReport,
    PluginsHook,
};
pub use kernel::KERNEL_WORKGROUP;
pub use timing::{
    BOOTSTRAP_RESAMPLES, FrameTimings, MAX_DIAGNOSTIC_LAG_FRAMES, PairedTimings, PassTime,
    RatioInterval, SpanTiming, Stats, TimeSource,
};
