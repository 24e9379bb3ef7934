//! The visual-field level function of eq. 1–8 (documented on [`VisualField`]).

use std::f64::consts::PI;

use glam::{DQuat, DVec3, DVec4};
use serde::{Deserialize, Serialize};

use super::error::FoveatedError;
use crate::input::{self, Expected, InvalidInput};

/// Smallest sine of the angle between a gaze and its up hint that
/// [`GazeFrame::new`] accepts. Below it the cross product E_f × up is of the
/// order of its own rounding error (a few 1e-16 per component), so E_r would
/// point in a direction set by rounding; 1e-9 (a 0.2-milliarcsecond angle)
/// leaves that error a millionth of E_r while refusing only up hints that are
/// parallel to the gaze for every practical purpose.
const MIN_GAZE_UP_SINE: f64 = 1e-9;

/// The operator's gaze frame of eq. 1–3: eye position V and the orthonormal
/// axes E_f (gaze), E_r (right of the gaze) and E_u (up of the gaze), world
/// coordinates in metres. Built by [`GazeFrame::new`] or
/// [`GazeFrame::from_rotation`], so the axes are always unit and orthogonal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GazeFrame {
    eye: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
}

impl GazeFrame {
    /// A right-handed gaze frame from an eye position (m), a gaze direction
    /// and an up hint, neither of which need be unit: E_f = gaze/|gaze|,
    /// E_r = E_f × up_hint normalised, E_u = E_r × E_f.
    ///
    /// Errors: [`FoveatedError::Input`] for a non-finite eye, or a gaze or up
    /// hint that is zero or not finite; [`FoveatedError::DegenerateDirection`]
    /// for an up hint parallel to the gaze (the roll would be undefined, and
    /// the field is not roll invariant because up and down differ). Use
    /// [`GazeFrame::from_rotation`] for a tracker that reports an orientation.
    pub fn new(eye: DVec3, gaze: DVec3, up_hint: DVec3) -> Result<Self, FoveatedError> {
        let eye = input::finite_vec3("eye position (m)", eye)?;
        let forward = input::direction("gaze direction", gaze)?;
        let up_hint = input::direction("gaze up hint", up_hint)?;
        let right = forward.cross(up_hint);
        if right.length() < MIN_GAZE_UP_SINE {
            return Err(FoveatedError::DegenerateDirection(
                "up hint parallel to the gaze",
            ));
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

    /// A gaze frame from an eye position (m) and a head or eye orientation in
    /// Bevy's convention: the gaze is the rotated −Z, right the rotated +X, up
    /// the rotated +Y. The quaternion need not be unit; it is normalised.
    ///
    /// Errors: [`FoveatedError::Input`] for a non-finite eye or quaternion, or
    /// a quaternion too short to normalise.
    pub fn from_rotation(eye: DVec3, rotation: DQuat) -> Result<Self, FoveatedError> {
        const WHAT: &str = "eye rotation (quaternion)";
        let eye = input::finite_vec3("eye position (m)", eye)?;
        let q = DVec4::from(rotation);
        if let Some(bad) = q.to_array().into_iter().find(|c| !c.is_finite()) {
            return Err(InvalidInput::new(WHAT, bad, Expected::FiniteVector).into());
        }
        let q = q
            .try_normalize()
            .map(DQuat::from_vec4)
            .ok_or(InvalidInput::new(WHAT, q.length(), Expected::Direction))?;
        Ok(Self {
            eye,
            forward: q * DVec3::NEG_Z,
            right: q * DVec3::X,
            up: q * DVec3::Y,
        })
    }

    /// Eye position V (world, m).
    #[inline]
    pub fn eye(&self) -> DVec3 {
        self.eye
    }

    /// E_f, the unit gaze direction.
    #[inline]
    pub fn forward(&self) -> DVec3 {
        self.forward
    }

    /// E_r, unit, to the right of the gaze.
    #[inline]
    pub fn right(&self) -> DVec3 {
        self.right
    }

    /// E_u, unit, up from the gaze (E_u = E_r × E_f).
    #[inline]
    pub fn up(&self) -> DVec3 {
        self.up
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

/// The two angles of the paper's fig. 2 between the gaze and a ray, in
/// radians. Plain data: any values are accepted, and the level of non-finite
/// angles is 1 (see [`VisualField::level_of_angles`]).
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
    /// l ≤ central radius (π/6 in the paper): central field, level 1.
    Central,
    /// central < l ≤ L: peripheral field, level falls linearly.
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

/// The angular extents of a visual field, in radians from the gaze: plain
/// data, checked when a [`VisualField`] is built from it.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FieldExtents {
    /// Radius of the central field, where the level is 1.
    pub central: f64,
    /// Ear-side (temporal) extent.
    pub ear: f64,
    /// Nose-side (nasal) extent; only the per-eye models use it.
    pub nose: f64,
    /// Upper extent.
    pub upper: f64,
    /// Lower extent.
    pub lower: f64,
}

impl FieldExtents {
    /// The paper's field: central radius π/6 (30°), the threshold of eq. 8;
    /// ear side 5π/9 (100°), nose side π/3 (60°), up π/3 (60°), down 7π/18
    /// (70°), the extents of §2 (the Japanese average the paper takes from
    /// Mitsuhashi, Hatada and Yano, *Image and Visual Information Science*,
    /// Corona Publishing, 2009), of which eq. 7 uses the ear side, up and down.
    ///
    /// Clinical perimetry gives nearly the same field: central vision is the
    /// inner 30°, and the peripheral field extends 100° laterally (to the ear
    /// side), 60° medially (to the nose), 60° up and 75° down (R. H. Spector,
    /// "Visual Fields", ch. 116 of Walker, Hall and Hurst (eds.), *Clinical
    /// Methods*, 3rd ed., Butterworths, 1990).
    pub const PAPER: Self = Self {
        central: PI / 6.0,
        ear: 5.0 * PI / 9.0,
        nose: PI / 3.0,
        upper: PI / 3.0,
        lower: 7.0 * PI / 18.0,
    };
}

/// The visual field and its level function: eq. 4–8 of Mochizuki and Makino.
///
/// A ray direction in the gaze frame (eq. 1–3, [`GazeFrame::to_local`]) is
/// turned into the two angles (m_α, m_β) of the paper's fig. 2 (eq. 4–5,
/// [`VisualField::angles`]); its level is 1 inside the central field
/// (l ≤ π/6), falls linearly to 0 at the peripheral boundary L (eq. 6–8,
/// [`VisualField::level_of_angles`]), and is 0 beyond. The linear fall is
/// the paper's choice (eq. 8), not a measured acuity curve.
///
/// Built by [`VisualField::paper`], [`VisualField::with_options`] (the
/// paper's extents) or [`VisualField::new`] (checked extents), so the level
/// functions trust it and check nothing per ray.
///
/// # Angles by atan2
///
/// The paper writes eq. 4–5 as `acos` of a normalised component. `acos` of a
/// rounded ratio slightly above 1 is NaN, and its slope is infinite at 0 and
/// π, so here the same angles are computed as
///
/// * eq. 4: m_α = acos(d_f / √(d_f² + d_r²)) = atan2(|d_r|, d_f) ∈ [0, π],
/// * eq. 5: m_β = ±acos|d_f / √(d_f² + d_u²)| (sign of d_u) = atan2(d_u, |d_f|) ∈ [−π/2, π/2],
///
/// which are identical where the paper's forms are defined and finite for
/// every finite direction, including a gaze behind the head (m_α → π).
///
/// # Where the paper's angles are singular
///
/// m_α is undefined at d_f = d_r = 0 (straight up or down) and m_β at
/// d_f = d_u = 0 (straight right or left). Here atan2(0, 0) = 0 is used. Up
/// and down are harmless: l ≥ π/2 > L there, so the level is 0 in a whole
/// neighbourhood. Right/left on the ear side are a genuine discontinuity of
/// the paper's level function: near ±E_r, m_α ≈ π/2 while m_β takes any
/// value in [−π/2, π/2] depending on the approach, so the level jumps between
/// 0 and (100° − 90°)/(100° − 30°) = 1/7 (the value returned exactly at
/// ±E_r). It is a property of the paper's parametrisation, deep in the
/// periphery where the level is at most 1/7. Everywhere else the level is
/// continuous.
///
/// # The boundary (eq. 7) and its options
///
/// Eq. 7 is, with φ the polar angle of (m_α, m_β), L(φ) = √(a²cos²φ + b²sin²φ),
/// with a = 5π/9 (100°, ear side) and b = π/3 (60°) above, 7π/18 (70°) below
/// (the extents of [`FieldExtents::PAPER`]). It is not an ellipse (an
/// ellipse has 1/L² = cos²φ/a² + sin²φ/b²), and because m_α is unsigned the
/// nose side (π/3 in the paper's §2) never enters it. Both are kept as the
/// default ([`EyeModel::Paper`], [`BoundaryShape::PaperEq7`]);
/// [`EyeModel::LeftEye`]/[`EyeModel::RightEye`] (signed m_α, ear and nose
/// sides swapped between the eyes) and [`BoundaryShape::TrueEllipse`] are
/// opt-in.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct VisualField {
    extents: FieldExtents,
    eye: EyeModel,
    boundary: BoundaryShape,
}

impl Default for VisualField {
    fn default() -> Self {
        Self::paper()
    }
}

impl VisualField {
    /// The paper's field ([`FieldExtents::PAPER`]), unsigned m_α, eq. 7 boundary.
    pub const fn paper() -> Self {
        Self::with_options(EyeModel::Paper, BoundaryShape::PaperEq7)
    }

    /// The paper's extents with an explicit eye model and boundary shape.
    pub const fn with_options(eye: EyeModel, boundary: BoundaryShape) -> Self {
        Self {
            extents: FieldExtents::PAPER,
            eye,
            boundary,
        }
    }

    /// A field with its own extents. The central radius must lie in (0, π],
    /// and each outer extent (ear, nose, up, down) in [central, π], so that
    /// eq. 8's fall runs outwards from the central field.
    ///
    /// Errors: [`FoveatedError::Input`] naming the first extent out of range.
    pub fn new(
        extents: FieldExtents,
        eye: EyeModel,
        boundary: BoundaryShape,
    ) -> Result<Self, FoveatedError> {
        let central = input::positive("central field radius (rad)", extents.central)?;
        input::in_range("central field radius (rad)", central, 0.0, PI)?;
        for (what, v) in [
            ("ear-side field extent (rad)", extents.ear),
            ("nose-side field extent (rad)", extents.nose),
            ("upper field extent (rad)", extents.upper),
            ("lower field extent (rad)", extents.lower),
        ] {
            input::in_range(what, v, central, PI)?;
        }
        Ok(Self {
            extents,
            eye,
            boundary,
        })
    }

    /// The extents, in radians.
    pub fn extents(&self) -> FieldExtents {
        self.extents
    }

    /// The horizontal angle convention.
    pub fn eye_model(&self) -> EyeModel {
        self.eye
    }

    /// The boundary shape.
    pub fn boundary_shape(&self) -> BoundaryShape {
        self.boundary
    }

    /// Eq. 4–5 (atan2 forms, see the type's docs) for a direction in the gaze
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
        let e = &self.extents;
        match self.eye {
            EyeModel::Paper => e.ear,
            EyeModel::RightEye if m_alpha >= 0.0 => e.ear,
            EyeModel::LeftEye if m_alpha <= 0.0 => e.ear,
            EyeModel::RightEye | EyeModel::LeftEye => e.nose,
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
        let b = if mb >= 0.0 {
            self.extents.upper
        } else {
            self.extents.lower
        };
        let l2 = ma * ma + mb * mb;
        if l2 == 0.0 {
            return a;
        }
        match self.boundary {
            // Eq. 7 literally: √((a² m_α² + b² m_β²) / (m_α² + m_β²)).
            BoundaryShape::PaperEq7 => ((a * a * ma * ma + b * b * mb * mb) / l2).sqrt(),
            BoundaryShape::TrueEllipse => {
                a * b * l2.sqrt() / (b * b * ma * ma + a * a * mb * mb).sqrt()
            }
        }
    }

    /// The region of eq. 8 for given angles; [`FieldRegion::Central`] (full
    /// quality) for non-finite angles, like [`VisualField::level_of_angles`].
    pub fn region(&self, angles: FieldAngles) -> FieldRegion {
        let l = angles.eccentricity();
        if !l.is_finite() || l <= self.extents.central {
            FieldRegion::Central
        } else if l <= self.boundary(angles) {
            FieldRegion::Peripheral
        } else {
            FieldRegion::Outside
        }
    }

    /// Eq. 6 and 8: the level in [0, 1] for given angles.
    ///
    /// Documented fallback (when unsure, full quality): non-finite angles give 1.
    pub fn level_of_angles(&self, angles: FieldAngles) -> f64 {
        let l = angles.eccentricity();
        let central = self.extents.central;
        if !l.is_finite() || l <= central {
            return 1.0;
        }
        let big_l = self.boundary(angles);
        if l > big_l {
            return 0.0;
        }
        // central < l ≤ L here, so the denominator is positive.
        ((big_l - l) / (big_l - central)).clamp(0.0, 1.0)
    }

    /// The level of a direction given in the gaze frame, (d_f, d_r, d_u); it
    /// need not be unit.
    ///
    /// Documented fallback: a zero or non-finite direction has no angles and
    /// gives 1 (full quality).
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
    const P: FieldExtents = FieldExtents::PAPER;

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
            let b = if phi >= 0.0 { P.upper } else { P.lower };
            let polar = (P.ear.powi(2) * phi.cos().powi(2) + b * b * phi.sin().powi(2)).sqrt();
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
        for &(a, b) in &[
            (10.0, 5.0),
            (50.0, -20.0),
            (70.0, 30.0),
            (-80.0, 10.0),
            (35.0, 35.0),
        ] {
            let d = dir_ab(a, b);
            let m = DVec3::new(d.x, -d.y, d.z);
            assert!((l.level_local(d) - r.level_local(m)).abs() < 1e-15);
        }
        // On the ear side the per-eye model equals the paper's.
        let p = VisualField::paper();
        assert!(
            (r.level_local(dir_ab(55.0, 20.0)) - p.level_local(dir_ab(55.0, 20.0))).abs() < 1e-15
        );
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
        // Angles are plain data: non-finite ones are full quality, central.
        let nan = FieldAngles {
            m_alpha: f64::NAN,
            m_beta: 0.3,
        };
        assert_eq!(
            (f.level_of_angles(nan), f.region(nan)),
            (1.0, FieldRegion::Central)
        );
        let inf = FieldAngles {
            m_alpha: 0.1,
            m_beta: f64::NEG_INFINITY,
        };
        assert_eq!(
            (f.level_of_angles(inf), f.region(inf)),
            (1.0, FieldRegion::Central)
        );
        // The gaze frame itself refuses such input (see
        // `gaze_frame_input_errors_name_the_input`); these are directions
        // handed to the level function directly.
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
            assert!((at(P.central - d) - at(P.central + d)).abs() < 1e-8);
            // At L eq. 8 is 0 by construction; what can fail is the linear
            // fall reaching it: d/(L − π/6) just inside, 0 just outside.
            let inside = 1e-6;
            assert!((at(big_l - inside) - inside / (big_l - P.central)).abs() < 1e-12);
            assert!(at(big_l + d) == 0.0 && at(big_l) < 1e-12);
        }
    }

    #[test]
    fn boundary_and_level_are_continuous_across_the_angle_axes() {
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
                        assert!(
                            dl <= 2.0 * eps && dv <= 2.0 * eps,
                            "{eye:?} {shape:?} φ {axis}° l {l_deg}°: ΔL {dl}, Δlevel {dv}"
                        );
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
        assert!((a.forward() - b.forward()).length() < 1e-12);
        assert!((a.right() - b.right()).length() < 1e-12);
        assert!((a.up() - b.up()).length() < 1e-12);
        // A quaternion of any length is normalised; a zero or NaN one is refused.
        let c = GazeFrame::from_rotation(DVec3::ONE, q * 3.0).unwrap();
        assert!((c.forward() - a.forward()).length() < 1e-12);
        let zero =
            GazeFrame::from_rotation(DVec3::ONE, DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0)).unwrap_err();
        assert!(
            matches!(zero, FoveatedError::Input(e) if e.expected == Expected::Direction && e.value == 0.0)
        );
        let nan = GazeFrame::from_rotation(DVec3::ONE, DQuat::from_xyzw(0.0, f64::NAN, 0.0, 1.0))
            .unwrap_err();
        assert!(
            matches!(nan, FoveatedError::Input(e) if e.expected == Expected::FiniteVector && e.value.is_nan())
        );
        let d = DVec3::new(0.3, -0.5, 0.8);
        assert!((a.to_world(a.to_local(d)) - d).length() < 1e-12);
    }

    #[test]
    fn new_rejects_impossible_fields_naming_the_extent() {
        let ok = |e: FieldExtents| VisualField::new(e, EyeModel::Paper, BoundaryShape::PaperEq7);
        assert_eq!(ok(P).unwrap(), VisualField::paper());
        let range = |what: &'static str, value: f64, min: f64| {
            FoveatedError::Input(InvalidInput::new(
                what,
                value,
                Expected::Range { min, max: PI },
            ))
        };
        // An outer extent inside the 30° central radius.
        assert_eq!(
            ok(FieldExtents { upper: 0.4, ..P }),
            Err(range("upper field extent (rad)", 0.4, P.central))
        );
        assert_eq!(
            ok(FieldExtents { ear: 4.0, ..P }),
            Err(range("ear-side field extent (rad)", 4.0, P.central))
        );
        assert_eq!(
            ok(FieldExtents { nose: 0.1, ..P }),
            Err(range("nose-side field extent (rad)", 0.1, P.central))
        );
        let lower = ok(FieldExtents {
            lower: f64::INFINITY,
            ..P
        })
        .unwrap_err();
        assert_eq!(
            lower,
            range("lower field extent (rad)", f64::INFINITY, P.central)
        );
        // The central radius: positive, then at most π.
        let positive = |value| {
            FoveatedError::Input(InvalidInput::new(
                "central field radius (rad)",
                value,
                Expected::Positive,
            ))
        };
        assert_eq!(ok(FieldExtents { central: 0.0, ..P }), Err(positive(0.0)));
        assert!(matches!(ok(FieldExtents { central: f64::NAN, ..P }),
            Err(FoveatedError::Input(e)) if e.expected == Expected::Positive && e.value.is_nan()));
        assert_eq!(
            ok(FieldExtents { central: 4.0, ..P }),
            Err(range("central field radius (rad)", 4.0, 0.0))
        );
        // An extent equal to the central radius is a step, not a ramp: legal,
        // and the level stays in [0, 1] across it.
        let step = ok(FieldExtents {
            upper: P.central,
            ..P
        })
        .unwrap();
        assert_eq!(step.level_local(dir_ab(0.0, 29.0)), 1.0);
        assert_eq!(step.level_local(dir_ab(0.0, 31.0)), 0.0);
        // Accessors give back what was built.
        let f = VisualField::new(P, EyeModel::LeftEye, BoundaryShape::TrueEllipse).unwrap();
        assert_eq!(
            (f.extents(), f.eye_model(), f.boundary_shape()),
            (P, EyeModel::LeftEye, BoundaryShape::TrueEllipse)
        );
    }

    #[test]
    fn gaze_frame_input_errors_name_the_input() {
        let e = GazeFrame::new(DVec3::new(0.0, f64::NAN, 0.0), DVec3::NEG_Z, DVec3::Y).unwrap_err();
        assert!(matches!(e, FoveatedError::Input(i) if i.what == "eye position (m)"));
        let e = GazeFrame::new(DVec3::ZERO, DVec3::ZERO, DVec3::Y).unwrap_err();
        assert_eq!(
            e,
            FoveatedError::Input(InvalidInput::new(
                "gaze direction",
                0.0,
                Expected::Direction
            ))
        );
        let e = GazeFrame::new(DVec3::ZERO, DVec3::NEG_Z, DVec3::ZERO).unwrap_err();
        assert_eq!(
            e,
            FoveatedError::Input(InvalidInput::new("gaze up hint", 0.0, Expected::Direction))
        );
        assert_eq!(
            GazeFrame::new(DVec3::ZERO, DVec3::Y * 2.0, DVec3::Y),
            Err(FoveatedError::DegenerateDirection(
                "up hint parallel to the gaze"
            ))
        );
        // A gaze of any length is normalised; the frame is orthonormal.
        let f = GazeFrame::new(
            DVec3::ONE,
            DVec3::new(0.0, 0.0, -5.0),
            DVec3::new(0.0, 3.0, 1.0),
        )
        .unwrap();
        assert_eq!(
            (f.eye(), f.forward(), f.right()),
            (DVec3::ONE, DVec3::NEG_Z, DVec3::X)
        );
        assert!((f.up() - DVec3::Y).length() < 1e-15);
    }

    #[test]
    fn ear_side_of_a_rotated_gaze_stays_within_the_documented_jump() {
        // In a rotated frame the world ray E_r has rounding-size d_f and d_u,
        // so m_β is arbitrary there (the singularity of the type's docs): the
        // level may be anything in [0, 1/7], and must be finite.
        let f = VisualField::paper();
        for k in 0..50 {
            let (yaw, pitch) = (0.13 * k as f64, 0.05 * k as f64 - 1.2);
            let gaze = DVec3::new(
                yaw.sin() * pitch.cos(),
                pitch.sin(),
                -yaw.cos() * pitch.cos(),
            );
            let g = GazeFrame::new(DVec3::ZERO, gaze, DVec3::Y).unwrap();
            for d in [g.right(), -g.right()] {
                let l = f.level(&g, d);
                assert!(
                    l.is_finite() && (0.0..=1.0 / 7.0 + 1e-12).contains(&l),
                    "{gaze}: {l}"
                );
            }
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
