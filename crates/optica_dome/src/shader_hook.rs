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

/// Bevy's `view_transformations` shader and whether the patch is in.
#[derive(Resource)]
pub(crate) struct ViewTransformations {
    handle: Handle<Shader>,
    done: bool,
}

impl FromWorld for ViewTransformations {
    fn from_world(world: &mut World) -> Self {
        Self {
            handle: world.resource::<AssetServer>().load(VIEW_TRANSFORMATIONS),
            done: false,
        }
    }
}

/// Whether the patch still has to be applied.
pub(crate) fn patch_pending(hook: Option<Res<ViewTransformations>>) -> bool {
    hook.is_none_or(|h| !h.done)
}

/// Applies the patch once Bevy's shader is loaded. A source that does not
/// look as expected (another Bevy version) is left alone, with an error in
/// the log: dome cameras then render with a plain perspective.
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
    hook.done = true;
    let Source::Wgsl(source) = &shader.source else {
        error!("optica_dome: {VIEW_TRANSFORMATIONS} is not WGSL; dome cameras cannot project");
        return;
    };
    if source.contains(MARKER) {
        return;
    }
    match patched(source) {
        Ok(text) => {
            let mut new = Shader::from_wgsl(text, shader.path.clone());
            new.file_dependencies = shader.file_dependencies.clone();
            new.shader_defs = shader.shader_defs.clone();
            let id = hook.handle.id();
            if let Err(e) = shaders.insert(id, new) {
                error!("optica_dome: could not replace {VIEW_TRANSFORMATIONS}: {e}");
            }
        }
        Err(missing) => error!(
            "optica_dome: {VIEW_TRANSFORMATIONS} has no `{missing}` (a Bevy other than 0.19?); \
             dome cameras cannot project"
        ),
    }
}

/// Bevy's source with the dome branches, or the line that was not found.
fn patched(source: &str) -> Result<String, &'static str> {
    let mut text = source.to_string();
    let at = text.find(ANCHOR_IMPORT).ok_or(ANCHOR_IMPORT)? + ANCHOR_IMPORT.len();
    text.insert_str(
        at,
        &format!("\n{MARKER}\n#import optica_dome::projection as dome_projection"),
    );
    for (signature, branch) in BRANCHES {
        let at = text.find(signature).ok_or(signature)? + signature.len();
        text.insert_str(at, branch);
    }
    Ok(text)
}
