//! Fresnel reflectance of a bare interface (cos form) and of an interface
//! carrying one thin anti-reflection layer (exact single-layer thin film).
//!
//! Everything here is unpolarised (mean of s and p) and lossless (real
//! indices). A lens path's throughput ([`crate::lens::trace`]) multiplies
//! these per-interface means, as Hullin et al.'s blog does; that is an
//! approximation — the exact unpolarised value averages the s and p
//! *products* — low by 13 % for two reflections at 30° on n = 1.5
//! (`R̄² = 1.72e-3` against `½(R_s² + R_p²) = 1.99e-3`; see
//! [`crate::lens`], "Real-ray tracing and ghost paths"). [`try_fresnel_sp`] gives the separate
//! s and p values for an exact per-polarisation product. Angles enter as the cosine of the angle of incidence in the first
//! medium; the sign of `cos_i` is ignored, so a dot product with a normal
//! facing either way can be passed directly.
//!
//! The cos form is used because the sin/tan form (`−sin(i−t)/sin(i+t)`,
//! `tan(i−t)/tan(i+t)`) is 0/0 at normal incidence.
//!
//! ## Why not the formula of the 2011 lens-flare supplement
//! Hullin et al.'s supplement (and most open lens-flare code copied from it)
//! adds the outer reflection `r01` and one inner reflection `t01·t01·r12`, with
//! the transmission coefficient of the *first* interface squared. The wave
//! that comes back out crosses the interface in the other direction, so the
//! product must be `t01·t10 = 1 − r01²`, and the infinite series of internal
//! reflections gives the Airy denominator. With both, per polarisation,
//!
//! `R = (r01² + r12² + 2 r01 r12 cos 2δ) / (1 + r01² r12² + 2 r01 r12 cos 2δ)`,
//! `δ = 2π n_c d cos θ_c / λ`
//!
//! (Born & Wolf, *Principles of Optics*, §1.6.4; Macleod, *Thin-Film Optical
//! Filters*, ch. 2). The supplement's version overestimates reflectance: it
//! gives 0.043 % instead of 0 for an ideal quarter-wave layer on n = 1.52,
//! and 1.58 % instead of 1.26 % for MgF₂ on that glass, at normal incidence
//! (see the test `coating_supplement_formula_overestimates`).
//!
//! We evaluate the same quantity in the characteristic-matrix form with
//! optical admittances (`η_s = n cos θ`, `η_p = cos θ / n`), which equals the
//! formula above where the film wave propagates and stays exact and smooth
//! where it is evanescent (frustrated total internal reflection in the
//! coating, `n1 sin θ > n_c`), including at the coating's critical angle where
//! the `r01, r12` form is 0/0.

use serde::Serialize;

use crate::input::{self, Expected, InvalidInput};

fn check_index(n: f64) -> Result<f64, InvalidInput> {
    input::positive("refractive index", n)
}

/// `cos²` of the refraction angle from `n1` into `n2`, negative beyond the
/// critical angle. Written as `((n2 − n1)(n2 + n1) + n1² cos² i) / n2²`
/// rather than `1 − (n1/n2)² sin² i`: the latter cancels at grazing
/// incidence between similar indices; this one only where it must (near the
/// critical angle, where the problem itself is ill-conditioned).
pub fn cos_sq_refracted(cos_i: f64, n1: f64, n2: f64) -> f64 {
    ((n2 - n1) * (n2 + n1) + n1 * n1 * cos_i * cos_i) / (n2 * n2)
}

/// How far past 1 a cosine may be and still count as 1: the dot product of
/// two unit `f64` vectors can exceed 1 by a few ulps (~1e-16); 1e-9 allows
/// for vectors normalised a few operations earlier, and is far below any
/// angle that matters optically (1e-9 in the cosine is ~4.5e-5 rad at 0°).
const COSINE_ROUNDOFF: f64 = 1e-9;

fn check_cos(cos_i: f64) -> Result<f64, InvalidInput> {
    let c = cos_i.abs();
    if c <= 1.0 + COSINE_ROUNDOFF {
        Ok(c.min(1.0))
    } else {
        Err(InvalidInput::new(
            "cosine of incidence",
            cos_i,
            Expected::Range {
                min: -1.0,
                max: 1.0,
            },
        ))
    }
}

/// Power reflectances `(R_s, R_p)` of a bare interface from `n1` into `n2` at
/// incidence cosine `cos_i`; `None` on total internal reflection.
///
/// `r_s = (n1 cos i − n2 cos t)/(n1 cos i + n2 cos t)`,
/// `r_p = (n2 cos i − n1 cos t)/(n2 cos i + n1 cos t)` (Hecht, *Optics*, eq. 4.42/4.43).
pub fn try_fresnel_sp(cos_i: f64, n1: f64, n2: f64) -> Result<Option<(f64, f64)>, InvalidInput> {
    let cos_i = check_cos(cos_i)?;
    let n1 = check_index(n1)?;
    let n2 = check_index(n2)?;
    if n1 == n2 {
        return Ok(Some((0.0, 0.0)));
    }
    let cos2_t = cos_sq_refracted(cos_i, n1, n2);
    if cos2_t < 0.0 {
        return Ok(None);
    }
    if cos_i == 0.0 {
        // Grazing incidence on a real interface: the limit is total reflection
        // (and the quotients below would be 0/0 when cos t = 0 too).
        return Ok(Some((1.0, 1.0)));
    }
    let cos_t = cos2_t.sqrt();
    let rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
    let rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
    Ok(Some((rs * rs, rp * rp)))
}

/// Unpolarised Fresnel reflectance `(R_s + R_p)/2` of a bare interface from
/// `n1` into `n2` at incidence cosine `cos_i` (sign ignored); 1 on total
/// internal reflection.
pub fn try_fresnel_unpolarized(cos_i: f64, n1: f64, n2: f64) -> Result<f64, InvalidInput> {
    Ok(match try_fresnel_sp(cos_i, n1, n2)? {
        Some((rs, rp)) => 0.5 * (rs + rp),
        None => 1.0,
    })
}

/// Unpolarised Fresnel reflectance; 1 on total internal reflection.
///
/// Documented fallback: invalid input (NaN, non-positive index, `|cos_i| > 1`)
/// returns 1.0 — all light reflected, none transmitted, no NaN. Use
/// [`try_fresnel_unpolarized`] for a typed error.
pub fn fresnel_unpolarized(cos_i: f64, n1: f64, n2: f64) -> f64 {
    try_fresnel_unpolarized(cos_i, n1, n2).unwrap_or(1.0)
}

/// A single homogeneous thin-film layer on an interface (an anti-reflection
/// coating): its index and physical thickness, checked when it is built.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Coating {
    index: f64,
    thickness_nm: f64,
}

/// Above this evanescent decay exponent the tunnelling through the layer is
/// below e^−80 ≈ 1e−35 and is dropped, which keeps cosh/sinh from overflowing.
const MAX_EVANESCENT_EXPONENT: f64 = 40.0;

/// `(cos δ, sin δ / δ)` for a phase given by its square `δ²`, which is
/// negative for an evanescent layer (then `δ = i y` and the pair is
/// `(cosh y, sinh y / y)`), so both cases stay in real arithmetic.
fn cos_and_sinc(phase_sq: f64) -> (f64, f64) {
    if phase_sq >= 0.0 {
        let x = phase_sq.sqrt();
        let sinc = if x < 1e-4 {
            1.0 - x * x / 6.0
        } else {
            x.sin() / x
        };
        (x.cos(), sinc)
    } else {
        let y = (-phase_sq).sqrt().min(MAX_EVANESCENT_EXPONENT);
        let sinhc = if y < 1e-4 {
            1.0 + y * y / 6.0
        } else {
            y.sinh() / y
        };
        (y.cosh(), sinhc)
    }
}

/// Reflectance of one polarisation of a single layer, characteristic-matrix
/// form (Macleod ch. 2): `[B, C] = [[cos δ, i sin δ/η1], [i η1 sin δ, cos δ]]·[1, η2]`,
/// `r = (η0 B − C)/(η0 B + C)`. With `S = sin δ / η1` (finite as `η1 → 0`) and
/// `η1 sin δ = η1² S`, `B = cos δ + i η2 S`, `C = η2 cos δ + i η1² S`, all of
/// `cos δ, S, η1²` real even for an evanescent layer, so
/// `R = ((η0−η2)² cos²δ + S²(η0η2 − η1²)²) / ((η0+η2)² cos²δ + S²(η0η2 + η1²)²)`.
fn film_reflectance(eta0: f64, eta1_sq: f64, eta2: f64, cos_d: f64, s: f64) -> f64 {
    let a = (eta0 - eta2) * cos_d;
    let b = s * (eta0 * eta2 - eta1_sq);
    let c = (eta0 + eta2) * cos_d;
    let d = s * (eta0 * eta2 + eta1_sq);
    let den = c * c + d * d;
    if den > 0.0 {
        ((a * a + b * b) / den).clamp(0.0, 1.0)
    } else {
        1.0
    }
}

/// Exact unpolarised reflectance of a single layer of index `n_c` and
/// thickness `d_nm` between media `n1` (incident side) and `n2`, at incidence
/// cosine `cos_i` (in `n1`, sign ignored) and vacuum wavelength `wavelength_nm`.
///
/// Returns 1 when `n1 sin i > n2` (no propagating wave in the last medium:
/// lossless total reflection whatever the layer does). A layer of zero
/// thickness gives exactly the bare Fresnel reflectance.
pub fn try_single_layer_reflectance(
    cos_i: f64,
    n1: f64,
    n_c: f64,
    d_nm: f64,
    n2: f64,
    wavelength_nm: f64,
) -> Result<f64, InvalidInput> {
    let cos0 = check_cos(cos_i)?;
    let n1 = check_index(n1)?;
    let n_c = check_index(n_c)?;
    let n2 = check_index(n2)?;
    input::non_negative("coating thickness (nm)", d_nm)?;
    input::positive("wavelength (nm)", wavelength_nm)?;
    // Snell invariant n sin θ, carried through all three media.
    let cos2_sq = cos_sq_refracted(cos0, n1, n2);
    if cos2_sq < 0.0 {
        return Ok(1.0);
    }
    if cos0 == 0.0 {
        // Grazing incidence: total reflection in the limit (admittances 0/0).
        return Ok(if n1 == n2 && n_c == n1 { 0.0 } else { 1.0 });
    }
    let cos2 = cos2_sq.sqrt();
    // cos²θ_c, negative when the coating wave is evanescent.
    let cosc_sq = cos_sq_refracted(cos0, n1, n_c);
    let k = 2.0 * std::f64::consts::PI * d_nm / wavelength_nm;
    // δ² = (2π n_c d cos θ_c / λ)².
    let (cos_d, sinc) = cos_and_sinc(k * k * n_c * n_c * cosc_sq);
    // s: η = n cos θ, so η1² = n_c² cos²θ_c and δ/η1 = 2π d/λ.
    let rs = film_reflectance(n1 * cos0, n_c * n_c * cosc_sq, n2 * cos2, cos_d, k * sinc);
    // p: η = cos θ / n, so η1² = cos²θ_c / n_c² and δ/η1 = 2π n_c² d/λ.
    let rp = film_reflectance(
        cos0 / n1,
        cosc_sq / (n_c * n_c),
        cos2 / n2,
        cos_d,
        k * n_c * n_c * sinc,
    );
    Ok(0.5 * (rs + rp))
}

impl Coating {
    /// A layer of optical thickness λ/4 at `design_wavelength_nm`
    /// (physical thickness `λ / (4 n)`), the classic single-layer AR coating;
    /// ideal (R = 0 at normal incidence) when `index = √(n1 n2)`.
    ///
    /// Errors: an index that is not finite and positive, or a design
    /// wavelength that is not finite and positive.
    pub fn quarter_wave(index: f64, design_wavelength_nm: f64) -> Result<Self, InvalidInput> {
        let index = input::positive("coating index", index)?;
        let wavelength = input::positive("coating design wavelength (nm)", design_wavelength_nm)?;
        Ok(Self {
            index,
            thickness_nm: wavelength / (4.0 * index),
        })
    }

    /// A layer of refractive `index` and physical thickness `thickness_nm`.
    ///
    /// Errors: an index that is not finite and positive, or a thickness that
    /// is negative or not finite (zero thickness is the bare interface).
    pub fn new(index: f64, thickness_nm: f64) -> Result<Self, InvalidInput> {
        let index = input::positive("coating index", index)?;
        let thickness_nm = input::non_negative("coating thickness (nm)", thickness_nm)?;
        Ok(Self {
            index,
            thickness_nm,
        })
    }

    /// Refractive index of the layer (MgF₂ ≈ 1.38).
    pub fn index(&self) -> f64 {
        self.index
    }

    /// Physical thickness of the layer in nm.
    pub fn thickness_nm(&self) -> f64 {
        self.thickness_nm
    }

    /// The index `√(n1 n2)` that makes a quarter-wave layer reflect nothing at
    /// normal incidence at its design wavelength.
    pub fn ideal_index(n1: f64, n2: f64) -> f64 {
        (n1 * n2).sqrt()
    }

    /// Unpolarised reflectance of the coated interface, light arriving from
    /// `n1` (cosine `cos_i`, sign ignored) and leaving into `n2`; the layer is
    /// between them whichever side the light comes from. See
    /// [`try_single_layer_reflectance`].
    pub fn try_reflectance(
        &self,
        cos_i: f64,
        n1: f64,
        n2: f64,
        wavelength_nm: f64,
    ) -> Result<f64, InvalidInput> {
        try_single_layer_reflectance(cos_i, n1, self.index, self.thickness_nm, n2, wavelength_nm)
    }

    /// [`Coating::try_reflectance`] for the tracers' inner loops, whose
    /// indices and wavelengths were checked when the lens was prepared.
    /// Documented fallback, as [`fresnel_unpolarized`]: invalid `cos_i`,
    /// `n1`, `n2` or wavelength give 1.0 (all light reflected). Never NaN.
    pub fn reflectance(&self, cos_i: f64, n1: f64, n2: f64, wavelength_nm: f64) -> f64 {
        self.try_reflectance(cos_i, n1, n2, wavelength_nm)
            .unwrap_or(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use std::f64::consts::PI;

    /// The textbook per-polarisation Airy formula in the `r01, r12` form (Macleod ch. 2), for
    /// a propagating layer; used to check the matrix form against it.
    fn airy_r01_r12(cos0: f64, n0: f64, n1: f64, d: f64, n2: f64, lambda: f64) -> f64 {
        let inv = n0 * (1.0 - cos0 * cos0).sqrt();
        let cos1 = (1.0 - (inv / n1).powi(2)).sqrt();
        let cos2 = (1.0 - (inv / n2).powi(2)).sqrt();
        let delta = 2.0 * PI * n1 * d * cos1 / lambda;
        let r = |a: f64, b: f64| {
            let c2d = (2.0 * delta).cos();
            (a * a + b * b + 2.0 * a * b * c2d) / (1.0 + a * a * b * b + 2.0 * a * b * c2d)
        };
        let rs01 = (n0 * cos0 - n1 * cos1) / (n0 * cos0 + n1 * cos1);
        let rs12 = (n1 * cos1 - n2 * cos2) / (n1 * cos1 + n2 * cos2);
        let rp01 = (n1 * cos0 - n0 * cos1) / (n1 * cos0 + n0 * cos1);
        let rp12 = (n2 * cos1 - n1 * cos2) / (n2 * cos1 + n1 * cos2);
        0.5 * (r(rs01, rs12) + r(rp01, rp12))
    }

    /// Transmittance from the Airy transmission series, written with the
    /// transmission coefficients of each interface (tangential-field
    /// convention, Macleod ch. 2): `t = t01 t12 e^{iδ} / (1 + r01 r12 e^{2iδ})`,
    /// `T = (η2/η0)|t|²`. Independent of the reflection code.
    fn airy_transmittance(cos0: f64, n0: f64, n1: f64, d: f64, n2: f64, lambda: f64) -> f64 {
        let inv = n0 * (1.0 - cos0 * cos0).sqrt();
        let cos1 = (1.0 - (inv / n1).powi(2)).sqrt();
        let cos2 = (1.0 - (inv / n2).powi(2)).sqrt();
        let delta = 2.0 * PI * n1 * d * cos1 / lambda;
        let one = |e0: f64, e1: f64, e2: f64| {
            let r01 = (e0 - e1) / (e0 + e1);
            let r12 = (e1 - e2) / (e1 + e2);
            let t01 = 2.0 * e0 / (e0 + e1);
            let t12 = 2.0 * e1 / (e1 + e2);
            // |1 + r01 r12 e^{2iδ}|²
            let den = 1.0 + (r01 * r12).powi(2) + 2.0 * r01 * r12 * (2.0 * delta).cos();
            (e2 / e0) * (t01 * t12).powi(2) / den
        };
        0.5 * (one(n0 * cos0, n1 * cos1, n2 * cos2) + one(cos0 / n0, cos1 / n1, cos2 / n2))
    }

    #[test]
    fn fresnel_normal_incidence_hand_value() {
        // ((1 − 1.5)/(1 + 1.5))² = 0.04, both ways.
        assert!((fresnel_unpolarized(1.0, 1.0, 1.5) - 0.04).abs() < 1e-15);
        assert!((fresnel_unpolarized(-1.0, 1.5, 1.0) - 0.04).abs() < 1e-15);
        // Brewster angle tan θ_B = 1.5: R_p = 0.
        let cb = (1.0 / (1.0f64 + 2.25).sqrt()).min(1.0);
        let (_, rp) = try_fresnel_sp(cb, 1.0, 1.5).unwrap().unwrap();
        assert!(rp < 1e-30);
        // Beyond the critical angle (glass → air at 60°): 1.
        assert_eq!(fresnel_unpolarized(0.5, 1.5, 1.0), 1.0);
        assert_eq!(fresnel_unpolarized(1.0, f64::NAN, 1.0), 1.0);
        assert!(try_fresnel_unpolarized(1.5, 1.0, 1.5).is_err());
    }

    #[test]
    fn coatings_are_checked_when_built() {
        let c = Coating::quarter_wave(1.38, 550.0).unwrap();
        assert!((c.thickness_nm() - 550.0 / (4.0 * 1.38)).abs() < 1e-12 && c.index() == 1.38);
        let e = Coating::quarter_wave(0.0, 550.0).unwrap_err();
        assert_eq!((e.what, e.expected), ("coating index", Expected::Positive));
        let e = Coating::quarter_wave(1.38, f64::NAN).unwrap_err();
        assert_eq!(e.what, "coating design wavelength (nm)");
        let e = Coating::new(1.38, -1.0).unwrap_err();
        assert_eq!(
            (e.what, e.expected),
            ("coating thickness (nm)", Expected::NonNegative)
        );
        assert_eq!(Coating::new(1.38, 0.0).unwrap().thickness_nm(), 0.0);
    }

    #[test]
    fn bad_numbers_name_themselves() {
        let e = try_fresnel_unpolarized(1.5, 1.0, 1.5).unwrap_err();
        assert_eq!(
            (e.what, e.expected),
            (
                "cosine of incidence",
                Expected::Range {
                    min: -1.0,
                    max: 1.0
                }
            )
        );
        let e = try_fresnel_unpolarized(1.0, f64::NAN, 1.5).unwrap_err();
        assert_eq!(e.what, "refractive index");
        let e = try_single_layer_reflectance(1.0, 1.0, 1.38, 100.0, 1.5, -550.0).unwrap_err();
        assert_eq!(
            (e.what, e.expected),
            ("wavelength (nm)", Expected::Positive)
        );
        // The inner-loop form falls back to total reflection, never NaN.
        let c = Coating::quarter_wave(1.38, 550.0).unwrap();
        assert_eq!(c.reflectance(1.0, 1.0, 1.5, f64::NAN), 1.0);
        assert_eq!(fresnel_unpolarized(f64::NAN, 1.0, 1.5), 1.0);
    }

    #[test]
    fn coating_ideal_quarter_wave_is_zero() {
        // n_c = √(1 · 1.52), λ/4 at 550 nm, normal incidence, 550 nm: R = 0.
        let nc = Coating::ideal_index(1.0, 1.52);
        let c = Coating::quarter_wave(nc, 550.0).unwrap();
        assert!(c.reflectance(1.0, 1.0, 1.52, 550.0) < 1e-30);
        // And from the glass side.
        assert!(c.reflectance(1.0, 1.52, 1.0, 550.0) < 1e-30);
    }

    #[test]
    fn coating_mgf2_known_value() {
        // MgF2 (1.38) quarter-wave at 550 nm on 1.52, normal incidence, 550 nm:
        // R = ((n0 n2 − nc²)/(n0 n2 + nc²))² = ((1.52 − 1.9044)/(1.52 + 1.9044))²
        //   = (−0.3844 / 3.4244)² = 0.112253² = 0.0126008 ≈ 1.26 %.
        let c = Coating::quarter_wave(1.38, 550.0).unwrap();
        let r = c.reflectance(1.0, 1.0, 1.52, 550.0);
        assert!((r - 0.0126008).abs() < 1e-6, "{r}");
        // Uncoated 1.52 is (0.52/2.52)² = 4.26 %: the coating helps.
        assert!(r < fresnel_unpolarized(1.0, 1.0, 1.52) / 3.0);
        // Off the design wavelength the layer is no longer λ/4: R rises.
        assert!(c.reflectance(1.0, 1.0, 1.52, 450.0) > r);
        assert!(c.reflectance(1.0, 1.0, 1.52, 700.0) > r);
    }

    #[test]
    fn coating_zero_thickness_is_bare_fresnel() {
        let c = Coating::new(1.38, 0.0).unwrap();
        for &ci in &[1.0, 0.9, 0.5, 0.1, 0.01] {
            for &(a, b) in &[(1.0, 1.52), (1.7, 1.0), (1.5, 1.9)] {
                let bare = fresnel_unpolarized(ci, a, b);
                assert!(
                    (c.reflectance(ci, a, b, 550.0) - bare).abs() < 1e-14,
                    "{ci} {a} {b}"
                );
            }
        }
    }

    #[test]
    fn coating_supplement_formula_overestimates() {
        // The 2011 supplement's two-beam sum with t01² in place of t01 t10, at
        // normal incidence on the ideal quarter-wave layer (n 1 → 1.2329 → 1.52):
        // r01 = (1 − nc)/(1 + nc), r12 = (nc − 1.52)/(nc + 1.52), t01 = 2/(1 + nc),
        // amplitude r01 + t01² r12 cos π. Hand: nc = 1.232883, r01 = −0.104297,
        // r12 = −0.104297, t01² = 0.802284, → −0.104297 + 0.083676 = −0.020621,
        // R ≈ 4.25e-4 per polarisation, where the exact answer is 0.
        let nc = Coating::ideal_index(1.0, 1.52);
        let r01 = (1.0 - nc) / (1.0 + nc);
        let r12 = (nc - 1.52) / (nc + 1.52);
        let t01 = 2.0 / (1.0 + nc);
        let supplement = (r01 - t01 * t01 * r12).powi(2);
        assert!((supplement - 4.25e-4).abs() < 1e-6, "{supplement}");
        // With t01 t10 = 1 − r01² the two-beam sum is already close to 0; ours is 0.
        let t01t10 = 1.0 - r01 * r01;
        assert!((r01 - t01t10 * r12).powi(2) < 2e-6);
        assert!(
            Coating::quarter_wave(nc, 550.0)
                .unwrap()
                .reflectance(1.0, 1.0, 1.52, 550.0)
                < 1e-30
        );
        // MgF2 (1.38): r01 = −0.159664, r12 = −0.048276, t01² = 0.706165:
        // (−0.159664 + 0.034091)² = 0.015769 — 1.58 % against the exact 1.26 %.
        let (r01, r12, t01): (f64, f64, f64) = (-0.38 / 2.38, -0.14 / 2.90, 2.0 / 2.38);
        let supplement = (r01 - t01 * t01 * r12).powi(2);
        assert!((supplement - 0.015769).abs() < 1e-6, "{supplement}");
        let ours = Coating::quarter_wave(1.38, 550.0)
            .unwrap()
            .reflectance(1.0, 1.0, 1.52, 550.0);
        assert!(supplement > ours + 0.003);
    }

    #[test]
    fn coating_frustrated_tir_is_smooth_and_bounded() {
        // Glass 1.7 → MgF2 1.38 → glass 1.65: coating critical angle
        // sin θ = 1.38/1.7 (cos ≈ 0.584); cross it finely: R stays in [0,1]
        // and continuous (no 0/0 at the critical angle itself).
        let c = Coating::quarter_wave(1.38, 550.0).unwrap();
        let crit_cos = (1.0 - (1.38f64 / 1.7).powi(2)).sqrt();
        let mut prev = c.reflectance(crit_cos + 1e-3, 1.7, 1.65, 550.0);
        for i in -1000..=1000 {
            let ci = crit_cos + i as f64 * 1e-6;
            let r = c.try_reflectance(ci, 1.7, 1.65, 550.0).unwrap();
            assert!(r.is_finite() && (0.0..=1.0).contains(&r));
            if i > -1000 {
                assert!((r - prev).abs() < 1e-3, "jump at {ci}: {prev} → {r}");
            }
            prev = r;
        }
        let exact = c.try_reflectance(crit_cos, 1.7, 1.65, 550.0).unwrap();
        assert!(exact.is_finite());
        // A thick evanescent layer reflects everything.
        let thick = Coating::new(1.38, 1e5).unwrap();
        assert!((thick.reflectance(0.3, 1.7, 1.65, 550.0) - 1.0).abs() < 1e-12);
    }

    fn idx() -> impl Strategy<Value = f64> {
        1.0f64..2.0
    }

    proptest! {
        #[test]
        fn fresnel_bounded_and_finite(ci in -1f64..=1.0, n1 in idx(), n2 in idx()) {
            let r = try_fresnel_unpolarized(ci, n1, n2).unwrap();
            prop_assert!(r.is_finite() && (0.0..=1.0).contains(&r));
            // R + T = 1 with T from the transmission coefficients,
            // T = (n2 cos t)/(n1 cos i)·|t|², t_s = 2 n1 cos i/(n1 cos i + n2 cos t),
            // t_p = 2 n1 cos i/(n2 cos i + n1 cos t) (Hecht eq. 4.44/4.45).
            let c = ci.abs();
            let ct2 = cos_sq_refracted(c, n1, n2);
            if ct2 > 0.0 && c > 1e-6 {
                let ct = ct2.sqrt();
                let ts = 2.0 * n1 * c / (n1 * c + n2 * ct);
                let tp = 2.0 * n1 * c / (n2 * c + n1 * ct);
                let t = (n2 * ct) / (n1 * c) * 0.5 * (ts * ts + tp * tp);
                prop_assert!((r + t - 1.0).abs() < 1e-12, "R {} T {}", r, t);
                // Symmetric under swapping sides (reciprocity).
                // Going back from the denser side, cos i is recovered from
                // cos t through a cancelling difference (n1² − n2²) + n2² cos² t,
                // error ~1e-16/cos² i; allow for it near grazing.
                let back = fresnel_unpolarized(ct, n2, n1);
                prop_assert!((back - r).abs() < 1e-12 + 1e-15 / (c * c), "{} vs {}", back, r);
            }
        }

        #[test]
        fn fresnel_finite_or_typed(ci in -3f64..3.0, n1 in -1f64..3.0, n2 in -1f64..3.0) {
            match try_fresnel_unpolarized(ci, n1, n2) {
                Ok(r) => prop_assert!(r.is_finite() && (0.0..=1.0).contains(&r)),
                Err(_) => prop_assert!(ci.abs() > 1.0 || n1 <= 0.0 || n2 <= 0.0),
            }
            prop_assert!(fresnel_unpolarized(ci, n1, n2).is_finite());
        }

        #[test]
        fn coating_matches_airy_and_conserves_energy(
            ci in 0.05f64..=1.0, n0 in idx(), nc in 1.2f64..2.4, n2 in idx(),
            d in 0.0f64..600.0, lambda in 380f64..780.0,
        ) {
            let r = try_single_layer_reflectance(ci, n0, nc, d, n2, lambda).unwrap();
            prop_assert!(r.is_finite() && (0.0..=1.0).contains(&r));
            let inv2 = n0 * n0 * (1.0 - ci * ci);
            // Propagating everywhere (margin keeps the r01/r12 reference well conditioned).
            if inv2 < (nc * nc).min(n2 * n2) * (1.0 - 1e-6) {
                let airy = airy_r01_r12(ci, n0, nc, d, n2, lambda);
                prop_assert!((r - airy).abs() < 1e-10, "matrix {} airy {}", r, airy);
                let t = airy_transmittance(ci, n0, nc, d, n2, lambda);
                prop_assert!((r + t - 1.0).abs() < 1e-10, "R {} T {}", r, t);
                // Reciprocity: the same stack seen from the other side at the
                // conjugate angle reflects the same (lossless film).
                let c2 = (1.0 - inv2 / (n2 * n2)).sqrt();
                let back = try_single_layer_reflectance(c2, n2, nc, d, n0, lambda).unwrap();
                prop_assert!((back - r).abs() < 1e-10);
            }
        }

        #[test]
        fn coating_finite_or_typed(
            ci in -2f64..2.0, n0 in -1f64..3.0, nc in -1f64..3.0, n2 in -1f64..3.0,
            d in -10f64..1e4, lambda in -10f64..2000.0,
        ) {
            match try_single_layer_reflectance(ci, n0, nc, d, n2, lambda) {
                Ok(r) => prop_assert!(r.is_finite() && (0.0..=1.0).contains(&r)),
                Err(_) => prop_assert!(ci.abs() > 1.0 || n0 <= 0.0 || nc <= 0.0 || n2 <= 0.0 || d < 0.0 || lambda <= 0.0),
            }
            match Coating::new(nc, d) {
                Ok(c) => prop_assert!(c.reflectance(ci, n0, n2, lambda).is_finite()),
                Err(e) => prop_assert!(
                    (e.what == "coating index" && nc <= 0.0) || (e.what == "coating thickness (nm)" && d < 0.0),
                    "{e}"
                ),
            }
        }
    }
}
