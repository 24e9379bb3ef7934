//! The radial fisheye mappings a dome camera can use: a direction at polar
//! angle θ from the axis lands at radius `r = f·g(θ)` from the image centre,
//! at its own azimuth (D9 in the module docs).
//!
//! | lens | g(θ) | field of view |
//! |---|---|---|
//! | equidistant (f-θ, the domemaster's) | θ | < 360° |
//! | equisolid angle (equal area) | 2 sin(θ/2) | < 360° |
//! | stereographic (conformal) | 2 tan(θ/2) | < 360° |
//! | orthographic | sin θ | ≤ 180° |
//! | polynomial (Kannala–Brandt) | k₁θ + k₂θ³ + k₃θ⁵ + k₄θ⁷ | < 360°, g rising |
//!
//! The scale f is chosen so that the rim θ_max = FOV/2 lands on the image
//! circle (D3 generalised): `f = R/g(θ_max)`, R half the shorter side. So
//! only the polynomial's shape matters, not its units: coefficients from a
//! calibration tool (OpenCV's `fisheye` model, Kalibr's `equidistant`
//! model) can be used as they are, with the field of view the lens covers.
//!
//! Past the rim, the orthographic and polynomial mappings are continued by
//! a parabola, `g(θ_max) + g'(θ_max)·d + ½·c·d²` with d = θ − θ_max and
//! `c = g(θ_max)/θ_max²`: sin θ turns back past 90°, and a fitted
//! polynomial says nothing reliable beyond the angles it was fitted on.
//! Geometry there lies outside the image circle and is masked; the
//! continuation only has to keep it there (rising, so nothing folds back
//! into the image) and has to meet the lens smoothly (same slope at the
//! rim: a kink would bend the image of every edge crossing the rim, which
//! the refinement's curvature estimate does not see; a straight
//! continuation with a steeper slope cost 6.7 px at a 0.5 px tolerance).
//! The other mappings rise all the way to the antipode.

use serde::{Deserialize, Serialize};

use super::error::DomeError;
use crate::input;

/// Points at which a polynomial's slope g'(θ) is checked to be positive
/// over the field of view: g' is a cubic in θ², so it changes sign at most
/// three times, and a dip below zero narrower than 1/4096 of the field of
/// view would need coefficients no lens calibration produces.
const MONOTONE_CHECKS: u32 = 4096;

/// A radial fisheye mapping, `r = f·g(θ)` (see the module docs for g and
/// the limits of each).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub enum FisheyeLens {
    /// r = f·θ: equal steps of angle are equal steps of radius. The
    /// domemaster standard, and the paper's projection.
    #[default]
    Equidistant,
    /// r = 2f·sin(θ/2): equal solid angles cover equal image areas; most
    /// photographic fisheyes.
    Equisolid,
    /// r = 2f·tan(θ/2): conformal (small shapes keep their shape, circles
    /// stay circles), stretched towards the rim.
    Stereographic,
    /// r = f·sin θ: a hemisphere seen from afar; at most 180°.
    Orthographic,
    /// r = f·(k₁θ + k₂θ³ + k₃θ⁵ + k₄θ⁷), the Kannala–Brandt model camera
    /// calibration tools fit to real lenses. k₁ must be positive and r must
    /// rise over the whole field of view.
    Polynomial {
        /// k₁ … k₄.
        k: [f64; 4],
    },
}

impl FisheyeLens {
    /// g(θ) without the continuation past the rim.
    fn g(&self, t: f64) -> f64 {
        match self {
            Self::Equidistant => t,
            Self::Equisolid => 2.0 * (0.5 * t).sin(),
            Self::Stereographic => 2.0 * (0.5 * t).tan(),
            Self::Orthographic => t.sin(),
            Self::Polynomial { k } => {
                let t2 = t * t;
                t * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])))
            }
        }
    }

    /// g'(θ).
    fn dg(&self, t: f64) -> f64 {
        match self {
            Self::Equidistant => 1.0,
            Self::Equisolid => (0.5 * t).cos(),
            Self::Stereographic => 1.0 / (0.5 * t).cos().powi(2),
            Self::Orthographic => t.cos(),
            Self::Polynomial { k } => {
                let t2 = t * t;
                k[0] + t2 * (3.0 * k[1] + t2 * (5.0 * k[2] + t2 * 7.0 * k[3]))
            }
        }
    }

    /// g''(θ).
    fn d2g(&self, t: f64) -> f64 {
        match self {
            Self::Equidistant => 0.0,
            Self::Equisolid => -0.5 * (0.5 * t).sin(),
            Self::Stereographic => {
                let c = (0.5 * t).cos();
                (0.5 * t).tan() / (c * c)
            }
            Self::Orthographic => -t.sin(),
            Self::Polynomial { k } => {
                let t2 = t * t;
                t * (6.0 * k[1] + t2 * (20.0 * k[2] + t2 * 42.0 * k[3]))
            }
        }
    }

    /// Whether the mapping is continued by a line past the rim.
    fn continued(&self) -> bool {
        matches!(self, Self::Orthographic | Self::Polynomial { .. })
    }

    /// The widest field of view the mapping takes, in degrees (exclusive
    /// for all but the orthographic, whose 180° is allowed).
    pub fn max_fov_deg(&self) -> f64 {
        match self {
            Self::Orthographic => 180.0,
            _ => 360.0,
        }
    }

    /// The four coefficients of the mapping as a Kannala–Brandt polynomial
    /// would give them, where the mapping is one exactly (equidistant:
    /// k = (1, 0, 0, 0)); `None` for the others.
    pub fn polynomial(&self) -> Option<[f64; 4]> {
        match self {
            Self::Equidistant => Some([1.0, 0.0, 0.0, 0.0]),
            Self::Polynomial { k } => Some(*k),
            _ => None,
        }
    }
}

/// A lens checked against a field of view: g with its continuation past
/// the rim, and the rim's radius g(θ_max).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct RadialMap {
    lens: FisheyeLens,
    theta_max: f64,
    g_max: f64,
    /// g'(θ_max), the continuation's slope at the rim.
    rim_slope: f64,
    /// The continuation's second derivative (0 where there is none).
    bend: f64,
}

impl RadialMap {
    /// Checks `lens` for a field of view of `2·theta_max`: the
    /// orthographic up to 180°; a polynomial with finite coefficients,
    /// k₁ > 0 and g' > 0 over the field of view.
    pub fn new(lens: FisheyeLens, fov_deg: f64, theta_max: f64) -> Result<Self, DomeError> {
        match lens {
            FisheyeLens::Orthographic => {
                input::in_range(
                    "orthographic fisheye field of view (deg)",
                    fov_deg,
                    super::MIN_FOV_DEG,
                    180.0,
                )?;
            }
            FisheyeLens::Polynomial { k } => {
                const NAMES: [&str; 4] = [
                    "polynomial fisheye k1",
                    "polynomial fisheye k2",
                    "polynomial fisheye k3",
                    "polynomial fisheye k4",
                ];
                for (name, c) in NAMES.iter().zip(k) {
                    input::finite(name, c)?;
                }
                input::positive(NAMES[0], k[0])?;
                for i in 1..=MONOTONE_CHECKS {
                    let t = theta_max * f64::from(i) / f64::from(MONOTONE_CHECKS);
                    let slope = lens.dg(t);
                    if !(slope > 0.0 && slope.is_finite()) {
                        return Err(DomeError::LensFolds {
                            theta_deg: t.to_degrees(),
                        });
                    }
                }
            }
            _ => {}
        }
        let g_max = lens.g(theta_max);
        // Both ≥ 0 (a polynomial's slope was checked up to the rim, and
        // cos θ_max ≥ 0 for the orthographic), so the parabola rises.
        let rim_slope = lens.dg(theta_max).max(0.0);
        let bend = if lens.continued() {
            g_max / (theta_max * theta_max)
        } else {
            0.0
        };
        Ok(Self {
            lens,
            theta_max,
            g_max,
            rim_slope,
            bend,
        })
    }

    /// The lens.
    pub fn lens(&self) -> FisheyeLens {
        self.lens
    }

    /// g(θ_max), the rim's radius in units of f.
    pub fn g_max(&self) -> f64 {
        self.g_max
    }

    /// Whether θ lies on the continuation past the rim.
    fn beyond(&self, t: f64) -> bool {
        self.lens.continued() && t > self.theta_max
    }

    /// g(θ), continued past the rim where the lens needs it.
    pub fn radius(&self, t: f64) -> f64 {
        if self.beyond(t) {
            let d = t - self.theta_max;
            self.g_max + d * (self.rim_slope + 0.5 * self.bend * d)
        } else {
            self.lens.g(t)
        }
    }

    /// dg/dθ.
    pub fn slope(&self, t: f64) -> f64 {
        if self.beyond(t) {
            self.rim_slope + self.bend * (t - self.theta_max)
        } else {
            self.lens.dg(t)
        }
    }

    /// d²g/dθ².
    pub fn bend(&self, t: f64) -> f64 {
        if self.beyond(t) {
            self.bend
        } else {
            self.lens.d2g(t)
        }
    }

    /// θ of a radius `u` ∈ [0, g_max] (in units of f): the inverse mapping
    /// inside the image circle (closed forms; Newton's method safeguarded
    /// by bisection for a polynomial, which rises there).
    pub fn theta_of_radius(&self, u: f64) -> f64 {
        let u = u.clamp(0.0, self.g_max);
        match self.lens {
            FisheyeLens::Equidistant => u,
            FisheyeLens::Equisolid => 2.0 * (0.5 * u).min(1.0).asin(),
            FisheyeLens::Stereographic => 2.0 * (0.5 * u).atan(),
            FisheyeLens::Orthographic => u.min(1.0).asin(),
            FisheyeLens::Polynomial { .. } => {
                let (mut lo, mut hi) = (0.0, self.theta_max);
                let mut t = u / self.g_max * self.theta_max;
                for _ in 0..100 {
                    let e = self.lens.g(t) - u;
                    if e == 0.0 {
                        break;
                    }
                    if e > 0.0 {
                        hi = t;
                    } else {
                        lo = t;
                    }
                    let newton = t - e / self.lens.dg(t);
                    let next = if newton > lo && newton < hi {
                        newton
                    } else {
                        0.5 * (lo + hi)
                    };
                    let done = (next - t).abs() <= 1e-15 * self.theta_max;
                    t = next;
                    if done {
                        break;
                    }
                }
                t
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const LENSES: [FisheyeLens; 5] = [
        FisheyeLens::Equidistant,
        FisheyeLens::Equisolid,
        FisheyeLens::Stereographic,
        FisheyeLens::Orthographic,
        FisheyeLens::Polynomial {
            k: [1.0, -0.05, 0.004, -0.0002],
        },
    ];

    #[test]
    fn derivatives_match_finite_differences() {
        for lens in LENSES {
            let fov = lens.max_fov_deg().min(300.0);
            let map = RadialMap::new(lens, fov, 0.5 * fov.to_radians()).unwrap();
            for i in 1..40 {
                let t = f64::from(i) * 0.5 * fov.to_radians() / 40.0;
                let h = 1e-5;
                let d1 = (map.radius(t + h) - map.radius(t - h)) / (2.0 * h);
                let d2 = (map.radius(t + h) - 2.0 * map.radius(t) + map.radius(t - h)) / (h * h);
                assert!((d1 - map.slope(t)).abs() < 1e-7, "{lens:?} θ {t}");
                assert!((d2 - map.bend(t)).abs() < 1e-3, "{lens:?} θ {t}: {d2}");
            }
        }
    }

    #[test]
    fn inverse_round_trips_inside_the_circle() {
        for lens in LENSES {
            for fov in [30.0, 180.0, lens.max_fov_deg().min(330.0)] {
                let tm = 0.5 * f64::to_radians(fov);
                let map = RadialMap::new(lens, fov, tm).unwrap();
                for i in 0..=200 {
                    let t = tm * f64::from(i) / 200.0;
                    let back = map.theta_of_radius(map.radius(t));
                    assert!((back - t).abs() < 1e-12, "{lens:?} {fov}: {t} → {back}");
                }
            }
        }
    }

    #[test]
    fn past_the_rim_every_mapping_keeps_rising() {
        for lens in LENSES {
            let fov = lens.max_fov_deg().min(180.0);
            let tm = 0.5 * f64::to_radians(fov);
            let map = RadialMap::new(lens, fov, tm).unwrap();
            let mut last = map.radius(tm);
            for i in 1..100 {
                let t = tm + (PI - 1e-3 - tm) * f64::from(i) / 100.0;
                let r = map.radius(t);
                assert!(r > last && r.is_finite(), "{lens:?} at {t}");
                last = r;
            }
        }
    }

    #[test]
    fn impossible_lenses_are_refused_with_a_reason() {
        let ortho = RadialMap::new(FisheyeLens::Orthographic, 190.0, 95f64.to_radians());
        match ortho {
            Err(DomeError::Input(e)) => {
                assert_eq!(e.what, "orthographic fisheye field of view (deg)")
            }
            other => panic!("{other:?}"),
        }
        let poly =
            |k: [f64; 4]| RadialMap::new(FisheyeLens::Polynomial { k }, 200.0, 100f64.to_radians());
        match poly([1.0, f64::NAN, 0.0, 0.0]) {
            Err(DomeError::Input(e)) => assert_eq!(e.what, "polynomial fisheye k2"),
            other => panic!("{other:?}"),
        }
        match poly([0.0, 1.0, 0.0, 0.0]) {
            Err(DomeError::Input(e)) => assert_eq!(e.what, "polynomial fisheye k1"),
            other => panic!("{other:?}"),
        }
        // g' = 1 − 0.6θ² is zero at θ = 74.0°, inside a 200° field of view.
        match poly([1.0, -0.2, 0.0, 0.0]) {
            Err(DomeError::LensFolds { theta_deg }) => {
                let want = (1.0f64 / 0.6).sqrt().to_degrees();
                assert!((theta_deg - want).abs() < 0.05, "{theta_deg}");
            }
            other => panic!("{other:?}"),
        }
        assert!(poly([1.0, -0.02, 0.0, 0.0]).is_ok());
    }
}
