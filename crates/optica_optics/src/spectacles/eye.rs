//! The eye model in dioptres (documented on [`Eye`]).

use glam::{DMat2, DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::input::{self, Expected, InvalidInput};

/// Accommodation amplitude (D) of an age group by Hofstetter's formulas
/// (H. W. Hofstetter, "Useful age-amplitude formula", *Optometry World* 38,
/// 42–45, 1950).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum HofstetterBound {
    /// Minimum expected amplitude: `15 − 0.25·age`.
    Min,
    /// Mean amplitude: `18.5 − 0.3·age`.
    Mean,
    /// Maximum expected amplitude: `25 − 0.4·age`.
    Max,
}

/// Accommodation amplitude in dioptres at `age_years` by Hofstetter (1950):
/// mean `18.5 − 0.3·age`, min `15 − 0.25·age`, max `25 − 0.4·age`,
/// clamped at 0 (the formulas go negative past ~60 years).
///
/// Errors: a non-finite or negative age.
pub fn hofstetter_amplitude_d(age_years: f64, bound: HofstetterBound) -> Result<f64, InvalidInput> {
    let age = input::non_negative("age (years)", age_years)?;
    let amp = match bound {
        HofstetterBound::Min => 15.0 - 0.25 * age,
        HofstetterBound::Mean => 18.5 - 0.3 * age,
        HofstetterBound::Max => 25.0 - 0.4 * age,
    };
    Ok(amp.max(0.0))
}

/// Reference age `y0` (years) of Watson & Yellott's age term: the mean age
/// of Stanley & Davies' observers (Watson & Yellott 2012).
pub const WATSON_YELLOTT_REFERENCE_AGE: f64 = 28.58;
/// Ages (years) over which Watson & Yellott fitted the age term, the range
/// of the data of B. Winn, D. Whitaker, D. B. Elliott and N. J. Phillips,
/// "Factors affecting light-adapted pupil size in normal human subjects",
/// *Investigative Ophthalmology & Visual Science* 35(3), 1994;
/// [`pupil_diameter_watson_yellott_mm`] clamps the age to it.
pub const WATSON_YELLOTT_AGE_RANGE: (f64, f64) = (20.0, 83.0);

/// Pupil diameter (mm) by P. A. Stanley and A. K. Davies, "The effect of
/// field of view size on steady-state pupil diameter", *Ophthalmic and
/// Physiological Optics* 15(6), 1995, from the corneal flux density
/// `F = L·a` (cd/m² × deg², finite and >= 0, checked by the caller):
/// `D_SD = 7.75 − 5.75·(F/846)^0.41 / ((F/846)^0.41 + 2)`.
fn pupil_diameter_stanley_davies_mm(flux_cd_m2_deg2: f64) -> f64 {
    let x = (flux_cd_m2_deg2 / 846.0).powf(0.41);
    7.75 - 5.75 * x / (x + 2.0)
}

/// How many eyes the adapting field is seen with, for
/// [`pupil_diameter_watson_yellott_mm`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum AdaptedEyes {
    /// One eye: the flux counts a tenth (`M(1) = 0.1`).
    One,
    /// Both eyes (`M(2) = 1`).
    Both,
}

/// Light-adapted pupil diameter in mm by the unified formula of
/// A. B. Watson and J. I. Yellott, "A unified formula for light-adapted
/// pupil size", *Journal of Vision* 12(10):12, 2012 (their eq. 21), for an
/// adapting luminance `L` (cd/m²) over a circular field of
/// `field_diameter_deg` (area `a = π·(diameter/2)²` deg²), an observer of
/// `age_years` (`y`), with one or both eyes adapted:
///
/// ```text
/// F    = L · a · M(e),  M(1) = 0.1, M(2) = 1       effective corneal flux density
/// D_SD = 7.75 − 5.75·(F/846)^0.41 / ((F/846)^0.41 + 2)   (Stanley & Davies 1995)
/// D_U  = D_SD + (y − y0)·(0.02132 − 0.009562·D_SD),  y0 = 28.58
/// ```
///
/// Documented policy: the age is clamped to 20–83 years, the range of the
/// data the age term was fitted to ([`WATSON_YELLOTT_AGE_RANGE`]).
/// Errors: a non-finite or negative luminance or age, a non-finite or
/// non-positive field.
pub fn pupil_diameter_watson_yellott_mm(
    luminance_cd_m2: f64,
    field_diameter_deg: f64,
    age_years: f64,
    eyes: AdaptedEyes,
) -> Result<f64, InvalidInput> {
    let l = input::non_negative("adapting luminance (cd/m²)", luminance_cd_m2)?;
    let field = input::positive("adapting field diameter (deg)", field_diameter_deg)?;
    let age = input::non_negative("age (years)", age_years)?;
    let monocular = match eyes {
        AdaptedEyes::One => 0.1,
        AdaptedEyes::Both => 1.0,
    };
    let area = std::f64::consts::PI * (0.5 * field).powi(2);
    let d_sd = pupil_diameter_stanley_davies_mm(l * area * monocular);
    let y = age.clamp(WATSON_YELLOTT_AGE_RANGE.0, WATSON_YELLOTT_AGE_RANGE.1);
    Ok(d_sd + (y - WATSON_YELLOTT_REFERENCE_AGE) * (0.02132 - 0.009562 * d_sd))
}

/// Largest |refractive error| accepted (D). Beyond ±30 D the thin-eye model
/// and any spectacle correction are meaningless (spectacle lenses stop at
/// about ±20 D, [`MAX_LENS_POWER_D`](super::MAX_LENS_POWER_D)).
pub const MAX_REFRACTIVE_ERROR_D: f64 = 30.0;

/// Largest accommodation amplitude accepted (D): above Hofstetter's maximum
/// expected amplitude at any age (25 D at birth, [`HofstetterBound::Max`]).
pub const MAX_ACCOMMODATION_D: f64 = 30.0;

/// Largest pupil diameter accepted (m): 50 mm, the default lens blank's
/// diameter. Real pupils are 2–8 mm (Watson & Yellott 2012) and the paper
/// renders with 12 mm to exaggerate the blur; a pupil wider than the lens
/// cannot look through it.
pub const MAX_PUPIL_DIAMETER_M: f64 = 0.05;

/// The eye's focusing range and pupil, in dioptres and metres.
///
/// Everything is a vergence (dioptres, 1/m) measured from the entrance pupil:
/// an object at distance `z` (m, in front of the eye) has `V = 1/z`, an object
/// at infinity `V = 0`. With refractive error `R` (D; myopia `R < 0`) and
/// accommodation amplitude `Amp` (D):
///
/// ```text
/// P_far  = −R                     far point vergence (far point 1/P_far)
/// P_near = P_far + Amp            near point vergence
/// ΔD     = max(0, P_far − V) + max(0, V − P_near)     defocus (D)
/// β      = A·ΔD                   blur angle (rad), A the pupil diameter (m)
/// d      = A·z·ΔD                 object-space blur disc diameter (m)
/// ```
///
/// The disc `d` is the paper's eq. (1) `D_n = A z_n / n` for an object `z_n`
/// inside the near point `n`, and eq. (2) `D_f = A z_f / f` for one `z_f`
/// beyond the far point `f` (test `eye_disc_equals_paper_eq_1_and_2`). Unlike
/// eqs. (1)–(2) nothing divides by `n` or `f`, so an emmetrope (`f = ∞`),
/// `Amp = 0` (near point = far point) and a hyperope (`P_far < 0`, far point a
/// virtual point behind the eye) need no special case.
///
/// Astigmatism ([`Eye::with_astigmatism`]): the refractive error is a
/// prescription, sphere `R` in the axis meridian and `R + C` across it
/// (`R(θ) = R + C·sin²(θ − axis)`, the axis in the eye's frame from +x
/// towards +y, the optometric convention of the `spectacles` module docs):
/// the eye's error is the power of the spectacle lens that corrects it at
/// the cornea. Across a line of sight with frame `(e₁, e₂)` the error is the
/// symmetric matrix `R·I + C·(I − c cᵀ)` (its traceless part is [`Eye::astigmatic_matrix`]), `c` the
/// axis projected into the frame, and the eye accommodates to the circle of
/// least confusion: the scalar vergences above are the spherical
/// equivalent's (`R + C/2`), and what is left in focus is the astigmatic
/// part, a disc of diameter `A·s·|C|/2` at distance `s`
/// ([`naked_eye_displacements`](super::naked_eye_displacements)).
///
/// Built by the checked constructors ([`Eye::new`], [`Eye::from_age`],
/// [`Eye::from_near_far`], [`Eye::with_astigmatism`]); deserialisation runs
/// the same checks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawEye")]
pub struct Eye {
    refractive_error_d: f64,
    accommodation_d: f64,
    pupil_diameter_m: f64,
    cylinder_d: f64,
    axis_deg: f64,
}

/// The serialised form of an [`Eye`], unchecked.
#[derive(Deserialize)]
struct RawEye {
    refractive_error_d: f64,
    accommodation_d: f64,
    pupil_diameter_m: f64,
    #[serde(default)]
    cylinder_d: f64,
    #[serde(default)]
    axis_deg: f64,
}

impl TryFrom<RawEye> for Eye {
    type Error = InvalidInput;

    fn try_from(r: RawEye) -> Result<Self, InvalidInput> {
        Eye::new(r.refractive_error_d, r.accommodation_d, r.pupil_diameter_m)?
            .with_astigmatism(r.cylinder_d, r.axis_deg)
    }
}

/// Largest |cylinder| of an eye accepted (D): corneal astigmatism beyond
/// ~6 D is keratoconus territory, and spectacle cylinders stop near there.
pub const MAX_EYE_CYLINDER_D: f64 = 10.0;

impl Eye {
    /// An eye from its refractive error `R` (D; negative for myopia,
    /// positive for hyperopia, 0 for an emmetrope), accommodation amplitude
    /// `Amp` (D) and pupil diameter `A` (m; the paper uses 0.012).
    ///
    /// Errors: non-finite numbers, `|R|` above [`MAX_REFRACTIVE_ERROR_D`],
    /// `Amp` outside `0..=`[`MAX_ACCOMMODATION_D`], `A` outside
    /// `0..=`[`MAX_PUPIL_DIAMETER_M`].
    pub fn new(
        refractive_error_d: f64,
        accommodation_d: f64,
        pupil_diameter_m: f64,
    ) -> Result<Self, InvalidInput> {
        let r = MAX_REFRACTIVE_ERROR_D;
        Ok(Self {
            refractive_error_d: input::in_range("refractive error (D)", refractive_error_d, -r, r)?,
            accommodation_d: input::in_range(
                "accommodation amplitude (D)",
                accommodation_d,
                0.0,
                MAX_ACCOMMODATION_D,
            )?,
            pupil_diameter_m: input::in_range(
                "pupil diameter (m)",
                pupil_diameter_m,
                0.0,
                MAX_PUPIL_DIAMETER_M,
            )?,
            cylinder_d: 0.0,
            axis_deg: 0.0,
        })
    }

    /// The same eye with astigmatism: cylinder `C` (D, either sign, the
    /// power added across the axis) at `axis_deg` (degrees, the optometric
    /// convention; any finite angle, taken modulo 180). The refractive error
    /// stays the sphere, the error in the axis meridian. An eye
    /// "−1.00 / −2.00 × 90" is `Eye::new(-1.0, ..)?.with_astigmatism(-2.0, 90.0)`:
    /// −1 D vertically, −3 D horizontally, and the lens of that prescription
    /// corrects it.
    ///
    /// Errors: a non-finite axis, `|C|` above [`MAX_EYE_CYLINDER_D`].
    pub fn with_astigmatism(self, cylinder_d: f64, axis_deg: f64) -> Result<Self, InvalidInput> {
        let c = MAX_EYE_CYLINDER_D;
        Ok(Self {
            cylinder_d: input::in_range("eye cylinder (D)", cylinder_d, -c, c)?,
            axis_deg: input::finite("eye cylinder axis (deg)", axis_deg)?.rem_euclid(180.0),
            ..self
        })
    }

    /// Cylinder `C` (D); 0 for a stigmatic eye.
    pub fn cylinder_d(&self) -> f64 {
        self.cylinder_d
    }

    /// Cylinder axis (degrees, `0..180`).
    pub fn axis_deg(&self) -> f64 {
        self.axis_deg
    }

    /// Spherical equivalent `R + C/2` (D): the error the eye's scalar
    /// vergences use (the circle of least confusion).
    pub fn spherical_equivalent_d(&self) -> f64 {
        self.refractive_error_d + 0.5 * self.cylinder_d
    }

    /// The cylinder axis as a unit direction in the eye's frame.
    pub fn axis_direction(&self) -> DVec3 {
        let a = self.axis_deg.to_radians();
        DVec3::new(a.cos(), a.sin(), 0.0)
    }

    /// The astigmatic part of the error across a line of sight with frame
    /// `(e1, e2)`: the traceless symmetric matrix `C·(I/2 − c cᵀ)` (D), `c`
    /// the axis projected into the frame (`e1` where the sight line runs
    /// along the axis, which no forward sight line does). Zero for a
    /// stigmatic eye. The whole error is `(R + C/2)·I + this`.
    pub fn astigmatic_matrix(&self, e1: DVec3, e2: DVec3) -> DMat2 {
        if self.cylinder_d == 0.0 {
            return DMat2::ZERO;
        }
        let axis = self.axis_direction();
        let c = DVec2::new(axis.dot(e1), axis.dot(e2)).normalize_or(DVec2::X);
        let outer = DMat2::from_cols(c * c.x, c * c.y);
        (DMat2::IDENTITY * 0.5 - outer) * self.cylinder_d
    }

    /// The vergence (D) that the eye, accommodated by `accommodation_d`,
    /// focuses from the pupil across a line of sight with frame `(e1, e2)`,
    /// as a symmetric matrix: `(P_far + a)·I − astigmatic part`. Pupil
    /// offset `r` (in the frame) takes the direction `aim − V·r`.
    pub fn vergence_matrix(&self, e1: DVec3, e2: DVec3, accommodation_d: f64) -> DMat2 {
        DMat2::IDENTITY * (self.far_point_vergence_d() + accommodation_d)
            - self.astigmatic_matrix(e1, e2)
    }

    /// An eye of `age_years` whose amplitude is Hofstetter's `bound`.
    pub fn from_age(
        refractive_error_d: f64,
        age_years: f64,
        bound: HofstetterBound,
        pupil_diameter_m: f64,
    ) -> Result<Self, InvalidInput> {
        Self::new(
            refractive_error_d,
            hofstetter_amplitude_d(age_years, bound)?,
            pupil_diameter_m,
        )
    }

    /// The paper's eye from its near and far point distances (m, from the
    /// pupil; `f64::INFINITY` for an emmetrope's far point) and pupil `A`:
    /// `R = −1/f`, `Amp = 1/n − 1/f`. Fig. 8: emmetrope `n = 0.2, f = 10`;
    /// myope–presbyope `n = 0.5, f = 1.3`; `A = 0.012`.
    ///
    /// Errors: a non-positive or non-finite near point, a far point nearer
    /// than the near point or NaN, and [`Eye::new`]'s ranges.
    pub fn from_near_far(
        near_m: f64,
        far_m: f64,
        pupil_diameter_m: f64,
    ) -> Result<Self, InvalidInput> {
        let near = input::positive("near point (m)", near_m)?;
        if !(far_m >= near) {
            return Err(InvalidInput::new(
                "far point (m)",
                far_m,
                Expected::Range {
                    min: near,
                    max: f64::INFINITY,
                },
            ));
        }
        let p_far = 1.0 / far_m;
        Self::new(-p_far, 1.0 / near - p_far, pupil_diameter_m)
    }

    /// Refractive error `R` (D): negative for myopia, positive for hyperopia.
    pub fn refractive_error_d(&self) -> f64 {
        self.refractive_error_d
    }

    /// Accommodation amplitude `Amp` (D).
    pub fn accommodation_d(&self) -> f64 {
        self.accommodation_d
    }

    /// Pupil diameter `A` (m).
    pub fn pupil_diameter_m(&self) -> f64 {
        self.pupil_diameter_m
    }

    /// Far point vergence `P_far = −R` (D); for an astigmatic eye that of
    /// the spherical equivalent, `−(R + C/2)`.
    pub fn far_point_vergence_d(&self) -> f64 {
        -self.spherical_equivalent_d()
    }

    /// Near point vergence `P_near = P_far + Amp` (D).
    pub fn near_point_vergence_d(&self) -> f64 {
        self.far_point_vergence_d() + self.accommodation_d
    }

    /// Far point distance `1/P_far` (m): `+∞` for an emmetrope, negative for
    /// a hyperope (a virtual point behind the eye).
    pub fn far_point_m(&self) -> f64 {
        distance_of_vergence(self.far_point_vergence_d())
    }

    /// Near point distance `1/P_near` (m), `+∞` or negative like
    /// [`Eye::far_point_m`].
    pub fn near_point_m(&self) -> f64 {
        distance_of_vergence(self.near_point_vergence_d())
    }

    /// Defocus `ΔD = max(0, P_far − V) + max(0, V − P_near)` (D) of an object
    /// of vergence `V` (D): its distance from the interval `[P_far, P_near]`.
    /// Errors: a non-finite `V`.
    pub fn defocus_at_vergence_d(&self, vergence_d: f64) -> Result<f64, InvalidInput> {
        let v = input::finite("object vergence (D)", vergence_d)?;
        Ok(
            (self.far_point_vergence_d() - v).max(0.0)
                + (v - self.near_point_vergence_d()).max(0.0),
        )
    }

    /// Defocus (D) of a point at distance `z_m` (m) in front of the pupil;
    /// `z = +∞` is allowed (`V = 0`). Errors: NaN, zero or negative distance.
    pub fn defocus_d(&self, z_m: f64) -> Result<f64, InvalidInput> {
        self.defocus_at_vergence_d(vergence_of_distance(z_m)?)
    }

    /// Blur angle `β = A·ΔD` (rad) of a point at `z_m`: the angular diameter
    /// of its blur disc as seen from the eye. Finite also at `z = ∞`.
    pub fn blur_angle_rad(&self, z_m: f64) -> Result<f64, InvalidInput> {
        Ok(self.pupil_diameter_m * self.defocus_d(z_m)?)
    }

    /// Object-space blur disc diameter `A·z·ΔD` (m) of a point at finite
    /// `z_m > 0` — the paper's `D_n` (eq. 1) and `D_f` (eq. 2). Errors: a
    /// distance that is not finite and positive (at `z = ∞` the disc is
    /// infinite; use [`Eye::blur_angle_rad`]).
    pub fn blur_disc_diameter_m(&self, z_m: f64) -> Result<f64, InvalidInput> {
        let z = input::positive("distance in front of the pupil (m)", z_m)?;
        Ok(self.pupil_diameter_m * z * self.defocus_d(z)?)
    }
}

/// `1/z` for `z > 0` (0 at `+∞`), else an error.
fn vergence_of_distance(z_m: f64) -> Result<f64, InvalidInput> {
    // `+∞` is accepted (vergence 0), so this is not `input::positive`.
    if !(z_m > 0.0) {
        return Err(InvalidInput::new(
            "distance in front of the pupil (m)",
            z_m,
            Expected::Positive,
        ));
    }
    Ok(1.0 / z_m)
}

/// `1/V`, with `+∞` for `V = 0` (never `−∞`, whatever the sign of zero).
fn distance_of_vergence(v: f64) -> f64 {
    if v == 0.0 { f64::INFINITY } else { 1.0 / v }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn eye_hofstetter_hand_values() {
        // Hofstetter at 40: mean 18.5 − 12 = 6.5, min 15 − 10 = 5, max 25 − 16 = 9.
        assert!((hofstetter_amplitude_d(40.0, HofstetterBound::Mean).unwrap() - 6.5).abs() < 1e-12);
        assert!((hofstetter_amplitude_d(40.0, HofstetterBound::Min).unwrap() - 5.0).abs() < 1e-12);
        assert!((hofstetter_amplitude_d(40.0, HofstetterBound::Max).unwrap() - 9.0).abs() < 1e-12);
        // At 70 all three are negative and clamp to 0.
        for b in [
            HofstetterBound::Min,
            HofstetterBound::Mean,
            HofstetterBound::Max,
        ] {
            assert_eq!(hofstetter_amplitude_d(70.0, b).unwrap(), 0.0);
        }
        let nan = hofstetter_amplitude_d(f64::NAN, HofstetterBound::Mean).unwrap_err();
        assert_eq!(
            (nan.what, nan.expected),
            ("age (years)", Expected::NonNegative)
        );
        assert_eq!(
            hofstetter_amplitude_d(-1.0, HofstetterBound::Mean)
                .unwrap_err()
                .value,
            -1.0
        );
        // The accommodation cap lies above Hofstetter's maximum at birth.
        assert!(hofstetter_amplitude_d(0.0, HofstetterBound::Max).unwrap() < MAX_ACCOMMODATION_D);
    }

    #[test]
    fn eye_watson_yellott_hand_values() {
        // Hand computation of eq. 21: L = 100 cd/m², 60° field (a = 900π deg²),
        // both eyes: F/846 = 334.21, ^0.41 = 10.84, D_SD = 2.89595 mm; at the
        // reference age 28.58 D_U = D_SD; at 50: 2.89595 + 21.42·(0.02132 −
        // 0.009562·2.89595) = 2.75948 mm.
        let wy = |l, f, y, e| pupil_diameter_watson_yellott_mm(l, f, y, e);
        assert!((wy(100.0, 60.0, 28.58, AdaptedEyes::Both).unwrap() - 2.895_952_5).abs() < 1e-6);
        assert!((wy(100.0, 60.0, 50.0, AdaptedEyes::Both).unwrap() - 2.759_483_6).abs() < 1e-6);
        // Age clamped to 20..83: 10 years gives the 20-year value (2.95062).
        assert!((wy(100.0, 60.0, 10.0, AdaptedEyes::Both).unwrap() - 2.950_616_5).abs() < 1e-6);
        // One eye, 1 cd/m², 60 years: F = 0.1·900π, D_SD = 6.35929, D_U = 5.11859 mm.
        assert!((wy(1.0, 60.0, 60.0, AdaptedEyes::One).unwrap() - 5.118_594_8).abs() < 1e-6);
        // Darkness: F = 0 gives Stanley & Davies' maximum, 7.75 mm.
        assert_eq!(pupil_diameter_stanley_davies_mm(0.0), 7.75);
        // Bad input names the quantity.
        assert_eq!(
            wy(f64::NAN, 60.0, 60.0, AdaptedEyes::One).unwrap_err().what,
            "adapting luminance (cd/m²)"
        );
        let field = wy(1.0, 0.0, 60.0, AdaptedEyes::One).unwrap_err();
        assert_eq!(
            (field.what, field.expected),
            ("adapting field diameter (deg)", Expected::Positive)
        );
        assert_eq!(
            wy(1.0, 60.0, -3.0, AdaptedEyes::One).unwrap_err().what,
            "age (years)"
        );
    }

    #[test]
    fn eye_watson_yellott_in_physiological_range() {
        // Real pupils are 2–8 mm (Watson & Yellott 2012): larger in the dark,
        // smaller in bright light.
        let mut prev = f64::INFINITY;
        for k in -4..=4 {
            let d = pupil_diameter_watson_yellott_mm(10f64.powi(k), 60.0, 30.0, AdaptedEyes::Both)
                .unwrap();
            assert!((2.0..=8.0).contains(&d), "{k}: {d}");
            assert!(d < prev);
            prev = d;
        }
    }

    #[test]
    fn eye_far_near_points() {
        // Myope −2 D with 3 D of accommodation: far point 1/|R| = 0.5 m,
        // near point 1/(|R| + Amp) = 1/(2 + 3) = 0.2 m.
        let e = Eye::new(-2.0, 3.0, 0.004).unwrap();
        assert!((e.far_point_m() - 0.5).abs() < 1e-15);
        assert!((e.near_point_m() - 0.2).abs() < 1e-15);
        assert_eq!(
            (
                e.refractive_error_d(),
                e.accommodation_d(),
                e.pupil_diameter_m()
            ),
            (-2.0, 3.0, 0.004)
        );
        // Emmetrope: far point at infinity, no special case.
        let e = Eye::new(0.0, 5.0, 0.004).unwrap();
        assert_eq!(e.far_point_m(), f64::INFINITY);
        assert_eq!(e.defocus_d(f64::INFINITY).unwrap(), 0.0);
        // Hyperope +2 D: virtual far point 0.5 m behind the eye; even
        // infinity is 2 D out of focus when accommodation is exhausted.
        let e = Eye::new(2.0, 0.0, 0.004).unwrap();
        assert!((e.far_point_m() + 0.5).abs() < 1e-15);
        assert!((e.defocus_d(f64::INFINITY).unwrap() - 2.0).abs() < 1e-15);
        // The paper's Fig. 8(b): near 0.5 m, far 1.3 m.
        let e = Eye::from_near_far(0.5, 1.3, 0.012).unwrap();
        assert!((e.near_point_m() - 0.5).abs() < 1e-12 && (e.far_point_m() - 1.3).abs() < 1e-12);
        // Fig. 8(a)'s emmetrope with an infinite far point.
        assert_eq!(
            Eye::from_near_far(0.2, f64::INFINITY, 0.012)
                .unwrap()
                .refractive_error_d(),
            0.0
        );
        let swapped = Eye::from_near_far(1.0, 0.5, 0.01).unwrap_err();
        assert_eq!((swapped.what, swapped.value), ("far point (m)", 0.5));
        assert_eq!(
            Eye::from_near_far(0.0, 1.0, 0.01).unwrap_err().what,
            "near point (m)"
        );
        assert_eq!(
            Eye::new(f64::NAN, 1.0, 0.004).unwrap_err().what,
            "refractive error (D)"
        );
        let r = Eye::new(-40.0, 1.0, 0.004).unwrap_err();
        assert_eq!(
            r.expected,
            Expected::Range {
                min: -30.0,
                max: 30.0
            }
        );
        assert_eq!(
            Eye::new(-1.0, -1.0, 0.004).unwrap_err().what,
            "accommodation amplitude (D)"
        );
        assert_eq!(
            Eye::new(-1.0, 1.0, 0.06).unwrap_err().what,
            "pupil diameter (m)"
        );
    }

    #[test]
    fn eye_deserialisation_is_checked() {
        let e = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let v = serde_json::to_value(e).unwrap();
        assert_eq!(serde_json::from_value::<Eye>(v.clone()).unwrap(), e);
        let mut bad = v;
        bad["pupil_diameter_m"] = serde_json::json!(-0.004);
        assert!(
            serde_json::from_value::<Eye>(bad)
                .unwrap_err()
                .to_string()
                .contains("pupil diameter (m)")
        );
    }

    #[test]
    fn eye_disc_equals_paper_eq_1_and_2() {
        // Paper, Fig. 8(b) eye: n = 0.5 m, f = 1.3 m, A = 0.012 m.
        let (n, f, a) = (0.5, 1.3, 0.012);
        let e = Eye::from_near_far(n, f, a).unwrap();
        // Eq. (1): an object z_n = 0.2 inside the near point: D_n = A z_n / n
        // = 0.012·0.2/0.5 = 4.8 mm.
        let z_n = 0.2;
        let d_n = a * z_n / n;
        assert!((d_n - 0.0048).abs() < 1e-15);
        assert!((e.blur_disc_diameter_m(n - z_n).unwrap() - d_n).abs() < 1e-15);
        // Eq. (2): z_f = 2.6 beyond the far point: D_f = A z_f / f = 0.024 m.
        let z_f = 2.6;
        let d_f = a * z_f / f;
        assert!((e.blur_disc_diameter_m(f + z_f).unwrap() - d_f).abs() < 1e-15);
        // Between near and far: no blur.
        assert_eq!(e.blur_disc_diameter_m(0.8).unwrap(), 0.0);
        // Blur angle = disc / distance = A·ΔD: at 3.9 m, ΔD = 1/1.3 − 1/3.9.
        let beta = e.blur_angle_rad(3.9).unwrap();
        assert!((beta - a * (1.0 / 1.3 - 1.0 / 3.9)).abs() < 1e-15);
        assert!((beta * 3.9 - d_f).abs() < 1e-15);
    }

    #[test]
    fn eye_zero_pupil_and_zero_amplitude() {
        // Zero pupil: a pinhole, no blur anywhere.
        let e = Eye::new(-3.0, 0.0, 0.0).unwrap();
        for z in [0.05, 0.333, 10.0] {
            assert_eq!(e.blur_disc_diameter_m(z).unwrap(), 0.0);
        }
        // Amp = 0: near = far; blur is zero only at that one distance.
        let e = Eye::new(-3.0, 0.0, 0.004).unwrap();
        assert_eq!(e.near_point_m(), e.far_point_m());
        assert_eq!(e.defocus_at_vergence_d(3.0).unwrap(), 0.0);
        assert!((e.defocus_at_vergence_d(2.5).unwrap() - 0.5).abs() < 1e-15);
        assert!((e.defocus_at_vergence_d(3.5).unwrap() - 0.5).abs() < 1e-15);
        for z in [0.0, -1.0, f64::NAN] {
            let err = e.defocus_d(z).unwrap_err();
            assert_eq!(
                (err.what, err.expected),
                ("distance in front of the pupil (m)", Expected::Positive),
                "{z}"
            );
        }
        assert_eq!(
            e.defocus_at_vergence_d(f64::INFINITY).unwrap_err().expected,
            Expected::Finite
        );
        assert_eq!(
            e.blur_disc_diameter_m(f64::INFINITY).unwrap_err().value,
            f64::INFINITY
        );
    }

    proptest! {
        #[test]
        fn eye_finite_in_finite_out(r in -40f64..40.0, amp in -2f64..35.0, a in -0.01f64..0.06, z in -1f64..100.0) {
            match Eye::new(r, amp, a) {
                Ok(e) => {
                    for v in [e.far_point_m(), e.near_point_m()] {
                        prop_assert!(!v.is_nan());
                    }
                    match e.blur_disc_diameter_m(z) {
                        Ok(d) => prop_assert!(d.is_finite() && d >= 0.0),
                        Err(err) => prop_assert!(z <= 0.0 && err.expected == Expected::Positive),
                    }
                }
                Err(_) => prop_assert!(r.abs() > 30.0 || !(0.0..=30.0).contains(&amp) || !(0.0..=0.05).contains(&a)),
            }
        }

        #[test]
        fn eye_blur_monotonic_in_distance_from_focus_range(
            r in -10f64..10.0, amp in 0f64..10.0, a in 0.001f64..0.012,
            v in -20f64..20.0, dv in 0f64..5.0,
        ) {
            // ΔD is the distance of V from [P_far, P_near]: moving V further
            // out on either side never lowers it, and it grows at slope 1.
            let e = Eye::new(r, amp, a).unwrap();
            let (pf, pn) = (e.far_point_vergence_d(), e.near_point_vergence_d());
            let d0 = e.defocus_at_vergence_d(v).unwrap();
            if v >= pn {
                let d1 = e.defocus_at_vergence_d(v + dv).unwrap();
                prop_assert!((d1 - d0 - dv).abs() < 1e-9);
            }
            if v <= pf {
                let d1 = e.defocus_at_vergence_d(v - dv).unwrap();
                prop_assert!((d1 - d0 - dv).abs() < 1e-9);
            }
            if v > pf && v < pn {
                prop_assert_eq!(d0, 0.0);
            }
            let beta = a * d0;
            prop_assert!(beta >= 0.0 && beta.is_finite());
        }
    }
}
