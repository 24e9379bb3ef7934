//! Paraxial (first-order) optics of a prescription: the y–nu trace, the ABCD
//! matrix, focal lengths, the paraxial image plane and the entrance pupil.
//!
//! State of a paraxial ray: height `y` (mm) and reduced angle `ω = n·u`.
//! At surface k with curvature c and media n → n', the power is
//! `φ = (n' − n)·c` and refraction is `ω' = ω − y·φ`; a gap of thickness t in
//! index n' transfers `y' = y + t·ω'/n'` (Smith, *Modern Optical Engineering*,
//! 4th ed., ch. 2; the standard y–nu trace). As matrices on (y, ω):
//! refraction `[[1, 0], [−φ, 1]]`, transfer `[[1, t/n'], [0, 1]]`.

use thiserror::Error;

use super::prescription::LensPrescription;
use crate::input::{self, InvalidInput};

/// A paraxial ray: height and reduced angle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParaxialRay {
    /// Height above the axis in mm.
    pub y: f64,
    /// Reduced angle `n·u` (u the slope dy/dz in the current medium).
    pub omega: f64,
}

/// A 2×2 ray-transfer matrix on (y, ω), row-major: `[[A, B], [C, D]]`.
pub type Abcd = [[f64; 2]; 2];

/// First-order properties of a lens at one wavelength (object at infinity).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParaxialProperties {
    /// Wavelength in nm.
    pub wavelength_nm: f64,
    /// Effective focal length `1/Φ = −1/C` in mm.
    pub efl_mm: f64,
    /// Back focal length: last vertex to the rear focal point, in mm.
    pub bfl_mm: f64,
    /// Front focal length: front focal point to the first vertex, in mm.
    pub ffl_mm: f64,
    /// z of the paraxial image plane (rear focal plane) in the lens frame
    /// (first vertex at z = 0).
    pub image_z_mm: f64,
    /// z of the entrance pupil (the paraxial image of the stop in object space).
    pub entrance_pupil_z_mm: f64,
    /// Radius of the entrance pupil in mm.
    pub entrance_pupil_radius_mm: f64,
    /// `efl / (2 · entrance pupil radius)`.
    pub f_number: f64,
}

/// Why first-order properties do not exist.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum ParaxialError {
    /// A wavelength that is not a finite number > 0.
    #[error(transparent)]
    Input(#[from] InvalidInput),
    /// The system has no power (C = 0): no finite focal length.
    #[error("the system is afocal (zero power): no finite focal length")]
    Afocal,
    /// The stop is imaged to infinity by the elements in front of it.
    #[error("the entrance pupil is at infinity (the front group images the stop to infinity)")]
    PupilAtInfinity,
    /// A glass gives no index, or one below 1, at this wavelength
    /// ([`crate::glass::Glass::try_index`]: evaluated as given, never clamped or replaced).
    #[error("surface {surface}: the glass has no index >= 1 at {wavelength_nm} nm")]
    Index {
        /// Index of the surface.
        surface: usize,
        /// The wavelength.
        wavelength_nm: f64,
    },
    /// A surface range that is empty or runs past the last surface.
    #[error("no surfaces {from}..={to} in a lens of {count} surfaces")]
    SurfaceRange {
        /// First surface asked for.
        from: usize,
        /// Last surface asked for.
        to: usize,
        /// Surfaces in the lens.
        count: usize,
    },
}

/// A system whose power `|C|` times its length scale (the larger of the
/// table's track length and its widest semi-aperture) is below this is
/// afocal. The ABCD product of up to [`super::MAX_SURFACES`] surfaces carries
/// a relative round-off of order 1e-14, so a zero-power system (a slab)
/// comes out below 1e-12, while any lens is orders of magnitude above it (a
/// 100 m focal length on a 100 mm lens is 1e-3).
const AFOCAL_RELATIVE_POWER: f64 = 1e-12;

/// When `|A|` of the matrix from the first vertex to the stop is below this,
/// the front group images the stop to infinity within round-off: the
/// entrance pupil (radius `h_stop / |A|`) would be more than 1e12 times the
/// stop, i.e. [`ParaxialError::PupilAtInfinity`].
const PUPIL_AT_INFINITY_A: f64 = 1e-12;

/// Refractive index in front of each surface and after each surface at
/// `wavelength_nm`, by [`crate::glass::Glass::try_index`]: a glass with no
/// index >= 1 there is an error naming the surface (`Err(k)`), not the
/// fallback of [`crate::glass::Glass::index`] (which clamps the wavelength
/// and turns a non-positive index into 1, i.e. air).
pub(crate) fn indices(
    p: &LensPrescription,
    wavelength_nm: f64,
) -> Result<(Vec<f64>, Vec<f64>), usize> {
    let surfaces = p.surfaces();
    let mut before = Vec::with_capacity(surfaces.len());
    let mut after = Vec::with_capacity(surfaces.len());
    let mut n = 1.0; // object space is air
    for (k, s) in surfaces.iter().enumerate() {
        let n2 = s.glass_after.try_index(wavelength_nm).map_err(|_| k)?;
        before.push(n);
        after.push(n2);
        n = n2;
    }
    Ok((before, after))
}

/// [`indices`] with the error of this module.
fn indices_at(
    p: &LensPrescription,
    wavelength_nm: f64,
) -> Result<(Vec<f64>, Vec<f64>), ParaxialError> {
    let wavelength_nm = input::positive("wavelength (nm)", wavelength_nm)?;
    indices(p, wavelength_nm).map_err(|surface| ParaxialError::Index {
        surface,
        wavelength_nm,
    })
}

/// `a · b` for 2×2 matrices.
fn mat_mul(a: Abcd, b: Abcd) -> Abcd {
    [
        [
            a[0][0] * b[0][0] + a[0][1] * b[1][0],
            a[0][0] * b[0][1] + a[0][1] * b[1][1],
        ],
        [
            a[1][0] * b[0][0] + a[1][1] * b[1][0],
            a[1][0] * b[0][1] + a[1][1] * b[1][1],
        ],
    ]
}

impl LensPrescription {
    /// Traces a paraxial ray given just in front of the first vertex (in air)
    /// and returns its state just after each surface: the height at the
    /// surface and the reduced angle after refraction there.
    pub fn trace_paraxial(
        &self,
        wavelength_nm: f64,
        start: ParaxialRay,
    ) -> Result<Vec<ParaxialRay>, ParaxialError> {
        let (before, after) = indices_at(self, wavelength_nm)?;
        let surfaces = self.surfaces();
        let mut out = Vec::with_capacity(surfaces.len());
        let (mut y, mut omega) = (start.y, start.omega);
        for (k, s) in surfaces.iter().enumerate() {
            if k > 0 {
                y += surfaces[k - 1].thickness_after_mm * omega / after[k - 1];
            }
            omega -= y * (after[k] - before[k]) * s.curvature;
            out.push(ParaxialRay { y, omega });
        }
        Ok(out)
    }

    /// The ABCD matrix on (y, ω) from just in front of surface `from` to just
    /// after surface `to` (inclusive), refractions and the gaps between them
    /// included. [`ParaxialError::SurfaceRange`] unless
    /// `from <= to < surfaces().len()`.
    pub fn abcd_between(
        &self,
        wavelength_nm: f64,
        from: usize,
        to: usize,
    ) -> Result<Abcd, ParaxialError> {
        let count = self.surfaces().len();
        let (before, after) = indices_at(self, wavelength_nm)?;
        if !(from <= to && to < count) {
            return Err(ParaxialError::SurfaceRange { from, to, count });
        }
        Ok(self.abcd_with(&before, &after, from, to))
    }

    /// [`Self::abcd_between`] with the indices evaluated and the range checked.
    fn abcd_with(&self, before: &[f64], after: &[f64], from: usize, to: usize) -> Abcd {
        let surfaces = self.surfaces();
        let mut m: Abcd = [[1.0, 0.0], [0.0, 1.0]];
        for k in from..=to {
            if k > from {
                let t = surfaces[k - 1].thickness_after_mm / after[k - 1];
                m = mat_mul([[1.0, t], [0.0, 1.0]], m);
            }
            let phi = (after[k] - before[k]) * surfaces[k].curvature;
            m = mat_mul([[1.0, 0.0], [-phi, 1.0]], m);
        }
        m
    }

    /// The system matrix from the first vertex to the last (both refractions
    /// included).
    pub fn system_matrix(&self, wavelength_nm: f64) -> Result<Abcd, ParaxialError> {
        self.abcd_between(wavelength_nm, 0, self.surfaces().len() - 1)
    }

    /// First-order properties at `wavelength_nm` (use [`crate::glass::LAMBDA_D_NM`]
    /// for the d line, as patents do).
    pub fn paraxial(&self, wavelength_nm: f64) -> Result<ParaxialProperties, ParaxialError> {
        let (before, after) = indices_at(self, wavelength_nm)?;
        let surfaces = self.surfaces();
        let last = surfaces.len() - 1; // a prescription has at least one surface
        let n_image = after[last];
        let [[a, _b], [c, d]] = self.abcd_with(&before, &after, 0, last);
        let length = self.table_image_z().max(
            surfaces
                .iter()
                .map(|s| s.semi_aperture_mm)
                .fold(0.0, f64::max),
        );
        if !(c.is_finite()) || c.abs() * length < AFOCAL_RELATIVE_POWER {
            return Err(ParaxialError::Afocal);
        }
        let efl = -1.0 / c;
        let bfl = -a * n_image / c;
        // Front focal length: a ray from the front focal point leaves parallel;
        // with the object-space index of air (1), FFL = D / C (distance from
        // the front focal point to the first vertex).
        let ffl = -d / c;
        let last_z = self.vertex_z()[last];
        let stop = self.stop_index();
        // Heights at the stop for unit height and for unit slope at vertex 0:
        // h = a_s·y0 + b_s·u0 (object space is air, so ω0 = u0).
        let m_stop = if stop == 0 {
            [[1.0, 0.0], [0.0, 1.0]]
        } else {
            let m = self.abcd_with(&before, &after, 0, stop - 1);
            let t = surfaces[stop - 1].thickness_after_mm / after[stop - 1];
            mat_mul([[1.0, t], [0.0, 1.0]], m)
        };
        let (a_s, b_s) = (m_stop[0][0], m_stop[0][1]);
        if !(a_s.abs() >= PUPIL_AT_INFINITY_A) {
            return Err(ParaxialError::PupilAtInfinity);
        }
        let ep_radius = self.stop_semi_aperture_mm() / a_s.abs();
        Ok(ParaxialProperties {
            wavelength_nm,
            efl_mm: efl,
            bfl_mm: bfl,
            ffl_mm: ffl,
            image_z_mm: last_z + bfl,
            entrance_pupil_z_mm: b_s / a_s,
            entrance_pupil_radius_mm: ep_radius,
            f_number: efl / (2.0 * ep_radius),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::builtin;
    use super::*;
    use crate::glass::{Glass, LAMBDA_D_NM};
    use crate::input::Expected;
    use crate::lens::{LensSurface, PrescriptionError};

    #[test]
    fn tessar_and_double_gauss_focal_lengths_match_the_patents() {
        // US 2,854,889 and US 2,701,982 state f = 100 mm; the last row's
        // thickness is the back focal distance of each table.
        for (p, bfd) in [
            (builtin::tessar(), 79.831),
            (builtin::double_gauss(), 55.742),
        ] {
            let q = p.paraxial(LAMBDA_D_NM).unwrap();
            assert!(
                (q.efl_mm / 100.0 - 1.0).abs() < 0.005,
                "{}: EFL {}",
                p.name(),
                q.efl_mm
            );
            // The tables round radii to 0.01 mm, which moves the focus by
            // ~0.1 mm; hold the BFL to 0.2 % of the tabulated back focus.
            assert!(
                (q.bfl_mm / bfd - 1.0).abs() < 0.002,
                "{}: BFL {} vs {bfd}",
                p.name(),
                q.bfl_mm
            );
        }
    }

    #[test]
    fn heliar_focal_length_is_the_normalised_one() {
        // US 2,645,156 Example 1 is normalised to F = 1 (file scaled x100).
        let q = builtin::heliar().paraxial(LAMBDA_D_NM).unwrap();
        assert!((q.efl_mm / 100.0 - 1.0).abs() < 0.005, "EFL {}", q.efl_mm);
        assert!((q.bfl_mm / 82.030 - 1.0).abs() < 0.002, "BFL {}", q.bfl_mm);
        // The stop semi-aperture was chosen for f/3.5.
        assert!((q.f_number - 3.5).abs() < 0.01, "f/{}", q.f_number);
    }

    #[test]
    fn thin_lens_makers_formula() {
        // A thin biconvex lens, n = 1.5, R = ±100: 1/f = (n−1)(2/R) → f = 100.
        let p = LensPrescription::new(
            "thin",
            "lensmaker's equation",
            vec![
                LensSurface::stop(0.0, Glass::Air, 10.0),
                LensSurface::new(100.0, 0.0, Glass::Constant(1.5), 10.0),
                LensSurface::new(-100.0, 100.0, Glass::Air, 10.0),
            ],
        )
        .unwrap();
        let q = p.paraxial(550.0).unwrap();
        assert!((q.efl_mm - 100.0).abs() < 1e-12);
        assert!((q.bfl_mm - 100.0).abs() < 1e-12);
        assert!((q.f_number - 5.0).abs() < 1e-12);
        assert!(q.entrance_pupil_z_mm.abs() < 1e-12);
    }

    #[test]
    fn thick_lens_gullstrand() {
        // Thick lens: Φ = Φ1 + Φ2 − (t/n)Φ1Φ2 (Gullstrand); BFL = f(1 − (t/n)Φ1).
        let (n, r1, r2, t) = (1.6, 40.0, -60.0, 8.0);
        let p = LensPrescription::new(
            "thick",
            "Gullstrand",
            vec![
                LensSurface::new(r1, t, Glass::Constant(n), 15.0),
                LensSurface::new(r2, 5.0, Glass::Air, 15.0),
                LensSurface::stop(50.0, Glass::Air, 8.0),
            ],
        )
        .unwrap();
        let (p1, p2) = ((n - 1.0) / r1, (1.0 - n) / r2);
        let phi = p1 + p2 - t / n * p1 * p2;
        let q = p.paraxial(600.0).unwrap();
        assert!((q.efl_mm - 1.0 / phi).abs() < 1e-9);
        // BFL measured from the last vertex: that is the stop, 5 mm behind surface 2.
        let bfl_from_s2 = (1.0 - t / n * p1) / phi;
        assert!((q.bfl_mm - (bfl_from_s2 - 5.0)).abs() < 1e-9);
    }

    #[test]
    fn y_nu_trace_and_abcd_agree() {
        let p = builtin::double_gauss();
        let trace = p
            .trace_paraxial(LAMBDA_D_NM, ParaxialRay { y: 1.0, omega: 0.0 })
            .unwrap();
        let [[a, _], [c, _]] = p.system_matrix(LAMBDA_D_NM).unwrap();
        let last = trace.last().unwrap();
        assert!((last.y - a).abs() < 1e-12 && (last.omega - c).abs() < 1e-15);
        // The determinant of a (y, nu) system matrix is 1 (Lagrange invariant).
        let m = p.system_matrix(LAMBDA_D_NM).unwrap();
        assert!((m[0][0] * m[1][1] - m[0][1] * m[1][0] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn achromat_focal_length_varies_little_from_f_to_c() {
        // The Tessar is an achromat: its EFL changes by well under 1 % between
        // the F and C lines (the glasses' nd/vd give the dispersion).
        let p = builtin::tessar();
        let f = p.paraxial(crate::glass::LAMBDA_F_NM).unwrap().efl_mm;
        let c = p.paraxial(crate::glass::LAMBDA_C_NM).unwrap().efl_mm;
        assert!(
            (f - c).abs() < 1.0,
            "achromat: EFL varies < 1 % over F–C, got {f} vs {c}"
        );
    }

    /// A singlet (stop, then one glass) with `glass`.
    fn singlet_of(glass: Glass) -> Result<LensPrescription, PrescriptionError> {
        LensPrescription::new(
            "singlet",
            "test",
            vec![
                LensSurface::stop(2.0, Glass::Air, 5.0),
                LensSurface::new(50.0, 4.0, glass, 10.0),
                LensSurface::new(-50.0, 45.0, Glass::Air, 10.0),
            ],
        )
    }

    #[test]
    fn glass_without_an_index_is_an_index_error_not_air() {
        // 1.5/0.05 (a file medium with an absurd Abbe number) is 1.5 at the
        // d line and −2.98 at 700 nm: no prescription holds it.
        assert!(matches!(
            singlet_of(Glass::Abbe { nd: 1.5, vd: 0.05 }),
            Err(PrescriptionError::IndexOverVisible { surface: 1, .. })
        ));
        // 1.5/1.2 is usable over 380–780 nm (2.38 … 1.23) and valid, but its
        // Cauchy curve A + B/λ² falls below 1 in the infrared (0.965 at
        // 1500 nm): `Glass::index` would turn that into 1.0 (air) and trace
        // on; the paraxial code reports an index error there instead.
        let p = singlet_of(Glass::Abbe { nd: 1.5, vd: 1.2 }).unwrap();
        assert!(p.paraxial(780.0).is_ok());
        let want = ParaxialError::Index {
            surface: 1,
            wavelength_nm: 1500.0,
        };
        assert_eq!(p.paraxial(1500.0), Err(want.clone()));
        assert_eq!(
            p.trace_paraxial(1500.0, ParaxialRay { y: 1.0, omega: 0.0 }),
            Err(want.clone())
        );
        assert_eq!(p.system_matrix(1500.0), Err(want));
    }

    #[test]
    fn matrices_of_bad_ranges_are_typed_not_panics() {
        let p = builtin::tessar();
        let n = p.surfaces().len();
        assert!(p.abcd_between(LAMBDA_D_NM, 0, n - 1).is_ok());
        assert_eq!(
            p.abcd_between(LAMBDA_D_NM, 0, n),
            Err(ParaxialError::SurfaceRange {
                from: 0,
                to: n,
                count: n
            })
        );
        assert_eq!(
            p.abcd_between(LAMBDA_D_NM, 3, 1),
            Err(ParaxialError::SurfaceRange {
                from: 3,
                to: 1,
                count: n
            })
        );
        assert!(matches!(
            p.abcd_between(LAMBDA_D_NM, usize::MAX, usize::MAX),
            Err(ParaxialError::SurfaceRange { .. })
        ));
        // A single surface: from = to = 0 is its refraction alone.
        let m = p.abcd_between(LAMBDA_D_NM, 0, 0).unwrap();
        assert_eq!((m[0][0], m[0][1], m[1][1]), (1.0, 0.0, 1.0));
        assert!((m[1][0] + (1.6910 - 1.0) / 42.97).abs() < 1e-12);
    }

    #[test]
    fn bad_wavelength_and_afocal_are_typed() {
        let p = builtin::tessar();
        for bad in [f64::NAN, -5.0, 0.0, f64::INFINITY] {
            let e = p.paraxial(bad).unwrap_err();
            assert!(
                matches!(e, ParaxialError::Input(i) if i.what == "wavelength (nm)" && i.expected == Expected::Positive),
                "{bad}: {e}"
            );
        }
        let flat = LensPrescription::new(
            "slab",
            "flat glass has no power",
            vec![
                LensSurface::stop(1.0, Glass::Air, 5.0),
                LensSurface::new(f64::INFINITY, 5.0, Glass::Constant(1.5), 10.0),
                LensSurface::new(f64::INFINITY, 5.0, Glass::Air, 10.0),
            ],
        )
        .unwrap();
        assert_eq!(flat.paraxial(550.0), Err(ParaxialError::Afocal));
    }
}
