//! The eye model in dioptres: far and near point, accommodation by age
//! (Hofstetter), pupil size by luminance and age (Watson & Yellott 2012), and
//! the defocus blur of a point.
//!
//! Everything is a vergence (dioptres, 1/m) measured from the entrance pupil:
//! an object at distance `z` (m, in front of the eye) has `V = 1/z`, an object
//! at infinity `V = 0`. With refractive error `R` (D; myopia `R < 0`) and
//! accommodation amplitude `Amp` (D):
//!
//! ```text
//! P_far  = −R                     far point vergence (far point 1/P_far)
//! P_near = P_far + Amp            near point vergence
//! ΔD     = max(0, P_far − V) + max(0, V − P_near)     defocus (D)
//! β      = A·ΔD                   blur angle (rad), A the pupil diameter (m)
//! d      = A·z·ΔD                 object-space blur disc diameter (m)
//! ```
//!
//! The disc `d` is the paper's eq. (1) `D_n = A z_n / n` for an object `z_n`
//! inside the near point `n`, and eq. (2) `D_f = A z_f / f` for one `z_f`
//! beyond the far point `f` (test `eye_disc_equals_paper_eq_1_and_2`). Unlike
//! eqs. (1)–(2) nothing divides by `n` or `f`, so an emmetrope (`f = ∞`),
//! `Amp = 0` (near point = far point) and a hyperope (`P_far < 0`, far point a
//! virtual point behind the eye) need no special case.

use serde::{Deserialize, Serialize};

use super::error::SpectaclesError;

/// Accommodation amplitude (D) of an age group by Hofstetter's formulas.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum HofstetterBound {
    /// Minimum expected amplitude: `15 − 0.25·age`.
    Min,
    /// Mean amplitude: `18.5 − 0.3·age`.
    Mean,
    /// Maximum expected amplitude: `25 − 0.4·age`.
    Max,
}

/// Accommodation amplitude in dioptres at `age_years` by Hofstetter
/// (mean `18.5 − 0.3·age`, min `15 − 0.25·age`, max `25 − 0.4·age`),
/// clamped at 0 (the formulas go negative past ~60 years).
///
/// Errors: a non-finite or negative age.
pub fn hofstetter_amplitude_d(age_years: f64, bound: HofstetterBound) -> Result<f64, SpectaclesError> {
    if !age_years.is_finite() {
        return Err(SpectaclesError::NonFinite("age"));
    }
    if age_years < 0.0 {
        return Err(SpectaclesError::OutOfRange { what: "age (years)", value: age_years, min: 0.0, max: f64::INFINITY });
    }
    let amp = match bound {
        HofstetterBound::Min => 15.0 - 0.25 * age_years,
        HofstetterBound::Mean => 18.5 - 0.3 * age_years,
        HofstetterBound::Max => 25.0 - 0.4 * age_years,
    };
    Ok(amp.max(0.0))
}

/// Reference age `y0` of Watson & Yellott's age term (the mean age of
/// Stanley & Davies' observers).
pub const WATSON_YELLOTT_REFERENCE_AGE: f64 = 28.58;
/// Ages (years) over which Watson & Yellott fitted the age term (the data of
/// Winn et al. 1994); [`pupil_diameter_watson_yellott_mm`] clamps to it.
pub const WATSON_YELLOTT_AGE_RANGE: (f64, f64) = (20.0, 83.0);

/// Pupil diameter (mm) by Stanley & Davies (1995) from the corneal flux
/// density `F = L·a` (cd/m² × deg²):
/// `D_SD = 7.75 − 5.75·(F/846)^0.41 / ((F/846)^0.41 + 2)`.
///
/// Errors: a non-finite or negative flux.
pub fn pupil_diameter_stanley_davies_mm(flux_cd_m2_deg2: f64) -> Result<f64, SpectaclesError> {
    if !flux_cd_m2_deg2.is_finite() {
        return Err(SpectaclesError::NonFinite("corneal flux density"));
    }
    if flux_cd_m2_deg2 < 0.0 {
        return Err(SpectaclesError::OutOfRange {
            what: "corneal flux density (cd/m²·deg²)",
            value: flux_cd_m2_deg2,
            min: 0.0,
            max: f64::INFINITY,
        });
    }
    let x = (flux_cd_m2_deg2 / 846.0).powf(0.41);
    Ok(7.75 - 5.75 * x / (x + 2.0))
}

/// What the pupil is adapted to, for [`pupil_diameter_watson_yellott_mm`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PupilConditions {
    /// Adapting luminance `L` in cd/m².
    pub luminance_cd_m2: f64,
    /// Diameter of the (circular, fixated) adapting field in degrees; the
    /// formula takes its area `a = π·(diameter/2)²` deg².
    pub field_diameter_deg: f64,
    /// Observer's age `y` in years.
    pub age_years: f64,
    /// Number of adapted eyes `e` (1 or 2).
    pub eyes: u8,
}

/// Light-adapted pupil diameter in mm by the unified formula of
/// A. B. Watson and J. I. Yellott, "A unified formula for light-adapted
/// pupil size", *Journal of Vision* 12(10):12, 2012 (their eq. 21):
///
/// ```text
/// F    = L · a · M(e),  M(1) = 0.1, M(2) = 1       effective corneal flux density
/// D_SD = 7.75 − 5.75·(F/846)^0.41 / ((F/846)^0.41 + 2)   (Stanley & Davies 1995)
/// D_U  = D_SD + (y − y0)·(0.02132 − 0.009562·D_SD),  y0 = 28.58
/// ```
///
/// Documented policy: the age is clamped to 20–83 years, the range of the
/// data the age term was fitted to ([`WATSON_YELLOTT_AGE_RANGE`]).
/// Errors: non-finite inputs, negative luminance, a non-positive field,
/// `eyes` other than 1 or 2, a negative age.
pub fn pupil_diameter_watson_yellott_mm(c: &PupilConditions) -> Result<f64, SpectaclesError> {
    for (v, name) in [
        (c.luminance_cd_m2, "luminance"),
        (c.field_diameter_deg, "field diameter"),
        (c.age_years, "age"),
    ] {
        if !v.is_finite() {
            return Err(SpectaclesError::NonFinite(name));
        }
    }
    if c.luminance_cd_m2 < 0.0 {
        return Err(SpectaclesError::OutOfRange { what: "luminance (cd/m²)", value: c.luminance_cd_m2, min: 0.0, max: f64::INFINITY });
    }
    if !(c.field_diameter_deg > 0.0) {
        return Err(SpectaclesError::OutOfRange { what: "field diameter (deg)", value: c.field_diameter_deg, min: f64::MIN_POSITIVE, max: f64::INFINITY });
    }
    if c.age_years < 0.0 {
        return Err(SpectaclesError::OutOfRange { what: "age (years)", value: c.age_years, min: 0.0, max: f64::INFINITY });
    }
    let monocular = match c.eyes {
        1 => 0.1,
        2 => 1.0,
        e => return Err(SpectaclesError::OutOfRange { what: "adapted eyes", value: e as f64, min: 1.0, max: 2.0 }),
    };
    let area = std::f64::consts::PI * (0.5 * c.field_diameter_deg).powi(2);
    let d_sd = pupil_diameter_stanley_davies_mm(c.luminance_cd_m2 * area * monocular)?;
    let y = c.age_years.clamp(WATSON_YELLOTT_AGE_RANGE.0, WATSON_YELLOTT_AGE_RANGE.1);
    Ok(d_sd + (y - WATSON_YELLOTT_REFERENCE_AGE) * (0.02132 - 0.009562 * d_sd))
}

/// The eye's focusing range and pupil, in dioptres and metres.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Eye {
    /// Refractive error `R` in dioptres: negative for myopia, positive for
    /// hyperopia, 0 for an emmetrope.
    pub refractive_error_d: f64,
    /// Accommodation amplitude `Amp` in dioptres (>= 0).
    pub accommodation_d: f64,
    /// Pupil diameter `A` in metres (>= 0; the paper uses 0.012, real pupils
    /// are 0.002–0.008).
    pub pupil_diameter_m: f64,
}

/// Largest |refractive error| accepted (D). Beyond ±30 D the thin-eye model
/// and any spectacle correction are meaningless.
pub const MAX_REFRACTIVE_ERROR_D: f64 = 30.0;

impl Eye {
    /// An eye from its refractive error `R` (D), accommodation amplitude (D)
    /// and pupil diameter (m).
    ///
    /// Errors: non-finite numbers, `|R| > 30 D`, negative amplitude or pupil.
    pub fn new(refractive_error_d: f64, accommodation_d: f64, pupil_diameter_m: f64) -> Result<Self, SpectaclesError> {
        for (v, name) in [
            (refractive_error_d, "refractive error"),
            (accommodation_d, "accommodation amplitude"),
            (pupil_diameter_m, "pupil diameter"),
        ] {
            if !v.is_finite() {
                return Err(SpectaclesError::NonFinite(name));
            }
        }
        if refractive_error_d.abs() > MAX_REFRACTIVE_ERROR_D {
            return Err(SpectaclesError::OutOfRange {
                what: "refractive error (D)",
                value: refractive_error_d,
                min: -MAX_REFRACTIVE_ERROR_D,
                max: MAX_REFRACTIVE_ERROR_D,
            });
        }
        if accommodation_d < 0.0 {
            return Err(SpectaclesError::OutOfRange { what: "accommodation amplitude (D)", value: accommodation_d, min: 0.0, max: f64::INFINITY });
        }
        if pupil_diameter_m < 0.0 {
            return Err(SpectaclesError::OutOfRange { what: "pupil diameter (m)", value: pupil_diameter_m, min: 0.0, max: f64::INFINITY });
        }
        Ok(Self { refractive_error_d, accommodation_d, pupil_diameter_m })
    }

    /// An eye of `age_years` whose amplitude is Hofstetter's `bound`.
    pub fn from_age(refractive_error_d: f64, age_years: f64, bound: HofstetterBound, pupil_diameter_m: f64) -> Result<Self, SpectaclesError> {
        Self::new(refractive_error_d, hofstetter_amplitude_d(age_years, bound)?, pupil_diameter_m)
    }

    /// The paper's eye from its near and far point distances (m, from the
    /// pupil; `f64::INFINITY` for an emmetrope's far point) and pupil `A`:
    /// `R = −1/f`, `Amp = 1/n − 1/f`. Fig. 8: emmetrope `n = 0.2, f = 10`;
    /// myope–presbyope `n = 0.5, f = 1.3`; `A = 0.012`.
    ///
    /// Errors: non-positive or NaN distances, `n > f`.
    pub fn from_near_far(near_m: f64, far_m: f64, pupil_diameter_m: f64) -> Result<Self, SpectaclesError> {
        if near_m.is_nan() || far_m.is_nan() {
            return Err(SpectaclesError::NonFinite("near or far point"));
        }
        if !(near_m > 0.0 && far_m >= near_m) {
            return Err(SpectaclesError::OutOfRange { what: "near point (m), must be > 0 and <= far point", value: near_m, min: f64::MIN_POSITIVE, max: far_m });
        }
        let p_far = 1.0 / far_m;
        Self::new(-p_far, 1.0 / near_m - p_far, pupil_diameter_m)
    }

    /// Far point vergence `P_far = −R` (D).
    pub fn far_point_vergence_d(&self) -> f64 {
        -self.refractive_error_d
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
    /// A non-finite `V` is a typed error.
    pub fn defocus_at_vergence_d(&self, vergence_d: f64) -> Result<f64, SpectaclesError> {
        if !vergence_d.is_finite() {
            return Err(SpectaclesError::NonFinite("vergence"));
        }
        Ok((self.far_point_vergence_d() - vergence_d).max(0.0) + (vergence_d - self.near_point_vergence_d()).max(0.0))
    }

    /// Defocus (D) of a point at distance `z_m` (m) in front of the pupil;
    /// `z = +∞` is allowed (`V = 0`). Errors: NaN, zero or negative distance.
    pub fn defocus_d(&self, z_m: f64) -> Result<f64, SpectaclesError> {
        self.defocus_at_vergence_d(vergence_of_distance(z_m)?)
    }

    /// Blur angle `β = A·ΔD` (rad) of a point at `z_m`: the angular diameter
    /// of its blur disc as seen from the eye. Finite also at `z = ∞`.
    pub fn blur_angle_rad(&self, z_m: f64) -> Result<f64, SpectaclesError> {
        Ok(self.pupil_diameter_m * self.defocus_d(z_m)?)
    }

    /// Object-space blur disc diameter `A·z·ΔD` (m) of a point at finite
    /// `z_m > 0` — the paper's `D_n` (eq. 1) and `D_f` (eq. 2). Errors as
    /// [`Eye::defocus_d`], plus an infinite distance (the disc is infinite).
    pub fn blur_disc_diameter_m(&self, z_m: f64) -> Result<f64, SpectaclesError> {
        if !z_m.is_finite() {
            return Err(SpectaclesError::NonFinite("distance"));
        }
        Ok(self.pupil_diameter_m * z_m * self.defocus_d(z_m)?)
    }
}

/// `1/z` for `z > 0` (0 at `+∞`), else a typed error.
pub fn vergence_of_distance(z_m: f64) -> Result<f64, SpectaclesError> {
    if z_m.is_nan() {
        return Err(SpectaclesError::NonFinite("distance"));
    }
    if !(z_m > 0.0) {
        return Err(SpectaclesError::OutOfRange { what: "distance in front of the eye (m)", value: z_m, min: f64::MIN_POSITIVE, max: f64::INFINITY });
    }
    Ok(1.0 / z_m)
}

/// `1/V`, with `+∞` for `V = 0` (never `−∞`, whatever the sign of zero).
pub fn distance_of_vergence(v: f64) -> f64 {
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
        for b in [HofstetterBound::Min, HofstetterBound::Mean, HofstetterBound::Max] {
            assert_eq!(hofstetter_amplitude_d(70.0, b).unwrap(), 0.0);
        }
        assert!(hofstetter_amplitude_d(f64::NAN, HofstetterBound::Mean).is_err());
        assert!(hofstetter_amplitude_d(-1.0, HofstetterBound::Mean).is_err());
    }

    #[test]
    fn eye_watson_yellott_hand_values() {
        // Hand computation of eq. 21: L = 100 cd/m², 60° field (a = 900π deg²),
        // both eyes: F/846 = 334.21, ^0.41 = 10.84, D_SD = 2.89595 mm; at the
        // reference age 28.58 D_U = D_SD; at 50: 2.89595 + 21.42·(0.02132 −
        // 0.009562·2.89595) = 2.75948 mm.
        let mut c = PupilConditions { luminance_cd_m2: 100.0, field_diameter_deg: 60.0, age_years: 28.58, eyes: 2 };
        assert!((pupil_diameter_watson_yellott_mm(&c).unwrap() - 2.895_952_5).abs() < 1e-6);
        c.age_years = 50.0;
        assert!((pupil_diameter_watson_yellott_mm(&c).unwrap() - 2.759_483_6).abs() < 1e-6);
        // Age clamped to 20..83: 10 years gives the 20-year value (2.95062).
        c.age_years = 10.0;
        assert!((pupil_diameter_watson_yellott_mm(&c).unwrap() - 2.950_616_5).abs() < 1e-6);
        // One eye, 1 cd/m², 60 years: F = 0.1·900π, D_SD = 6.35929, D_U = 5.11859 mm.
        let mono = PupilConditions { luminance_cd_m2: 1.0, field_diameter_deg: 60.0, age_years: 60.0, eyes: 1 };
        assert!((pupil_diameter_watson_yellott_mm(&mono).unwrap() - 5.118_594_8).abs() < 1e-6);
        // Darkness: F = 0 gives Stanley & Davies' maximum, 7.75 mm.
        assert_eq!(pupil_diameter_stanley_davies_mm(0.0).unwrap(), 7.75);
        // Bad input is typed.
        assert!(pupil_diameter_watson_yellott_mm(&PupilConditions { eyes: 3, ..mono }).is_err());
        assert!(pupil_diameter_watson_yellott_mm(&PupilConditions { luminance_cd_m2: f64::NAN, ..mono }).is_err());
        assert!(pupil_diameter_watson_yellott_mm(&PupilConditions { field_diameter_deg: 0.0, ..mono }).is_err());
    }

    #[test]
    fn eye_watson_yellott_in_physiological_range() {
        // REFERENCE.md: real pupils are 2–8 mm; larger in the dark, smaller
        // when older (at photopic levels the age slope is negative).
        let mut prev = f64::INFINITY;
        for k in -4..=4 {
            let c = PupilConditions { luminance_cd_m2: 10f64.powi(k), field_diameter_deg: 60.0, age_years: 30.0, eyes: 2 };
            let d = pupil_diameter_watson_yellott_mm(&c).unwrap();
            assert!((2.0..=8.0).contains(&d), "{k}: {d}");
            assert!(d < prev);
            prev = d;
        }
    }

    #[test]
    fn eye_far_near_points() {
        // Myope −2 D with 3 D of accommodation: far point 0.5 m, near point
        // 1/(2 + 3) = 0.2 m (REFERENCE.md: far 1/|R|, near 1/(|R| + Amp)).
        let e = Eye::new(-2.0, 3.0, 0.004).unwrap();
        assert!((e.far_point_m() - 0.5).abs() < 1e-15);
        assert!((e.near_point_m() - 0.2).abs() < 1e-15);
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
        assert!(Eye::from_near_far(1.0, 0.5, 0.01).is_err());
        assert!(Eye::new(f64::NAN, 1.0, 0.004).is_err());
        assert!(Eye::new(-40.0, 1.0, 0.004).is_err());
        assert!(Eye::new(-1.0, -1.0, 0.004).is_err());
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
        assert!(e.defocus_d(0.0).is_err() && e.defocus_d(-1.0).is_err() && e.defocus_d(f64::NAN).is_err());
        assert!(e.blur_disc_diameter_m(f64::INFINITY).is_err());
    }

    proptest! {
        #[test]
        fn eye_finite_in_finite_out(r in -40f64..40.0, amp in -2f64..15.0, a in -0.01f64..0.02, z in -1f64..100.0) {
            match Eye::new(r, amp, a) {
                Ok(e) => {
                    for v in [e.far_point_m(), e.near_point_m()] {
                        prop_assert!(!v.is_nan());
                    }
                    match e.blur_disc_diameter_m(z) {
                        Ok(d) => prop_assert!(d.is_finite() && d >= 0.0),
                        Err(_) => prop_assert!(z <= 0.0),
                    }
                }
                Err(_) => prop_assert!(r.abs() > 30.0 || amp < 0.0 || a < 0.0),
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
