//! The harness' own tests, in one binary so that Bevy links once.
//!
//! They render on Mesa's lavapipe (`llvmpipe`): install `mesa-vulkan-drivers`.
//! A missing driver fails them with a message saying so; nothing skips.

mod golden_workflow;
mod headless;
mod kernel;
mod metrics;
mod randomise;
mod timing;
mod user_scene;
