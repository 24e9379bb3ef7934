//! Level quantisation and the level → LOD-step state machine with a dead band
//! and a minimum dwell time (documented on [`LodHysteresis`]).

use serde::{Deserialize, Serialize};

use super::budget::{ROUND_SLACK, sanitize_level};
use super::error::FoveatedError;
use crate::input::{self, Expected, InvalidInput};

/// How the continuous level of eq. 8 is quantised before eq. 9/10.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum LevelQuantization {
    /// The paper: the continuous level.
    #[default]
    Continuous,
    /// S steps: level ↦ ⌊S · level⌋ / S (never more detail than eq. 8 asks;
    /// S = 1 keeps only the central field). `Steps(0)` acts as `Steps(1)`.
    Steps(u32),
}

impl LevelQuantization {
    /// The quantised level. NaN → 1 (full quality).
    pub fn apply(&self, level: f64) -> f64 {
        let level = sanitize_level(level);
        match *self {
            Self::Continuous => level,
            Self::Steps(s) => {
                let s = s.max(1);
                step_of(level, s) as f64 / s as f64
            }
        }
    }
}

/// ⌊S · level⌋ with a little slack so that k/S maps back to k.
#[inline]
fn step_of(level: f64, steps: u32) -> u32 {
    ((sanitize_level(level) * steps as f64 + ROUND_SLACK).floor() as u32).min(steps)
}

/// Default number of level steps S of [`HysteresisParams`]: 8. A step of
/// 1/8 is finer than eq. 9's reflection steps (1/Reflect_max = 1/3 for the
/// paper's Reflect_max = 3) and than a chain of a few meshes, while leaving
/// room for the default dead band, which must stay below one step (δ < 1/S).
pub const DEFAULT_LEVEL_STEPS: u32 = 8;

/// Default dead band δ of [`HysteresisParams`], in level units: 0.05. The
/// steepest ramp of eq. 8 for the paper's field is the upward one, 1/(60° −
/// 30°) per degree of ray angle, so a gaze jitter of up to 1° (the order of
/// an eye tracker's noise) moves a level by at most 1/30 ≈ 0.033 < 0.05 and
/// never switches a step back and forth. The exception is near the ear side
/// (±E_r), where the paper's angles amplify gaze motion (see
/// [`VisualField`](super::VisualField)); there the level is at most 1/7.
/// δ < 1/S holds for S up to 19.
pub const DEFAULT_DEAD_BAND: f64 = 0.05;

/// Default minimum dwell before a downgrade, in seconds: 0.25, about one
/// fixation. Mean fixation durations are 225 ms in silent reading, 275 ms in
/// visual search and 330 ms in scene perception (K. Rayner, "Eye movements
/// in reading and information processing: 20 years of research",
/// *Psychological Bulletin* 124(3), 1998), so detail is not taken away from
/// a region the viewer has just looked at before the next fixation.
pub const DEFAULT_MIN_DWELL_S: f64 = 0.25;

/// Parameters of [`LodHysteresis`], checked by [`HysteresisParams::new`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HysteresisParams {
    steps: u32,
    dead_band: f64,
    min_dwell_s: f64,
}

impl Default for HysteresisParams {
    /// [`DEFAULT_LEVEL_STEPS`], [`DEFAULT_DEAD_BAND`], [`DEFAULT_MIN_DWELL_S`].
    fn default() -> Self {
        Self {
            steps: DEFAULT_LEVEL_STEPS,
            dead_band: DEFAULT_DEAD_BAND,
            min_dwell_s: DEFAULT_MIN_DWELL_S,
        }
    }
}

impl HysteresisParams {
    /// S level steps (steps 0..=S, level k/S), a dead band δ in level units
    /// and a minimum dwell in seconds.
    ///
    /// Errors: [`FoveatedError::Input`] for S = 0, a dead band outside
    /// 0 ≤ δ < 1/S (a band of a whole step would hold a slot forever), or a
    /// dwell that is negative or not finite.
    pub fn new(steps: u32, dead_band: f64, min_dwell_s: f64) -> Result<Self, FoveatedError> {
        if steps == 0 {
            return Err(
                InvalidInput::new("hysteresis level steps", 0.0, Expected::Positive).into(),
            );
        }
        let step = 1.0 / steps as f64;
        if !(dead_band >= 0.0 && dead_band < step) {
            // `Expected::Range` is inclusive and δ must stay below one step:
            // the largest accepted value is the float just below 1/S.
            let max = step.next_down();
            return Err(InvalidInput::new(
                "hysteresis dead band (level)",
                dead_band,
                Expected::Range { min: 0.0, max },
            )
            .into());
        }
        let min_dwell_s = input::non_negative("hysteresis minimum dwell (s)", min_dwell_s)?;
        Ok(Self {
            steps,
            dead_band,
            min_dwell_s,
        })
    }

    /// The number of level steps S.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// The dead band δ, in level units.
    pub fn dead_band(&self) -> f64 {
        self.dead_band
    }

    /// The minimum dwell before a downgrade, in seconds.
    pub fn min_dwell_s(&self) -> f64 {
        self.min_dwell_s
    }
}

/// The per-slot level → LOD-step state machine, so that gaze jitter does not
/// make the LOD thrash.
///
/// The paper recomputes every ray's level each frame (§3.3.3, Step 2). With a
/// tracker that jitters by a degree, a pixel near a step edge would flip its
/// reflection depth and mesh every frame. This holds a discrete step
/// k ∈ 0..=S (level k/S) per slot (a pixel, a tile or an object):
///
/// * **Upgrade** (more detail) as soon as the level has risen past the upper
///   edge of the current step by the dead band: level ≥ min((k+1)/S + δ, 1).
///   Upgrades are never delayed: too little detail where the user looks is the
///   visible error.
/// * **Downgrade** only when the level has fallen below the lower edge by the
///   dead band, level ≤ max(k/S − δ, 0), *and* the step has been held for at
///   least the minimum dwell time.
///
/// Downgrades are at least a dwell apart, so there are D ≤ ⌈T/dwell⌉ of them
/// in T seconds; between two downgrades the step can only rise, at most S
/// times. A slot therefore switches at most D + (D + 1)·S times in T seconds
/// whatever the input does, and not at all while the input jitters by less
/// than the dead band around a step edge. A NaN level holds the current step
/// (first frame: full quality); time running backwards restarts the dwell
/// clock. The paper has no hysteresis; this is an addition.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LodHysteresis {
    params: HysteresisParams,
    /// Current step and the time it was entered; `None` before the first update.
    state: Option<(u32, f64)>,
    switches: u64,
}

impl LodHysteresis {
    /// A state machine before its first update.
    pub fn new(params: HysteresisParams) -> Self {
        Self {
            params,
            state: None,
            switches: 0,
        }
    }

    /// Feeds the level of this frame at time `t_s` (seconds) and returns the
    /// step to use.
    pub fn update(&mut self, level: f64, t_s: f64) -> u32 {
        let s = self.params.steps;
        let Some((cur, since)) = self.state else {
            // First frame: take the target at once (NaN → full quality).
            let k = if level.is_nan() { s } else { step_of(level, s) };
            self.state = Some((k, if t_s.is_finite() { t_s } else { 0.0 }));
            return k;
        };
        if level.is_nan() {
            return cur;
        }
        let since = if t_s.is_finite() && t_s < since {
            // Clock went backwards: restart the dwell from now.
            self.state = Some((cur, t_s));
            t_s
        } else {
            since
        };
        let level = sanitize_level(level);
        let target = step_of(level, s);
        let sf = s as f64;
        let d = self.params.dead_band;
        let upgrade = target > cur && level >= ((cur + 1) as f64 / sf + d).min(1.0);
        let downgrade = target < cur
            && level <= (cur as f64 / sf - d).max(0.0)
            && t_s.is_finite()
            && t_s - since >= self.params.min_dwell_s;
        if upgrade || downgrade {
            self.state = Some((target, if t_s.is_finite() { t_s } else { since }));
            self.switches += 1;
            target
        } else {
            cur
        }
    }

    /// The current step, if any update happened.
    pub fn step(&self) -> Option<u32> {
        self.state.map(|(k, _)| k)
    }

    /// The current level k/S (1 before the first update: full quality).
    pub fn level(&self) -> f64 {
        self.step()
            .map_or(1.0, |k| k as f64 / self.params.steps as f64)
    }

    /// How many times the step changed (not counting the first frame).
    pub fn switches(&self) -> u64 {
        self.switches
    }
}

/// One [`LodHysteresis`] per pixel: turns a frame's continuous levels into
/// held, quantised levels.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PixelLodGrid {
    slots: Vec<LodHysteresis>,
}

impl PixelLodGrid {
    /// A grid of `len` slots.
    pub fn new(len: usize, params: HysteresisParams) -> Self {
        Self {
            slots: vec![LodHysteresis::new(params); len],
        }
    }

    /// Updates every slot with its level at time `t_s` and returns the held
    /// levels k/S. Errors: [`FoveatedError::LengthMismatch`] for a `levels`
    /// slice of another length than the grid.
    pub fn update(&mut self, levels: &[f64], t_s: f64) -> Result<Vec<f64>, FoveatedError> {
        if levels.len() != self.slots.len() {
            return Err(FoveatedError::LengthMismatch {
                what: "levels for the pixel grid",
                expected: self.slots.len(),
                got: levels.len(),
            });
        }
        Ok(self
            .slots
            .iter_mut()
            .zip(levels)
            .map(|(h, &l)| {
                h.update(l, t_s);
                h.level()
            })
            .collect())
    }

    /// Total step changes over all slots.
    pub fn switches(&self) -> u64 {
        self.slots.iter().map(|h| h.switches()).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use rand::{RngExt, SeedableRng};
    use rand_xoshiro::SplitMix64;

    fn params() -> HysteresisParams {
        HysteresisParams::new(4, 0.05, 0.25).unwrap()
    }

    #[test]
    fn quantization_floors_to_steps() {
        let q = LevelQuantization::Steps(4);
        assert_eq!(q.apply(1.0), 1.0);
        assert_eq!(q.apply(0.99), 0.75);
        assert_eq!(q.apply(0.5), 0.5);
        assert_eq!(q.apply(0.24), 0.0);
        assert_eq!(q.apply(f64::NAN), 1.0);
        assert_eq!(LevelQuantization::Steps(0).apply(0.7), 0.0);
        assert_eq!(LevelQuantization::Continuous.apply(0.37), 0.37);
        // Doubling S never lowers a quantised level (nested grids), which is
        // why the sweep's error falls as S doubles.
        for i in 0..=1000 {
            let l = i as f64 / 1000.0;
            for s in [1, 2, 4, 8, 16, 32] {
                assert!(
                    LevelQuantization::Steps(2 * s).apply(l)
                        >= LevelQuantization::Steps(s).apply(l)
                );
            }
        }
    }

    #[test]
    fn upgrades_at_once_downgrades_after_dwell() {
        let mut h = LodHysteresis::new(params());
        assert_eq!(h.update(0.5, 0.0), 2);
        // Rising past 0.75 + 0.05 upgrades immediately, even at t = 0.01.
        assert_eq!(h.update(0.81, 0.01), 3);
        // Falling to 0.6 (< 0.75 − 0.05) before the dwell does not downgrade...
        assert_eq!(h.update(0.6, 0.1), 3);
        // ...after 0.25 s it does.
        assert_eq!(h.update(0.6, 0.27), 2);
        assert_eq!(h.switches(), 2);
    }

    #[test]
    fn dead_band_holds_near_an_edge() {
        let mut h = LodHysteresis::new(params());
        assert_eq!(h.update(0.49, 0.0), 1);
        // 0.51 is in step 2 but within δ of the edge: hold.
        assert_eq!(h.update(0.51, 1.0), 1);
        assert_eq!(h.update(0.56, 2.0), 2);
        // 0.47 is in step 1 but within δ below 0.5: hold.
        assert_eq!(h.update(0.47, 3.0), 2);
        assert_eq!(h.update(0.44, 4.0), 1);
    }

    #[test]
    fn extremes_are_reachable() {
        let mut h = LodHysteresis::new(params());
        h.update(0.9, 0.0);
        assert_eq!(
            h.update(1.0, 0.0),
            4,
            "the central plateau (level exactly 1) reaches the top step"
        );
        assert_eq!(
            h.update(0.0, 1.0),
            0,
            "outside the field (level exactly 0) reaches step 0"
        );
    }

    #[test]
    fn nan_holds_and_first_nan_is_full_quality() {
        let mut h = LodHysteresis::new(params());
        assert_eq!(h.update(f64::NAN, 0.0), 4);
        assert_eq!(h.update(0.3, 1.0), 1);
        assert_eq!(h.update(f64::NAN, 2.0), 1);
        assert_eq!(h.update(0.3, f64::NAN), 1);
    }

    #[test]
    fn bad_params_are_rejected_naming_the_parameter() {
        let input = |r: Result<HysteresisParams, FoveatedError>| match r {
            Err(FoveatedError::Input(e)) => (e.what, e.expected),
            other => panic!("expected an input error, got {other:?}"),
        };
        assert_eq!(
            input(HysteresisParams::new(0, 0.0, 0.0)),
            ("hysteresis level steps", Expected::Positive)
        );
        // δ must stay below one step, 1/4: the largest accepted value is the float below 0.25.
        let below_quarter = 0.25f64.next_down();
        let band = (
            "hysteresis dead band (level)",
            Expected::Range {
                min: 0.0,
                max: below_quarter,
            },
        );
        assert_eq!(input(HysteresisParams::new(4, 0.3, 0.0)), band);
        assert_eq!(input(HysteresisParams::new(4, 0.25, 0.0)), band);
        assert_eq!(input(HysteresisParams::new(4, -0.01, 0.0)), band);
        assert_eq!(input(HysteresisParams::new(4, f64::NAN, 0.0)), band);
        assert!(HysteresisParams::new(4, below_quarter, 0.0).is_ok());
        let dwell = ("hysteresis minimum dwell (s)", Expected::NonNegative);
        assert_eq!(input(HysteresisParams::new(4, 0.0, f64::NAN)), dwell);
        assert_eq!(input(HysteresisParams::new(4, 0.0, -1.0)), dwell);
        let p = HysteresisParams::new(4, 0.05, 0.25).unwrap();
        assert_eq!((p.steps(), p.dead_band(), p.min_dwell_s()), (4, 0.05, 0.25));
        // The defaults are valid and are the named constants.
        let d = HysteresisParams::default();
        assert_eq!(
            HysteresisParams::new(DEFAULT_LEVEL_STEPS, DEFAULT_DEAD_BAND, DEFAULT_MIN_DWELL_S),
            Ok(d)
        );
    }

    #[test]
    fn default_dead_band_absorbs_a_degree_of_gaze_jitter() {
        // The doc's claim: along the steepest ramp of eq. 8 (straight up,
        // 1/30° per degree) a 1° gaze move changes the level by less than δ.
        use super::super::level::VisualField;
        use glam::DVec3;
        let f = VisualField::paper();
        let up = |deg: f64| f.level_local(DVec3::new(1.0, 0.0, deg.to_radians().tan()));
        for k in 0..29 {
            let a = 30.5 + k as f64;
            assert!((up(a) - up(a + 1.0)).abs() < DEFAULT_DEAD_BAND, "{a}°");
        }
        assert!(DEFAULT_DEAD_BAND < 1.0 / DEFAULT_LEVEL_STEPS as f64);
    }

    #[test]
    fn no_thrash_under_jitter() {
        // A level jittering ±0.04 around the step edge 0.5 at 90 Hz for 10 s:
        // without hysteresis it would flip on about half the frames (~450).
        // With δ = 0.05 > 0.04 it never switches after the first frame.
        let mut h = LodHysteresis::new(params());
        let mut naive = 0;
        let mut last = None;
        let mut rng = SplitMix64::seed_from_u64(12345);
        for i in 0..900 {
            let l: f64 = rng.random_range(0.46..0.54);
            h.update(l, i as f64 / 90.0);
            let k = step_of(l, 4);
            if last.is_some_and(|p| p != k) {
                naive += 1;
            }
            last = Some(k);
        }
        assert!(naive > 300, "the jitter does cross the edge ({naive})");
        assert_eq!(h.switches(), 0);
    }

    #[test]
    fn grid_updates_every_pixel() {
        let mut g = PixelLodGrid::new(3, params());
        assert_eq!(
            g.update(&[1.0, 0.5, 0.0], 0.0).unwrap(),
            vec![1.0, 0.5, 0.0]
        );
        assert_eq!(
            g.update(&[1.0], 0.0),
            Err(FoveatedError::LengthMismatch {
                what: "levels for the pixel grid",
                expected: 3,
                got: 1
            })
        );
    }

    proptest! {
        /// Whatever the input (large jitter, NaN), the switch count in T
        /// seconds stays within D + (D + 1)·S, D = ⌈T/dwell⌉ (`LodHysteresis` docs).
        #[test]
        fn switches_are_bounded(levels in proptest::collection::vec(-0.5f64..1.5, 1..400)) {
            let p = params();
            let mut h = LodHysteresis::new(p);
            let dt = 1.0 / 90.0;
            for (i, &l) in levels.iter().enumerate() {
                let l = if i % 37 == 5 { f64::NAN } else { l };
                let k = h.update(l, i as f64 * dt);
                prop_assert!(k <= p.steps);
            }
            let t = levels.len() as f64 * dt;
            let d = (t / p.min_dwell_s).ceil() as u64;
            let bound = d + (d + 1) * p.steps as u64;
            prop_assert!(h.switches() <= bound, "{} > {}", h.switches(), bound);
        }
    }
}
