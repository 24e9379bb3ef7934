//! The spectacles' pipelines, specialised on first use through Bevy's
//! `Specialized*Pipelines` caches (a scene without an eye camera, a lens
//! or a mirror queues none): the resolve per variant and target format,
//! the lens's copy and draw per target format, and the exit rays' march
//! per depth kind (the lens's and a per-vertex mirror's).

use bevy::core_pipeline::FullscreenShader;
use optica_plugin_kit::fullscreen_pipeline;
use bevy::prelude::*;
use bevy::render::render_resource::binding_types::{
    sampler, storage_buffer, storage_buffer_read_only, texture_2d, texture_depth_2d,
    texture_depth_2d_multisampled, uniform_buffer,
};
use bevy::render::render_resource::{
    BindGroupLayoutDescriptor, BindGroupLayoutEntries, ColorTargetState, ColorWrites,
    ComputePipelineDescriptor, FilterMode, FragmentState, PipelineCache, RenderPipelineDescriptor,
    Sampler, SamplerBindingType, SamplerDescriptor, ShaderStages, SpecializedComputePipeline,
    SpecializedComputePipelines, SpecializedRenderPipeline, SpecializedRenderPipelines,
    TextureFormat, TextureSampleType, VertexState,
};
use bevy::render::renderer::RenderDevice;
use bevy::render::view::{ExtractedView, Msaa};

use super::prepare::{LensParams, ResolveParams};
use super::{MirrorPipelineIds, RefractionPipelineIds, ResolvePipelineIds, Variant};
use crate::CloneShading;
use crate::clones::CloneResolve;
use crate::mirror::MirrorEnvironment;
use crate::refraction::{LensRefraction, LensVertex};

/// Where `embedded_asset!` puts the passes' shaders (the plugin embeds
/// them).
const RESOLVE_SHADER: &str = "embedded://optica_spectacles/shaders/resolve.wgsl";
const LENS_SHADER: &str = "embedded://optica_spectacles/shaders/lens_refraction.wgsl";

/// The layouts, samplers and shaders of the spectacles' passes.
#[derive(Resource)]
pub(super) struct SpectaclesPipelines {
    /// The resolve's layouts: the clones' colours, reprojection from a
    /// single-sampled depth, from an MSAA depth.
    resolve_layouts: [BindGroupLayoutDescriptor; 3],
    /// Bilinear: a view whose size differs from the tiles' (while the
    /// atlas catches up with a resized window) is still filled; the lens
    /// reads the view through it too.
    pub(super) linear: Sampler,
    /// Nearest, for the reprojection's gathers (depth textures take no
    /// filtering sampler).
    pub(super) gather: Sampler,
    /// The march's layouts: single-sampled depth, then MSAA.
    march_layouts: [BindGroupLayoutDescriptor; 2],
    pub(super) draw_layout: BindGroupLayoutDescriptor,
    fullscreen: FullscreenShader,
    resolve_shader: Handle<Shader>,
    lens_shader: Handle<Shader>,
}

impl SpectaclesPipelines {
    pub(super) fn resolve_layout(&self, variant: Variant) -> &BindGroupLayoutDescriptor {
        &self.resolve_layouts[match variant {
            Variant::Full => 0,
            Variant::Reprojected { multisampled } => 1 + usize::from(multisampled),
        }]
    }

    pub(super) fn march_layout(&self, multisampled: bool) -> &BindGroupLayoutDescriptor {
        &self.march_layouts[usize::from(multisampled)]
    }
}

/// A full-screen or lens draw into a target of `format`.
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub(super) enum DrawKey {
    /// The clones' mean over the view.
    Resolve {
        variant: Variant,
        format: TextureFormat,
    },
    /// The view copied before the lens is drawn over it.
    LensCopy { format: TextureFormat },
    /// The lens's back surface, with its exit rays' coordinates.
    Lens { format: TextureFormat },
}

/// The exit rays' march through a depth (single-sampled or MSAA).
#[derive(Clone, Copy, PartialEq, Eq, Hash, Debug)]
pub(super) struct MarchKey {
    multisampled: bool,
}

fn resolve_layout(variant: Variant) -> BindGroupLayoutDescriptor {
    let common = (
        texture_2d(TextureSampleType::Float { filterable: true }),
        sampler(SamplerBindingType::Filtering),
        uniform_buffer::<ResolveParams>(false),
    );
    let label = "optica_spectacles_resolve_layout";
    match variant {
        Variant::Full => BindGroupLayoutDescriptor::new(
            label,
            &BindGroupLayoutEntries::sequential(ShaderStages::FRAGMENT, common),
        ),
        Variant::Reprojected { multisampled } => BindGroupLayoutDescriptor::new(
            label,
            &BindGroupLayoutEntries::sequential(
                ShaderStages::FRAGMENT,
                (
                    common.0,
                    common.1,
                    common.2,
                    texture_2d(TextureSampleType::Float { filterable: false }),
                    if multisampled {
                        texture_depth_2d_multisampled()
                    } else {
                        texture_depth_2d()
                    },
                    sampler(SamplerBindingType::NonFiltering),
                ),
            ),
        ),
    }
}

fn march_layout(multisampled: bool) -> BindGroupLayoutDescriptor {
    BindGroupLayoutDescriptor::new(
        "optica_spectacles_lens_march",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::COMPUTE,
            (
                uniform_buffer::<LensParams>(false),
                storage_buffer_read_only::<Vec<LensVertex>>(false),
                storage_buffer::<Vec<Vec4>>(false),
                if multisampled {
                    texture_depth_2d_multisampled()
                } else {
                    texture_depth_2d()
                },
            ),
        ),
    )
}

pub(super) fn init_spectacles_pipelines(
    mut commands: Commands,
    render_device: Res<RenderDevice>,
    asset_server: Res<AssetServer>,
    fullscreen: Res<FullscreenShader>,
) {
    let draw_layout = BindGroupLayoutDescriptor::new(
        "optica_spectacles_lens_draw",
        &BindGroupLayoutEntries::sequential(
            ShaderStages::VERTEX_FRAGMENT,
            (
                uniform_buffer::<LensParams>(false),
                storage_buffer_read_only::<Vec<LensVertex>>(false),
                storage_buffer_read_only::<Vec<Vec4>>(false),
                texture_2d(TextureSampleType::Float { filterable: true }),
                sampler(SamplerBindingType::Filtering),
            ),
        ),
    );
    commands.insert_resource(SpectaclesPipelines {
        resolve_layouts: [
            resolve_layout(Variant::Full),
            resolve_layout(Variant::Reprojected {
                multisampled: false,
            }),
            resolve_layout(Variant::Reprojected { multisampled: true }),
        ],
        linear: render_device.create_sampler(&SamplerDescriptor {
            label: Some("optica_spectacles_linear"),
            mag_filter: FilterMode::Linear,
            min_filter: FilterMode::Linear,
            ..default()
        }),
        gather: render_device.create_sampler(&SamplerDescriptor {
            label: Some("optica_spectacles_resolve_gather"),
            ..default()
        }),
        march_layouts: [march_layout(false), march_layout(true)],
        draw_layout,
        fullscreen: fullscreen.clone(),
        resolve_shader: asset_server.load(RESOLVE_SHADER),
        lens_shader: asset_server.load(LENS_SHADER),
    });
}

impl SpecializedComputePipeline for SpectaclesPipelines {
    type Key = MarchKey;

    fn specialize(&self, key: MarchKey) -> ComputePipelineDescriptor {
        ComputePipelineDescriptor {
            label: Some("optica_spectacles_lens_march".into()),
            layout: vec![self.march_layout(key.multisampled).clone()],
            immediate_size: 0,
            shader: self.lens_shader.clone(),
            shader_defs: if key.multisampled {
                vec!["MARCH".into(), "MULTISAMPLED".into()]
            } else {
                vec!["MARCH".into()]
            },
            entry_point: Some("march".into()),
            zero_initialize_workgroup_memory: false,
        }
    }
}

impl SpecializedRenderPipeline for SpectaclesPipelines {
    type Key = DrawKey;

    fn specialize(&self, key: DrawKey) -> RenderPipelineDescriptor {
        let target = |format| {
            vec![Some(ColorTargetState {
                format,
                blend: None,
                write_mask: ColorWrites::ALL,
            })]
        };
        match key {
            DrawKey::Resolve { variant, format } => fullscreen_pipeline(
                "optica_spectacles_resolve",
                self.resolve_layout(variant),
                &self.fullscreen,
                &self.resolve_shader,
                "fragment",
                match variant {
                    Variant::Full => vec!["FULL".into()],
                    Variant::Reprojected { multisampled: true } => vec!["MULTISAMPLED".into()],
                    Variant::Reprojected { .. } => vec![],
                },
                format,
            ),
            DrawKey::LensCopy { format } => fullscreen_pipeline(
                "optica_spectacles_lens_copy",
                &self.draw_layout,
                &self.fullscreen,
                &self.lens_shader,
                "copy_fragment",
                vec![],
                format,
            ),
            DrawKey::Lens { format } => RenderPipelineDescriptor {
                label: Some("optica_spectacles_lens_draw".into()),
                layout: vec![self.draw_layout.clone()],
                vertex: VertexState {
                    shader: self.lens_shader.clone(),
                    entry_point: Some("lens_vertex".into()),
                    ..default()
                },
                fragment: Some(FragmentState {
                    shader: self.lens_shader.clone(),
                    entry_point: Some("lens_fragment".into()),
                    targets: target(format),
                    ..default()
                }),
                ..default()
            },
        }
    }
}

/// Specialises the pipelines of every eye camera (the resolve), lens
/// camera (the march, the copy and the lens) and mirror environment
/// camera (the march); the cache queues a pipeline the first time its key
/// is asked for.
#[allow(clippy::type_complexity)]
pub(super) fn prepare_spectacles_pipelines(
    mut commands: Commands,
    pipeline_cache: Res<PipelineCache>,
    pipelines: Res<SpectaclesPipelines>,
    mut compute: ResMut<SpecializedComputePipelines<SpectaclesPipelines>>,
    mut render: ResMut<SpecializedRenderPipelines<SpectaclesPipelines>>,
    views: Query<(
        Entity,
        &ExtractedView,
        &Msaa,
        Option<&CloneResolve>,
        Option<&LensRefraction>,
        Has<MirrorEnvironment>,
    )>,
) {
    for (entity, view, msaa, resolve, lens, mirror) in &views {
        let multisampled = msaa.samples() > 1;
        let format = view.target_format;
        let mut draw = |key| render.specialize(&pipeline_cache, &pipelines, key);
        let mut entity = commands.entity(entity);
        if let Some(resolve) = resolve {
            let variant = match resolve.shading {
                CloneShading::Full => Variant::Full,
                CloneShading::Reprojected => Variant::Reprojected { multisampled },
            };
            entity.insert(ResolvePipelineIds {
                variant,
                id: draw(DrawKey::Resolve { variant, format }),
            });
        }
        if lens.is_some_and(|l| !l.vertices.is_empty() && !l.indices.is_empty()) {
            let copy = draw(DrawKey::LensCopy { format });
            let lens = draw(DrawKey::Lens { format });
            entity.insert(RefractionPipelineIds {
                march: compute.specialize(&pipeline_cache, &pipelines, MarchKey { multisampled }),
                multisampled,
                copy,
                lens,
            });
        }
        if mirror {
            // The environment camera's depth is single-sampled (its own
            // camera, no MSAA).
            entity.insert(MirrorPipelineIds {
                march: compute.specialize(
                    &pipeline_cache,
                    &pipelines,
                    MarchKey {
                        multisampled: false,
                    },
                ),
            });
        }
    }
}
