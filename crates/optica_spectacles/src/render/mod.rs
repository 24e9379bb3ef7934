//! The render world: on an eye camera, the clones' resolve and then the
//! lens's refraction drawn over the view, both before Bevy's
//! post-processing; on a per-vertex mirror's environment camera, the
//! reflected rays' march; on a cube-map face camera, the copy into its
//! cube. Views without the plugin's components run no pass and queue no
//! pipeline.
//!
//! In the lens flare's (and bloom's) shape: [`pipelines`] specialises each
//! view's pipelines (`RenderSystems::Prepare`), [`prepare`] writes its
//! buffers (`PrepareResources`) and makes the bind groups that do not read
//! the view's post-process textures (`PrepareBindGroups`), and [`passes`]
//! records them in the view's `Core3d` schedule (making there only the
//! bind groups that read the view it draws over).

use bevy::core_pipeline::{Core3d, Core3dSystems};
use bevy::prelude::*;
use optica_plugin_kit::prepare_systems;
use bevy::render::extract_component::ExtractComponentPlugin;
use bevy::render::render_resource::{
    BindGroup, CachedComputePipelineId, CachedRenderPipelineId, SpecializedComputePipelines,
    SpecializedRenderPipelines,
};
use bevy::render::{GpuResourceAppExt, Render, RenderApp, RenderStartup};

use crate::clones::CloneResolve;
use crate::mirror::{CubeFace, MirrorEnvironment};
use crate::refraction::LensRefraction;

mod passes;
mod pipelines;
mod prepare;

pub use prepare::MARCH_STEPS;

use passes::{copy_cube_face, mirror_march, refraction_pass, resolve_pass};
use pipelines::{SpectaclesPipelines, init_spectacles_pipelines, prepare_spectacles_pipelines};
use prepare::{prepare_spectacles_bind_groups, prepare_spectacles_resources};

/// Adds the passes.
pub(crate) struct SpectaclesRenderPlugin;

impl Plugin for SpectaclesRenderPlugin {
    fn build(&self, app: &mut App) {
        app.add_plugins((
            ExtractComponentPlugin::<CloneResolve>::default(),
            ExtractComponentPlugin::<LensRefraction>::default(),
            ExtractComponentPlugin::<MirrorEnvironment>::default(),
            ExtractComponentPlugin::<CubeFace>::default(),
        ));
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        render_app
            .init_gpu_resource::<SpecializedComputePipelines<SpectaclesPipelines>>()
            .init_gpu_resource::<SpecializedRenderPipelines<SpectaclesPipelines>>()
            .add_systems(RenderStartup, init_spectacles_pipelines)
            .add_systems(
                Render,
                prepare_systems(
                    prepare_spectacles_pipelines,
                    prepare_spectacles_resources,
                    prepare_spectacles_bind_groups,
                ),
            )
            .add_systems(
                Core3d,
                (
                    (resolve_pass, refraction_pass).chain(),
                    mirror_march,
                    copy_cube_face,
                )
                    .in_set(Core3dSystems::EarlyPostProcess),
            );
    }
}

/// Which resolve: the clones' colours, or reprojection from the sharp view
/// with a single- or multisampled depth.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Variant {
    Full,
    Reprojected { multisampled: bool },
}

/// An eye camera's resolve pipeline.
#[derive(Component)]
struct ResolvePipelineIds {
    variant: Variant,
    id: CachedRenderPipelineId,
}

/// A lens camera's pipelines: the march (for its depth's sample count),
/// the view's copy and the lens's draw.
#[derive(Component)]
struct RefractionPipelineIds {
    march: CachedComputePipelineId,
    multisampled: bool,
    copy: CachedRenderPipelineId,
    lens: CachedRenderPipelineId,
}

/// A mirror environment camera's march.
#[derive(Component)]
struct MirrorPipelineIds {
    march: CachedComputePipelineId,
}

/// The resolve's bind group when it reads the clones' colours alone.
#[derive(Component)]
struct ResolveFullBinding(BindGroup);

/// The lens march's bind group (its depth is bindable).
#[derive(Component)]
struct RefractionMarchBinding(BindGroup);

/// A mirror march's bind group.
#[derive(Component)]
struct MirrorMarchBinding(BindGroup);
