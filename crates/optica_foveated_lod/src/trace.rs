//! Recorded head traces: CSV in, CSV out, sample lookup by time.

use bevy::prelude::*;
use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::head::TrackedHead;

/// Why a head trace could not be read.
#[derive(Debug, Error)]
pub enum TraceError {
    /// The CSV is malformed: a missing column, text where a number belongs.
    #[error("head trace, {0}")]
    Csv(#[from] csv::Error),
    /// A sample's time is not finite or earlier than the one before it.
    #[error("head trace, row {row}: time {t} s is not finite or goes backwards")]
    Time {
        /// Data row, counting from 1.
        row: usize,
        /// The time given.
        t: f64,
    },
    /// The trace has no samples.
    #[error("head trace has no samples")]
    Empty,
}

/// A recorded head: samples in time order.
///
/// # CSV columns
///
/// A header row names the columns; their order is free and unknown columns
/// are an error. Units are seconds, metres and Bevy's axes (+Y up, the
/// identity orientation looks along −Z).
///
/// | column | required | meaning |
/// |---|---|---|
/// | `t` | yes | sample time (s), not decreasing |
/// | `head_x`, `head_y`, `head_z` | yes | the point between the eyes (m) |
/// | `qx`, `qy`, `qz`, `qw` | yes | head orientation quaternion |
/// | `ipd` | no | interpupillary distance (m); default 0.063 |
/// | `gaze_x`, `gaze_y`, `gaze_z` | no | gaze direction (world, any length); empty: the head's forward |
/// | `left_gaze_x` … `right_gaze_z` | no | each eye's gaze (all six, or none) |
/// | `valid` | no | 0 when the tracker lost the head; default 1 |
///
/// Optional cells may be empty. A `NaN` in a required cell is kept: that
/// sample is a dropout (the last valid gaze is held, then full quality), as
/// a tracker recording it would be replayed.
///
/// ```
/// use optica_foveated_lod::HeadTrace;
/// let csv = "t,head_x,head_y,head_z,qx,qy,qz,qw,gaze_x,gaze_y,gaze_z\n\
///            0.0,0,1.6,0,0,0,0,1,0,0,-1\n\
///            0.5,0,1.6,0,0,0,0,1,1,0,-1\n";
/// let trace = HeadTrace::from_csv(csv.as_bytes())?;
/// assert_eq!(trace.len(), 2);
/// assert_eq!(trace.at(0.7, false).unwrap().gaze, Some(bevy::math::Vec3::new(1.0, 0.0, -1.0)));
/// # Ok::<(), optica_foveated_lod::TraceError>(())
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct HeadTrace {
    samples: Vec<TrackedHead>,
}

#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Row {
    t: f64,
    head_x: f32,
    head_y: f32,
    head_z: f32,
    qx: f32,
    qy: f32,
    qz: f32,
    qw: f32,
    #[serde(default)]
    ipd: Option<f32>,
    #[serde(default)]
    gaze_x: Option<f32>,
    #[serde(default)]
    gaze_y: Option<f32>,
    #[serde(default)]
    gaze_z: Option<f32>,
    #[serde(default)]
    left_gaze_x: Option<f32>,
    #[serde(default)]
    left_gaze_y: Option<f32>,
    #[serde(default)]
    left_gaze_z: Option<f32>,
    #[serde(default)]
    right_gaze_x: Option<f32>,
    #[serde(default)]
    right_gaze_y: Option<f32>,
    #[serde(default)]
    right_gaze_z: Option<f32>,
    #[serde(default)]
    valid: Option<u8>,
}

const DEFAULT_IPD: f32 = 0.063;

/// How close (s) a sample's time may be to the replay time and still count
/// as at it: far below any tracker's sample interval (1 ms at 1 kHz), far
/// above the rounding of times in seconds (about 1e-16 s near 1 s, 2e-7 s
/// near a Unix time of 1.7e9 s).
pub const ON_TIME_S: f64 = 1e-6;

fn vec3(x: Option<f32>, y: Option<f32>, z: Option<f32>) -> Option<Vec3> {
    Some(Vec3::new(x?, y?, z?))
}

impl Row {
    fn head(&self) -> TrackedHead {
        // No normalisation here: a NaN stays NaN and makes the sample a
        // dropout downstream; a non-unit quaternion is normalised.
        let q = Quat::from_xyzw(self.qx, self.qy, self.qz, self.qw);
        let q = if q.length_squared() > 0.0 {
            q.normalize()
        } else {
            q
        };
        let gaze = vec3(self.gaze_x, self.gaze_y, self.gaze_z);
        let centre = Vec3::new(self.head_x, self.head_y, self.head_z);
        let mut head = TrackedHead::looking(centre, q, gaze, self.ipd.unwrap_or(DEFAULT_IPD));
        head.eye_gaze = match (
            vec3(self.left_gaze_x, self.left_gaze_y, self.left_gaze_z),
            vec3(self.right_gaze_x, self.right_gaze_y, self.right_gaze_z),
        ) {
            (Some(l), Some(r)) => Some([l, r]),
            _ => None,
        };
        head.timestamp_s = self.t;
        head.valid = self.valid.unwrap_or(1) != 0;
        head
    }

    fn of(head: &TrackedHead) -> Self {
        let c = head.centre();
        let q = head.orientation;
        let (l, r) = match head.eye_gaze {
            Some([l, r]) => (Some(l), Some(r)),
            None => (None, None),
        };
        Self {
            t: head.timestamp_s,
            head_x: c.x,
            head_y: c.y,
            head_z: c.z,
            qx: q.x,
            qy: q.y,
            qz: q.z,
            qw: q.w,
            ipd: Some(head.eyes[0].distance(head.eyes[1])),
            gaze_x: head.gaze.map(|g| g.x),
            gaze_y: head.gaze.map(|g| g.y),
            gaze_z: head.gaze.map(|g| g.z),
            left_gaze_x: l.map(|g| g.x),
            left_gaze_y: l.map(|g| g.y),
            left_gaze_z: l.map(|g| g.z),
            right_gaze_x: r.map(|g| g.x),
            right_gaze_y: r.map(|g| g.y),
            right_gaze_z: r.map(|g| g.z),
            valid: Some(head.valid as u8),
        }
    }
}

impl HeadTrace {
    /// A trace of these samples; their `timestamp_s` must not decrease.
    pub fn new(samples: Vec<TrackedHead>) -> Result<Self, TraceError> {
        if samples.is_empty() {
            return Err(TraceError::Empty);
        }
        let mut last = f64::NEG_INFINITY;
        for (i, s) in samples.iter().enumerate() {
            if !(s.timestamp_s.is_finite() && s.timestamp_s >= last) {
                return Err(TraceError::Time {
                    row: i + 1,
                    t: s.timestamp_s,
                });
            }
            last = s.timestamp_s;
        }
        Ok(Self { samples })
    }

    /// Reads a trace in the CSV format above.
    pub fn from_csv(reader: impl std::io::Read) -> Result<Self, TraceError> {
        let mut csv = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(reader);
        let samples = csv
            .deserialize::<Row>()
            .map(|row| row.map(|r| r.head()))
            .collect::<Result<Vec<_>, _>>()?;
        Self::new(samples)
    }

    /// Writes the trace as CSV (every column).
    pub fn to_csv(&self, writer: impl std::io::Write) -> Result<(), TraceError> {
        let mut csv = csv::Writer::from_writer(writer);
        for s in &self.samples {
            csv.serialize(Row::of(s))?;
        }
        csv.flush().map_err(csv::Error::from)?;
        Ok(())
    }

    /// The samples.
    pub fn samples(&self) -> &[TrackedHead] {
        &self.samples
    }

    /// The number of samples.
    pub fn len(&self) -> usize {
        self.samples.len()
    }

    /// Never true: a trace has at least one sample.
    pub fn is_empty(&self) -> bool {
        self.samples.is_empty()
    }

    /// The duration from the first sample to the last (s).
    pub fn duration_s(&self) -> f64 {
        self.samples.last().map_or(0.0, |s| s.timestamp_s)
            - self.samples.first().map_or(0.0, |s| s.timestamp_s)
    }

    /// The sample playing `t` seconds after the first one: the last at or
    /// before it (`None` before the first).
    ///
    /// A sample within [`ON_TIME_S`] of `t` counts as at it, so a sample
    /// whose time falls on a frame's time plays on that frame although the
    /// two were rounded differently (a 100 Hz trace replayed in 10 ms steps
    /// plays every sample once).
    ///
    /// With `looping`, the trace repeats with a period of its duration plus
    /// its last sample interval, so the last sample plays for as long as the
    /// others before the first comes again.
    pub fn at(&self, t: f64, looping: bool) -> Option<&TrackedHead> {
        let t0 = self.samples.first()?.timestamp_s;
        let mut t = t;
        let period = self.period_s();
        if looping && period > 0.0 && t.is_finite() {
            t = t.rem_euclid(period);
            // Rounding can put a time a hair under a whole period at the
            // period itself: that is the first sample again.
            if t + ON_TIME_S >= period {
                t = 0.0;
            }
        }
        if t.is_nan() || t < -ON_TIME_S {
            return None;
        }
        let i = self
            .samples
            .partition_point(|s| s.timestamp_s - t0 <= t + ON_TIME_S);
        self.samples.get(i.checked_sub(1)?)
    }

    /// The period of a looping replay (s): the duration plus the last
    /// sample interval; 0 for a single sample or samples all at one time.
    pub fn period_s(&self) -> f64 {
        let n = self.samples.len();
        if n < 2 {
            return 0.0;
        }
        let last = self.samples[n - 1].timestamp_s - self.samples[n - 2].timestamp_s;
        self.duration_s() + last
    }
}
