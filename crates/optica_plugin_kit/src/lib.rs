//! # optica_plugin_kit — what the optica plugins share on the Bevy side
//!
//! The five plugin crates (`optica_spectacles`, `optica_compound_eye`,
//! `optica_foveated_lod`, `optica_lens_flare`, `optica_dome`) are built in
//! one shape; the few pieces that shape repeats word for word live here
//! once:
//!
//! - [`prepare_systems`]: a render world's three prepare stages in their
//!   order (pipelines specialised, then buffers, then bind groups);
//! - [`fullscreen_pipeline`]: a full-screen pass's render pipeline (Bevy's
//!   full-screen triangle, one fragment entry, one colour target);
//! - [`require_asset_server`]: the check that a plugin is added after
//!   Bevy's `AssetPlugin`, whose absence would otherwise leave the plugin
//!   without its embedded shaders and nothing said;
//! - [`slider`] (feature `egui`): the panels' slider, which clamps what
//!   the user enters and never rewrites a setting just by showing it.
//!
//! An app using the plugins needs none of it directly.

#![warn(missing_docs)]

use bevy::core_pipeline::FullscreenShader;
use bevy::ecs::schedule::ScheduleConfigs;
use bevy::ecs::system::ScheduleSystem;
use bevy::prelude::*;
use bevy::render::RenderSystems;
use bevy::render::render_resource::{
    BindGroupLayoutDescriptor, ColorTargetState, ColorWrites, FragmentState,
    RenderPipelineDescriptor, TextureFormat,
};
use bevy::shader::ShaderDefVal;

/// A plugin's prepare systems in the `Render` schedule, in the shape of
/// Bevy's bloom: `pipelines` specialise each view's pipelines in
/// `RenderSystems::Prepare`, before the resources (so that a view's first
/// frame with pipelines queued also gets its buffers); `resources` make
/// buffers and textures in `PrepareResources`; `bind_groups` make the bind
/// groups in `PrepareBindGroups`.
pub fn prepare_systems<M1, M2, M3>(
    pipelines: impl IntoScheduleConfigs<ScheduleSystem, M1>,
    resources: impl IntoScheduleConfigs<ScheduleSystem, M2>,
    bind_groups: impl IntoScheduleConfigs<ScheduleSystem, M3>,
) -> ScheduleConfigs<ScheduleSystem> {
    (
        pipelines
            .in_set(RenderSystems::Prepare)
            .before(RenderSystems::PrepareResources),
        resources.in_set(RenderSystems::PrepareResources),
        bind_groups.in_set(RenderSystems::PrepareBindGroups),
    )
        .into_configs()
}

/// A full-screen pass: Bevy's full-screen triangle as the vertex stage,
/// `entry` of `shader` (with `shader_defs`) as the fragment stage, one bind
/// group of `layout`, writing `format` unblended.
pub fn fullscreen_pipeline(
    label: &'static str,
    layout: &BindGroupLayoutDescriptor,
    fullscreen: &FullscreenShader,
    shader: &Handle<Shader>,
    entry: &'static str,
    shader_defs: Vec<ShaderDefVal>,
    format: TextureFormat,
) -> RenderPipelineDescriptor {
    RenderPipelineDescriptor {
        label: Some(label.into()),
        layout: vec![layout.clone()],
        vertex: fullscreen.to_vertex_state(),
        fragment: Some(FragmentState {
            shader: shader.clone(),
            shader_defs,
            entry_point: Some(entry.into()),
            targets: vec![Some(ColorTargetState {
                format,
                blend: None,
                write_mask: ColorWrites::ALL,
            })],
        }),
        ..default()
    }
}

/// Panics, naming `krate` and `plugin`, when `app` has no `AssetServer`
/// yet: the plugin embeds its shaders, which needs Bevy's `AssetPlugin`
/// (part of `DefaultPlugins`) added first.
#[track_caller]
pub fn require_asset_server(app: &App, krate: &str, plugin: &str) {
    assert!(
        app.world().contains_resource::<AssetServer>(),
        "{krate}: add {plugin} after Bevy's AssetPlugin (DefaultPlugins): it embeds its shaders"
    );
}

/// A slider over `range` that clamps what the user enters, not what it
/// shows: egui's default clamps on sight, which would rewrite a setting
/// outside the range just by opening the panel.
#[cfg(feature = "egui")]
pub fn slider<'a, N: bevy_egui::egui::emath::Numeric>(
    value: &'a mut N,
    range: std::ops::RangeInclusive<N>,
) -> bevy_egui::egui::Slider<'a> {
    bevy_egui::egui::Slider::new(value, range).clamping(bevy_egui::egui::SliderClamping::Edits)
}
