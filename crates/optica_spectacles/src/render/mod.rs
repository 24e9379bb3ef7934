//! The render world: the clones' resolve ([`resolve`]) and the lens's
//! refraction drawn over the view ([`refraction`]), both on the eye
//! camera before Bevy's post-processing. Pipelines are queued when the
//! first camera needs them; views without the plugin's components run
//! neither pass.

use bevy::prelude::*;

pub(crate) mod mirror;
pub(crate) mod refraction;
pub(crate) mod resolve;


/// Adds the passes.
pub(crate) struct SpectaclesRenderPlugin;

impl Plugin for SpectaclesRenderPlugin {
    fn build(&self, app: &mut App) {
        resolve::build(app);
        refraction::build(app);
        mirror::build(app);
    }
}
