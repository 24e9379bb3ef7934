//! Head/eye tracker input with dropout handling (documented on [`GazeTracker`]).

use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};

use super::error::FoveatedError;
use super::level::{GazeFrame, VisualField};
use crate::input;

/// One tracker reading, as the tracker reported it (unchecked: see
/// [`TrackerSample::frame`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum TrackerSample {
    /// Eye position, gaze direction and an up hint (see [`GazeFrame::new`]).
    Gaze {
        /// Eye position.
        eye: DVec3,
        /// Gaze direction (need not be unit).
        gaze: DVec3,
        /// Up hint, not parallel to the gaze.
        up: DVec3,
    },
    /// Eye position and head orientation (Bevy convention, see [`GazeFrame::from_rotation`]).
    Pose {
        /// Eye position.
        eye: DVec3,
        /// Orientation.
        rotation: DQuat,
    },
    /// The tracker reported nothing this frame.
    Missing,
}

impl TrackerSample {
    /// The gaze frame of this sample, or why it is unusable: the errors of
    /// [`GazeFrame::new`] and [`GazeFrame::from_rotation`], and
    /// [`FoveatedError::MissingSample`] for [`TrackerSample::Missing`].
    pub fn frame(&self) -> Result<GazeFrame, FoveatedError> {
        match *self {
            Self::Gaze { eye, gaze, up } => GazeFrame::new(eye, gaze, up),
            Self::Pose { eye, rotation } => GazeFrame::from_rotation(eye, rotation),
            Self::Missing => Err(FoveatedError::MissingSample),
        }
    }
}

/// What the renderer should use this frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum GazeEstimate {
    /// A fresh valid sample.
    Tracked(GazeFrame),
    /// The last valid sample, `age_s` seconds old (≤ the timeout).
    Held {
        /// The last valid frame.
        frame: GazeFrame,
        /// Seconds since it was measured.
        age_s: f64,
    },
    /// No usable gaze: render full quality. `last` is the last valid frame, if
    /// any, which a CAVE still needs as its projection eye.
    FullQuality {
        /// Last valid frame, kept for the eye position.
        last: Option<GazeFrame>,
    },
}

impl GazeEstimate {
    /// The gaze frame used for foveation, if any.
    pub fn frame(&self) -> Option<&GazeFrame> {
        match self {
            Self::Tracked(f) | Self::Held { frame: f, .. } => Some(f),
            Self::FullQuality { .. } => None,
        }
    }

    /// The eye position to project from: the current or last valid one.
    pub fn eye(&self) -> Option<DVec3> {
        match self {
            Self::Tracked(f) | Self::Held { frame: f, .. } => Some(f.eye()),
            Self::FullQuality { last } => last.map(|f| f.eye()),
        }
    }

    /// The level of a world ray direction (from the eye): eq. 1–8 with the
    /// estimated gaze, or 1 under [`GazeEstimate::FullQuality`].
    pub fn level(&self, field: &VisualField, dir_world: DVec3) -> f64 {
        match self.frame() {
            Some(f) => field.level(f, dir_world),
            None => 1.0,
        }
    }
}

/// Filters head/eye tracker samples (Step 1 of the paper's §3.3.3, "get the
/// operator's eye position and gaze direction") against dropouts.
///
/// Trackers drop out (occlusion, out of range) and some report NaN. Policy
/// (an addition; the paper does not discuss dropouts):
///
/// 1. A valid sample (finite, non-degenerate) is used as is: [`GazeEstimate::Tracked`].
/// 2. An invalid or missing sample keeps the last valid pose while it is at
///    most `timeout_s` old: [`GazeEstimate::Held`]. A short dropout should not
///    make the whole view flash to full quality and back.
/// 3. After the timeout, or before any valid sample, the estimate is
///    [`GazeEstimate::FullQuality`]: every ray gets level 1, i.e. the
///    unfoveated image. Where the gaze is unknown, no region may be degraded.
///
/// A NaN timestamp is treated like a missing sample and does not advance the
/// clock.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct GazeTracker {
    timeout_s: f64,
    last: Option<(GazeFrame, f64)>,
}

impl GazeTracker {
    /// A filter that holds the last valid pose for at most `timeout_s` seconds.
    /// Errors: [`FoveatedError::Input`] for a negative or non-finite timeout.
    pub fn new(timeout_s: f64) -> Result<Self, FoveatedError> {
        let timeout_s = input::non_negative("tracker hold timeout (s)", timeout_s)?;
        Ok(Self {
            timeout_s,
            last: None,
        })
    }

    /// Feeds the sample of time `t_s` (seconds) and returns the estimate to use.
    pub fn update(&mut self, sample: TrackerSample, t_s: f64) -> GazeEstimate {
        if t_s.is_finite()
            && let Ok(frame) = sample.frame()
        {
            self.last = Some((frame, t_s));
            return GazeEstimate::Tracked(frame);
        }
        match self.last {
            Some((frame, t0)) => {
                // A NaN clock or a clock that went backwards counts as age 0
                // for holding, but never extends the hold past the timeout.
                let age = if t_s.is_finite() {
                    (t_s - t0).max(0.0)
                } else {
                    0.0
                };
                if age <= self.timeout_s {
                    GazeEstimate::Held { frame, age_s: age }
                } else {
                    GazeEstimate::FullQuality { last: Some(frame) }
                }
            }
            None => GazeEstimate::FullQuality { last: None },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::Expected;

    fn good() -> TrackerSample {
        TrackerSample::Gaze {
            eye: DVec3::ZERO,
            gaze: DVec3::NEG_Z,
            up: DVec3::Y,
        }
    }

    fn nan() -> TrackerSample {
        TrackerSample::Gaze {
            eye: DVec3::ZERO,
            gaze: DVec3::new(f64::NAN, 0.0, -1.0),
            up: DVec3::Y,
        }
    }

    #[test]
    fn nan_input_holds_then_falls_back_to_full_quality() {
        let mut t = GazeTracker::new(0.2).unwrap();
        assert!(matches!(t.update(good(), 0.0), GazeEstimate::Tracked(_)));
        let held = t.update(nan(), 0.1);
        assert!(matches!(held, GazeEstimate::Held { age_s, .. } if (age_s - 0.1).abs() < 1e-12));
        assert!(matches!(
            t.update(TrackerSample::Missing, 0.2),
            GazeEstimate::Held { .. }
        ));
        let lost = t.update(nan(), 0.3);
        assert!(matches!(lost, GazeEstimate::FullQuality { last: Some(_) }));
        // Full quality means level 1 even straight behind the gaze.
        assert_eq!(lost.level(&VisualField::paper(), DVec3::Z), 1.0);
        assert_eq!(lost.eye(), Some(DVec3::ZERO));
        // A valid sample resumes tracking.
        assert!(matches!(t.update(good(), 0.4), GazeEstimate::Tracked(_)));
    }

    #[test]
    fn no_valid_sample_yet_is_full_quality() {
        let mut t = GazeTracker::new(0.2).unwrap();
        assert_eq!(
            t.update(nan(), 0.0),
            GazeEstimate::FullQuality { last: None }
        );
        let degenerate = TrackerSample::Gaze {
            eye: DVec3::ZERO,
            gaze: DVec3::Y,
            up: DVec3::Y,
        };
        assert_eq!(
            t.update(degenerate, 0.1),
            GazeEstimate::FullQuality { last: None }
        );
        let bad_pose = TrackerSample::Pose {
            eye: DVec3::ZERO,
            rotation: DQuat::from_xyzw(f64::NAN, 0.0, 0.0, 1.0),
        };
        assert_eq!(
            t.update(bad_pose, 0.2),
            GazeEstimate::FullQuality { last: None }
        );
    }

    #[test]
    fn nan_clock_is_a_missing_sample() {
        let mut t = GazeTracker::new(0.2).unwrap();
        t.update(good(), 0.0);
        assert!(matches!(
            t.update(good(), f64::NAN),
            GazeEstimate::Held { .. }
        ));
        for bad in [f64::NAN, -1.0, f64::INFINITY] {
            assert!(matches!(GazeTracker::new(bad),
                Err(FoveatedError::Input(e)) if e.what == "tracker hold timeout (s)" && e.expected == Expected::NonNegative));
        }
        assert_eq!(
            TrackerSample::Missing.frame(),
            Err(FoveatedError::MissingSample)
        );
    }

    #[test]
    fn tracked_level_uses_the_gaze() {
        let mut t = GazeTracker::new(0.2).unwrap();
        let e = t.update(good(), 0.0);
        let f = VisualField::paper();
        assert_eq!(e.level(&f, DVec3::NEG_Z), 1.0);
        assert_eq!(e.level(&f, DVec3::Z), 0.0);
    }
}
