//! The flare's passes in the view's `Core3d` schedule, each timed as a
//! span of its own (`optica/lens_flare/{occlusion, trace, fill, cells, coarse,
//! draw, composite}`).

use bevy::prelude::*;
use bevy::render::diagnostic::RecordDiagnostics;
use bevy::render::render_resource::{
    BindGroup, CommandEncoder, ComputePassDescriptor, ComputePipeline, IndexFormat, LoadOp,
    Operations, PipelineCache, RenderPassColorAttachment, RenderPassDescriptor, StoreOp,
    TextureView,
};
use bevy::render::renderer::{RenderContext, ViewQuery};
use bevy::render::view::ViewTarget;

use super::FlareBinding;

/// Traces the grids, then draws their cells into the view target.
pub(super) fn flare_passes(
    view: ViewQuery<(&ViewTarget, &FlareBinding)>,
    pipeline_cache: Res<PipelineCache>,
    mut ctx: RenderContext,
) {
    let (target, binding) = view.into_inner();
    let (Some(trace), Some(fill), Some(cells), Some(draw)) = (
        pipeline_cache.get_compute_pipeline(binding.trace),
        pipeline_cache.get_compute_pipeline(binding.fill),
        pipeline_cache.get_compute_pipeline(binding.cells),
        pipeline_cache.get_render_pipeline(binding.draw),
    ) else {
        return;
    };
    let starburst = binding
        .starburst
        .and_then(|id| pipeline_cache.get_render_pipeline(id));
    let reduced = match &binding.reduced {
        Some((texture, group, id)) => match pipeline_cache.get_render_pipeline(*id) {
            Some(pipeline) => Some((texture, group, pipeline)),
            None => return,
        },
        None => None,
    };
    let coarse = match &binding.coarse {
        Some((texture, group, upsample, draw)) => match (
            pipeline_cache.get_render_pipeline(*upsample),
            pipeline_cache.get_render_pipeline(*draw),
        ) {
            (Some(upsample), Some(draw)) => Some((texture, group, upsample, draw)),
            _ => return,
        },
        None => None,
    };
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let occlusion = binding.occlusion.as_ref().and_then(|(group, id)| {
        pipeline_cache
            .get_compute_pipeline(*id)
            .map(|pipeline| (group, pipeline))
    });
    let span = diagnostics.time_span(ctx.command_encoder(), "optica/lens_flare");
    let encoder = ctx.command_encoder();
    if let Some((group, pipeline)) = occlusion {
        let groups = (binding.lights, 1);
        compute_pass(encoder, &diagnostics, "occlusion", pipeline, group, groups);
    }
    if binding.retrace {
        let groups = groups_for(binding.threads);
        compute_pass(
            encoder,
            &diagnostics,
            "trace",
            trace,
            &binding.trace_group,
            groups,
        );
        let groups = groups_for(binding.rays);
        compute_pass(
            encoder,
            &diagnostics,
            "fill",
            fill,
            &binding.trace_group,
            groups,
        );
        // The cells' colours and triangles follow the rays alone (the
        // draw scales them by the intensity and each light's visibility),
        // so a still view's hold too.
        let groups = groups_for(binding.spans);
        compute_pass(
            encoder,
            &diagnostics,
            "cells",
            cells,
            &binding.cells_group,
            groups,
        );
    }
    // The ghosts: onto the view, or into their reduced-resolution target
    // (cleared), which is then scaled up onto the view with the
    // starburst.
    let view_attachment = target.get_unsampled_color_attachment();
    let ghost_attachment = match &reduced {
        Some((texture, ..)) => cleared(texture),
        None => view_attachment.clone(),
    };
    // The large ghosts first, into their own target at half the
    // resolution, which the ghosts' pass then scales up into its own.
    if let Some((texture, _, _, coarse_draw)) = &coarse {
        let attachments = [Some(cleared(texture))];
        let mut pass = ctx
            .command_encoder()
            .begin_render_pass(&only_into("optica_lens_flare_coarse", &attachments));
        let pass_span = diagnostics.pass_span(&mut pass, "coarse");
        pass.set_pipeline(coarse_draw);
        pass.set_bind_group(0, &binding.draw_group, &[]);
        pass.set_index_buffer((*binding.indices).slice(..), IndexFormat::Uint32);
        pass.draw_indexed(6 * binding.fine_cells..6 * binding.cell_count, 0, 0..1);
        pass_span.end(&mut pass);
    }
    {
        let attachments = [Some(ghost_attachment)];
        let mut pass = ctx
            .command_encoder()
            .begin_render_pass(&only_into("optica_lens_flare_draw", &attachments));
        let pass_span = diagnostics.pass_span(&mut pass, "draw");
        pass.set_pipeline(draw);
        pass.set_bind_group(0, &binding.draw_group, &[]);
        pass.set_index_buffer((*binding.indices).slice(..), IndexFormat::Uint32);
        pass.draw_indexed(0..6 * binding.fine_cells, 0, 0..1);
        if let Some((_, group, upsample, _)) = coarse {
            pass.set_pipeline(upsample);
            pass.set_bind_group(0, group, &[]);
            pass.draw(0..3, 0..1);
            pass.set_bind_group(0, &binding.draw_group, &[]);
        }
        if let (None, Some(starburst)) = (&reduced, starburst) {
            pass.set_pipeline(starburst);
            pass.draw(0..6, 0..binding.lights);
        }
        pass_span.end(&mut pass);
    }
    if let Some((_, group, upsample)) = reduced {
        let attachments = [Some(view_attachment)];
        let mut pass = ctx
            .command_encoder()
            .begin_render_pass(&only_into("optica_lens_flare_composite", &attachments));
        let pass_span = diagnostics.pass_span(&mut pass, "composite");
        pass.set_pipeline(upsample);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..3, 0..1);
        if let Some(starburst) = starburst {
            pass.set_pipeline(starburst);
            pass.set_bind_group(0, &binding.draw_group, &[]);
            pass.draw(0..6, 0..binding.lights);
        }
        pass_span.end(&mut pass);
    }
    span.end(ctx.command_encoder());
}

/// A render pass drawing into `attachments` alone.
fn only_into<'a>(
    label: &'a str,
    attachments: &'a [Option<RenderPassColorAttachment<'a>>],
) -> RenderPassDescriptor<'a> {
    RenderPassDescriptor {
        label: Some(label),
        color_attachments: attachments,
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    }
}

/// An attachment of `view`, cleared before the pass adds to it.
fn cleared(view: &TextureView) -> RenderPassColorAttachment<'_> {
    RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: Operations {
            load: LoadOp::Clear(Default::default()),
            store: StoreOp::Store,
        },
    }
}

/// Dispatches `groups` (x, y) workgroups of `pipeline` with `group` in a
/// compute pass of its own, timed as `optica/lens_flare/{span}`.
fn compute_pass(
    encoder: &mut CommandEncoder,
    diagnostics: &impl RecordDiagnostics,
    span: &'static str,
    pipeline: &ComputePipeline,
    group: &BindGroup,
    (x, y): (u32, u32),
) {
    let label = format!("optica_lens_flare_{span}");
    let mut pass = encoder.begin_compute_pass(&ComputePassDescriptor {
        label: Some(&label),
        timestamp_writes: None,
    });
    let pass_span = diagnostics.pass_span(&mut pass, span);
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, group, &[]);
    pass.dispatch_workgroups(x, y, 1);
    pass_span.end(&mut pass);
}

/// Workgroups of 64 for `threads` threads, as (x, y) within the 65535 a
/// dimension allows (the shaders rebuild the index from both).
fn groups_for(threads: u32) -> (u32, u32) {
    let groups = threads.div_ceil(64);
    (groups.min(65535), groups.div_ceil(65535))
}
