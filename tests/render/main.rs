//! Headless render tests of optica. One binary, so Bevy links once.
//!
//! They render on Mesa's lavapipe (`llvmpipe`): install `mesa-vulkan-drivers`.
//! A missing driver fails the tests with a message saying so; nothing skips.
//! Regenerate goldens with `OPTICA_UPDATE_GOLDEN=1 cargo test --workspace --test render`.

mod harness;
mod scenes;
