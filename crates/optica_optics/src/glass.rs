//! Optical glass: refractive index as a function of wavelength.
//!
//! Three models:
//! - **Sellmeier** (manufacturers' data sheets): `n² = 1 + Σ Bᵢ λ² / (λ² − Cᵢ)`,
//!   λ in µm, Cᵢ in µm². Used for N-BK7 (Schott data sheet coefficients).
//! - **n_d / V_d** (what lens patents and spectacle-lens makers publish): a
//!   two-term Cauchy curve `n(λ) = A + B / λ²` (λ in µm) through `n_d` at the
//!   helium d line whose `n_F − n_C = (n_d − 1) / V_d`. See [`cauchy_from_abbe`]
//!   for the model's limits.
//! - **Constant** and **Air** (index 1; lens systems here use indices relative
//!   to air, as patents do).
//!
//! The public API takes wavelengths in nm; the formulas work in µm inside.

use serde::{Deserialize, Serialize};
use thiserror::Error;

use crate::input::{self, InvalidInput};

/// Helium d line (nm), where `n_d` is defined.
pub const LAMBDA_D_NM: f64 = 587.5618;
/// Hydrogen F line (nm), blue end of the Abbe number.
pub const LAMBDA_F_NM: f64 = 486.1327;
/// Hydrogen C line (nm), red end of the Abbe number.
pub const LAMBDA_C_NM: f64 = 656.2725;

/// Shortest wavelength (nm) the models are evaluated at; [`Glass::index`]
/// clamps to `[MIN_WAVELENGTH_NM, MAX_WAVELENGTH_NM]` (the range of Schott's
/// N-BK7 Sellmeier fit is 300–2500 nm).
pub const MIN_WAVELENGTH_NM: f64 = 300.0;
/// Longest wavelength (nm) the models are evaluated at.
pub const MAX_WAVELENGTH_NM: f64 = 2500.0;

/// Why a glass or an index could not be built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum GlassError {
    /// A number that is not finite or out of range (index, Abbe number,
    /// Sellmeier coefficient, wavelength).
    #[error(transparent)]
    Input(#[from] InvalidInput),
    /// The glass model gives no physical index (finite and >= 1) at this wavelength.
    #[error("the glass model gives index {index} at {wavelength_nm} nm, not a finite number >= 1")]
    NoIndex {
        /// The wavelength asked for, nm.
        wavelength_nm: f64,
        /// What the model gave.
        index: f64,
    },
}

/// A dispersive (or not) optical medium.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Glass {
    /// Index 1 at every wavelength.
    Air,
    /// The same index at every wavelength.
    Constant(f64),
    /// Three-term Sellmeier with `b` (dimensionless) and `c` (µm²).
    Sellmeier {
        /// B₁..B₃.
        b: [f64; 3],
        /// C₁..C₃ in µm².
        c: [f64; 3],
    },
    /// The n_d/V_d model (two-term Cauchy through n_d, see [`cauchy_from_abbe`]).
    Abbe {
        /// Index at the d line.
        nd: f64,
        /// Abbe number `(n_d − 1)/(n_F − n_C)`.
        vd: f64,
    },
}

/// N-BK7 Sellmeier B coefficients (Schott data sheet).
pub const N_BK7_B: [f64; 3] = [1.03961212, 0.231792344, 1.01046945];
/// N-BK7 Sellmeier C coefficients in µm² (Schott data sheet).
pub const N_BK7_C: [f64; 3] = [0.00600069867, 0.0200179144, 103.560653];

/// Catalog entries given by n_d/V_d: (canonical name, n_d, V_d). Spectacle
/// materials as published by lens makers; "crown" is ophthalmic crown glass.
/// The high-index spectacle materials are sold by their index ("1.67"); their
/// canonical names carry an `index-` prefix so that no catalog name is a
/// number (a number in a lens file is always a constant index).
const ABBE_CATALOG: [(&str, f64, f64); 7] = [
    ("CR-39", 1.498, 58.0),
    ("crown", 1.523, 59.0),
    ("Trivex", 1.53, 44.0),
    ("polycarbonate", 1.586, 30.0),
    ("index-1.60", 1.60, 41.0),
    ("index-1.67", 1.67, 32.0),
    ("index-1.74", 1.74, 33.0),
];

/// Bare numeric spellings [`Glass::catalog`] still accepts for the
/// high-index spectacle materials (exact text only: `1.670` is not one), so
/// callers that name a spectacle material by its index keep working. They are
/// not canonical names, and the lens file never looks them up: there a number
/// is a constant index.
const NUMERIC_ALIASES: [(&str, &str); 3] = [
    ("1.60", "index-1.60"),
    ("1.67", "index-1.67"),
    ("1.74", "index-1.74"),
];

/// Canonical catalog names, in [`Glass::catalog_names`] order. None of them
/// parses as a number.
const CATALOG_NAMES: [&str; 9] = [
    "air",
    "N-BK7",
    "CR-39",
    "crown",
    "Trivex",
    "polycarbonate",
    "index-1.60",
    "index-1.67",
    "index-1.74",
];

/// The visible band (nm) over which a lens prescription's glasses must have a
/// usable index ([`Glass::first_bad_index`]).
pub const VISIBLE_NM: (f64, f64) = (380.0, 780.0);

/// Cauchy coefficients `(A, B)` (B in µm²) of the n_d/V_d model:
/// `n(λ) = A + B/λ²` with `n(λ_d) = n_d` and `n(λ_F) − n(λ_C) = (n_d − 1)/V_d`,
/// so `B = (n_d − 1) / (V_d (λ_F⁻² − λ_C⁻²))` and `A = n_d − B/λ_d²`.
///
/// Model and limits: it reproduces n_d and the F–C dispersion exactly, and
/// nothing else. A real glass's curve is not exactly `A + B/λ²` (its UV
/// and IR absorptions shape it), and the error grows with distance from
/// 486–656 nm, fastest into the IR: for N-BK7 (through its own 1.5168/64.17)
/// it stays below 1.3e-4 over 380–700 nm (under 2 % of the F–C dispersion,
/// 8e-3), but is 4e-4 at 800 nm, 1.3e-3 at 1000 nm and 1.1e-2 at 2000 nm
/// (test `glass_abbe_model_limits`). Partial dispersion (secondary spectrum)
/// cannot be represented. Good enough for visible-band chromatic aberration
/// of spectacle and photographic glasses; use Sellmeier data when it exists.
pub fn cauchy_from_abbe(nd: f64, vd: f64) -> (f64, f64) {
    let inv2 = |nm: f64| 1.0 / (nm * 1e-3).powi(2);
    let b = (nd - 1.0) / (vd * (inv2(LAMBDA_F_NM) - inv2(LAMBDA_C_NM)));
    let a = nd - b * inv2(LAMBDA_D_NM);
    (a, b)
}

fn sellmeier(b: &[f64; 3], c: &[f64; 3], lambda_um: f64) -> f64 {
    let l2 = lambda_um * lambda_um;
    let n2 = 1.0 + (0..3).map(|i| b[i] * l2 / (l2 - c[i])).sum::<f64>();
    n2.sqrt()
}

impl Glass {
    /// Refractive index at `wavelength_nm`.
    ///
    /// Documented fallbacks (never NaN): a wavelength outside
    /// `[MIN_WAVELENGTH_NM, MAX_WAVELENGTH_NM]` is clamped into it, a NaN
    /// wavelength is taken as the d line, and a glass whose model gives a
    /// non-finite or non-positive index (hand-built bad coefficients) gives
    /// 1.0. Use [`Glass::try_index`] to get errors instead.
    pub fn index(&self, wavelength_nm: f64) -> f64 {
        let nm = if wavelength_nm.is_nan() {
            LAMBDA_D_NM
        } else {
            wavelength_nm.clamp(MIN_WAVELENGTH_NM, MAX_WAVELENGTH_NM)
        };
        let n = self.raw_index(nm);
        if n.is_finite() && n > 0.0 { n } else { 1.0 }
    }

    /// Refractive index at `wavelength_nm`, or an error for a non-finite or
    /// non-positive wavelength, or a model giving an index that is not finite
    /// and >= 1. Wavelengths outside the model range are evaluated as given.
    pub fn try_index(&self, wavelength_nm: f64) -> Result<f64, GlassError> {
        input::positive("wavelength (nm)", wavelength_nm)?;
        let n = self.raw_index(wavelength_nm);
        if n.is_finite() && n >= 1.0 {
            Ok(n)
        } else {
            Err(GlassError::NoIndex {
                wavelength_nm,
                index: n,
            })
        }
    }

    fn raw_index(&self, nm: f64) -> f64 {
        match *self {
            Glass::Air => 1.0,
            Glass::Constant(n) => n,
            Glass::Sellmeier { b, c } => sellmeier(&b, &c, nm * 1e-3),
            Glass::Abbe { nd, vd } => {
                let (a, b) = cauchy_from_abbe(nd, vd);
                let um = nm * 1e-3;
                a + b / (um * um)
            }
        }
    }

    /// Index at the d line (587.56 nm).
    pub fn nd(&self) -> f64 {
        match *self {
            Glass::Abbe { nd, .. } => nd,
            _ => self.index(LAMBDA_D_NM),
        }
    }

    /// Abbe number `V_d = (n_d − 1)/(n_F − n_C)`; `f64::INFINITY` for a
    /// medium without dispersion (air, constant index).
    pub fn abbe(&self) -> f64 {
        match *self {
            Glass::Abbe { vd, .. } => vd,
            _ => {
                let dn = self.index(LAMBDA_F_NM) - self.index(LAMBDA_C_NM);
                if dn > 0.0 {
                    (self.nd() - 1.0) / dn
                } else {
                    f64::INFINITY
                }
            }
        }
    }

    /// True when the index depends on wavelength.
    pub fn is_dispersive(&self) -> bool {
        self.abbe().is_finite()
    }

    /// The n_d/V_d model from user numbers, rejecting a non-finite or < 1
    /// index and a non-finite or non-positive Abbe number.
    pub fn abbe_checked(nd: f64, vd: f64) -> Result<Glass, GlassError> {
        let nd = input::at_least("refractive index n_d", nd, 1.0)?;
        let vd = input::positive("Abbe number V_d", vd)?;
        Ok(Glass::Abbe { nd, vd })
    }

    /// A constant index from a user number, rejecting non-finite or < 1.
    pub fn constant_checked(n: f64) -> Result<Glass, GlassError> {
        Ok(Glass::Constant(input::at_least(
            "refractive index",
            n,
            1.0,
        )?))
    }

    /// Sellmeier coefficients from user numbers: all finite and non-negative,
    /// and the index at the d line finite and >= 1.
    pub fn sellmeier_checked(b: [f64; 3], c: [f64; 3]) -> Result<Glass, GlassError> {
        for x in b {
            input::non_negative("Sellmeier B coefficient", x)?;
        }
        for x in c {
            input::non_negative("Sellmeier C coefficient (µm²)", x)?;
        }
        let g = Glass::Sellmeier { b, c };
        g.try_index(LAMBDA_D_NM)?;
        Ok(g)
    }

    /// Schott N-BK7 (Sellmeier).
    pub fn n_bk7() -> Glass {
        Glass::Sellmeier {
            b: N_BK7_B,
            c: N_BK7_C,
        }
    }

    /// A catalog glass by name, case-insensitive (surrounding spaces ignored);
    /// see [`Glass::catalog_names`]. `None` for an unknown name.
    ///
    /// The high-index spectacle materials are `index-1.60`, `index-1.67` and
    /// `index-1.74`. For spectacle code that names them by their index, the
    /// exact texts `1.60`, `1.67` and `1.74` are accepted as aliases here
    /// (any other number, `1.670` included, is `None`); the lens file does
    /// not use this lookup for numbers (there `1.67` is `Constant(1.67)`).
    pub fn catalog(name: &str) -> Option<Glass> {
        let name = name.trim();
        let name = NUMERIC_ALIASES
            .iter()
            .find(|(alias, _)| *alias == name)
            .map_or(name, |(_, canonical)| canonical);
        if name.eq_ignore_ascii_case("air") {
            return Some(Glass::Air);
        }
        if name.eq_ignore_ascii_case("N-BK7") {
            return Some(Glass::n_bk7());
        }
        ABBE_CATALOG
            .iter()
            .find(|(n, _, _)| n.eq_ignore_ascii_case(name))
            .map(|&(_, nd, vd)| Glass::Abbe { nd, vd })
    }

    /// The canonical names [`Glass::catalog`] knows.
    pub fn catalog_names() -> &'static [&'static str] {
        &CATALOG_NAMES
    }

    /// The first wavelength in `[lo_nm, hi_nm]` (checked every 5 nm, both
    /// ends included) where the index is not finite or lies outside
    /// `[min, max]`, with the index there (NaN when the model has none);
    /// `None` when the whole band is fine. A Sellmeier term with `B ≠ 0` whose
    /// pole `√C` falls in the band is reported at the pole even when the
    /// 5 nm samples step over it.
    ///
    /// This is what lens validation uses (with [`VISIBLE_NM`] and indices in
    /// [1, 3]): [`Glass::index`] hides a bad curve behind its fallback, and
    /// a glass can be fine at the d line and not elsewhere — `1.5/0.05` (an
    /// absurd Abbe number) has `n(700 nm) = −2.98`.
    pub fn first_bad_index(
        &self,
        lo_nm: f64,
        hi_nm: f64,
        min: f64,
        max: f64,
    ) -> Option<(f64, f64)> {
        if let Glass::Sellmeier { b, c } = self {
            let (lo2, hi2) = ((lo_nm * 1e-3).powi(2), (hi_nm * 1e-3).powi(2));
            for i in 0..3 {
                if b[i] != 0.0 && (lo2..=hi2).contains(&c[i]) {
                    return Some((c[i].sqrt() * 1e3, f64::NAN));
                }
            }
        }
        let steps = (((hi_nm - lo_nm) / 5.0).ceil().max(0.0) as usize).min(100_000);
        (0..=steps)
            .map(|k| {
                if k == steps {
                    hi_nm
                } else {
                    lo_nm + 5.0 * k as f64
                }
            })
            .find_map(|nm| {
                let n = self.raw_index(nm);
                (!(n.is_finite() && n >= min && n <= max)).then_some((nm, n))
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn glass_n_bk7_data_sheet() {
        // Schott N-BK7 data sheet: n_d = 1.51680, V_d = 64.17,
        // n_F = 1.52238, n_C = 1.51432.
        let g = Glass::catalog("N-BK7").unwrap();
        assert!((g.nd() - 1.5168).abs() < 1e-4, "{}", g.nd());
        assert!((g.abbe() - 64.17).abs() < 0.02, "{}", g.abbe());
        assert!((g.index(LAMBDA_F_NM) - 1.52238).abs() < 2e-5);
        assert!((g.index(LAMBDA_C_NM) - 1.51432).abs() < 2e-5);
        // Normal dispersion across the visible.
        let mut prev = f64::INFINITY;
        for nm in (380..=780).step_by(10) {
            let n = g.index(nm as f64);
            assert!(n < prev);
            prev = n;
        }
    }

    #[test]
    fn glass_abbe_model_reproduces_nd_and_vd() {
        for name in Glass::catalog_names() {
            let g = Glass::catalog(name).unwrap();
            if let Glass::Abbe { nd, vd } = g {
                assert!((g.index(LAMBDA_D_NM) - nd).abs() < 1e-12, "{name}");
                let dn = g.index(LAMBDA_F_NM) - g.index(LAMBDA_C_NM);
                assert!((dn - (nd - 1.0) / vd).abs() < 1e-12, "{name}");
                assert!(g.index(400.0) > g.index(700.0));
            }
        }
        // Published values for the spectacle materials.
        assert_eq!(
            Glass::catalog("polycarbonate"),
            Some(Glass::Abbe {
                nd: 1.586,
                vd: 30.0
            })
        );
        assert_eq!(Glass::catalog("1.74").unwrap().nd(), 1.74);
        assert_eq!(Glass::catalog("cr-39").unwrap().abbe(), 58.0);
    }

    #[test]
    fn glass_abbe_model_limits() {
        // The Cauchy curve through N-BK7's own n_d/V_d against its Sellmeier
        // curve: the numbers quoted in `cauchy_from_abbe`'s documentation.
        let s = Glass::n_bk7();
        let c = Glass::abbe_checked(s.nd(), s.abbe()).unwrap();
        let err = |nm: f64| (s.index(nm) - c.index(nm)).abs();
        // Python check of the same numbers: 420 nm −1.07e-4, 700 nm −1.27e-4,
        // 800 nm −3.97e-4, 1000 nm −1.30e-3, 2000 nm −1.11e-2.
        for nm in (380..=700).step_by(5) {
            assert!(err(nm as f64) < 1.3e-4, "{nm}: {}", err(nm as f64));
        }
        assert!(err(800.0) > 3e-4 && err(800.0) < 5e-4, "{}", err(800.0));
        assert!(err(1000.0) > 1e-3 && err(1000.0) < 2e-3, "{}", err(1000.0));
        assert!(err(2000.0) > 1e-2, "{}", err(2000.0));
    }

    #[test]
    fn glass_catalog_names_case_insensitive() {
        for name in Glass::catalog_names() {
            assert!(Glass::catalog(name).is_some(), "{name}");
            assert_eq!(Glass::catalog(&name.to_uppercase()), Glass::catalog(name));
            assert_eq!(Glass::catalog(&name.to_lowercase()), Glass::catalog(name));
        }
        assert_eq!(Glass::catalog(" n-bk7 "), Some(Glass::n_bk7()));
        assert_eq!(
            Glass::catalog("TRIVEX"),
            Some(Glass::Abbe { nd: 1.53, vd: 44.0 })
        );
        assert_eq!(Glass::catalog("unobtainium"), None);
        assert_eq!(Glass::Air.abbe(), f64::INFINITY);
        // No canonical name is a number (a number in a lens file is a
        // constant index); the bare spectacle spellings are exact aliases.
        assert!(
            Glass::catalog_names()
                .iter()
                .all(|n| n.parse::<f64>().is_err())
        );
        assert_eq!(Glass::catalog("1.67"), Glass::catalog("index-1.67"));
        assert_eq!(
            Glass::catalog("index-1.67"),
            Some(Glass::Abbe { nd: 1.67, vd: 32.0 })
        );
        assert_eq!(Glass::catalog("1.670"), None);
        assert_eq!(Glass::catalog("1.5"), None);
        assert!(!Glass::Constant(1.5).is_dispersive());
    }

    #[test]
    fn glass_checked_constructors_reject_bad_numbers() {
        use crate::input::Expected;
        let what = |r: Result<Glass, GlassError>| match r {
            Err(GlassError::Input(e)) => (e.what, e.expected),
            other => panic!("expected an input error, got {other:?}"),
        };
        let nd = ("refractive index n_d", Expected::AtLeast(1.0));
        assert_eq!(what(Glass::abbe_checked(f64::NAN, 40.0)), nd);
        assert_eq!(what(Glass::abbe_checked(0.9, 40.0)), nd);
        assert_eq!(what(Glass::abbe_checked(f64::INFINITY, 40.0)), nd);
        assert_eq!(
            what(Glass::abbe_checked(1.5, 0.0)),
            ("Abbe number V_d", Expected::Positive)
        );
        assert_eq!(
            what(Glass::abbe_checked(1.5, f64::NAN)),
            ("Abbe number V_d", Expected::Positive)
        );
        assert!(Glass::abbe_checked(1.5, 40.0).is_ok());
        assert_eq!(
            what(Glass::constant_checked(0.5)),
            ("refractive index", Expected::AtLeast(1.0))
        );
        assert_eq!(
            what(Glass::sellmeier_checked([f64::NAN, 0.0, 0.0], [0.0; 3])).0,
            "Sellmeier B coefficient"
        );
        assert_eq!(
            what(Glass::sellmeier_checked([1.0, 0.0, 0.0], [-1.0, 0.0, 0.0])).0,
            "Sellmeier C coefficient (µm²)"
        );
        // Finite, non-negative coefficients with a pole at the d line: no index there.
        let pole_c = [(LAMBDA_D_NM * 1e-3).powi(2), 0.0, 0.0];
        assert!(matches!(
            Glass::sellmeier_checked([1.0, 0.0, 0.0], pole_c),
            Err(GlassError::NoIndex { .. })
        ));
        assert!(Glass::sellmeier_checked(N_BK7_B, N_BK7_C).is_ok());
        assert!(
            matches!(Glass::n_bk7().try_index(-1.0), Err(GlassError::Input(e)) if e.what == "wavelength (nm)")
        );
        assert!(Glass::n_bk7().index(f64::NAN).is_finite());
        // A hand-built Sellmeier with a pole at the d line falls back to 1.
        let pole = Glass::Sellmeier {
            b: [1.0, 0.0, 0.0],
            c: pole_c,
        };
        assert!(pole.index(LAMBDA_D_NM).is_finite());
    }

    #[test]
    fn glass_first_bad_index_over_the_visible() {
        // 1.5/0.05: fine at the d line, n(700 nm) = −2.98 (A + B/λ² with
        // B = 0.5/(0.05·(λF⁻² − λC⁻²)) = 5.237 µm², A = 1.5 − B/λd² = −13.67).
        let g = Glass::Abbe { nd: 1.5, vd: 0.05 };
        assert!((g.try_index(LAMBDA_D_NM).unwrap() - 1.5).abs() < 1e-12);
        assert!(
            (g.raw_index(700.0) + 2.98).abs() < 0.01,
            "{}",
            g.raw_index(700.0)
        );
        let (nm, n) = g
            .first_bad_index(VISIBLE_NM.0, VISIBLE_NM.1, 1.0, 3.0)
            .unwrap();
        assert!(
            nm < LAMBDA_D_NM && n > 3.0,
            "too high in the blue first: {nm} nm, n = {n}"
        );
        let (nm, n) = g
            .first_bad_index(LAMBDA_D_NM, VISIBLE_NM.1, 1.0, 3.0)
            .unwrap();
        assert!(nm > LAMBDA_D_NM && n < 1.0, "{nm} nm, n = {n}");
        for name in Glass::catalog_names() {
            assert_eq!(
                Glass::catalog(name)
                    .unwrap()
                    .first_bad_index(VISIBLE_NM.0, VISIBLE_NM.1, 1.0, 3.0),
                None,
                "{name}"
            );
        }
        // A weak Sellmeier pole at 502.5 nm, between two 5 nm samples.
        let pole = Glass::Sellmeier {
            b: [1e-9, 0.2, 0.0],
            c: [0.5025f64.powi(2), 0.01, 0.0],
        };
        let (nm, n) = pole
            .first_bad_index(VISIBLE_NM.0, VISIBLE_NM.1, 1.0, 3.0)
            .unwrap();
        assert!((nm - 502.5).abs() < 1e-9 && n.is_nan(), "{nm} {n}");
    }

    proptest! {
        #[test]
        fn glass_index_finite_and_decreasing(
            nd in 1.0f64..2.2, vd in 15.0f64..100.0,
            nm in 300f64..2500.0, dnm in 1f64..500.0,
        ) {
            for g in [Glass::abbe_checked(nd, vd).unwrap(), Glass::n_bk7()] {
                let n0 = g.try_index(nm).unwrap();
                let n1 = g.try_index(nm + dnm).unwrap();
                prop_assert!(n0.is_finite() && n0 >= 1.0);
                prop_assert!(n1 <= n0);
            }
        }

        #[test]
        fn glass_any_input_is_finite_or_typed(nd in -5f64..5.0, vd in -100f64..100.0, nm in -1e4f64..1e4) {
            match Glass::abbe_checked(nd, vd) {
                Ok(g) => {
                    prop_assert!(g.index(nm).is_finite());
                    prop_assert!(g.abbe().is_finite() && g.nd().is_finite());
                }
                Err(_) => prop_assert!(nd < 1.0 || vd <= 0.0),
            }
            let raw = Glass::Abbe { nd, vd };
            prop_assert!(raw.index(nm).is_finite());
        }
    }
}
