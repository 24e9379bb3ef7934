//! A workaround for Bevy 0.19.1's full-screen material, which draws the
//! rim mask ([`DomeRimMask`]): it keeps each view's bind groups until the
//! view's textures change, but they also hold the material's uniform
//! buffer, which Bevy reallocates when it grows. When dome cameras come and
//! go (a stereo pair, a dome beside a preview), a view can keep bind groups
//! on the old, smaller buffer while its place in the new one lies past the
//! old one's end: the mask pass reads out of bounds, a wgpu validation
//! error that stops rendering. Found by the soak test
//! (`tests/render/soak.rs`, which fails on it at its seventh frame
//! without this).

use bevy::core_pipeline::fullscreen_material::FullscreenMaterialBindGroup;
use bevy::prelude::*;
use bevy::render::extract_component::ComponentUniforms;
use bevy::render::render_resource::BufferId;

use crate::DomeRimMask;

/// Drops every view's rim-mask bind groups when the uniform buffer is not
/// the one they were made with, so that Bevy makes them anew this frame.
/// Runs after the uniforms are written (`PrepareResources`) and before
/// Bevy makes the bind groups (`PrepareBindGroups`).
pub(super) fn drop_stale_rim_mask_bind_groups(
    mut commands: Commands,
    uniforms: Res<ComponentUniforms<DomeRimMask>>,
    views: Query<Entity, With<FullscreenMaterialBindGroup<DomeRimMask>>>,
    mut last: Local<Option<BufferId>>,
) {
    let buffer = uniforms.uniforms().buffer().map(|b| b.id());
    if buffer == *last {
        return;
    }
    *last = buffer;
    for view in &views {
        commands
            .entity(view)
            .remove::<FullscreenMaterialBindGroup<DomeRimMask>>();
    }
}
