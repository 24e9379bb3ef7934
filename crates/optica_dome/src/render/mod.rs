//! The render world of the cube mode: a full-screen pass on the dome
//! camera resamples the face cameras' images into the domemaster, before
//! tonemapping and the rim mask (`optica/dome/cube_resample`). A scene
//! without a cube-mode camera queues no pipeline and runs no pass. (The
//! vertex mode has no pass of its own: it goes through Bevy's mesh
//! pipelines, see the crate's `shader_hook`.)
//!
//! In the lens flare's (and bloom's) shape: [`pipelines`] specialises the
//! view's pipeline (`RenderSystems::Prepare`), [`prepare`] writes its
//! uniform (`PrepareResources`) and makes its bind group
//! (`PrepareBindGroups`), and [`passes`] records the pass.

use bevy::core_pipeline::fullscreen_material::fullscreen_material_system;
use bevy::core_pipeline::tonemapping::tonemapping;
use bevy::core_pipeline::{Core3d, Core3dSystems};
use bevy::prelude::*;
use optica_plugin_kit::prepare_systems;
use bevy::render::extract_component::ExtractComponentPlugin;
use bevy::render::render_resource::{CachedRenderPipelineId, SpecializedRenderPipelines};
use bevy::render::{GpuResourceAppExt, Render, RenderApp, RenderStartup, RenderSystems};

use crate::DomeRimMask;
use crate::cube::DomeCubeSampling;

mod passes;
mod pipelines;
mod prepare;
mod rim_mask;

use passes::resample;
use pipelines::{ResamplePipeline, init_resample_pipeline, prepare_resample_pipelines};
use prepare::{prepare_resample_bind_groups, prepare_resample_resources};

/// Adds the cube mode's resampling pass.
pub(crate) struct CubeResamplePlugin;

impl Plugin for CubeResamplePlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins(ExtractComponentPlugin::<DomeCubeSampling>::default());
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        render_app
            .init_gpu_resource::<SpecializedRenderPipelines<ResamplePipeline>>()
            .add_systems(RenderStartup, init_resample_pipeline)
            .add_systems(
                Render,
                prepare_systems(
                    prepare_resample_pipelines,
                    prepare_resample_resources,
                    prepare_resample_bind_groups,
                ),
            )
            // After the rim masks' uniforms are written, before Bevy makes
            // their bind groups.
            .add_systems(
                Render,
                rim_mask::drop_stale_rim_mask_bind_groups
                    .in_set(RenderSystems::PrepareResourcesFlush)
                    .run_if(any_with_component::<DomeRimMask>),
            )
            .add_systems(
                Core3d,
                resample
                    .in_set(Core3dSystems::PostProcess)
                    .before(fullscreen_material_system::<DomeRimMask>)
                    .before(tonemapping),
            );
    }
}

/// A cube-mode view's resampling pipeline (for its target format).
#[derive(Component)]
struct ResamplePipelineId(CachedRenderPipelineId);
