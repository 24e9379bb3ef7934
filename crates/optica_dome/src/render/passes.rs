//! The resampling pass: the domemaster written from the faces, in the
//! dome camera's `Core3d` schedule.

use bevy::prelude::*;
use bevy::render::diagnostic::RecordDiagnostics;
use bevy::render::render_resource::{
    PipelineCache, RenderPassColorAttachment, RenderPassDescriptor,
};
use bevy::render::renderer::{RenderContext, ViewQuery};
use bevy::render::view::ViewTarget;

use super::ResamplePipelineId;
use super::prepare::ResampleBinding;

/// Writes the domemaster from the faces (before tonemapping and the rim
/// mask).
pub(super) fn resample(
    view: ViewQuery<(&ViewTarget, &ResamplePipelineId, &ResampleBinding)>,
    pipeline_cache: Res<PipelineCache>,
    mut ctx: RenderContext,
) {
    let (view_target, ResamplePipelineId(id), binding) = view.into_inner();
    let Some(pipeline) = pipeline_cache.get_render_pipeline(*id) else {
        return;
    };
    let post_process = view_target.post_process_write();
    let pass = RenderPassDescriptor {
        label: Some("optica_dome_cube_resample"),
        color_attachments: &[Some(RenderPassColorAttachment {
            view: post_process.destination,
            depth_slice: None,
            resolve_target: None,
            ops: default(),
        })],
        ..default()
    };
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let mut render_pass = ctx.command_encoder().begin_render_pass(&pass);
    let span = diagnostics.pass_span(&mut render_pass, "optica/dome/cube_resample");
    render_pass.set_pipeline(pipeline);
    render_pass.set_bind_group(0, &binding.bind_group, &[]);
    render_pass.draw(0..3, 0..1);
    span.end(&mut render_pass);
}
