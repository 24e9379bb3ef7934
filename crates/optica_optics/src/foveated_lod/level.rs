//! The visual-field level function of eq. 1–8.
//!
//! A ray direction is expressed in the gaze frame (eq. 1–3), turned into the
//! two angles (m_α, m_β) of the paper's fig. 2 (eq. 4–5), and its level is a
//! piecewise-linear fall-off from 1 inside the central field (l ≤ π/6) to 0 at
//! the peripheral boundary L (eq. 6–8).
//!
//! ## Angles by atan2
//!
//! The paper writes eq. 4–5 as `acos` of a normalised component. `acos` of a
//! rounded ratio slightly above 1 is NaN, and its slope is infinite at 0 and
//! π, so here the same angles are computed as
//!
//! * eq. 4: m_α = acos(d_f / √(d_f² + d_r²)) = atan2(|d_r|, d_f) ∈ [0, π],
//! * eq. 5: m_β = ±acos|d_f / √(d_f² + d_u²)| (sign of d_u) = atan2(d_u, |d_f|) ∈ [−π/2, π/2],
//!
//! which are identical where the paper's forms are defined and finite for every
//! finite direction, including a gaze behind the head (m_α → π).
//!
//! ## Where the paper's angles are singular
//!
//! m_α is undefined at d_f = d_r = 0 (straight up or down) and m_β at
//! d_f = d_u = 0 (straight right or left). Here atan2(0, 0) = 0 is used. Up and
//! down are harmless: l ≥ π/2 > L there, so the level is 0 in a whole
//! neighbourhood. Right/left on the ear side are a genuine discontinuity of the
//! paper's level function: near ±E_r, m_α ≈ π/2 while m_β takes any value in
//! [−π/2, π/2] depending on the approach, so the level jumps between 0 and
//! (100° − 90°)/(100° − 30°) = 1/7 (the value returned exactly at ±E_r). It is
//! a property of the paper's parametrisation, not of this code, and it lies
//! deep in the periphery where the level is at most 1/7. Everywhere else the
//! level is continuous (tested numerically).
//!
//! ## The boundary (eq. 7) and its options
//!
//! Eq. 7 is, with φ the polar angle of (m_α, m_β), L(φ) = √(a²cos²φ + b²sin²φ),
//! with a = 5π/9 (100°, ear side) and b = π/3 (60°) above, 7π/18 (70°) below.
//! It is not an ellipse (an ellipse has 1/L² = cos²φ/a² + sin²φ/b²), and
//! because m_α is unsigned the nose side (π/3 in §2) never enters it. Both are
//! kept as the default ([`EyeModel::Paper`], [`BoundaryShape::PaperEq7`]);
//! [`EyeModel::LeftEye`]/[`EyeModel::RightEye`] (signed m_α, ear and nose sides
//! swapped between the eyes) and [`BoundaryShape::TrueEllipse`] are opt-in.

use std::f64::consts::PI;

use glam::{DQuat, DVec3};
use serde::{Deserialize, Serialize};

use super::error::FoveatedError;

/// Radius of the central field, π/6 (30°): the paper's threshold in eq. 8.
pub const CENTRAL_RADIUS: f64 = PI / 6.0;
/// Ear-side (temporal) extent of the field, 5π/9 (100°): §2 and eq. 7.
pub const EAR_SIDE: f64 = 5.0 * PI / 9.0;
/// Nose-side (nasal) extent, π/3 (60°): §2; used only by the per-eye option.
pub const NOSE_SIDE: f64 = PI / 3.0;
/// Upper extent, π/3 (60°): §2 and eq. 7 (m_β ≥ 0).
pub const UPPER_SIDE: f64 = PI / 3.0;
/// Lower extent, 7π/18 (70°): §2 and eq. 7 (m_β < 0).
pub const LOWER_SIDE: f64 = 7.0 * PI / 18.0;

/// The operator's gaze frame: eye position V and the orthonormal axes E_f
/// (gaze), E_r (right of the gaze) and E_u (up of the gaze) of eq. 1–3.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GazeFrame {
    /// Eye position V (world).
    pub eye: DVec3,
    /// E_f, unit gaze direction.
    pub forward: DVec3,
    /// E_r, unit, to the right of the gaze.
    pub right: DVec3,
    /// E_u, unit, up from the gaze (E_u = E_r × E_f).
    pub up: DVec3,
}

impl GazeFrame {
    /// A right-handed gaze frame from an eye, a gaze direction and an up hint
    /// (E_r = E_f × up_hint, E_u = E_r × E_f).
    ///
    /// Errors: non-finite input, a zero gaze, or an up hint parallel to the
    /// gaze (roll would be undefined, and the field is not roll invariant
    /// because up and down differ). Use [`GazeFrame::from_rotation`] for a
    /// tracker that reports an orientation.
    pub fn new(eye: DVec3, gaze: DVec3, up_hint: DVec3) -> Result<Self, FoveatedError> {
        if !eye.is_finite() {
            return Err(FoveatedError::NonFinite("eye position"));
        }
        if !gaze.is_finite() || !up_hint.is_finite() {
            return Err(FoveatedError::NonFinite("gaze or up direction"));
        }
        let forward = gaze
            .try_normalize()
            .ok_or(FoveatedError::DegenerateDirection("zero gaze"))?;
        let up_hint = up_hint
            .try_normalize()
            .ok_or(FoveatedError::DegenerateDirection("zero up hint"))?;
        let right = forward.cross(up_hint);
        // sin of the angle between gaze and up hint; below ~1e-9 the cross
        // product is rounding noise and E_r would point anywhere.
        if right.length() < 1e-9 {
            return Err(FoveatedError::DegenerateDirection("up hint parallel to gaze"));
        }
        let right = right.normalize();
        let up = right.cross(forward);
        Ok(Self {
            eye,
            forward,
            right,
            up,
        })
    }

    /// A gaze frame from a head/eye orientation in Bevy's convention: the gaze
    /// is the rotated −Z, right the rotated +X, up the rotated +Y.
    pub fn from_rotation(eye: DVec3, rotation: DQuat) -> Result<Self, FoveatedError> {
        if !eye.is_finite() || !rotation.is_finite() {
            return Err(FoveatedError::NonFinite("eye position or rotation"));
        }
        let len = rotation.length();
        if len.is_nan() || len <= 1e-12 {
            return Err(FoveatedError::DegenerateDirection("zero quaternion"));
        }
        let q = rotation / len;
        Ok(Self {
            eye,
            forward: q * DVec3::NEG_Z,
            right: q * DVec3::X,
            up: q * DVec3::Y,
        })
    }

    /// Eq. 1–3: the world direction D' in the gaze frame, D = (d_f, d_r, d_u)
    /// with d_f = E_f·D', d_r = E_r·D', d_u = E_u·D' (returned as x, y, z).
    #[inline]
    pub fn to_local(&self, dir_world: DVec3) -> DVec3 {
        DVec3::new(
            self.forward.dot(dir_world),
            self.right.dot(dir_world),
            self.up.dot(dir_world),
        )
    }

    /// The inverse of [`GazeFrame::to_local`]: (d_f, d_r, d_u) to a world direction.
    #[inline]
    pub fn to_world(&self, local: DVec3) -> DVec3 {
        self.forward * local.x + self.right * local.y + self.up * local.z
    }
}

/// The two angles of fig. 2 between the gaze and a ray, in radians.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FieldAngles {
    /// m_α, the horizontal angle (eq. 4). Unsigned in [0, π] for
    /// [`EyeModel::Paper`]; signed in (−π, π] (positive to the right) for the
    /// per-eye models.
    pub m_alpha: f64,
    /// m_β, the vertical angle (eq. 5), in [−π/2, π/2], positive up.
    pub m_beta: f64,
}

impl FieldAngles {
    /// Eq. 6: l = √(m_α² + m_β²), the distance from the origin of the (α, β) plane.
    #[inline]
    pub fn eccentricity(&self) -> f64 {
        self.m_alpha.hypot(self.m_beta)
    }
}

/// Which field region a ray falls in (§3.3.1, the cases of eq. 8).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum FieldRegion {
    /// l ≤ π/6: central field, level 1.
    Central,
    /// π/6 < l ≤ L: peripheral field, level falls linearly.
    Peripheral,
    /// L < l: outside the field, level 0 (not traced, background).
    Outside,
}

/// How the horizontal angle and the horizontal extent of the field are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum EyeModel {
    /// The paper: unsigned m_α (eq. 4) and the ear-side extent on both sides
    /// (eq. 7 uses 5π/9 only), i.e. one cyclopean eye.
    #[default]
    Paper,
    /// Left eye: signed m_α; the ear (temporal) side is the left (−E_r), the
    /// nose side the right (+E_r).
    LeftEye,
    /// Right eye: signed m_α; the ear side is the right (+E_r), the nose side
    /// the left.
    RightEye,
}

/// The shape of the peripheral boundary L(φ) in the (m_α, m_β) plane.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum BoundaryShape {
    /// Eq. 7 as printed: L² = (a² m_α² + b² m_β²) / (m_α² + m_β²),
    /// i.e. L(φ) = √(a²cos²φ + b²sin²φ).
    #[default]
    PaperEq7,
    /// A true ellipse with the same semi-axes: L(φ) = a b / √(b²cos²φ + a²sin²φ).
    TrueEllipse,
}

/// The visual field and its level function (eq. 4–8).
///
/// The defaults are the paper's: 30° central radius, 100° ear side, 60° nose
/// side (unused by the default model), 60° up, 70° down, [`EyeModel::Paper`],
/// [`BoundaryShape::PaperEq7`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct VisualField {
    /// Central-field radius in radians (π/6).
    pub central: f64,
    /// Ear-side extent in radians (5π/9).
    pub ear: f64,
    /// Nose-side extent in radians (π/3); only the per-eye models use it.
    pub nose: f64,
    /// Upper extent in radians (π/3).
    pub upper: f64,
    /// Lower extent in radians (7π/18).
    pub lower: f64,
    /// Horizontal angle convention.
    pub eye: EyeModel,
    /// Boundary shape.
    pub boundary: BoundaryShape,
}

impl Default for VisualField {
    fn default() -> Self {
        Self::paper()
    }
}

impl VisualField {
    /// The paper's field (§2, eq. 7–8), unsigned m_α, eq. 7 boundary.
    pub const fn paper() -> Self {
        Self {
            central: CENTRAL_RADIUS,
            ear: EAR_SIDE,
            nose: NOSE_SIDE,
            upper: UPPER_SIDE,
            lower: LOWER_SIDE,
            eye: EyeModel::Paper,
            boundary: BoundaryShape::PaperEq7,
        }
    }

    /// The paper's angles with an explicit eye model and boundary shape.
    pub const fn with_options(eye: EyeModel, boundary: BoundaryShape) -> Self {
        let mut f = Self::paper();
        f.eye = eye;
        f.boundary = boundary;
        f
    }

    /// [`VisualField::validate`] as a cheap test (no allocation), for use per ray.
    #[inline]
    pub fn is_valid(&self) -> bool {
        let extent_ok = |v: f64| v > self.central && v <= PI;
        let nose_ok = self.eye == EyeModel::Paper || extent_ok(self.nose);
        self.central.is_finite()
            && self.central > 0.0
            && self.ear.is_finite()
            && self.upper.is_finite()
            && self.lower.is_finite()
            && self.nose.is_finite()
            && extent_ok(self.ear)
            && extent_ok(self.upper)
            && extent_ok(self.lower)
            && nose_ok
    }

    /// Checks that eq. 8 is well defined: all angles finite, 0 < central, and
    /// every extent the model uses greater than the central radius and at most π.
    ///
    /// The fields are public (and deserialisable), so the level functions do
    /// not trust them: for a field that fails this check,
    /// [`VisualField::level_of_angles`] (and so [`VisualField::level`] and
    /// the tracer's `pixel_levels`) return 1 everywhere — when unsure, full
    /// quality — and [`VisualField::region`] returns [`FieldRegion::Central`].
    pub fn validate(&self) -> Result<(), FoveatedError> {
        let all = [self.central, self.ear, self.nose, self.upper, self.lower];
        if all.iter().any(|v| !v.is_finite()) {
            return Err(FoveatedError::NonFinite("visual-field angle"));
        }
        if self.central <= 0.0 {
            return Err(FoveatedError::InvalidField(format!(
                "central radius {} ≤ 0",
                self.central
            )));
        }
        let mut used = vec![("ear", self.ear), ("upper", self.upper), ("lower", self.lower)];
        if self.eye != EyeModel::Paper {
            used.push(("nose", self.nose));
        }
        for (name, v) in used {
            if v <= self.central || v > PI {
                return Err(FoveatedError::InvalidField(format!(
                    "{name} extent {v} rad must lie in (central = {}, π]",
                    self.central
                )));
            }
        }
        Ok(())
    }

    /// Eq. 4–5 (atan2 forms, see the module docs) for a direction in the gaze
    /// frame, `local = (d_f, d_r, d_u)`; it need not be unit.
    #[inline]
    pub fn angles(&self, local: DVec3) -> FieldAngles {
        let (df, dr, du) = (local.x, local.y, local.z);
        let m_alpha = match self.eye {
            EyeModel::Paper => dr.abs().atan2(df),
            EyeModel::LeftEye | EyeModel::RightEye => dr.atan2(df),
        };
        // `+ 0.0` turns atan2's −0 into +0 so that the singular directions
        // get exactly m_β = 0 as documented.
        let m_beta = du.atan2(df.abs()) + 0.0;
        FieldAngles { m_alpha, m_beta }
    }

    /// The horizontal semi-axis a for the side of the field `m_alpha` lies on.
    #[inline]
    fn horizontal_extent(&self, m_alpha: f64) -> f64 {
        match self.eye {
            EyeModel::Paper => self.ear,
            EyeModel::RightEye => {
                if m_alpha >= 0.0 {
                    self.ear
                } else {
                    self.nose
                }
            }
            EyeModel::LeftEye => {
                if m_alpha <= 0.0 {
                    self.ear
                } else {
                    self.nose
                }
            }
        }
    }

    /// Eq. 7: the length L of the segment from the origin through (m_α, m_β) to
    /// the boundary between the peripheral field and the outside.
    ///
    /// At the origin (φ undefined) the value along the α axis, a, is returned;
    /// eq. 8 never needs it there because l = 0 is central.
    pub fn boundary(&self, angles: FieldAngles) -> f64 {
        let (ma, mb) = (angles.m_alpha, angles.m_beta);
        let a = self.horizontal_extent(ma);
        let b = if mb >= 0.0 { self.upper } else { self.lower };
        let l2 = ma * ma + mb * mb;
        if l2 == 0.0 {
            return a;
        }
        match self.boundary {
            // Eq. 7 literally: √((a² m_α² + b² m_β²) / (m_α² + m_β²)).
            BoundaryShape::PaperEq7 => ((a * a * ma * ma + b * b * mb * mb) / l2).sqrt(),
            BoundaryShape::TrueEllipse => a * b * l2.sqrt() / (b * b * ma * ma + a * a * mb * mb).sqrt(),
        }
    }

    /// The region of eq. 8 for given angles. [`FieldRegion::Central`] (full
    /// quality) for an invalid field (see [`VisualField::validate`]) or
    /// non-finite angles, like [`VisualField::level_of_angles`].
    pub fn region(&self, angles: FieldAngles) -> FieldRegion {
        let l = angles.eccentricity();
        if !self.is_valid() || !l.is_finite() || l <= self.central {
            FieldRegion::Central
        } else if l <= self.boundary(angles) {
            FieldRegion::Peripheral
        } else {
            FieldRegion::Outside
        }
    }

    /// Eq. 6 and 8: the level in [0, 1] for given angles.
    ///
    /// Documented fallback (when unsure, full quality): non-finite angles, and
    /// any angles for a field that fails [`VisualField::validate`] (say a NaN
    /// central radius from a hand-edited config), give 1.
    pub fn level_of_angles(&self, angles: FieldAngles) -> f64 {
        let l = angles.eccentricity();
        if !l.is_finite() || !self.is_valid() {
            return 1.0;
        }
        if l <= self.central {
            return 1.0;
        }
        let big_l = self.boundary(angles);
        if l > big_l {
            return 0.0;
        }
        let denom = big_l - self.central;
        if denom.is_nan() || denom <= 0.0 {
            // Unreachable for a valid field (L ≥ min extent > central); full quality if it ever is.
            return 1.0;
        }
        ((big_l - l) / denom).clamp(0.0, 1.0)
    }

    /// The level of a direction given in the gaze frame, (d_f, d_r, d_u).
    ///
    /// Documented fallback: a zero or non-finite direction, or an invalid
    /// field, gives 1 (full quality).
    pub fn level_local(&self, local: DVec3) -> f64 {
        if !local.is_finite() || local == DVec3::ZERO {
            return 1.0;
        }
        self.level_of_angles(self.angles(local))
    }

    /// The level (eq. 1–8) of the world direction `dir_world` of a ray from the
    /// eye, for the gaze `frame`. Same fallback as [`VisualField::level_local`].
    #[inline]
    pub fn level(&self, frame: &GazeFrame, dir_world: DVec3) -> f64 {
        self.level_local(frame.to_local(dir_world))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const DEG: f64 = PI / 180.0;

    /// A local direction at horizontal angle `a` (right positive) and vertical
    /// angle `b` in the paper's sense: tan(m_α) = d_r/d_f, tan(m_β) = d_u/d_f.
    fn dir_ab(a_deg: f64, b_deg: f64) -> DVec3 {
        DVec3::new(1.0, (a_deg * DEG).tan(), (b_deg * DEG).tan())
    }

    #[test]
    fn hand_computed_levels_on_the_axes() {
        let f = VisualField::paper();
        // Gaze itself: l = 0, central.
        assert_eq!(f.level_local(DVec3::X), 1.0);
        // 30° right: l = π/6 exactly on the central edge → 1 (eq. 8, first case).
        assert!((f.level_local(dir_ab(30.0, 0.0)) - 1.0).abs() < 1e-12);
        // 65° right: L = 100°, (100 − 65)/(100 − 30) = 0.5.
        assert!((f.level_local(dir_ab(65.0, 0.0)) - 0.5).abs() < 1e-12);
        // 65° left gives the same (m_α unsigned).
        assert!((f.level_local(dir_ab(-65.0, 0.0)) - 0.5).abs() < 1e-12);
        // 45° up: L = 60°, (60 − 45)/(60 − 30) = 0.5.
        assert!((f.level_local(dir_ab(0.0, 45.0)) - 0.5).abs() < 1e-12);
        // 50° down: L = 70°, (70 − 50)/(70 − 30) = 0.5.
        assert!((f.level_local(dir_ab(0.0, -50.0)) - 0.5).abs() < 1e-12);
        // 61° up, 71° down, 101° right: outside → 0.
        assert_eq!(f.level_local(dir_ab(0.0, 61.0)), 0.0);
        assert_eq!(f.level_local(dir_ab(0.0, -71.0)), 0.0);
        let r101 = DVec3::new((101.0 * DEG).cos(), (101.0 * DEG).sin(), 0.0);
        assert_eq!(f.level_local(r101), 0.0);
    }

    #[test]
    fn hand_computed_level_on_the_diagonal() {
        // m_α = m_β = 40°: l = 40√2° = 56.5685°; eq. 7: L = √((100² + 60²)/2)° = √6800° = 82.4621°;
        // eq. 8: (82.4621 − 56.5685)/(82.4621 − 30) = 0.493567.
        let f = VisualField::paper();
        let a = f.angles(dir_ab(40.0, 40.0));
        assert!((a.m_alpha - 40.0 * DEG).abs() < 1e-12 && (a.m_beta - 40.0 * DEG).abs() < 1e-12);
        assert!((f.boundary(a) - 6800f64.sqrt() * DEG).abs() < 1e-12);
        let expect = (6800f64.sqrt() - 40.0 * 2f64.sqrt()) / (6800f64.sqrt() - 30.0);
        assert!((f.level_local(dir_ab(40.0, 40.0)) - expect).abs() < 1e-12);
        assert!((expect - 0.493567).abs() < 1e-6);
        // The true ellipse: L = 100·60/√6800 = 72.7607°, a smaller field on the diagonal.
        let e = VisualField::with_options(EyeModel::Paper, BoundaryShape::TrueEllipse);
        assert!((e.boundary(a) - 6000.0 / 6800f64.sqrt() * DEG).abs() < 1e-12);
        assert!(e.level_local(dir_ab(40.0, 40.0)) < expect);
    }

    #[test]
    fn eq7_matches_polar_form_and_not_an_ellipse() {
        let f = VisualField::paper();
        for k in 0..=36 {
            let phi = (k as f64) * 5.0 * DEG - 90.0 * DEG;
            let angles = FieldAngles {
                m_alpha: 0.7 * phi.cos(),
                m_beta: 0.7 * phi.sin(),
            };
            let b = if phi >= 0.0 { UPPER_SIDE } else { LOWER_SIDE };
            let polar = (EAR_SIDE.powi(2) * phi.cos().powi(2) + b * b * phi.sin().powi(2)).sqrt();
            assert!((f.boundary(angles) - polar).abs() < 1e-12, "phi {phi}");
        }
    }

    #[test]
    fn per_eye_models_swap_nose_and_ear() {
        // 50° right. Right eye: ear side, L = 100°, (100 − 50)/70 = 5/7.
        // Left eye: nose side, L = 60°, (60 − 50)/30 = 1/3.
        let r = VisualField::with_options(EyeModel::RightEye, BoundaryShape::PaperEq7);
        let l = VisualField::with_options(EyeModel::LeftEye, BoundaryShape::PaperEq7);
        assert!((r.level_local(dir_ab(50.0, 0.0)) - 5.0 / 7.0).abs() < 1e-12);
        assert!((l.level_local(dir_ab(50.0, 0.0)) - 1.0 / 3.0).abs() < 1e-12);
        // Mirror symmetry: the left eye at (f, r, u) is the right eye at (f, −r, u).
        for &(a, b) in &[(10.0, 5.0), (50.0, -20.0), (70.0, 30.0), (-80.0, 10.0), (35.0, 35.0)] {
            let d = dir_ab(a, b);
            let m = DVec3::new(d.x, -d.y, d.z);
            assert!((l.level_local(d) - r.level_local(m)).abs() < 1e-15);
        }
        // On the ear side the per-eye model equals the paper's.
        let p = VisualField::paper();
        assert!((r.level_local(dir_ab(55.0, 20.0)) - p.level_local(dir_ab(55.0, 20.0))).abs() < 1e-15);
    }

    #[test]
    fn paper_model_is_left_right_symmetric() {
        let f = VisualField::paper();
        for i in 0..200 {
            let t = i as f64 * 0.173;
            let d = DVec3::new(t.cos(), (1.3 * t).sin(), (0.7 * t).cos() - 0.3);
            let m = DVec3::new(d.x, -d.y, d.z);
            assert_eq!(f.level_local(d), f.level_local(m));
        }
    }

    #[test]
    fn behind_the_head_is_finite_and_outside() {
        let f = VisualField::paper();
        // Straight behind: m_α = π, m_β = 0, l = π > L → 0, region Outside.
        let a = f.angles(DVec3::NEG_X);
        assert_eq!(a.m_alpha, PI);
        assert_eq!(a.m_beta, 0.0);
        assert_eq!(f.level_local(DVec3::NEG_X), 0.0);
        assert_eq!(f.region(a), FieldRegion::Outside);
        for eye in [EyeModel::Paper, EyeModel::LeftEye, EyeModel::RightEye] {
            for shape in [BoundaryShape::PaperEq7, BoundaryShape::TrueEllipse] {
                let g = VisualField::with_options(eye, shape);
                for d in [
                    DVec3::NEG_X,
                    DVec3::new(-1.0, 1e-300, 0.0),
                    DVec3::new(-1.0, -1e-300, -1e-300),
                ] {
                    let v = g.level_local(d);
                    assert!(v.is_finite() && v == 0.0);
                }
            }
        }
    }

    #[test]
    fn nan_and_zero_directions_fall_back_to_full_quality() {
        let f = VisualField::paper();
        assert_eq!(f.level_local(DVec3::new(f64::NAN, 0.0, 1.0)), 1.0);
        assert_eq!(f.level_local(DVec3::new(f64::INFINITY, 0.0, 1.0)), 1.0);
        assert_eq!(f.level_local(DVec3::ZERO), 1.0);
        assert!(GazeFrame::new(DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 0.0), DVec3::Y).is_err());
        assert!(GazeFrame::new(DVec3::ZERO, DVec3::Y, DVec3::Y).is_err());
        assert!(GazeFrame::new(DVec3::ZERO, DVec3::ZERO, DVec3::Y).is_err());
    }

    #[test]
    fn singular_directions_have_the_documented_values() {
        let f = VisualField::paper();
        // ±E_r: m_α = 90°, m_β = 0 by atan2(0, 0) = 0 → (100 − 90)/(100 − 30) = 1/7.
        assert!((f.level_local(DVec3::Y) - 1.0 / 7.0).abs() < 1e-12);
        assert!((f.level_local(DVec3::NEG_Y) - 1.0 / 7.0).abs() < 1e-12);
        // ±E_u: level 0 in a whole neighbourhood (l ≥ 90° > 70°).
        for d in [
            DVec3::Z,
            DVec3::NEG_Z,
            DVec3::new(1e-3, 1e-3, 1.0),
            DVec3::new(-1e-3, 1e-3, -1.0),
        ] {
            assert_eq!(f.level_local(d), 0.0);
        }
    }

    #[test]
    fn continuous_across_the_axes() {
        // Step across each axis plane with a tiny offset ε and compare both
        // sides: d_r = 0 in front (m_α = 0 axis), d_u = 0 (m_β = 0 axis),
        // d_f = 0 at the side (behind-the-head plane), and d_r = 0 behind.
        let eps = 1e-9;
        for field in [
            VisualField::paper(),
            VisualField::with_options(EyeModel::RightEye, BoundaryShape::PaperEq7),
            VisualField::with_options(EyeModel::LeftEye, BoundaryShape::TrueEllipse),
        ] {
            for k in 0..50 {
                let s = 0.02 + k as f64 * 0.04; // 0.02 .. 1.98
                let pairs = [
                    (DVec3::new(1.0, eps, s), DVec3::new(1.0, -eps, s)),
                    (DVec3::new(1.0, s, eps), DVec3::new(1.0, s, -eps)),
                    (DVec3::new(1.0, -s, eps), DVec3::new(1.0, -s, -eps)),
                    (DVec3::new(eps, 1.0, s), DVec3::new(-eps, 1.0, s)),
                    (DVec3::new(-1.0, eps, s), DVec3::new(-1.0, -eps, s)),
                ];
                for (a, b) in pairs {
                    let (la, lb) = (field.level_local(a), field.level_local(b));
                    assert!((la - lb).abs() < 1e-7, "{field:?} {a} {b}: {la} vs {lb}");
                }
            }
        }
    }

    #[test]
    fn central_and_boundary_edges_are_continuous() {
        let f = VisualField::paper();
        for k in 0..72 {
            let phi = k as f64 * 5.0 * DEG;
            let (c, s) = (phi.cos(), phi.sin());
            let at = |l: f64| {
                f.level_of_angles(FieldAngles {
                    m_alpha: (l * c).abs(),
                    m_beta: l * s,
                })
            };
            let big_l = f.boundary(FieldAngles {
                m_alpha: c.abs(),
                m_beta: s,
            });
            let d = 1e-10;
            assert!((at(CENTRAL_RADIUS - d) - at(CENTRAL_RADIUS + d)).abs() < 1e-8);
            // At L eq. 8 is 0 by construction; what can fail is the linear
            // fall reaching it: d/(L − π/6) just inside, 0 just outside.
            let inside = 1e-6;
            assert!((at(big_l - inside) - inside / (big_l - CENTRAL_RADIUS)).abs() < 1e-12);
            assert!(at(big_l + d) == 0.0 && at(big_l) < 1e-12);
        }
    }

    #[test]
    fn boundary_and_level_are_continuous_across_the_angle_axes() {
        // REFERENCE.md: "the boundary must be continuous across the axes".
        // b switches 60°/70° at m_β = 0 (φ = 0°, 180°); a switches ear/nose at
        // m_α = 0 for the per-eye models (φ = ±90°). |∂level/∂φ| ≤ |L′|/(L − π/6)
        // ≤ 0.92 per rad and |L′| ≤ 1 rad per rad for these angles, so a
        // step of 2ε may change either by at most 2ε; a switched semi-axis in a
        // term that does not vanish there would change them by ~0.1.
        let eps = 1e-7;
        for eye in [EyeModel::Paper, EyeModel::LeftEye, EyeModel::RightEye] {
            for shape in [BoundaryShape::PaperEq7, BoundaryShape::TrueEllipse] {
                let f = VisualField::with_options(eye, shape);
                for axis in [0.0, 90.0, 180.0, 270.0] {
                    for l_deg in [31.0, 45.0, 59.0, 69.0, 80.0, 89.0] {
                        let l = l_deg * DEG;
                        // The angles eq. 4–5 give: unsigned m_α for the paper's model.
                        let angles = |phi: f64| {
                            let ma = l * phi.cos();
                            FieldAngles {
                                m_alpha: if eye == EyeModel::Paper { ma.abs() } else { ma },
                                m_beta: l * phi.sin(),
                            }
                        };
                        let (a, b) = (angles(axis * DEG - eps), angles(axis * DEG + eps));
                        let dl = (f.boundary(a) - f.boundary(b)).abs();
                        let dv = (f.level_of_angles(a) - f.level_of_angles(b)).abs();
                        assert!(dl <= 2.0 * eps && dv <= 2.0 * eps, "{eye:?} {shape:?} φ {axis}° l {l_deg}°: ΔL {dl}, Δlevel {dv}");
                    }
                }
            }
        }
    }

    #[test]
    fn from_rotation_matches_new() {
        let q = DQuat::from_rotation_y(0.4) * DQuat::from_rotation_x(-0.2);
        let a = GazeFrame::from_rotation(DVec3::ONE, q).unwrap();
        let b = GazeFrame::new(DVec3::ONE, q * DVec3::NEG_Z, q * DVec3::Y).unwrap();
        assert!((a.forward - b.forward).length() < 1e-12);
        assert!((a.right - b.right).length() < 1e-12);
        assert!((a.up - b.up).length() < 1e-12);
        let d = DVec3::new(0.3, -0.5, 0.8);
        assert!((a.to_world(a.to_local(d)) - d).length() < 1e-12);
    }

    #[test]
    fn validate_rejects_impossible_fields() {
        assert!(VisualField::paper().validate().is_ok());
        let mut f = VisualField::paper();
        f.upper = 0.4; // below the 30° central radius
        assert!(matches!(f.validate(), Err(FoveatedError::InvalidField(_))));
        f = VisualField::paper();
        f.central = f64::NAN;
        assert!(matches!(f.validate(), Err(FoveatedError::NonFinite(_))));
        // The nose extent only matters for the per-eye models.
        f = VisualField::paper();
        f.nose = 0.1;
        assert!(f.validate().is_ok());
        f.eye = EyeModel::LeftEye;
        assert!(f.validate().is_err());
    }

    #[test]
    fn invalid_field_gives_full_quality_not_background() {
        // A NaN central radius used to make every direction level 0 (background).
        let mut bad = Vec::new();
        for (name, set) in [
            ("central NaN", (|f: &mut VisualField| f.central = f64::NAN) as fn(&mut VisualField)),
            ("central 0", |f| f.central = 0.0),
            ("upper below central", |f| f.upper = 0.4),
            ("lower NaN", |f| f.lower = f64::NAN),
            ("ear > π", |f| f.ear = 4.0),
            ("ear ∞", |f| f.ear = f64::INFINITY),
        ] {
            let mut f = VisualField::paper();
            set(&mut f);
            assert!(f.validate().is_err() && !f.is_valid(), "{name}");
            bad.push((name, f));
        }
        let mut right_nose_bad = VisualField::with_options(EyeModel::RightEye, BoundaryShape::PaperEq7);
        right_nose_bad.nose = f64::NAN;
        bad.push(("per-eye nose NaN", right_nose_bad));
        let frame = GazeFrame::new(DVec3::ZERO, DVec3::NEG_Z, DVec3::Y).unwrap();
        for (name, f) in bad {
            for d in [DVec3::X, dir_ab(45.0, 10.0), dir_ab(0.0, -65.0), DVec3::NEG_X, DVec3::Y] {
                assert_eq!(f.level_local(d), 1.0, "{name}: {d}");
            }
            assert_eq!(f.level(&frame, DVec3::new(0.3, -0.2, -1.0)), 1.0, "{name}");
            let far = FieldAngles { m_alpha: 2.0, m_beta: 0.5 };
            assert_eq!((f.level_of_angles(far), f.region(far)), (1.0, FieldRegion::Central), "{name}");
        }
        // is_valid agrees with validate: the paper model ignores the nose
        // extent's range (not its finiteness).
        let mut p = VisualField::paper();
        p.nose = 0.1;
        assert!(p.is_valid() && p.validate().is_ok());
        p.nose = f64::NAN;
        assert!(!p.is_valid() && p.validate().is_err());
        for eye in [EyeModel::Paper, EyeModel::LeftEye, EyeModel::RightEye] {
            let f = VisualField::with_options(eye, BoundaryShape::TrueEllipse);
            assert!(f.is_valid() && f.validate().is_ok());
        }
    }

    fn unit(v: DVec3) -> DVec3 {
        v.normalize()
    }

    proptest! {
        #[test]
        fn level_is_finite_and_in_range(x in -1e6f64..1e6, y in -1e6f64..1e6, z in -1e6f64..1e6,
                                        eye in 0usize..3, shape in 0usize..2) {
            let eye = [EyeModel::Paper, EyeModel::LeftEye, EyeModel::RightEye][eye];
            let shape = [BoundaryShape::PaperEq7, BoundaryShape::TrueEllipse][shape];
            let f = VisualField::with_options(eye, shape);
            let v = f.level_local(DVec3::new(x, y, z));
            prop_assert!(v.is_finite() && (0.0..=1.0).contains(&v));
        }

        /// Numerical continuity: away from the documented ear-side singular
        /// directions ±E_r (|d_f|, |d_u| both small), a perturbation of 1e-7
        /// rad moves the level by a bounded amount. The bound: dlevel/dl ≤
        /// 1/(60° − 30°) ≈ 1.9 /rad, the angle map's gain ≤ 1/√(d_f² + d_u²) ≤
        /// 1/0.05 and L's slope adds about as much; 1e-4 is far above that.
        #[test]
        fn level_is_continuous_off_the_singular_directions(
            x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0,
            px in -1.0f64..1.0, py in -1.0f64..1.0, pz in -1.0f64..1.0,
            eye in 0usize..3, shape in 0usize..2,
        ) {
            let d = DVec3::new(x, y, z);
            prop_assume!(d.length() > 0.1);
            let d = unit(d);
            prop_assume!(d.x.hypot(d.z) > 0.05);
            let p = DVec3::new(px, py, pz);
            prop_assume!(p.length() > 0.1);
            let e = unit(d + p.normalize() * 1e-7);
            let eye = [EyeModel::Paper, EyeModel::LeftEye, EyeModel::RightEye][eye];
            let shape = [BoundaryShape::PaperEq7, BoundaryShape::TrueEllipse][shape];
            let f = VisualField::with_options(eye, shape);
            prop_assert!((f.level_local(d) - f.level_local(e)).abs() < 1e-4);
        }

        /// Levels fall monotonically along any ray of the (α, β) plane.
        #[test]
        fn level_falls_with_eccentricity(phi in -1.57f64..1.57, l1 in 0.0f64..3.0, l2 in 0.0f64..3.0) {
            let f = VisualField::paper();
            let (lo, hi) = if l1 < l2 { (l1, l2) } else { (l2, l1) };
            let at = |l: f64| f.level_of_angles(FieldAngles { m_alpha: l * phi.cos(), m_beta: l * phi.sin() });
            prop_assert!(at(lo) >= at(hi));
        }
    }
}
