//! The tracked head: what a tracker reports ([`TrackedHead`]), the gaze the
//! plugin uses after dropout filtering ([`GazeState`]), and where the head
//! comes from ([`HeadSource`]: simulated, replayed or set by the app).

use bevy::prelude::*;
use optica_optics::foveated_lod::{
    EyeModel, GazeEstimate, GazeFrame, GazeTracker, TrackerSample, VisualField,
};
use optica_optics::glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::settings::{CheckedFoveation, FieldEyes, FoveationClock};
use crate::trace::HeadTrace;

/// Which eye: index 0 is the left eye, 1 the right.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Reflect, Serialize, Deserialize)]
pub enum Eye {
    /// The left eye.
    Left,
    /// The right eye.
    Right,
    /// The point half-way between them, where the paper's single eye sits.
    #[default]
    Cyclopean,
}

/// The head as the tracker last reported it, in world coordinates (metres;
/// Bevy's axes: +Y up, a head with the identity orientation looks along −Z).
///
/// This is the one input of the plugin. Write it from any tracker (see
/// [`TrackedHead::from_openxr`] for OpenXR's eye-gaze pose) or let a
/// [`HeadSource`] write it. It is serialisable, so one process can read the
/// tracker and send it (for example as JSON over UDP) to one process per
/// CAVE wall, each of which writes it into its own app.
///
/// Write it only when it changes (`set_if_neq`, or assign a new value only
/// for a new sample): every system that reads the gaze does nothing in a
/// frame where the head has not changed.
///
/// A sample that is not [`valid`](Self::valid), or whose numbers are not
/// finite or degenerate (a zero gaze, a gaze parallel to the head's up),
/// counts as a dropout: the last valid gaze is kept for
/// [`Foveation::hold_timeout_s`](crate::Foveation::hold_timeout_s), then everything is drawn at full quality
/// until a valid sample arrives.
#[derive(Resource, Clone, Debug, PartialEq, Reflect, Serialize, Deserialize)]
#[reflect(Resource)]
pub struct TrackedHead {
    /// Left and right eye positions (m).
    pub eyes: [Vec3; 2],
    /// Head orientation: its −Z is the head's forward, +Y its up.
    pub orientation: Quat,
    /// The gaze direction both eyes converge along (any length). `None`: the
    /// head's forward (a head tracker without eye tracking).
    pub gaze: Option<Vec3>,
    /// Each eye's own gaze (left, right), where the tracker reports them;
    /// they replace [`gaze`](Self::gaze) for the per-eye fields.
    pub eye_gaze: Option<[Vec3; 2]>,
    /// When the tracker measured this sample (s, the tracker's clock; kept
    /// for recordings, not used to age the sample).
    pub timestamp_s: f64,
    /// False when the tracker says it lost the eyes or the head.
    pub valid: bool,
}

impl Default for TrackedHead {
    /// Eyes 1.6 m above the origin, 63 mm apart (an adult's mean
    /// interpupillary distance), looking along −Z; valid.
    fn default() -> Self {
        Self::looking(Vec3::new(0.0, 1.6, 0.0), Quat::IDENTITY, None, 0.063)
    }
}

impl TrackedHead {
    /// A valid head at `centre` (the point between the eyes) with the given
    /// orientation, gaze (`None`: straight ahead) and interpupillary
    /// distance `ipd` (m).
    pub fn looking(centre: Vec3, orientation: Quat, gaze: Option<Vec3>, ipd: f32) -> Self {
        let half = orientation * Vec3::X * (ipd / 2.0);
        Self {
            eyes: [centre - half, centre + half],
            orientation,
            gaze,
            eye_gaze: None,
            timestamp_s: 0.0,
            valid: true,
        }
    }

    /// A sample that says the tracker has lost the head: the pose is kept
    /// for [`Foveation::hold_timeout_s`](crate::Foveation::hold_timeout_s), then full quality.
    pub fn lost(&self) -> Self {
        Self {
            valid: false,
            ..self.clone()
        }
    }

    /// The point half-way between the eyes.
    pub fn centre(&self) -> Vec3 {
        (self.eyes[0] + self.eyes[1]) / 2.0
    }

    /// The position of `eye`.
    pub fn eye_position(&self, eye: Eye) -> Vec3 {
        match eye {
            Eye::Left => self.eyes[0],
            Eye::Right => self.eyes[1],
            Eye::Cyclopean => self.centre(),
        }
    }

    /// The gaze direction of `eye` (not normalised): the eye's own gaze when
    /// reported, else the common gaze, else the head's forward.
    pub fn gaze_of(&self, eye: Eye) -> Vec3 {
        let common = self.gaze.unwrap_or(self.orientation * Vec3::NEG_Z);
        match (eye, self.eye_gaze) {
            (Eye::Left, Some([l, _])) => l,
            (Eye::Right, Some([_, r])) => r,
            _ => common,
        }
    }

    /// The tracker sample of `eye`: `Missing` for an invalid head.
    pub fn sample(&self, eye: Eye) -> TrackerSample {
        if !self.valid {
            return TrackerSample::Missing;
        }
        TrackerSample::Gaze {
            eye: self.eye_position(eye).as_dvec3(),
            gaze: self.gaze_of(eye).as_dvec3(),
            up: (self.orientation * Vec3::Y).as_dvec3(),
        }
    }

    /// The head from an OpenXR eye-gaze pose (`XR_EXT_eye_gaze_interaction`),
    /// without depending on openxr: pass the `XrPosef` of the
    /// `/user/eyes_ext/input/gaze_ext/pose` action space located in the
    /// same reference space as the head (`position` as `[x, y, z]`,
    /// `orientation` as `[x, y, z, w]`), the head's (`XR_REFERENCE_SPACE_TYPE_VIEW`)
    /// pose, the time in nanoseconds (`XrTime`), the interpupillary
    /// distance, and whether the gaze is usable: `XrActionStatePose::isActive`
    /// and the location's `XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT`.
    ///
    /// OpenXR's spaces are right-handed with +Y up and −Z forward, like
    /// Bevy's, so the numbers carry over as they are; the gaze is the pose's
    /// −Z. A runtime without eye tracking (the extension not enabled, or
    /// `isActive` false) gives `gaze_tracked = false`: the head pose is kept
    /// and the gaze is the head's forward, as for a head-only tracker. So
    /// does a gaze orientation that is zero or not finite while
    /// `gaze_tracked` is true (some runtimes report it so for a frame when
    /// tracking starts). When the head pose itself is lost (a head
    /// orientation that is not finite gives an invalid sample), call
    /// [`TrackedHead::lost`] instead.
    ///
    /// ```
    /// use optica_foveated_lod::TrackedHead;
    /// // An eye-gaze pose 10° to the right of a head 1.6 m up.
    /// let (s, c) = (5f32.to_radians().sin(), 5f32.to_radians().cos());
    /// let gaze_pose = ([0.0, 1.6, 0.0], [0.0, -s, 0.0, c]);
    /// let head_pose = ([0.0, 1.6, 0.0], [0.0, 0.0, 0.0, 1.0]);
    /// let head = TrackedHead::from_openxr(gaze_pose, head_pose, 1_000_000_000, 0.063, true);
    /// let g = head.gaze.unwrap();
    /// assert!((g.x.atan2(-g.z).to_degrees() - 10.0).abs() < 1e-3);
    /// assert_eq!(head.timestamp_s, 1.0);
    /// ```
    pub fn from_openxr(
        gaze_pose: ([f32; 3], [f32; 4]),
        head_pose: ([f32; 3], [f32; 4]),
        time_ns: i64,
        ipd: f32,
        gaze_tracked: bool,
    ) -> Self {
        let head_rotation = Quat::from_array(head_pose.1).normalize();
        // A runtime that says the gaze is tracked but hands over a zero or
        // non-finite orientation gives no gaze: the head's forward stands in
        // for it, as for a runtime without eye tracking (documented above).
        let gaze_rotation = Quat::from_array(gaze_pose.1);
        let gaze =
            (gaze_tracked && gaze_rotation.is_finite() && gaze_rotation.length_squared() > 1e-12)
                .then(|| gaze_rotation.normalize() * Vec3::NEG_Z)
                .filter(|g| g.is_finite());
        let mut head = Self::looking(Vec3::from_array(head_pose.0), head_rotation, gaze, ipd);
        head.timestamp_s = time_ns as f64 * 1e-9;
        // A NaN quaternion normalises to NaN: the sample is then invalid and
        // the dropout policy applies.
        head.valid = head_rotation.is_finite();
        head
    }
}

/// The gaze the plugin uses this frame: each eye's [`GazeEstimate`] after the
/// dropout filter, and the cyclopean one. Read it (and its change ticks) in
/// your own systems; the plugin writes it only when it changes.
#[derive(Resource, Clone, Debug, PartialEq)]
pub struct GazeState {
    /// Left eye, right eye, cyclopean eye.
    pub estimates: [GazeEstimate; 3],
    /// The field of each estimate (per-eye sides where [`FieldEyes::PerEye`]).
    pub fields: [VisualField; 3],
}

impl Default for GazeState {
    fn default() -> Self {
        let full = GazeEstimate::FullQuality { last: None };
        Self {
            estimates: [full; 3],
            fields: [VisualField::paper(); 3],
        }
    }
}

impl GazeState {
    /// The estimate of `eye`.
    pub fn estimate(&self, eye: Eye) -> &GazeEstimate {
        &self.estimates[eye_index(eye)]
    }

    /// The visual field of `eye`.
    pub fn field(&self, eye: Eye) -> &VisualField {
        &self.fields[eye_index(eye)]
    }

    /// True when there is no usable gaze: every level is 1.
    pub fn full_quality(&self) -> bool {
        self.estimates.iter().all(|e| e.frame().is_none())
    }

    /// The level (eq. 1–8) of a world direction from `eye`.
    pub fn level(&self, eye: Eye, dir: DVec3) -> f64 {
        self.estimate(eye).level(self.field(eye), dir)
    }

    /// The level of the world point `p` for the eyes the field model uses:
    /// the cyclopean eye's, or the larger of the two eyes' (an object seen
    /// sharply by either eye must be detailed).
    pub fn level_of_point(&self, eyes: FieldEyes, p: DVec3) -> f64 {
        let at = |eye: Eye| {
            let e = self.estimate(eye);
            match e.eye() {
                Some(origin) if e.frame().is_some() => self.level(eye, p - origin),
                _ => 1.0,
            }
        };
        match eyes {
            FieldEyes::Cyclopean => at(Eye::Cyclopean),
            FieldEyes::PerEye => at(Eye::Left).max(at(Eye::Right)),
        }
    }

    /// The gaze frame of `eye`, if it is tracked or held.
    pub fn frame(&self, eye: Eye) -> Option<&GazeFrame> {
        self.estimate(eye).frame()
    }
}

pub(crate) fn eye_index(eye: Eye) -> usize {
    match eye {
        Eye::Left => 0,
        Eye::Right => 1,
        Eye::Cyclopean => 2,
    }
}

/// The dropout filters (one per eye), with the settings they were built for.
#[derive(Resource)]
pub(crate) struct GazeFilters {
    trackers: [GazeTracker; 3],
    timeout_s: f32,
    /// The samples last fed, per eye. A still head is not fed again every
    /// frame, so when a dropout starts, the last valid sample is fed once
    /// more at the previous frame's time: the hold counts from the moment
    /// the tracker was last known to see the head, not from when it last
    /// moved.
    last: [TrackerSample; 3],
    /// The clock's reading at the last update (s).
    last_now: Option<f64>,
}

impl GazeFilters {
    /// The clock's reading now: real time, or the head sample's time (the
    /// last reading where that is not finite).
    fn now(&self, clock: FoveationClock, head: &TrackedHead, real_s: f64) -> f64 {
        clock_now(clock, head, real_s, self.last_now)
    }
}

/// [`FoveationClock`]'s reading: `real_s`, or the head sample's time (or
/// `last` where it is not finite; 0 with neither).
pub(crate) fn clock_now(
    clock: FoveationClock,
    head: &TrackedHead,
    real_s: f64,
    last: Option<f64>,
) -> f64 {
    match clock {
        FoveationClock::Real => real_s,
        FoveationClock::HeadSample if head.timestamp_s.is_finite() => head.timestamp_s,
        FoveationClock::HeadSample => last.unwrap_or(0.0),
    }
}

impl GazeFilters {
    fn new(timeout_s: f32) -> Self {
        // CheckedFoveation keeps the timeout finite and ≥ 0.
        let t = GazeTracker::new(timeout_s as f64)
            .unwrap_or_else(|_| GazeTracker::new(0.0).expect("a zero timeout is valid"));
        Self {
            trackers: [t.clone(), t.clone(), t],
            timeout_s,
            last: [TrackerSample::Missing; 3],
            last_now: None,
        }
    }
}

impl Default for GazeFilters {
    fn default() -> Self {
        Self::new(CheckedFoveation::default().hold_timeout_s)
    }
}

/// Feeds the head to the dropout filters. Runs when the head or the settings
/// changed, or while a held gaze is ageing towards its timeout; otherwise
/// nothing is recomputed.
pub(crate) fn filter_gaze(
    head: Res<TrackedHead>,
    settings: Res<CheckedFoveation>,
    time: Res<Time<Real>>,
    mut filters: ResMut<GazeFilters>,
    mut state: ResMut<GazeState>,
    mut work: ResMut<crate::lod::FoveationWork>,
) {
    let ageing = state
        .estimates
        .iter()
        .any(|e| matches!(e, GazeEstimate::Held { .. }));
    if !(head.is_changed() || settings.is_changed() || ageing) {
        return;
    }
    if filters.timeout_s != settings.hold_timeout_s {
        *filters = GazeFilters::new(settings.hold_timeout_s);
    }
    work.gaze_updates += 1;
    let now = filters.now(settings.clock, &head, time.elapsed_secs_f64());
    let eyes = [Eye::Left, Eye::Right, Eye::Cyclopean];
    let mut next = GazeState {
        estimates: state.estimates,
        fields: eyes.map(|eye| settings.field(eye)),
    };
    let before = match settings.clock {
        FoveationClock::Real => now - time.delta_secs_f64(),
        FoveationClock::HeadSample => filters.last_now.unwrap_or(now),
    };
    filters.last_now = Some(now);
    for (i, eye) in eyes.into_iter().enumerate() {
        let sample = head.sample(eye);
        let last = filters.last[i];
        if sample.frame().is_err() && last.frame().is_ok() {
            filters.trackers[i].update(last, before);
        }
        filters.last[i] = sample;
        next.estimates[i] = filters.trackers[i].update(sample, now);
    }
    if !settings.enabled {
        next.estimates = next.estimates.map(|e| GazeEstimate::FullQuality {
            last: e.frame().copied(),
        });
    }
    state.set_if_neq(next);
}

/// Where [`TrackedHead`] comes from.
#[derive(Resource, Clone, Debug, Default)]
pub enum HeadSource {
    /// The app writes [`TrackedHead`] itself (a real tracker, a network
    /// stream): the plugin only reads it.
    #[default]
    External,
    /// A head steered from the keyboard (arrows move the gaze, W/S/A/D the
    /// head) or from code, for development without a tracker.
    Simulated(SimulatedGaze),
    /// A recorded trace replayed on the app's clock.
    Replay(HeadReplay),
    /// An ART DTrack tracker's ASCII stream over UDP (see
    /// [`crate::dtrack`]): the head from one body, mapped into the scene.
    DTrack(crate::dtrack::DTrackSettings),
}

/// A simulated head and gaze: the head at [`position`](Self::position) turned
/// by yaw and pitch, the eyes looking `gaze_yaw_deg` right and
/// `gaze_pitch_deg` up of the head's forward.
#[derive(Clone, Debug, PartialEq, Reflect)]
pub struct SimulatedGaze {
    /// The point between the eyes (m).
    pub position: Vec3,
    /// Head yaw (degrees, positive turns left, about +Y).
    pub head_yaw_deg: f32,
    /// Head pitch (degrees, positive up).
    pub head_pitch_deg: f32,
    /// Gaze yaw relative to the head (degrees, positive right).
    pub gaze_yaw_deg: f32,
    /// Gaze pitch relative to the head (degrees, positive up).
    pub gaze_pitch_deg: f32,
    /// Interpupillary distance (m).
    pub ipd: f32,
    /// Keyboard speed (degrees per second for the gaze, metres per second
    /// for the head); 0 turns the keyboard off.
    pub speed: f32,
    /// A simulated tracker dropout: the head is reported invalid.
    pub dropped: bool,
}

impl Default for SimulatedGaze {
    fn default() -> Self {
        Self {
            position: Vec3::new(0.0, 1.6, 0.0),
            head_yaw_deg: 0.0,
            head_pitch_deg: 0.0,
            gaze_yaw_deg: 0.0,
            gaze_pitch_deg: 0.0,
            ipd: 0.063,
            speed: 60.0,
            dropped: false,
        }
    }
}

impl SimulatedGaze {
    /// The head this simulation reports.
    pub fn head(&self) -> TrackedHead {
        let orientation = Quat::from_euler(
            EulerRot::YXZ,
            self.head_yaw_deg.to_radians(),
            self.head_pitch_deg.to_radians(),
            0.0,
        );
        let local = Quat::from_euler(
            EulerRot::YXZ,
            -self.gaze_yaw_deg.to_radians(),
            self.gaze_pitch_deg.to_radians(),
            0.0,
        ) * Vec3::NEG_Z;
        let mut head = TrackedHead::looking(
            self.position,
            orientation,
            Some(orientation * local),
            self.ipd,
        );
        head.valid = !self.dropped;
        head
    }
}

/// A [`HeadTrace`] played back from `start_s` on the app's clock (looping
/// when asked): each frame the head is the last sample at or before the
/// trace time.
#[derive(Clone, Debug)]
pub struct HeadReplay {
    /// The recording.
    pub trace: HeadTrace,
    /// App time (s, `Time<Virtual>`) at which the trace's first sample plays.
    pub start_s: f64,
    /// Start again at the end (else the last sample stays).
    pub looping: bool,
}

/// Writes [`TrackedHead`] from a simulated or replayed source (only when the
/// head it reports differs from the current one).
pub(crate) fn drive_head_source(
    mut source: ResMut<HeadSource>,
    mut head: ResMut<TrackedHead>,
    time: Res<Time>,
    keys: Option<Res<ButtonInput<KeyCode>>>,
    mut dtrack: (
        Commands,
        Option<ResMut<crate::dtrack::DTrackSocket>>,
        ResMut<crate::dtrack::DTrackStats>,
    ),
) {
    match source.bypass_change_detection() {
        HeadSource::External => {}
        HeadSource::DTrack(settings) => {
            let (commands, socket, stats) = &mut dtrack;
            let changed = crate::dtrack::read_dtrack(
                settings,
                socket,
                commands,
                stats.bypass_change_detection(),
                head.bypass_change_detection(),
            );
            if changed {
                head.set_changed();
            }
        }
        HeadSource::Simulated(sim) => {
            if let Some(keys) = keys {
                steer(sim, &keys, time.delta_secs());
            }
            let mut next = sim.head();
            next.timestamp_s = head.timestamp_s;
            if *head != next {
                next.timestamp_s = time.elapsed_secs_f64();
                *head = next;
            }
        }
        HeadSource::Replay(replay) => {
            let t = time.elapsed_secs_f64() - replay.start_s;
            if let Some(sample) = replay.trace.at(t, replay.looping) {
                head.set_if_neq(sample.clone());
            }
        }
    }
}

fn steer(sim: &mut SimulatedGaze, keys: &ButtonInput<KeyCode>, dt: f32) {
    let turn = sim.speed * dt;
    let axis = |neg: KeyCode, pos: KeyCode| {
        keys.pressed(pos) as i32 as f32 - keys.pressed(neg) as i32 as f32
    };
    sim.gaze_yaw_deg = (sim.gaze_yaw_deg + turn * axis(KeyCode::ArrowLeft, KeyCode::ArrowRight))
        .clamp(-90.0, 90.0);
    sim.gaze_pitch_deg =
        (sim.gaze_pitch_deg + turn * axis(KeyCode::ArrowDown, KeyCode::ArrowUp)).clamp(-80.0, 80.0);
    let step = sim.speed / 60.0 * dt;
    let forward = Quat::from_rotation_y(sim.head_yaw_deg.to_radians()) * Vec3::NEG_Z;
    let right = forward.cross(Vec3::Y);
    sim.position += (forward * axis(KeyCode::KeyS, KeyCode::KeyW)
        + right * axis(KeyCode::KeyA, KeyCode::KeyD))
        * step;
}

/// The field model of one eye of the settings.
pub(crate) fn eye_model(eyes: FieldEyes, eye: Eye) -> EyeModel {
    match (eyes, eye) {
        (FieldEyes::PerEye, Eye::Left) => EyeModel::LeftEye,
        (FieldEyes::PerEye, Eye::Right) => EyeModel::RightEye,
        _ => EyeModel::Paper,
    }
}
