//! How every mesh reaches the dome: Bevy's mesh, prepass and material
//! vertex shaders all go to clip space through
//! `bevy_pbr::view_transformations::position_world_to_clip`. The plugin
//! adds a branch to that function (and to `position_view_to_clip`) that
//! projects through the dome's lens when the view is a dome camera — recognised by
//! the mesh pipeline's `VIEW_PROJECTION_NONSTANDARD` shader def, which Bevy
//! sets for custom projections, and by the parameters the dome's
//! `clip_from_view` carries. Other views take Bevy's own path unchanged.
//!
//! A second patch makes attributes exact inside refined triangles: Bevy's
//! `pbr_fragment::pbr_input_from_standard_material` (where the standard
//! material's forward, deferred and prepass fragments read their vertex
//! output) first moves each dome fragment's interpolated position along its
//! screen differences to where its own ray meets its triangle's plane, and
//! every attribute by the same step (D11 of `optica_optics::dome`,
//! `plane_step` in `projection.wgsl`). Without it the rasteriser
//! interpolates texture coordinates across each refined triangle's image,
//! which no w makes exact under a fisheye.
//!
//! The patches are applied to the loaded shader assets once, when the first
//! `DomeCamera` appears; a scene without one keeps Bevy's shaders as they are.

use bevy::prelude::*;
use bevy::shader::Source;

use crate::{DomeCamera, DomeMode, DomeStatus, Error};

/// Bevy's shader library that the projection patch extends.
const VIEW_TRANSFORMATIONS: &str = "embedded://bevy_pbr/render/view_transformations.wgsl";

/// Bevy's fragment library that the exact-attribute patch extends.
const PBR_FRAGMENT: &str = "embedded://bevy_pbr/render/pbr_fragment.wgsl";

/// The import line the branch needs, added after this one.
const ANCHOR_IMPORT: &str = "#import bevy_pbr::prepass_bindings";

/// The functions the branch goes into: (signature, the branch).
const BRANCHES: [(&str, &str); 2] = [
    (
        "fn position_world_to_clip(world_pos: vec3<f32>) -> vec4<f32> {",
        "
#ifdef VIEW_PROJECTION_NONSTANDARD
    if dome_projection::is_dome(view_bindings::view.clip_from_view) {
        return dome_projection::clip_of_view(position_world_to_view(world_pos), view_bindings::view.clip_from_view);
    }
#endif",
    ),
    (
        "fn position_view_to_clip(view_pos: vec3<f32>) -> vec4<f32> {",
        "
#ifdef VIEW_PROJECTION_NONSTANDARD
    if dome_projection::is_dome(view_bindings::view.clip_from_view) {
        return dome_projection::clip_of_view(view_pos, view_bindings::view.clip_from_view);
    }
#endif",
    ),
];

/// Marks the patch in the source, so it is applied once.
const MARKER: &str = "// optica_dome: equidistant branch";

/// The fragment patch: its marker, the line its import follows, the
/// signature whose parameter it renames, and the function it adds.
const FRAGMENT_MARKER: &str = "// optica_dome: exact attributes";
const FRAGMENT_ANCHOR_IMPORT: &str = "#import bevy_pbr::{";
const FRAGMENT_SIGNATURE: &str = "fn pbr_input_from_standard_material(\n    in: VertexOutput,";
const FRAGMENT_RENAMED: &str = "fn pbr_input_from_standard_material(\n    in_dome: VertexOutput,";
/// Opens the renamed function's body: the exact input under the old name.
const FRAGMENT_BODY: &str = "\n    let in = optica_dome_exact(in_dome);";
const FRAGMENT_BODY_ANCHOR: &str = ") -> pbr_types::PbrInput {";
/// The function the patch adds before `pbr_input_from_standard_material`:
/// it works on whichever `VertexOutput` the pipeline imported (forward,
/// prepass), through the shader defs that declare its fields.
const FRAGMENT_EXACT: &str = "
// `v` moved by the step `s` along its own screen differences (called in
// uniform control flow: it takes derivatives).
fn optica_dome_step2(v: vec2<f32>, s: vec2<f32>) -> vec2<f32> {
    return v + s.x * dpdxFine(v) + s.y * dpdyFine(v);
}
fn optica_dome_step3(v: vec3<f32>, s: vec2<f32>) -> vec3<f32> {
    return v + s.x * dpdxFine(v) + s.y * dpdyFine(v);
}
fn optica_dome_step4(v: vec4<f32>, s: vec2<f32>) -> vec4<f32> {
    return v + s.x * dpdxFine(v) + s.y * dpdyFine(v);
}

// The vertex output with its attributes exact at this fragment's pixel in
// a dome view (D11 of optica_optics::dome): the interpolated position
// moved along its screen differences to its own ray's point on the
// triangle's plane, every other attribute by the same step. (The normal
// and tangent are there in the forward output always, in the prepass
// output only for normals or the deferred G-buffer.)
fn optica_dome_exact(in: VertexOutput) -> VertexOutput {
    var out = in;
#ifdef VIEW_PROJECTION_NONSTANDARD
#ifndef MESHLET_MESH_MATERIAL_PASS
    if dome_projection::is_dome(view.clip_from_view) && dome_projection::exact_attributes(view.clip_from_view) {
        let p = in.world_position.xyz;
        let dp_dx = dpdxFine(p);
        let dp_dy = dpdyFine(p);
        let ray = dome_projection::view_ray(in.position.xy, view.viewport, view.clip_from_view);
        let world_ray = (view.world_from_view * vec4<f32>(ray.xyz, 0.0)).xyz;
        let s = dome_projection::plane_step(view.world_position, world_ray, p, dp_dx, dp_dy) * ray.w;
        out.world_position = vec4<f32>(p + s.x * dp_dx + s.y * dp_dy, in.world_position.w);
#ifdef VERTEX_UVS_A
        out.uv = optica_dome_step2(in.uv, s);
#endif
#ifdef VERTEX_UVS_B
        out.uv_b = optica_dome_step2(in.uv_b, s);
#endif
#ifdef VERTEX_COLORS
        out.color = optica_dome_step4(in.color, s);
#endif
#ifdef PREPASS_PIPELINE
#ifdef NORMAL_PREPASS_OR_DEFERRED_PREPASS
        out.world_normal = optica_dome_step3(in.world_normal, s);
#ifdef VERTEX_TANGENTS
        out.world_tangent = optica_dome_step4(in.world_tangent, s);
#endif
#endif
#else
        out.world_normal = optica_dome_step3(in.world_normal, s);
#ifdef VERTEX_TANGENTS
        out.world_tangent = optica_dome_step4(in.world_tangent, s);
#endif
#endif
    }
#endif
#endif
    return out;
}
";

/// One of Bevy's shaders the plugin patches: its handle, how to patch its
/// text, and the outcome (`None` until the shader has loaded).
struct Patch {
    handle: Handle<Shader>,
    apply: fn(&str) -> Result<String, Error>,
    marker: &'static str,
    outcome: Option<Result<(), Error>>,
}

/// Bevy's `view_transformations` and `pbr_fragment` shaders and whether the
/// patches are in.
#[derive(Resource)]
pub(crate) struct ViewTransformations {
    patches: [Patch; 2],
}

impl ViewTransformations {
    /// `None` until every patch has an outcome.
    fn done(&self) -> bool {
        self.patches.iter().all(|p| p.outcome.is_some())
    }

    /// The projection patch's outcome, and the exact-attribute patch's
    /// (`None` while pending).
    fn outcomes(&self) -> (Option<&Result<(), Error>>, Option<&Result<(), Error>>) {
        (
            self.patches[0].outcome.as_ref(),
            self.patches[1].outcome.as_ref(),
        )
    }
}

impl FromWorld for ViewTransformations {
    fn from_world(world: &mut World) -> Self {
        // Without Bevy's asset plugin there is no shader to patch: say so
        // where the plugin is misplaced, rather than never drawing a dome.
        let Some(assets) = world.get_resource::<AssetServer>() else {
            panic!(
                "optica_dome: DomePlugin needs Bevy's AssetPlugin (add it after DefaultPlugins)"
            );
        };
        let patch = |path: &'static str, apply, marker| Patch {
            handle: assets.load(path),
            apply,
            marker,
            outcome: None,
        };
        Self {
            patches: [
                patch(VIEW_TRANSFORMATIONS, patched, MARKER),
                patch(PBR_FRAGMENT, patched_fragment, FRAGMENT_MARKER),
            ],
        }
    }
}

/// Whether a patch still has to be applied.
pub(crate) fn patch_pending(hook: Option<Res<ViewTransformations>>) -> bool {
    hook.is_none_or(|h| !h.done())
}

/// Applies the patches once Bevy's shaders are loaded. A source that does
/// not look as expected (another Bevy version) is left alone, with an error
/// in the log and in every vertex-mode camera's [`DomeStatus`]: without the
/// projection those cameras render with a plain perspective; without the
/// fragment patch, with attributes interpolated inside refined triangles.
pub(crate) fn patch_view_transformations(
    mut commands: Commands,
    hook: Option<ResMut<ViewTransformations>>,
    mut shaders: ResMut<Assets<Shader>>,
) {
    let Some(mut hook) = hook else {
        commands.init_resource::<ViewTransformations>();
        return;
    };
    // The exact-attribute step reads the dome's projection back from the
    // view: without the projection patch the view is drawn as a plain
    // perspective and the step must not run.
    let projected = hook.patches[0].outcome.clone();
    for (k, patch) in hook.patches.iter_mut().enumerate() {
        if patch.outcome.is_some() {
            continue;
        }
        if k > 0 {
            match &projected {
                None => continue,
                Some(Err(_)) => {
                    patch.outcome = Some(Err(Error::AttributePatch(
                        "not applied: the vertex projection is not in Bevy's view shader",
                    )));
                    continue;
                }
                Some(Ok(())) => {}
            }
        }
        let Some(shader) = shaders.get(&patch.handle) else {
            continue;
        };
        // The error of this patch: the projection's or the attributes'.
        let fail = if k == 0 {
            Error::ShaderPatch
        } else {
            Error::AttributePatch
        };
        let new = match &shader.source {
            Source::Wgsl(source) if source.contains(patch.marker) => Ok(None),
            Source::Wgsl(source) => (patch.apply)(source).map(|text| {
                let mut new = Shader::from_wgsl(text, shader.path.clone());
                new.file_dependencies = shader.file_dependencies.clone();
                new.shader_defs = shader.shader_defs.clone();
                Some(new)
            }),
            _ => Err(fail("Bevy's shader is not WGSL")),
        };
        let outcome = new.and_then(|new| match new {
            Some(new) => shaders
                .insert(patch.handle.id(), new)
                .map_err(|_| fail("the patched shader could not replace Bevy's")),
            None => Ok(()),
        });
        if let Err(why) = &outcome {
            error!("optica_dome: {why} (a Bevy other than 0.19?)");
        }
        patch.outcome = Some(outcome);
    }
}

/// Puts the patches' outcome in every dome camera's [`DomeStatus`]: in the
/// vertex mode, the projection patch's error, else (with exact attributes
/// on) the exact-attribute patch's (settings refusals come first).
pub(crate) fn report_patch(
    hook: Option<Res<ViewTransformations>>,
    mut cameras: Query<(&DomeCamera, &mut DomeStatus)>,
) {
    let Some(hook) = hook.filter(|h| h.done()) else {
        return;
    };
    let (Some(projection), Some(attributes)) = hook.outcomes() else {
        return;
    };
    for (dome, mut status) in &mut cameras {
        let patch_error = match (dome.mode, projection, attributes) {
            (DomeMode::Vertex, Err(e), _) => Some(e.clone()),
            (DomeMode::Vertex, Ok(()), Err(e)) if dome.exact_attributes => Some(e.clone()),
            _ => None,
        };
        let error = match &status.error {
            Some(Error::ShaderPatch(_) | Error::AttributePatch(_)) | None => patch_error,
            refused => refused.clone(),
        };
        let vertex_projection = Some(projection.is_ok());
        if status.error != error || status.vertex_projection != vertex_projection {
            status.error = error;
            status.vertex_projection = vertex_projection;
        }
    }
}

/// Bevy's source with the dome branches, or the line that was not found.
pub fn patched(source: &str) -> Result<String, Error> {
    let missing = Error::ShaderPatch;
    let mut text = source.to_string();
    let at = text.find(ANCHOR_IMPORT).ok_or(missing(ANCHOR_IMPORT))? + ANCHOR_IMPORT.len();
    text.insert_str(
        at,
        &format!("\n{MARKER}\n#import optica_dome::projection as dome_projection"),
    );
    for (signature, branch) in BRANCHES {
        let at = text.find(signature).ok_or(missing(signature))? + signature.len();
        text.insert_str(at, branch);
    }
    Ok(text)
}

/// Bevy's `pbr_fragment` source with the exact-attribute step, or the line
/// that was not found.
pub fn patched_fragment(source: &str) -> Result<String, Error> {
    let missing = Error::AttributePatch;
    let mut text = source.to_string();
    let at = text
        .find(FRAGMENT_ANCHOR_IMPORT)
        .ok_or(missing(FRAGMENT_ANCHOR_IMPORT))?;
    text.insert_str(
        at,
        &format!("{FRAGMENT_MARKER}\n#import optica_dome::projection as dome_projection\n"),
    );
    let at = text
        .find(FRAGMENT_SIGNATURE)
        .ok_or(missing(FRAGMENT_SIGNATURE))?;
    text.replace_range(at..at + FRAGMENT_SIGNATURE.len(), FRAGMENT_RENAMED);
    let body = text[at..]
        .find(FRAGMENT_BODY_ANCHOR)
        .ok_or(missing(FRAGMENT_BODY_ANCHOR))?
        + at
        + FRAGMENT_BODY_ANCHOR.len();
    text.insert_str(body, FRAGMENT_BODY);
    text.insert_str(at, FRAGMENT_EXACT);
    Ok(text)
}
