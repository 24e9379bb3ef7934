//! The domemaster's rim: the square target's corners lie outside the image
//! circle, where geometry beyond the field of view (up to the clip angle)
//! would otherwise show. A full-screen pass on dome views paints them.

use bevy::core_pipeline::fullscreen_material::FullscreenMaterial;
use bevy::prelude::*;
use bevy::render::extract_component::ExtractComponent;
use bevy::render::render_resource::ShaderType;
use bevy::shader::ShaderRef;

/// Where `embedded_asset!` puts the mask shader.
pub(crate) const SHADER_PATH: &str = "embedded://optica_dome/shaders/rim_mask.wgsl";

/// Paints a dome view outside its image circle (NDC radius 1) in `colour`,
/// with a one-pixel anti-aliased edge. The plugin adds it to every
/// [`crate::DomeCamera`]; change `colour` on the camera to suit a
/// projector's black level.
#[derive(Component, ExtractComponent, ShaderType, Reflect, Clone, Copy, Debug, PartialEq)]
#[reflect(Component, Default)]
pub struct DomeRimMask {
    /// The colour outside the circle, linear RGBA (the pass runs before
    /// tonemapping, on the view's HDR or linear colour).
    pub colour: Vec4,
}

impl Default for DomeRimMask {
    /// Black.
    fn default() -> Self {
        Self {
            colour: Vec4::new(0.0, 0.0, 0.0, 1.0),
        }
    }
}

impl FullscreenMaterial for DomeRimMask {
    fn fragment_shader() -> ShaderRef {
        SHADER_PATH.into()
    }
}
