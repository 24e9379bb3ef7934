//! # optica_dome — a fisheye dome camera for Bevy
//!
//! Renders a **fisheye domemaster** for planetarium domes, after Yuna
//! Johjima and Masao Fujimura, *Fragment refinement for real-time
//! equidistant projection* (Osaka Institute of Technology): every vertex is
//! projected in the vertex shader, so ordinary lit meshes
//! (`StandardMaterial`, Bevy's lights and shadows) appear on the dome. The
//! lens ([`DomeLens`]) is the paper's equidistant (f-θ) one by default, or
//! equisolid, stereographic, orthographic, or a calibrated lens's
//! Kannala–Brandt polynomial; the image circle fits the target's shorter
//! side, so non-square targets work too. Or it is no fisheye at all but an
//! equirectangular panorama of the whole sphere, drawn by the same method.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use optica_dome::{DomeCamera, DomePlugin};
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, DomePlugin))
//!     .add_systems(Startup, |mut commands: Commands| {
//!         commands.spawn((
//!             // A fisheye looking at the zenith; the audience front is −Y
//!             // of the camera, here world −Z.
//!             Transform::from_xyz(0.0, 1.6, 0.0).looking_to(Vec3::Y, Vec3::Z),
//!             DomeCamera::default(),
//!         ));
//!     })
//!     .run();
//! ```
//!
//! A 360° panorama: `DomeCamera { lens: DomeLens::Equirectangular,
//! ..default() }` on a camera looking at the horizon, rendering into a 2:1
//! target; its −Z is the image centre, its +Y the top row.
//!
//! ## How meshes reach the dome
//!
//! A [`DomeCamera`] gets a custom `Projection` ([`DomeClip`]) whose
//! frustum culling suits a fisheye (the view plane for FOV ≤ 180°, none
//! beyond). Bevy's mesh
//! pipeline marks views with custom projections by the shader def
//! `VIEW_PROJECTION_NONSTANDARD`; the plugin adds to Bevy's
//! `position_world_to_clip` (the one function every mesh, prepass and
//! material vertex shader reaches clip space through) a branch that
//! projects through the dome's lens for dome views. So a user's own material takes
//! part as long as its vertex shader goes through
//! `bevy_pbr::view_transformations` (or `mesh_functions`), as Bevy's do;
//! other cameras in the same app render as before. The branch is added
//! when the first `DomeCamera` appears; a scene without one keeps Bevy's
//! shader untouched.
//!
//! Clip space: NDC radius `g(θ)/g(θ_max)` along the point's azimuth (g the
//! lens's mapping; the image circle is inscribed in the target's shorter
//! side), depth `near/|p|`
//! (radial, reverse-Z) and `w = |p|`. The shader twin is tested against
//! `optica_optics::dome::DomeProjection::project` by readback.
//!
//! No w makes the rasteriser's interpolation exact under a fisheye, so
//! inside a refined triangle texture would land up to pixels from its
//! place. The plugin also patches Bevy's `pbr_input_from_standard_material`
//! (the standard material's forward, deferred and prepass fragments): each
//! dome fragment moves its interpolated position along its screen
//! differences to where its own pixel's ray meets the triangle's plane, and
//! its texture coordinates, normal, tangent and colour by the same step
//! (`optica_optics::dome::plane_step`, D11). Texture is then exact per pixel
//! whatever the tolerance, and refinement only has to place edges: on a
//! checkered room at 8 px the texels inside faces are all where the CPU
//! twin's rays find them (56 % of them were not before). A custom material
//! that reads its own vertex output gets the projection but not this step.
//! [`DomeCamera::exact_attributes`] turns it off. The `dome` report's
//! textured room (1024², 0.5 px, lavapipe, 2026-12-05): ꟻLIP 0.0019
//! against the rays' point-sampled image (0.0260 interpolated), 0.0258
//! against the 4 × 4 supersampled one, where one sample per pixel can do no
//! better than 0.0250; on that CPU rasteriser the step costs 1.58 [1.54,
//! 1.72]× a perspective view against 1.37 [1.34, 1.39]× interpolated.
//!
//! ## Refinement (the paper's §3.3) on the CPU
//!
//! Straight edges drawn between projected vertices sag away from the true
//! curved image of a 3D edge (the paper's fig. 1): a 10° edge at the rim of
//! a 4K, 180° dome is ~8 px off. WGSL has no geometry shader, so every mesh
//! a dome camera sees gets a refined *twin* on the CPU
//! (`optica_optics::dome::refine_triangle`): clipped behind the viewer
//! (FOV ≤ 180°; next to 180° carried 1° on past the rim so that the rim
//! itself is covered) or culled at the antipode guard (wider), and split until
//! every chord is within [`DomeCamera::tolerance_px`], measured in the
//! lens's own image (its curvature there, `optica_optics::dome` D10); neighbours split
//! their shared edges identically, so no crack opens. A twin is rebuilt only
//! when its mesh, its placement relative to the camera or the camera's
//! settings change. Twins live on the render layer [`DOME_LAYER`], which
//! only dome cameras see (every light is given it too); they carry their
//! original's material for `StandardMaterial`, and for any material `M`
//! whose [`DomeMaterialPlugin<M>`] is added. [`DomeRefineStats`] says what
//! the last pass rebuilt and what it cost.
//!
//! ## The paper's classification (§3.1)
//!
//! Mark meshes that keep their distance to the viewer and only turn about
//! it (stars, constellation art, a sky sphere centred on the camera, the
//! diurnal motion) [`DomeApparentSize::NearlyConstant`]: they are split
//! once with the paper's rotation-invariant step and not again while the
//! camera or the sky turns; the vertex shader drops what of them lies near
//! the antipode. Everything else is refined from the view whenever it moves
//! relative to the camera.
//!
//! ## Lines
//!
//! `LineList` and `LineStrip` meshes are refined like triangle edges
//! (clipped, split until their chords are within the tolerance) and drawn
//! as the GPU's one-pixel lines; [`lines`] builds constellation lines, a
//! graticule and polylines. A segment between two points on a sphere
//! around the viewer is seen along the great circle through them, so one
//! segment per arc draws it exactly.
//!
//! ## The cube-map mode
//!
//! [`DomeMode::CubeMap`] draws the scene with 4, 5 or 6 ordinary
//! perspective cameras (children of the dome camera; 4 up to 180°, 5 up to
//! 250°, 6 beyond, the cube turned as SGCT turns it) into linear HDR images
//! and resamples them per output pixel (bilinear, one guard texel per face
//! edge so filtering is seamless across the cube's edges). Any material and
//! any effect of a perspective camera works; the faces see render layer 0.
//! It costs one scene draw per face: at equal edge error the vertex mode is
//! cheaper (see the `dome` report). Modes can be switched at run time.
//!
//! ## Exporting a show
//!
//! [`DomeExportPlugin`] writes a domemaster PNG sequence of a frame range
//! (`domemaster_NNNNNN.png`); animate from [`DomeShowClock`] so that every
//! frame is a function of its number and a render farm can split the show
//! into ranges ([`parse_frame_range`] reads `A..B`). The `dome` example
//! does it from the command line (`--export DIR --frames A..B --size N`).
//!
//! ### On a render farm
//!
//! Each farm task renders one range into a folder every node sees; a
//! final step lists what is missing ([`DomeExport::missing`], the
//! example's `--check`) and the ranges that render it again
//! ([`frame_ranges`]). A frame is written under another name and renamed
//! when complete, so a task killed mid-write leaves its frame missing, not
//! truncated, and a task that cannot write exits with status 1. Frame `n`
//! is the same image, bit for bit, whichever task rendered it.
//!
//! `scripts/farm/` does this on Slurm as an array job:
//!
//! ```sh
//! # Frames 0..240 at 4K in 30 tasks of 8 frames, then the check step:
//! scripts/farm/submit-show.sh target/release/examples/dome /shared/show 0..240 8 -- --size 4096
//! # The check step's output names the tasks to rerun, e.g. 2 and 17:
//! scripts/farm/submit-show.sh target/release/examples/dome /shared/show 0..240 8 --tasks 2,17 -- --size 4096
//! ```
//!
//! - **What a node needs:** the binary (the example built with
//!   `--release --features dome`, or your own app with
//!   [`DomeExportPlugin`]) and a Vulkan driver. No GPU is required: Mesa's
//!   lavapipe (`mesa-vulkan-drivers`, Mesa 23 or later) renders on the
//!   CPU, the same frames up to its rasterisation.
//! - **Sizing ranges:** a task pays a start (Bevy, the device, the
//!   pipelines) before its first frame: 0.9 s, then 0.43 s a frame at
//!   1024² (debug build, lavapipe, 2 cores). Give each task at least ten
//!   times its start in frames (here 20 or more), and no more than a node
//!   should lose to a failure; for a farm of mixed nodes, more tasks than
//!   nodes so that fast nodes take more of them. Every frame is rendered
//!   from a settled state ([`DomeExport::warmup_updates`]), so a range
//!   costs the same whatever frame it starts at.
//! - **Tested** by `scripts/farm/slurm-test.sh` against a real Slurm (a
//!   one-node cluster on the loopback, `scripts/farm/local-slurm.sh`):
//!   4 tasks × 2 frames at 64², one task killed, the check step naming its
//!   frames, the rerun of that task alone, and every frame compared bit for
//!   bit with one process's render.
//!
//! ## Status and limits
//!
//! Any number of dome cameras, in either mode: each vertex-mode camera gets
//! twins refined for it, on its own render layer, and sees the meshes
//! and lights whose `RenderLayers` meet its [`DomeSees`] (the camera's
//! own layers when it was made a dome camera). Lines are one pixel wide whatever the
//! domemaster's size (draw wide lines as thin meshes, refined like any
//! triangle). Skinned and morphed meshes are refined in their rest pose. The square's
//! corners outside the image circle are painted by a full-screen pass
//! ([`DomeRimMask`], black by default). Light clusters use one cluster per
//! dome view (`ClusterConfig::Single`): Bevy's clustering assumes a planar
//! projection. Screen-space effects that rebuild positions from depth
//! (SSAO, SSR, TAA, depth of field) assume a planar projection too and do
//! not work on a vertex-mode dome camera (they do on the cube mode's faces).
//!
//! [`DomeLens::Equirectangular`] draws the whole sphere as a longitude–latitude
//! panorama (a 2:1 target for square pixels), by either mode: in the vertex
//! mode triangles and lines crossing its ±180° seam are cut there, and
//! those over a pole fill the pole's row (`optica_optics::dome`, E1–E2);
//! there is no rim to mask.
//!
//! A moving camera refines every twin again each frame, on Bevy's compute
//! pool. A mesh whose every triangle is small and in front is its own
//! twin (drawn as it is: nothing built or uploaded); the others keep their
//! whole triangles on the mesh's own vertices and add what refinement
//! makes. On two cores a 100k-triangle city around a zenith dome at
//! 0.5 px costs 9.5–10.6 ms of refinement a frame while the camera moves
//! (five runs at commit 0a4dc2b, 2026-12-04; 1M triangles 93–100 ms; the
//! `dome` report's `scene size` series measures it on your machine,
//! `optica_report dome_scale` runs it alone) and nothing while it rests: a third of its triangles stay whole, half lie behind the view
//! plane, and the tenth cut at the horizon or split near the viewer is
//! most of the cost.

#![warn(missing_docs)]

use bevy::asset::embedded_asset;
use bevy::camera::visibility::RenderLayers;
use bevy::core_pipeline::fullscreen_material::FullscreenMaterialPlugin;
use bevy::light::cluster::ClusterConfig;
use bevy::prelude::*;
use bevy::shader::load_shader_library;

mod cube;
mod error;
mod export;
pub mod lines;
mod mask;
#[cfg(feature = "egui")]
mod panel;
mod projection;
mod refine;
mod render;
mod settings;
mod shader_hook;
mod twin_mesh;

pub use cube::{DomeCubeFace, DomeCubeFaces, FIVE_FACE_MAX_FOV_DEG};
pub use export::{DomeExport, DomeExportPlugin, DomeShowClock, frame_ranges, parse_frame_range};

/// Inner parts for the render tests (the plugin crates' own unit tests do
/// not run: Bevy links once, in the umbrella's test binary): the export's
/// wait for pipelines and the vertex shader patch. Not for users.
#[doc(hidden)]
pub mod hooks {
    pub use crate::export::{ExportState, MAX_PIPELINE_WAIT_UPDATES, PendingPipelines};
    pub use crate::shader_hook::{patched, patched_fragment};
}
pub use error::Error;
#[cfg(feature = "egui")]
pub use panel::{DomePanelPlugin, dome_ui};
pub use refine::{
    DOME_LAYER, DomeLayer, DomeMaterialPlugin, DomeRefineStats, DomeTwin, DomeTwinEntities,
    DomeTwinOf, DomeTwins,
};
pub use settings::{
    DomeApparentSize, DomeCamera, DomeLens, DomeMode, DomeSees, DomeStatus, FACE_PX_RANGE,
    MAX_FOV_DEG, MIN_TOLERANCE_PX,
};
pub use twin_mesh::{pre_subdivide_mesh_asset, refine_mesh_asset};

use mask::DomeRimMask;
use projection::DomeClip;

/// A query filter that leaves out the entities the plugin makes for itself
/// (the vertex mode's twins, the cube mode's face cameras):
/// `Query<&Mesh3d, NotDomeHelper>` sees the scene's own meshes only.
pub type NotDomeHelper = (Without<DomeTwinOf>, Without<DomeCubeFace>);

/// What the plugin's passes and refinement compute, for the render tests
/// and the report to hold them to: the projection's GPU parameters, the
/// rim mask, the cube layout, and the twin meshes as the refinement builds
/// them. An app using the plugin needs none of it.
pub mod twins {
    pub use crate::cube::{CubeLayout, guarded_tan_half};
    pub use crate::mask::DomeRimMask;
    pub use crate::projection::DomeClip;
    pub use crate::twin_mesh::{Twin, TwinJob, twin_of_mesh, twins_of_meshes};
}

/// Adds [`DomeCamera`]: keeps each dome camera's projection in step with
/// its settings and, once a dome camera exists, puts the fisheye
/// branch into Bevy's vertex path.
pub struct DomePlugin;

impl Plugin for DomePlugin {
    fn build(&self, app: &mut App) {
        optica_plugin_kit::require_asset_server(app, "optica_dome", "DomePlugin");
        load_shader_library!(app, "shaders/projection.wgsl");
        embedded_asset!(app, "shaders/rim_mask.wgsl");
        embedded_asset!(app, "shaders/cube_resample.wgsl");
        app.add_plugins(FullscreenMaterialPlugin::<DomeRimMask>::default())
            .add_plugins(render::CubeResamplePlugin)
            .register_type::<DomeCamera>()
            .register_type::<DomeStatus>()
            .register_type::<DomeMode>()
            .register_type::<DomeLens>()
            .register_type::<DomeApparentSize>()
            .register_type::<DomeRefineStats>()
            .init_resource::<DomeRefineStats>()
            .register_type::<DomeShowClock>()
            .init_resource::<DomeShowClock>()
            .register_type::<DomeRimMask>()
            .add_plugins(DomeMaterialPlugin::<StandardMaterial>::default())
            .add_systems(
                PostUpdate,
                sync_projection.before(bevy::camera::CameraUpdateSystems),
            )
            .add_systems(
                PostUpdate,
                (
                    cube::sync_cube_faces,
                    cube::follow_dome_camera,
                    cube::follow_dome_sees,
                )
                    .after(sync_projection)
                    .before(bevy::transform::TransformSystems::Propagate),
            )
            .add_systems(
                PostUpdate,
                (refine::refine_twins, refine::light_the_dome_layer)
                    .after(bevy::transform::TransformSystems::Propagate)
                    .after(bevy::camera::CameraUpdateSystems)
                    // Also while twins outlive the last dome camera: the
                    // frame after it goes, `refine_twins` despawns them
                    // (gated on the camera alone they stayed, found by the
                    // soak).
                    .run_if(any_with_component::<DomeCamera>.or_else(any_with_component::<DomeTwinOf>)),
            )
            .add_systems(
                Update,
                (
                    shader_hook::patch_view_transformations.run_if(shader_hook::patch_pending),
                    shader_hook::report_patch,
                )
                    .chain()
                    .run_if(any_with_component::<DomeCamera>),
            );
    }
}

/// Gives every new or changed [`DomeCamera`] its projection, a single
/// light cluster, its render layers and, when it has none, a
/// [`DomeRimMask`]; invalid settings keep the last good projection and log
/// why. The camera's own `RenderLayers` become its [`DomeSees`] the first
/// time; a vertex-mode camera then draws its own [`DomeLayer`] (the
/// lowest from [`DOME_LAYER`] up that no other dome camera has), a
/// cube-mode camera nothing (its faces draw).
#[allow(clippy::type_complexity)]
fn sync_projection(
    mut commands: Commands,
    mut cameras: Query<
        (
            Entity,
            &DomeCamera,
            Has<DomeRimMask>,
            Option<&DomeSees>,
            Option<&DomeLayer>,
            Option<&RenderLayers>,
            &mut DomeStatus,
        ),
        Changed<DomeCamera>,
    >,
    taken: Query<(Entity, &DomeLayer)>,
) {
    let mut used: Vec<usize> = taken.iter().map(|(_, l)| l.0).collect();
    for (entity, dome, has_mask, sees, layer, layers, mut status) in &mut cameras {
        // The panorama fills its target: nothing to mask.
        if dome.lens == DomeLens::Equirectangular {
            commands.entity(entity).remove::<DomeRimMask>();
        } else if !has_mask {
            commands.entity(entity).insert(DomeRimMask::default());
        }
        if sees.is_none() {
            commands
                .entity(entity)
                .insert(DomeSees(layers.cloned().unwrap_or_default()));
        }
        // (A patch failure is put back by `shader_hook::report_patch`.)
        status.error = dome.validate().err();
        if let Some(why) = &status.error {
            warn!("optica_dome: {why}; the camera keeps its last projection");
            continue;
        }
        let clip = DomeClip::of(dome);
        // A cube-mode camera draws nothing itself (its faces do): no layer,
        // so no mesh, light or shadow work for its view.
        let layers = match dome.mode {
            DomeMode::Vertex => {
                let layer = layer.map_or_else(
                    || {
                        let free = (DOME_LAYER..)
                            .find(|l| !used.contains(l))
                            .unwrap_or(DOME_LAYER);
                        used.push(free);
                        commands.entity(entity).insert(DomeLayer(free));
                        free
                    },
                    |l| l.0,
                );
                RenderLayers::layer(layer)
            }
            DomeMode::CubeMap { .. } => RenderLayers::none(),
        };
        commands
            .entity(entity)
            .insert((Projection::custom(clip), ClusterConfig::Single, layers));
    }
}
