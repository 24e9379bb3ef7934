//! Headless render tests of optica's plugins, one binary so that Bevy links
//! once. They render on Mesa's lavapipe (`llvmpipe`): install
//! `mesa-vulkan-drivers`. A missing driver fails them with a message saying
//! so; nothing skips. Goldens are in `tests/golden/` (see `optica_harness`
//! for the update workflow: `OPTICA_GOLDEN=pending|missing|overwrite`).

mod compound_eye;
mod dome;
mod foveated_lod;
mod fuzz_corpus;
mod lens_flare;
mod plugin_shape;
mod randomised;
mod shader_variants;
mod soak;
// The showcase's scenes are the examples' (they use the umbrella crate's
// plugin features, all of which `showcase` turns on; CI builds with
// --all-features).
#[cfg(feature = "showcase")]
mod showcase;
mod spectacles;

/// A count from the environment variable `name` (a long run's size), or
/// `default` (the test command's).
pub fn count_from_env<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(default)
}

/// Runs `setup` for `frames` frames on wgpu's noop backend (naga validates
/// every shader; no driver needed) and checks that every pipeline compiled.
pub fn noop_pipelines(frames: u32, setup: impl FnOnce(&mut bevy::prelude::App)) -> optica_harness::PipelineReport {
    optica_harness::Headless::new(32, 32)
        .adapter(optica_harness::Adapter::Noop)
        .frames(frames)
        .check_pipelines(setup)
        .expect("pipelines compile")
}
