//! Level quantisation and a level → LOD-step state machine with a dead band
//! and a minimum dwell time, so that gaze jitter does not make the LOD thrash.
//!
//! The paper recomputes every ray's level each frame (§3.3.3, Step 2). With a
//! tracker that jitters by a degree, a pixel near a step edge would flip its
//! reflection depth and mesh every frame. [`LodHysteresis`] holds a discrete
//! step k ∈ 0..=S (level k/S) per slot (a pixel, a tile or an object):
//!
//! * **Upgrade** (more detail) as soon as the level has risen past the upper
//!   edge of the current step by the dead band: level ≥ min((k+1)/S + δ, 1).
//!   Upgrades are never delayed: too little detail where the user looks is the
//!   visible error.
//! * **Downgrade** only when the level has fallen below the lower edge by the
//!   dead band, level ≤ max(k/S − δ, 0), *and* the step has been held for at
//!   least the minimum dwell time.
//!
//! Downgrades are at least a dwell apart, so there are D ≤ ⌈T/dwell⌉ of them
//! in T seconds; between two downgrades the step can only rise, at most S
//! times. A slot therefore switches at most D + (D + 1)·S times in T seconds
//! whatever the input does, and not at all while the input jitters by less
//! than the dead band around a step edge. A NaN level holds the current step (first frame:
//! full quality); time running backwards restarts the dwell clock.

use serde::{Deserialize, Serialize};

use super::budget::sanitize_level;
use super::error::FoveatedError;

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
    ((sanitize_level(level) * steps as f64 + 1e-9).floor() as u32).min(steps)
}

/// Parameters of [`LodHysteresis`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HysteresisParams {
    /// Number of level steps S (≥ 1); steps are 0..=S, level k/S.
    pub steps: u32,
    /// Dead band δ in level units, 0 ≤ δ < 1/S.
    pub dead_band: f64,
    /// Minimum time a step is held before a downgrade, in seconds (≥ 0).
    pub min_dwell_s: f64,
}

impl HysteresisParams {
    /// Checks the ranges documented on the fields.
    pub fn validate(&self) -> Result<(), FoveatedError> {
        if self.steps == 0 {
            return Err(FoveatedError::InvalidParameter(
                "hysteresis needs at least one step".into(),
            ));
        }
        if !(self.dead_band >= 0.0 && self.dead_band < 1.0 / self.steps as f64) {
            return Err(FoveatedError::InvalidParameter(format!(
                "dead band {} must lie in [0, 1/S = {})",
                self.dead_band,
                1.0 / self.steps as f64
            )));
        }
        if !(self.min_dwell_s >= 0.0 && self.min_dwell_s.is_finite()) {
            return Err(FoveatedError::InvalidParameter(format!(
                "minimum dwell {} s must be finite and ≥ 0",
                self.min_dwell_s
            )));
        }
        Ok(())
    }
}

/// The per-slot state machine (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LodHysteresis {
    params: HysteresisParams,
    /// Current step and the time it was entered; `None` before the first update.
    state: Option<(u32, f64)>,
    switches: u64,
}

impl LodHysteresis {
    /// A state machine with validated parameters.
    pub fn new(params: HysteresisParams) -> Result<Self, FoveatedError> {
        params.validate()?;
        Ok(Self {
            params,
            state: None,
            switches: 0,
        })
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
        self.step().map_or(1.0, |k| k as f64 / self.params.steps as f64)
    }

    /// How many times the step changed (not counting the first frame).
    pub fn switches(&self) -> u64 {
        self.switches
    }
}

/// One [`LodHysteresis`] per pixel: turns a frame's continuous levels into
/// held, quantised levels.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PixelLodGrid {
    slots: Vec<LodHysteresis>,
}

impl PixelLodGrid {
    /// A grid of `len` slots.
    pub fn new(len: usize, params: HysteresisParams) -> Result<Self, FoveatedError> {
        let one = LodHysteresis::new(params)?;
        Ok(Self { slots: vec![one; len] })
    }

    /// Updates every slot with its level at time `t_s` and returns the held
    /// levels k/S. A `levels` slice of another length is an error.
    pub fn update(&mut self, levels: &[f64], t_s: f64) -> Result<Vec<f64>, FoveatedError> {
        if levels.len() != self.slots.len() {
            return Err(FoveatedError::InvalidParameter(format!(
                "{} levels for {} slots",
                levels.len(),
                self.slots.len()
            )));
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

    fn params() -> HysteresisParams {
        HysteresisParams {
            steps: 4,
            dead_band: 0.05,
            min_dwell_s: 0.25,
        }
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
                assert!(LevelQuantization::Steps(2 * s).apply(l) >= LevelQuantization::Steps(s).apply(l));
            }
        }
    }

    #[test]
    fn upgrades_at_once_downgrades_after_dwell() {
        let mut h = LodHysteresis::new(params()).unwrap();
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
        let mut h = LodHysteresis::new(params()).unwrap();
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
        let mut h = LodHysteresis::new(params()).unwrap();
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
        let mut h = LodHysteresis::new(params()).unwrap();
        assert_eq!(h.update(f64::NAN, 0.0), 4);
        assert_eq!(h.update(0.3, 1.0), 1);
        assert_eq!(h.update(f64::NAN, 2.0), 1);
        assert_eq!(h.update(0.3, f64::NAN), 1);
    }

    #[test]
    fn bad_params_are_rejected() {
        assert!(
            LodHysteresis::new(HysteresisParams {
                steps: 0,
                dead_band: 0.0,
                min_dwell_s: 0.0
            })
            .is_err()
        );
        assert!(
            LodHysteresis::new(HysteresisParams {
                steps: 4,
                dead_band: 0.3,
                min_dwell_s: 0.0
            })
            .is_err()
        );
        assert!(
            LodHysteresis::new(HysteresisParams {
                steps: 4,
                dead_band: 0.0,
                min_dwell_s: f64::NAN
            })
            .is_err()
        );
    }

    #[test]
    fn no_thrash_under_jitter() {
        // A level jittering ±0.04 around the step edge 0.5 at 90 Hz for 10 s:
        // without hysteresis it would flip on about half the frames (~450).
        // With δ = 0.05 > 0.04 it never switches after the first frame.
        let mut h = LodHysteresis::new(params()).unwrap();
        let mut naive = 0;
        let mut last = None;
        let mut seed = 12345u64;
        for i in 0..900 {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let u = (seed >> 11) as f64 / (1u64 << 53) as f64;
            let l = 0.5 + 0.08 * (u - 0.5);
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
        let mut g = PixelLodGrid::new(3, params()).unwrap();
        assert_eq!(g.update(&[1.0, 0.5, 0.0], 0.0).unwrap(), vec![1.0, 0.5, 0.0]);
        assert!(g.update(&[1.0], 0.0).is_err());
    }

    proptest! {
        /// Whatever the input (large jitter, NaN), the switch count in T
        /// seconds stays within D + (D + 1)·S, D = ⌈T/dwell⌉ (module docs).
        #[test]
        fn switches_are_bounded(levels in proptest::collection::vec(-0.5f64..1.5, 1..400)) {
            let p = params();
            let mut h = LodHysteresis::new(p).unwrap();
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
