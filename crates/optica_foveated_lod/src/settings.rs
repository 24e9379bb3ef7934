//! What users edit: the visual field and the switching policy
//! ([`Foveation`]) and its checked form, and the components they put on
//! meshes and cameras ([`GazeLod`], [`CaveView`] and its [`WallRect`],
//! [`GazeRayTracer`] and [`RayTraced`]).

use bevy::light::cluster::ClusterConfig;
use bevy::prelude::*;
use optica_optics::foveated_lod::{
    BoundaryShape, FieldExtents, FoveatedError, HysteresisParams, VisualField,
};

use crate::head::{Eye, eye_model};
use crate::{CaveViewStatus, GazeLodState, GazeRayTracerState};

/// Whose visual field decides the level.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum FieldEyes {
    /// One eye between the two, the paper's model: its m_α is unsigned, so
    /// the ear-side extent applies to both sides.
    #[default]
    Cyclopean,
    /// Each eye its own field (ear side out, nose side in); an object's level
    /// is the larger of the two eyes' levels, and a CAVE wall camera of one
    /// eye uses that eye's field.
    PerEye,
}

/// The shape of the peripheral boundary (eq. 7).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum FieldBoundary {
    /// Eq. 7 as printed: L(φ) = √(a²cos²φ + b²sin²φ).
    #[default]
    PaperEq7,
    /// A true ellipse with the same semi-axes.
    TrueEllipse,
}

/// The clock that ages a level's dwell and a held gaze.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect)]
pub enum FoveationClock {
    /// The app's real time (`Time<Real>`): a dwell is real seconds
    /// whatever the frame rate.
    #[default]
    Real,
    /// The head sample's own time, [`TrackedHead::timestamp_s`](crate::TrackedHead::timestamp_s):
    /// the levels are then a function of the head samples alone, so
    /// processes fed the same samples choose the same levels (the walls of
    /// a CAVE across processes, see [`crate::cluster`]), and a replay
    /// chooses the same levels at any frame rate. A sample whose time is
    /// not finite counts as at the last finite one (time stands still).
    HeadSample,
}

/// The foveation settings: the visual field (eq. 1–8 of Mochizuki and
/// Makino), how the tracker's dropouts are handled, and how levels are
/// quantised and held against flicker.
///
/// The defaults are the paper's field (central 30°, 100° to the ear side,
/// 60° up, 70° down), eight level steps with a dead band of 0.05 and a
/// quarter-second dwell before detail is taken away, and a gaze held for
/// 0.2 s through a tracker dropout; the mesh path foveates while that saves
/// at least a fifth of the triangles. Invalid settings (an extent outside
/// `central..=180°`, a dead band of a whole step) are logged once and the
/// defaults used instead.
#[derive(Resource, Clone, Debug, PartialEq, Reflect)]
#[reflect(Resource)]
pub struct Foveation {
    /// Off: every level is 1 (full quality), as if no gaze were known.
    pub enabled: bool,
    /// Radius of the central field, where the level is 1 (degrees).
    pub central_deg: f32,
    /// Extent to the ear side (degrees).
    pub ear_deg: f32,
    /// Extent to the nose side (degrees; only [`FieldEyes::PerEye`] uses it).
    pub nose_deg: f32,
    /// Extent upwards (degrees).
    pub upper_deg: f32,
    /// Extent downwards (degrees).
    pub lower_deg: f32,
    /// One cyclopean field or one per eye.
    pub eyes: FieldEyes,
    /// The boundary's shape.
    pub boundary: FieldBoundary,
    /// Level steps S: levels are k/S, k = 0..=S. A level is rounded down to
    /// its step, ⌊S·level⌋/S (never more detail than eq. 8 asks), and eq. 10's
    /// polygon budget and eq. 9's bounces are taken at the rounded level.
    pub steps: u32,
    /// A level must pass a step edge by this much (level units, < 1/S)
    /// before an object switches.
    pub dead_band: f32,
    /// An object keeps a finer level at least this long before it is made
    /// coarser (s); finer levels are taken at once.
    pub min_dwell_s: f32,
    /// How long the last valid gaze is kept through a tracker dropout
    /// before everything is drawn at full quality (s).
    pub hold_timeout_s: f32,
    /// The mesh path draws coarser meshes only while they save at least
    /// this fraction of the [`GazeLod`](crate::GazeLod) objects' triangles
    /// (see [`FoveationGate`](crate::FoveationGate)); 0 always foveates.
    pub min_saving: f32,
    /// The clock of [`min_dwell_s`](Self::min_dwell_s) and
    /// [`hold_timeout_s`](Self::hold_timeout_s).
    pub clock: FoveationClock,
}

impl Default for Foveation {
    fn default() -> Self {
        let e = FieldExtents::PAPER;
        let h = HysteresisParams::default();
        Self {
            enabled: true,
            central_deg: e.central.to_degrees() as f32,
            ear_deg: e.ear.to_degrees() as f32,
            nose_deg: e.nose.to_degrees() as f32,
            upper_deg: e.upper.to_degrees() as f32,
            lower_deg: e.lower.to_degrees() as f32,
            eyes: FieldEyes::Cyclopean,
            boundary: FieldBoundary::PaperEq7,
            steps: h.steps(),
            dead_band: h.dead_band() as f32,
            min_dwell_s: h.min_dwell_s() as f32,
            hold_timeout_s: 0.2,
            min_saving: 0.2,
            clock: FoveationClock::Real,
        }
    }
}

/// [`Foveation`] checked: what the systems use.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct CheckedFoveation {
    /// Foveation on.
    pub enabled: bool,
    /// The field model.
    pub eyes: FieldEyes,
    /// Left, right and cyclopean fields.
    pub fields: [VisualField; 3],
    /// Level steps, dead band and dwell.
    pub hysteresis: HysteresisParams,
    /// The dropout hold (s), finite and ≥ 0.
    pub hold_timeout_s: f32,
    /// The mesh path's saving threshold, in [0, 1].
    pub min_saving: f32,
    /// The clock of the dwell and the hold.
    pub clock: FoveationClock,
}

impl Default for CheckedFoveation {
    fn default() -> Self {
        Foveation::default()
            .check()
            .expect("the default foveation settings are valid")
    }
}

impl CheckedFoveation {
    /// The field of `eye`.
    pub fn field(&self, eye: Eye) -> VisualField {
        self.fields[crate::head::eye_index(eye)]
    }
}

impl Foveation {
    /// The settings checked, or the first one out of range.
    pub fn check(&self) -> Result<CheckedFoveation, FoveatedError> {
        let extents = FieldExtents {
            central: (self.central_deg as f64).to_radians(),
            ear: (self.ear_deg as f64).to_radians(),
            nose: (self.nose_deg as f64).to_radians(),
            upper: (self.upper_deg as f64).to_radians(),
            lower: (self.lower_deg as f64).to_radians(),
        };
        let boundary = match self.boundary {
            FieldBoundary::PaperEq7 => BoundaryShape::PaperEq7,
            FieldBoundary::TrueEllipse => BoundaryShape::TrueEllipse,
        };
        let field = |eye| VisualField::new(extents, eye_model(self.eyes, eye), boundary);
        let fields = [
            field(Eye::Left)?,
            field(Eye::Right)?,
            field(Eye::Cyclopean)?,
        ];
        let hysteresis =
            HysteresisParams::new(self.steps, self.dead_band as f64, self.min_dwell_s as f64)?;
        let hold_timeout_s = optica_optics::input::non_negative(
            "gaze hold timeout (s)",
            self.hold_timeout_s as f64,
        )? as f32;
        let min_saving = optica_optics::input::in_range(
            "minimum triangle saving",
            self.min_saving as f64,
            0.0,
            1.0,
        )? as f32;
        Ok(CheckedFoveation {
            min_saving,
            enabled: self.enabled,
            eyes: self.eyes,
            fields,
            hysteresis,
            hold_timeout_s,
            clock: self.clock,
        })
    }
}

/// Checks [`Foveation`] when it changes; invalid settings are logged once and
/// the defaults used.
pub(crate) fn check_foveation(foveation: Res<Foveation>, mut checked: ResMut<CheckedFoveation>) {
    if !foveation.is_changed() {
        return;
    }
    let next = foveation.check().unwrap_or_else(|e| {
        warn!("foveated LOD: {e}; using the default foveation settings");
        CheckedFoveation::default()
    });
    checked.set_if_neq(next);
}

/// Gaze-driven level of detail for this entity's mesh.
///
/// When the entity has a `Mesh3d`, the plugin builds, once per mesh and
/// setting, a chain of simplified copies (meshoptimizer's edge collapse)
/// with triangle counts N from `min_triangles` to `max_triangles` by eq. 10
/// of Mochizuki and Makino, N = level (N_max − N_min) + N_min, one per level
/// step of [`Foveation::steps`](crate::Foveation::steps). Every frame the
/// gaze or the object moved, it takes the level of the point of the
/// object's bounding sphere nearest the gaze (so an object is as detailed as
/// its most central part needs), quantises and holds it
/// ([`Foveation::dead_band`](crate::Foveation::dead_band),
/// [`Foveation::min_dwell_s`](crate::Foveation::min_dwell_s)), and swaps the
/// entity's `Mesh3d` to that level's mesh. Meshes are never rebuilt per
/// frame. [`GazeLodState`] says what was chosen.
///
/// The mesh must be an indexed triangle list with positions; others are
/// drawn as they are (logged once). Entities sharing a mesh share its chain.
/// Assign a new mesh by writing `Mesh3d` as usual: the chain follows.
///
/// ```no_run
/// use bevy::prelude::*;
/// use optica_foveated_lod::{FoveatedLodPlugin, GazeLod, HeadSource, SimulatedGaze};
///
/// fn setup(mut commands: Commands, mut meshes: ResMut<Assets<Mesh>>, mut materials: ResMut<Assets<StandardMaterial>>) {
///     commands.spawn((
///         Mesh3d(meshes.add(Sphere::new(0.5).mesh().ico(5).unwrap())),
///         MeshMaterial3d(materials.add(StandardMaterial::default())),
///         Transform::from_xyz(1.0, 1.6, -3.0),
///         GazeLod { min_triangles: 200, ..default() },
///     ));
///     commands.spawn((Camera3d::default(), Transform::from_xyz(0.0, 1.6, 0.0)));
/// }
///
/// App::new()
///     .add_plugins((DefaultPlugins, FoveatedLodPlugin))
///     .insert_resource(HeadSource::Simulated(SimulatedGaze::default()))
///     .add_systems(Startup, setup)
///     .run();
/// ```
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component)]
#[require(GazeLodState)]
pub struct GazeLod {
    /// N_min: the triangles of the coarsest level (the paper: 500).
    pub min_triangles: u32,
    /// N_max: the triangles of the finest level; `None`: the mesh's own.
    pub max_triangles: Option<u32>,
    /// Hide the object while its level is 0 (outside the visual field: the
    /// paper draws background there).
    pub hide_outside_field: bool,
}

/// A rectangular screen in world coordinates (m), seen from the side its
/// normal `(lower_right − lower_left) × (upper_left − lower_left)` points to.
#[derive(Clone, Copy, Debug, PartialEq, Reflect)]
pub struct WallRect {
    /// The lower-left corner as the viewer sees it.
    pub lower_left: Vec3,
    /// The lower-right corner.
    pub lower_right: Vec3,
    /// The upper-left corner.
    pub upper_left: Vec3,
}

/// A camera that draws one CAVE wall as `eye` sees it through that wall:
/// the plugin places the camera at the tracked eye, turns it to face the
/// wall and gives it the off-axis projection whose frustum passes through
/// the wall's four corners (Kooima's generalised perspective projection;
/// `optica_optics::foveated_lod::CaveWall::off_axis` is its CPU twin), so
/// a point on the wall lands on the pixel of the wall's own image there.
///
/// For stereo, as the paper ran its CAVE, give each wall two cameras, one
/// per eye ([`Eye::Left`], [`Eye::Right`]), each rendering to its own
/// target. The target should have the wall's [`aspect`](WallRect::aspect).
/// The camera is placed in world space: do not parent it.
///
/// When the head is lost the last valid eye position is kept. An eye on or
/// behind a wall's plane (the frustum does not exist there) is moved to
/// `min_eye_distance` in front of that wall for its camera only.
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component)]
#[require(Camera3d, CaveViewStatus)]
pub struct CaveView {
    /// The screen.
    pub wall: WallRect,
    /// The eye looking through it.
    pub eye: Eye,
    /// Near clip distance (m).
    pub near: f32,
    /// Far distance for culling (m).
    pub far: f32,
    /// The closest the projection eye may be to the wall's plane (m).
    pub min_eye_distance: f32,
}

/// Draws the camera's view by ray tracing the [`RayTraced`] objects on the
/// GPU, each ray at the level of its direction in the viewer's visual field
/// (the paper's §3.3.3): eq. 9 sets how many reflections and refractions it
/// may make, eq. 10 which mesh of each object's LOD chain it is tested
/// against, and a ray outside the field returns [`background`] untraced.
///
/// Rays in the periphery (level below 1) are traced on a grid
/// [`periphery_scale`] times coarser than the image, those below
/// [`outer_level`] on one twice coarser again, and blended up (Guenter et
/// al.'s nested foveated layers, 2012); the central field is traced at
/// every pixel. The tracer foveates only where
/// that saves at least [`Foveation::min_saving`] of the primary rays
/// (estimated each frame from the level map, see [`GazeRayTracerState`]);
/// else it traces every pixel at full quality.
///
/// The traced image replaces whatever the camera rasterised: give traced
/// meshes no material, so Bevy does not draw them too. For the same reason
/// the camera requires [`ClusterConfig::Single`]: lights are clustered for
/// a rasterised image nobody sees, so one cluster is enough (Bevy's GPU
/// clustering cannot do without any: `ClusterConfig::None` fails there).
///
/// [`background`]: GazeRayTracer::background
/// [`periphery_scale`]: GazeRayTracer::periphery_scale
/// [`outer_level`]: GazeRayTracer::outer_level
/// [`Foveation::min_saving`]: crate::Foveation::min_saving
#[derive(Component, Clone, Debug, PartialEq, Reflect)]
#[reflect(Component)]
#[require(Camera3d, GazeRayTracerState, ClusterConfig = ClusterConfig::Single)]
pub struct GazeRayTracer {
    /// Reflect_max of eq. 9: the bounces of a level-1 ray (the paper: 3;
    /// at most [`MAX_REFLECT`](crate::MAX_REFLECT)).
    pub reflect_max: u32,
    /// Off: every ray at level 1, every pixel traced (the reference).
    pub foveate: bool,
    /// Peripheral rays are traced on a grid this many times coarser per
    /// axis (1: every pixel; 2, the default, a quarter of the rays; at most
    /// [`MAX_PERIPHERY_SCALE`](crate::MAX_PERIPHERY_SCALE)).
    pub periphery_scale: u32,
    /// Rays of a level below this are traced on a grid twice coarser again
    /// (the outer layer; 0.5 by default, 0 for none).
    pub outer_level: f32,
    /// The colour of rays that hit nothing and of pixels outside the
    /// visual field (linear). Each channel is used clamped to 0..=65,504
    /// (the most a half-float target holds); NaN counts as 0.
    pub background: LinearRgba,
    /// Ambient light, added as ambient × albedo (linear; clamped as
    /// [`GazeRayTracer::background`]).
    pub ambient: LinearRgba,
}

/// A mesh the [`GazeRayTracer`] draws, and how it looks: the reference
/// tracer's Whitted material. Needs a `Mesh3d` (indexed triangles); its
/// LOD chain is built as for [`GazeLod`](crate::GazeLod), whose settings it
/// takes, and is traced, never rasterised by the mesh path.
#[derive(Component, Clone, Copy, Debug, PartialEq, Reflect)]
#[reflect(Component)]
#[require(crate::GazeLod)]
pub struct RayTraced {
    /// Albedo (linear).
    pub color: LinearRgba,
    /// Lambert weight.
    pub diffuse: f32,
    /// Phong weight.
    pub specular: f32,
    /// Phong exponent.
    pub shininess: f32,
    /// Mirrored fraction.
    pub reflectance: f32,
    /// Refracted fraction (reflectance + transmittance ≤ 1).
    pub transmittance: f32,
    /// Refractive index of the inside (≥ 1; the outside is air).
    pub ior: f32,
}
