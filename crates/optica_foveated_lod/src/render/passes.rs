//! The tracer's passes in the view's `Core3d` schedule: the trace
//! (compute: the periphery's layers, then every pixel) and the blit
//! (render: the traced image into the view's post-process target).

use bevy::prelude::*;
use bevy::render::diagnostic::RecordDiagnostics;
use bevy::render::render_resource::{
    ComputePassDescriptor, Operations, PipelineCache, RenderPassColorAttachment,
    RenderPassDescriptor,
};
use bevy::render::renderer::{RenderContext, ViewQuery};
use bevy::render::view::ViewTarget;

use super::prepare::ViewBuffers;
use super::{TracerBinding, TracerPipelineIds};
use crate::raytrace::TracerView;

/// `@workgroup_size` of the tracing passes (`LANES` invocations in
/// `raytrace.wgsl`).
const GROUP: UVec2 = UVec2::new(8, 4);

pub(super) fn trace_pass(
    view: ViewQuery<(
        &ViewTarget,
        &ViewBuffers,
        &TracerView,
        &TracerPipelineIds,
        &TracerBinding,
    )>,
    pipeline_cache: Res<PipelineCache>,
    mut ctx: RenderContext,
) {
    let (target, buffers, tv, ids, binding) = view.into_inner();
    let (Some(mid), Some(outer), Some(full), Some(blit)) = (
        pipeline_cache.get_compute_pipeline(ids.trace[0]),
        pipeline_cache.get_compute_pipeline(ids.trace[1]),
        pipeline_cache.get_compute_pipeline(ids.trace[2]),
        pipeline_cache.get_render_pipeline(ids.blit),
    ) else {
        return;
    };
    let post = target.post_process_write();
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    // The whole tracer, and within it the trace (compute) and the blit
    // (render): `optica/foveated_lod`, `.../trace`, `.../blit`.
    let span = diagnostics.time_span(ctx.command_encoder(), "optica/foveated_lod");
    {
        let mut pass = ctx
            .command_encoder()
            .begin_compute_pass(&ComputePassDescriptor {
                label: Some("optica_foveated_lod_trace"),
                timestamp_writes: None,
            });
        let pass_span = diagnostics.pass_span(&mut pass, "trace");
        pass.set_bind_group(0, &binding.trace_group, &[]);
        let groups = |n: UVec2| (n.x.div_ceil(GROUP.x), n.y.div_ceil(GROUP.y));
        if !tv.full_quality && tv.scale > 1 {
            pass.set_pipeline(mid);
            let (x, y) = groups(buffers.low_size);
            pass.dispatch_workgroups(x, y, 1);
            if buffers.has_outer {
                pass.set_pipeline(outer);
                let (x, y) = groups(buffers.outer_size);
                pass.dispatch_workgroups(x, y, 1);
            }
        }
        pass.set_pipeline(full);
        let (x, y) = groups(buffers.size);
        pass.dispatch_workgroups(x, y, 1);
        pass_span.end(&mut pass);
    }
    {
        let mut pass = ctx
            .command_encoder()
            .begin_render_pass(&RenderPassDescriptor {
                label: Some("optica_foveated_lod_blit"),
                color_attachments: &[Some(RenderPassColorAttachment {
                    view: post.destination,
                    depth_slice: None,
                    resolve_target: None,
                    ops: Operations::default(),
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
        // Cameras that share a target draw into their own viewport.
        let pass_span = diagnostics.pass_span(&mut pass, "blit");
        let (origin, size) = (buffers.origin.as_vec2(), buffers.size.as_vec2());
        pass.set_viewport(origin.x, origin.y, size.x, size.y, 0.0, 1.0);
        pass.set_bind_group(0, &binding.blit_group, &[]);
        pass.set_pipeline(blit);
        pass.draw(0..3, 0..1);
        pass_span.end(&mut pass);
    }
    span.end(ctx.command_encoder());
}
