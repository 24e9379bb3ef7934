//! How every mesh reaches the dome: Bevy's mesh, prepass and material
//! vertex shaders all go to clip space through
//! `bevy_pbr::view_transformations::position_world_to_clip`. The plugin
//! adds a branch to that function (and to `position_view_to_clip`) that
//! projects through the dome's lens when the view is a dome camera — recognised by
//! the mesh pipeline's `VIEW_PROJECTION_NONSTANDARD` shader def, which Bevy
//! sets for custom projections, and by the parameters the dome's
//! `clip_from_view` carries. Other views take Bevy's own path unchanged.
//!
//! The patch is applied to the loaded shader asset once, when the first
//! `DomeCamera` appears; a scene without one keeps Bevy's shader as it is.

use bevy::prelude::*;
use bevy::shader::Source;

use crate::{DomeCamera, DomeMode, DomeStatus, Error};

/// Bevy's shader library that the patch extends.
const VIEW_TRANSFORMATIONS: &str = "embedded://bevy_pbr/render/view_transformations.wgsl";

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

/// Bevy's `view_transformations` shader and whether the patch is in:
/// `None` until the shader has loaded, then the patch's outcome.
#[derive(Resource)]
pub(crate) struct ViewTransformations {
    handle: Handle<Shader>,
    outcome: Option<Result<(), Error>>,
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
        Self {
            handle: assets.load(VIEW_TRANSFORMATIONS),
            outcome: None,
        }
    }
}

/// Whether the patch still has to be applied.
pub(crate) fn patch_pending(hook: Option<Res<ViewTransformations>>) -> bool {
    hook.is_none_or(|h| h.outcome.is_none())
}

/// Applies the patch once Bevy's shader is loaded. A source that does not
/// look as expected (another Bevy version) is left alone, with an error in
/// the log and in every vertex-mode camera's [`DomeStatus`]: those cameras
/// then render with a plain perspective.
pub(crate) fn patch_view_transformations(
    mut commands: Commands,
    hook: Option<ResMut<ViewTransformations>>,
    mut shaders: ResMut<Assets<Shader>>,
) {
    let Some(mut hook) = hook else {
        commands.init_resource::<ViewTransformations>();
        return;
    };
    let Some(shader) = shaders.get(&hook.handle) else {
        return;
    };
    let new = match &shader.source {
        Source::Wgsl(source) if source.contains(MARKER) => Ok(None),
        Source::Wgsl(source) => patched(source).map(|text| {
            let mut new = Shader::from_wgsl(text, shader.path.clone());
            new.file_dependencies = shader.file_dependencies.clone();
            new.shader_defs = shader.shader_defs.clone();
            Some(new)
        }),
        _ => Err(Error::ShaderPatch("Bevy's view shader is not WGSL")),
    };
    let outcome = new.and_then(|new| match new {
        Some(new) => shaders
            .insert(hook.handle.id(), new)
            .map_err(|_| Error::ShaderPatch("the patched shader could not replace Bevy's")),
        None => Ok(()),
    });
    if let Err(why) = &outcome {
        error!(
            "optica_dome: {why} (a Bevy other than 0.19?); vertex-mode dome cameras draw a plain perspective"
        );
    }
    hook.outcome = Some(outcome);
}

/// Puts the patch's outcome in every dome camera's [`DomeStatus`]: the
/// vertex mode's error when it failed (settings refusals come first).
pub(crate) fn report_patch(
    hook: Option<Res<ViewTransformations>>,
    mut cameras: Query<(&DomeCamera, &mut DomeStatus)>,
) {
    let Some(outcome) = hook.as_ref().and_then(|h| h.outcome.as_ref()) else {
        return;
    };
    for (dome, mut status) in &mut cameras {
        let patch_error = match (outcome, dome.mode) {
            (Err(e), DomeMode::Vertex) => Some(e.clone()),
            _ => None,
        };
        let error = match &status.error {
            Some(Error::ShaderPatch(_)) | None => patch_error,
            refused => refused.clone(),
        };
        let vertex_projection = Some(outcome.is_ok());
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
