//! # optica_foveated_lod — gaze-driven level of detail for Bevy
//!
//! Draw detail only where the viewer looks. A [`TrackedHead`] resource holds
//! the eyes and gaze a tracker reports; each ray or object gets a *level*
//! in [0, 1] from the angle between it and the gaze (1 in the central
//! field, falling to 0 at the edge of the visual field); the level picks
//! how much detail it gets.
//!
//! It implements Naoki Mochizuki and Mitsunori Makino, "An Efficient Ray
//! Tracing with LOD Control by Human Eyesight for Immersive Display System"
//! (望月直樹, 牧野光則, 「没入型ディスプレイでの人間の視野を利用した
//! レイトレーシング法の詳細度制御」, Graduate School of Science and
//! Engineering, Chuo University; no venue or year printed, its newest
//! reference is from 2009): the visual-field level of its eq. 1–8, the
//! polygon budget of eq. 10, on the CAVE (front, right and floor screens)
//! it ran on. The CPU twin of every formula is
//! `optica_optics::foveated_lod`.
//!
//! ## Use
//!
//! Add [`FoveatedLodPlugin`]; write [`TrackedHead`] from your tracker (or
//! choose a [`HeadSource`]: a simulated gaze for development, a recorded
//! [`HeadTrace`]); then
//!
//! - give meshes a [`GazeLod`]: each gets a chain of simplified meshes, built
//!   once, and draws the level its position in the visual field asks for;
//! - for a CAVE, give each wall's camera a [`CaveView`] (two per wall, one
//!   per eye, for stereo): it follows the tracked eye with the wall's
//!   off-axis projection;
//! - for the paper's own method, give a camera a [`GazeRayTracer`] and
//!   meshes a [`RayTraced`] material: the view is ray traced on the GPU
//!   with a level per ray (see below).
//!
//! ```no_run
//! use bevy::prelude::*;
//! use optica_foveated_lod::{CaveView, Eye, FoveatedLodPlugin, GazeLod, HeadSource, SimulatedGaze, WallRect};
//!
//! fn setup(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>, mut materials: ResMut<Assets<StandardMaterial>>) {
//!     let model = meshes.add(Torus::new(0.2, 0.4).mesh().minor_resolution(48).major_resolution(64));
//!     for i in 0..8 {
//!         commands.spawn((
//!             Mesh3d(model.clone()),
//!             MeshMaterial3d(materials.add(StandardMaterial::default())),
//!             Transform::from_xyz(i as f32 - 3.5, 1.2, -1.0),
//!             GazeLod::default(),
//!         ));
//!     }
//!     let [front, right, floor] = WallRect::front_right_floor(3.0).unwrap();
//!     for wall in [front, right, floor] {
//!         // Each wall camera renders to its own target (a projector, a window).
//!         commands.spawn(CaveView::new(wall, Eye::Cyclopean));
//!     }
//! }
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, FoveatedLodPlugin))
//!     .insert_resource(HeadSource::Simulated(SimulatedGaze::default()))
//!     .add_systems(Startup, setup)
//!     .run();
//! ```
//!
//! ## Settings panel
//!
//! With the cargo feature `egui`, `foveation_ui` draws the settings into an
//! egui `Ui` and `FoveatedLodPanelPlugin` shows them in a window with the
//! simulated gaze, each object's level and the visual field with the
//! objects in it.
//!
//! ## Real trackers, several machines
//!
//! [`TrackedHead`] is plain data: write it from any tracker SDK.
//! [`TrackedHead::from_openxr`] maps OpenXR's eye-gaze pose
//! (`XR_EXT_eye_gaze_interaction`) without a dependency on openxr, and says
//! what to do for a runtime without eye tracking. It is serialisable
//! (serde).
//!
//! A CAVE across processes or machines ([`cluster`]): one head source
//! ([`cluster::HeadPublisher`], next to the tracker) publishes each sample
//! over UDP (postcard, a documented stable format) to one process per wall
//! (and per eye in stereo; [`cluster::CaveWallPlugin`] in a Bevy app), and
//! holds sample n + 1 until every wall drew frame n (a frame barrier; a
//! wall that does not answer within [`cluster::WALL_TIMEOUT`], 1 s, is
//! dropped, once, and a late or returning wall is sent the sample under
//! way). With [`Foveation::clock`] on [`FoveationClock::HeadSample`] the
//! levels are a function of the samples, so walls fed the same samples
//! draw the same levels. The `cave` example launches a head source and
//! three wall processes; tested against one process drawing the same
//! walls: every wall's frame n bit for bit, a wall killed (the others
//! wait one timeout) and one started late (in step from the frame it
//! joins). The latency from a sample to the walls' frames, measured by
//! the source: median 54–63 ms at 64² (debug build, lavapipe, 2 cores:
//! the frame's drawing and read-back, which the barrier waits for).
//! [`HeadTrace`] reads and writes recordings as CSV (columns documented
//! there), and [`HeadSource::Replay`] plays them back.
//! [`HeadSource::DTrack`] reads an ART DTrack tracker's ASCII stream over
//! UDP, the optical tracking most CAVEs use ([`dtrack`]: one body as the
//! head, a calibration into the scene, malformed datagrams counted and
//! dropped; tested on the loopback).
//!
//! ## Dropouts and bad numbers
//!
//! A sample marked invalid, or with a NaN or a zero gaze, is a dropout: the
//! last valid gaze is held for [`Foveation::hold_timeout_s`] (0.2 s), then
//! every level is 1 (full quality) until the tracker is back. Where the
//! gaze is unknown, nothing is drawn coarser. CAVE views keep the last
//! valid eye position.
//!
//! ## What runs, and when
//!
//! Nothing runs for a scene without a [`GazeLod`], a [`CaveView`] or a
//! [`GazeRayTracer`]; the [`GazeState`] (the filtered gaze) is kept up to
//! date only while one of them exists. The ray tracer queues its pipelines
//! and runs its passes only for views with a [`GazeRayTracer`]. Systems that read the head do nothing in a frame where it
//! did not change, except while a held gaze ages towards its timeout or an
//! object waits out its dwell before being made coarser. LOD chains are
//! built once per mesh and setting (meshoptimizer's simplification; a
//! 5,800-triangle mesh takes a few milliseconds on the main thread, once,
//! measured at 73752d6, 2026-12-02) and shared by every entity drawing
//! that mesh.
//!
//! ## Only where it pays
//!
//! Coarser meshes are drawn only while they save at least
//! [`Foveation::min_saving`] (a fifth) of the triangles of all [`GazeLod`]
//! objects together ([`FoveationGate`]); else every object draws its full
//! mesh, as without foveation.
//!
//! Measured (`optica_report foveated_lod`, series `mesh: <scene>, <gaze>`,
//! lavapipe, release; the paper's CAVE of three 256² walls, eight
//! 5,780-triangle models, its four scenes and two gazes, frame time
//! against full quality in the same run): where the levels take away
//! 47–66 % of the triangles the frame takes 0.63–0.81 of full quality's;
//! where they would take away 9 % (every model in front of a gaze at the
//! front wall) the frames were 0.99–1.27 of full quality's in two runs
//! before this rule (at 509dd07, 2026-12-02; no current series measures
//! it), nothing saved and the distinct meshes in the way of Bevy's
//! batching, and with it the same meshes as full quality are drawn (0.87
//! and 1.00 of it: lavapipe's noise). The
//! central field (≤ 30°) matches full quality to the bit in every case;
//! beyond it the image differs by an RMSE of 0.001–0.08 (8-bit sRGB).
//!
//! ## Latency
//!
//! A head written before `PostUpdate` (by a [`HeadSource`] in `PreUpdate`,
//! or by your system in `Update`) sets the levels of the same frame: the
//! plugin adds no frame of latency, and a saccade onto an object makes it
//! fully detailed in the frame that sees the new gaze (tested), and each
//! [`CaveView`] wall is drawn with the off-axis projection and the
//! position of that same head sample: the plugin aims the walls before
//! Bevy's camera update and transform propagation (tested with an eye
//! moving every frame: every wall within 1e-6 NDC of the ray through the
//! wall, where the projection used to lag a frame behind). What
//! remains is the tracker's own latency and the frame's render (Bevy's
//! pipelined rendering draws frame n while frame n + 1 updates: one frame,
//! 17 ms at 60 Hz), against the 50–70 ms end to end that studies of
//! gaze-contingent displays found unnoticed.
//!
//! ## Levels and flicker
//!
//! Levels are quantised into [`Foveation::steps`] steps S (8 by default):
//! a level is rounded down to its step, ⌊S·level⌋/S, so an object or a ray
//! never gets more detail than eq. 8 asks, and eq. 10's polygon budget (and
//! eq. 9's bounces for the tracer) is taken at the rounded level: with S = 8
//! a level of 0.6 draws the mesh of level 0.5. A finer step is
//! taken as soon as the level passes its edge by [`Foveation::dead_band`]
//! (a saccade makes the new fixation point detailed in the next frame); a
//! coarser one only after the object has kept its step for
//! [`Foveation::min_dwell_s`], so gaze jitter at a step edge does not make
//! a mesh flicker. The paper has no quantisation or hysteresis; they are
//! additions.
//!
//! ## Example and report
//!
//! The example `foveated_lod` is the paper's setting: a 3 m CAVE (front,
//! right, floor; `--stereo` for two eyes per wall), eight models of 5,780
//! triangles, a simulated gaze. The report `optica_report foveated_lod`
//! measures the mesh path in the paper's four scenes and two gazes: frame
//! time against full quality in the same run, the image error by
//! eccentricity band, the triangles drawn.
//!
//! ## The ray tracer (the paper's method)
//!
//! Give a camera a [`GazeRayTracer`] and meshes a [`RayTraced`] material
//! (and no `MeshMaterial3d`): the camera's image is then ray traced on the
//! GPU, a Whitted tracer with reflection and refraction, each primary ray
//! at the level of its direction in the visual field. Eq. 9 sets how many
//! bounces it and its secondary rays may make, eq. 10 which mesh of each
//! object's LOD chain they are tested against; rays outside the field are
//! the background, untraced. The chains are the mesh path's, each LOD with
//! its BVH built once on the CPU and uploaded once ([`TracedScene`](twins::TracedScene); built
//! again only when an object, its transform or material, or a light
//! changes). The CPU twin is `optica_optics::foveated_lod::render_layered`;
//! the GPU image matches it on all but a few silhouette pixels (tested on
//! lavapipe).
//!
//! ```no_run
//! use bevy::prelude::*;
//! use optica_foveated_lod::{FoveatedLodPlugin, GazeRayTracer, HeadSource, RayTraced, SimulatedGaze};
//!
//! fn setup(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>) {
//!     let ball = meshes.add(Sphere::new(0.5).mesh().ico(5).unwrap());
//!     commands.spawn((Mesh3d(ball.clone()), Transform::from_xyz(-0.6, 0.5, 0.0),
//!         RayTraced::mirror(LinearRgba::gray(0.9), 0.7)));
//!     commands.spawn((Mesh3d(ball), Transform::from_xyz(0.6, 0.5, 0.0),
//!         RayTraced::glass(LinearRgba::WHITE, 0.8, 1.5)));
//!     commands.spawn((PointLight::default(), Transform::from_xyz(1.0, 3.0, 2.0)));
//!     commands.spawn((GazeRayTracer::default(), Transform::from_xyz(0.0, 1.2, 3.0).looking_at(Vec3::ZERO, Vec3::Y)));
//! }
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, FoveatedLodPlugin))
//!     .insert_resource(HeadSource::Simulated(SimulatedGaze::default()))
//!     .add_systems(Startup, setup)
//!     .run();
//! ```
//!
//! Where the savings come from: wgpu has no variable-rate shading, so the
//! tracer saves what it controls. Shallower recursion and coarser meshes
//! (eq. 9, 10) save little with a BVH; rays outside the field save all
//! their work; and the periphery (level below 1) is traced on a grid
//! [`GazeRayTracer::periphery_scale`] times coarser (2: a quarter of the
//! rays) and blended up, while the central field is traced at every pixel
//! and matches full quality exactly. A peripheral pixel next to the
//! central field is traced itself rather than blended with untraced
//! texels. The tracer foveates only while the level map (sampled 32 × 32
//! each frame) says it saves at least [`Foveation::min_saving`] of the
//! primary rays ([`GazeRayTracerState`]): a gaze that holds the whole view
//! in its central field is traced as full quality, at full quality's cost.
//!
//! Measured (`optica_report foveated_lod`, series
//! `ray tracer: <scene>, <gaze>`, lavapipe, release; the paper's CAVE of
//! three 256² walls, eight 5,780-triangle models and a floor, its four
//! scenes and two gazes, frame time against `foveate: false` in
//! alternating blocks, 2026-12-05): 0.46–0.69 of full quality's frame
//! with the defaults (the paper's own table: 0.28–1.27), the central field
//! equal to full quality's and the image beyond 30° within an RMSE of
//! 0.01–0.15 (8-bit sRGB, largest where the field's edge cuts models off).
//! The CPU twin of the same schedule traces 16–27 % of full quality's
//! rays. What foveation cannot save: the central field, traced exactly as
//! full quality traces it, and Bevy's own three-camera frame (7.5–9.4 ms
//! of 28–45 ms). The series `ray tracer, central field alone` measures
//! that floor, the central field traced and nothing else: 0.37–0.54 of
//! full quality's frame. Coarser layers (`periphery_scale` 4, 8; series
//! `ray tracer: periphery scale (B, front gaze)`) bring scene B from 0.50
//! to 0.44–0.45 at an RMSE beyond 30° of 0.017–0.028.
//!
//! Limits: the objects are tested one after another (no BVH over them;
//! fine for tens of objects); shadow rays treat transparent objects as
//! opaque (Whitted's tracer did); a [`PointLight`] lights traced objects
//! at Bevy's default exposure ([`light_scale`](twins::light_scale)), other light types are
//! ignored; at most [`MAX_REFLECT`] bounces.
//!
#![warn(missing_docs)]

use bevy::asset::embedded_asset;
use bevy::camera::CameraUpdateSystems;
use bevy::camera::visibility::VisibilitySystems;
use bevy::prelude::*;
use bevy::transform::TransformSystems;

mod cave;
pub mod cluster;
mod error;
pub mod dtrack;
mod head;
mod lod;
#[cfg(feature = "egui")]
mod panel;
mod raytrace;
mod render;
mod settings;
mod trace;

pub use cave::CaveViewStatus;
pub use error::Error;
pub use head::{Eye, GazeState, HeadReplay, HeadSource, SimulatedGaze, TrackedHead};
pub use lod::{FoveationGate, FoveationWork, GazeLodState, LodChain, LodError};
#[cfg(feature = "egui")]
pub use panel::{FoveatedLodPanelPlugin, foveation_ui};
pub use raytrace::{GazeRayTracerState, MAX_PERIPHERY_SCALE, MAX_REFLECT};
pub use settings::{
    CaveView, FieldBoundary, FieldEyes, Foveation, FoveationClock, GazeLod, GazeRayTracer,
    RayTraced, WallRect,
};
pub use trace::{HeadTrace, TraceError};

/// What the plugin's systems and tracer compute, for the render tests and
/// the report to hold them to: the CAVE walls' off-axis projection, the
/// level of a bounding sphere, the scene as the tracer's shader reads it
/// and its CPU reference, the checked settings. An app using the plugin
/// needs none of it.
pub mod twins {
    pub use crate::cave::{OffAxisClip, aim};
    pub use crate::lod::level_of_sphere;
    pub use crate::raytrace::{TracedScene, light_scale, reference_of};
    pub use crate::settings::CheckedFoveation;
    pub use crate::trace::ON_TIME_S;
}

/// Adds [`TrackedHead`], [`Foveation`], [`HeadSource`] and the systems that
/// turn them into levels for [`GazeLod`] meshes, projections for
/// [`CaveView`] cameras and traced images for [`GazeRayTracer`] cameras.
pub struct FoveatedLodPlugin;

/// The system sets of the plugin, in `PostUpdate`.
#[derive(SystemSet, Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FoveatedLodSystems {
    /// The head filtered into [`GazeState`], chains built, CAVE cameras aimed
    /// (before transform propagation and before Bevy's camera update, so a
    /// wall's transform and its off-axis projection reach the renderer from
    /// the same head sample, in the frame the head moved).
    Gaze,
    /// Levels chosen, meshes swapped and tracer views prepared (after
    /// transform propagation and Bevy's camera update, so they read this
    /// frame's camera matrices; before visibility).
    Levels,
}

impl Plugin for FoveatedLodPlugin {
    fn build(&self, app: &mut App) {
        optica_plugin_kit::require_asset_server(app, "optica_foveated_lod", "FoveatedLodPlugin");
        embedded_asset!(app, "shaders/raytrace.wgsl");
        app.add_plugins(render::TracerRenderPlugin);
        let consumers = any_with_component::<GazeLod>
            .or_else(any_with_component::<CaveView>)
            .or_else(any_with_component::<GazeRayTracer>);
        app.init_resource::<TrackedHead>()
            .init_resource::<Foveation>()
            .init_resource::<settings::CheckedFoveation>()
            .init_resource::<HeadSource>()
            .init_resource::<GazeState>()
            .init_resource::<head::GazeFilters>()
            .init_resource::<lod::LodChains>()
            .init_resource::<lod::DwellPending>()
            .init_resource::<FoveationWork>()
            .init_resource::<FoveationGate>()
            .init_resource::<raytrace::TracedScene>()
            .init_resource::<dtrack::DTrackStats>()
            .register_type::<GazeRayTracer>()
            .register_type::<GazeRayTracerState>()
            .register_type::<RayTraced>()
            .register_type::<FoveationGate>()
            .register_type::<TrackedHead>()
            .register_type::<Foveation>()
            .register_type::<GazeLod>()
            .register_type::<GazeLodState>()
            .register_type::<CaveView>()
            .register_type::<CaveViewStatus>()
            .configure_sets(
                PostUpdate,
                (
                    FoveatedLodSystems::Gaze
                        .before(TransformSystems::Propagate)
                        .before(CameraUpdateSystems),
                    // Before Bevy's mesh and material change checks
                    // (`mark_3d_meshes_as_changed_if_their_assets_changed`,
                    // then the materials' specialisation check): a mesh a
                    // level swaps is seen by them in its own frame.
                    // Unordered, the executor's choice of order would
                    // decide whether it is seen this frame or the next,
                    // and processes fed the same samples (CAVE walls)
                    // could differ for a frame.
                    FoveatedLodSystems::Levels
                        .after(TransformSystems::Propagate)
                        .after(CameraUpdateSystems)
                        .before(VisibilitySystems::CalculateBounds)
                        .before(VisibilitySystems::VisibilityPropagate)
                        .before(bevy::mesh::mark_3d_meshes_as_changed_if_their_assets_changed),
                ),
            )
            .add_systems(
                PreUpdate,
                head::drive_head_source
                    .run_if(|s: Res<HeadSource>| !matches!(*s, HeadSource::External)),
            )
            .add_systems(
                PostUpdate,
                (
                    (
                        settings::check_foveation,
                        head::filter_gaze,
                        (
                            lod::build_chains.run_if(any_with_component::<GazeLod>),
                            cave::aim_cave_views.run_if(any_with_component::<CaveView>),
                        ),
                    )
                        .chain()
                        .run_if(consumers)
                        .in_set(FoveatedLodSystems::Gaze),
                    lod::select_levels
                        .run_if(any_with_component::<GazeLod>)
                        .in_set(FoveatedLodSystems::Levels),
                    (
                        raytrace::build_traced_scene.run_if(any_with_component::<RayTraced>),
                        raytrace::prepare_tracer_views.run_if(any_with_component::<GazeRayTracer>),
                    )
                        .in_set(FoveatedLodSystems::Levels),
                ),
            );
    }
}
