//! Sequential lens systems: prescriptions as patent tables give them, the
//! lens file format, paraxial optics and real-ray tracing of the primary path
//! and of the two-reflection ghost paths that lens flare is made of.
//!
//! The method is that of Hullin, Eisemann, Seidel and Lee, "Physically-Based
//! Real-Time Lens Flare Rendering", *ACM Transactions on Graphics* 30(4)
//! (SIGGRAPH 2011), article 108, as explained in the web article by
//! AngularSpectrumMTD, "Physically-Based Real-Time Lens Flare Rendering
//! (Matthias B. Hullin et al., Max Planck Institute for Informatics, ACM,
//! 2011)", Qiita, 25 August 2021 (in Japanese),
//! <https://qiita.com/AngularSpectrumMTD/items/aeea1046c0ec5d4dd1d5> — "the
//! blog" below. The blog numbers no equations, so it is cited by its section
//! headings, translated ("the blog's *Ray-bundle tracing*").
//!
//! ```
//! use optica_optics::lens::{self, Ray, TracePath};
//! use optica_optics::glass::LAMBDA_D_NM;
//! use optica_optics::glam::DVec3;
//!
//! let tessar = lens::builtin::tessar();
//! let first = tessar.paraxial(LAMBDA_D_NM).unwrap();
//! assert!((first.efl_mm - 100.0).abs() < 0.5);
//! let ghosts = lens::ghosts(&tessar);
//! assert_eq!(ghosts.len(), 21);
//! let (i, j) = ghosts[0];
//! let ray = Ray::new(DVec3::new(0.0, 5.0, -10.0), DVec3::Z).unwrap();
//! let hit = lens::trace(&tessar, ray, LAMBDA_D_NM, TracePath::ghost(i, j)).unwrap();
//! assert!(hit.throughput < 0.01);
//! ```
//!
//! # Conventions
//!
//! Lengths are in mm, wavelengths in nm. The optical axis is +z, from object
//! to image; the first vertex is at z = 0 and light travels towards +z.
//! Surfaces store their curvature `c = 1/R`, so a flat surface is exactly
//! `c = 0`. Surface `k` is followed by its thickness and medium, as in a
//! patent table; the medium in front of surface 0 is air. A
//! [`LensPrescription`] is checked once, when it is built or parsed, and
//! cannot be changed into an invalid one; [`PreparedLens`] evaluates its
//! indices at one wavelength for tracing many rays.
//!
//! # The lens file
//!
//! A human-readable prescription, one file per lens
//! ([`LensPrescription::parse`], [`LensPrescription::parse_bytes`] for an
//! asset loader's bytes, [`LensPrescription::load`]):
//!
//! ```text
//! # comments start with `#`, anywhere on a line
//! name = Brendel Tessar
//! source = US 2,854,889 (Brendel), example table
//! focal_length = 100        # optional, mm
//! f_number = 2.8            # optional
//! units = mm                # optional; only mm
//!
//! # radius  thickness  medium       semi_aperture  [coating]
//!   42.97     9.80     1.6910/54.8  19.2
//!   stop      4.00     air          15.0
//!   inf       1.87     N-BK7        17.3           qw:1.38@550
//! ```
//!
//! Each row is one surface with the thickness and medium that FOLLOW it (the
//! patent-table convention). Fields:
//! - `radius`: mm, `inf` (flat), or `stop` (the flat aperture stop);
//! - `thickness`: mm, >= 0;
//! - `medium`: `air`, a name [`Glass::catalog`] knows (`N-BK7`, `crown`,
//!   `CR-39`, `index-1.67`, ...), `nd/vd` like `1.6910/54.8`
//!   ([`Glass::Abbe`]), `n/inf` or a bare number like `1.5` for a constant
//!   index (no dispersion), or `sellmeier:B1,B2,B3,C1,C2,C3` (C in µm², all
//!   six finite and >= 0). A bare number is *always* a constant index —
//!   `1.67` and `1.670` alike; the dispersive spectacle material of index
//!   1.67 is `index-1.67` (or `1.67/32`). The glass must have an index in
//!   [1, 3] over 380–780 nm, not only at the d line (see
//!   [`PrescriptionError::IndexOverVisible`]);
//! - `semi_aperture`: clear radius in mm, > 0;
//! - `coating` (optional): `none`, `index/thickness_nm` like `1.38/99.6`, or
//!   `qw:index@wavelength_nm` for a quarter-wave layer.
//!
//! Every error names its line and, for a bad value, its field
//! ([`ParseError::line`], [`ParseError::Field`]); a table that parses but is
//! not a valid lens names the row of the surface at fault.
//! [`LensPrescription::to_lens_file`] writes the same format with every
//! number in the shortest form that reads back to the same `f64`, so a
//! written file parses to an equal prescription (catalog names come back as
//! their Sellmeier or Abbe data, which is the same glass).
//!
//! # Real-ray tracing and ghost paths
//!
//! A ghost path `(i, j)`, `i > j`, runs forward through surfaces `0..i`,
//! reflects at `i`, runs backward through `i-1 .. j+1`, reflects at `j`, then
//! forward through `j+1 ..` to the sensor. Only even numbers of reflections
//! reach the sensor, and those of more than two are too faint to draw, so
//! `n` Fresnel interfaces give `n(n−1)/2` ghosts ([`ghosts`]; the blog's
//! *Ghost enumeration*: "there are n(n−1)/2 ghosts"); the stop reflects
//! nothing and is not one. The sequence of surfaces is known, so no
//! acceleration structure is needed (the blog's *Ray-bundle tracing*).
//! Along the way:
//! - every hit updates `r_rel = max(r_rel, r / semi_aperture)` (the blog's
//!   `r_rel(new) = max(r_rel(old), r / r_surface)`); rays outside a
//!   semi-aperture keep going on the continued sphere so that a ray grid
//!   stays continuous — clipping is per pixel, later, on `r_rel > 1`;
//! - a ray that misses a sphere (no real intersection on the cap through the
//!   vertex) or meets total internal reflection where it must refract stops
//!   with a typed [`TraceError`] naming the surface;
//! - the throughput is the product of `T = 1 − R` at every refraction and `R`
//!   at the two reflections, unpolarised Fresnel (the blog's *Reflection and
//!   transmission of light (the Fresnel equations)*, cosine form) or the
//!   surface's single-layer coating ([`Coating`]), at the trace wavelength;
//! - the stop records where the ray crosses its plane, at every crossing.
//!
//! **Polarisation (the blog's approximation).** Each factor above is already
//! averaged over s and p (`R = (R_s + R_p)/2`), and the averages are
//! multiplied. Unpolarised light is an equal mix of s and p; for a meridional
//! ray every surface has the same plane of incidence, so s stays s and p
//! stays p, and the exact unpolarised throughput is the *mean of the
//! products*, `½(∏ T_s·R_s… + ∏ T_p·R_p…)`, not the product of the means
//! (for skew rays the planes of incidence turn and the exact value needs
//! Jones matrices). The two agree at normal incidence and differ off it: at
//! 30° on n = 1.5 (R_s = 5.78 %, R_p = 2.52 %) the two reflections of a
//! ghost give `R̄² = 1.72e-3` against `½(R_s² + R_p²) = 1.99e-3` (13 % low),
//! and a slab ghost with its two transmissions 1.58e-3 against 1.79e-3. We
//! keep the blog's product of means, so a ghost reflecting at such angles is
//! drawn about that much too dim.
//!
//! **Stop crossings.** A ghost `(i, j)` with `j < stop < i` crosses the stop
//! plane three times (forward, backward between the reflections, forward
//! again); any other path once. [`TraceResult::stop_xy_all`] records every
//! crossing, so an aperture shape (blades) can be tested at each one;
//! `r_rel` tests the stop's round semi-aperture at each crossing as at every
//! surface.
//!
//! # Shipped lenses
//!
//! [`builtin`] holds three expired patents' example tables, compiled in from
//! the crate's `lenses/` folder ([`LENS_FILES`]): Brendel's Tessar
//! (US 2,854,889), Angenieux's double Gauss (US 2,701,982) and Tronnier's
//! Heliar (US 2,645,156).

mod paraxial;
mod parse;
mod prescription;
mod trace;

pub use paraxial::{Abcd, ParaxialError, ParaxialProperties, ParaxialRay};
pub use parse::ParseError;
pub use prescription::{
    INDEX_RANGE, LensPrescription, LensSurface, MAX_SURFACES, PrescriptionError,
};
pub use trace::{
    MAX_STOP_CROSSINGS, Pass, PreparedLens, SurfaceData, TraceError, TracePath, TraceResult,
    ghosts, trace, trace_to,
};

// The types this module's signatures use, so that `lens::*` is enough to call it.
pub use crate::fresnel::Coating;
pub use crate::glass::Glass;
pub use crate::input::InvalidInput;
pub use crate::ray::Ray;

/// The lens files shipped in the crate's `lenses/` folder, compiled in:
/// `(file name, text)`. [`builtin`] parses them; a plugin can write them out
/// as assets, or parse them itself.
pub const LENS_FILES: &[(&str, &str)] = &[
    (
        "tessar-us2854889.lens",
        include_str!("../../lenses/tessar-us2854889.lens"),
    ),
    (
        "double-gauss-us2701982.lens",
        include_str!("../../lenses/double-gauss-us2701982.lens"),
    ),
    (
        "heliar-us2645156.lens",
        include_str!("../../lenses/heliar-us2645156.lens"),
    ),
];

/// Every lens file the crate ships: the three 100 mm primes of
/// [`LENS_FILES`] and the 33-interface zoom (Canon, US 5,537,259), which is
/// no 100 mm prime and so not among [`builtin`]'s.
pub const ALL_LENS_FILES: &[(&str, &str)] = &[
    LENS_FILES[0],
    LENS_FILES[1],
    LENS_FILES[2],
    (
        "zoom-canon-us5537259.lens",
        include_str!("../../lenses/zoom-canon-us5537259.lens"),
    ),
];

/// The shipped prescriptions, parsed from [`LENS_FILES`].
pub mod builtin {
    use super::{LENS_FILES, LensPrescription};

    fn shipped(index: usize) -> LensPrescription {
        // The files are compiled in and parsed by the tests, so a failure here
        // is a broken build, not bad user input.
        LensPrescription::parse(LENS_FILES[index].1)
            .unwrap_or_else(|e| panic!("shipped lens file {} is invalid: {e}", LENS_FILES[index].0))
    }

    /// Brendel Tessar, US 2,854,889: f = 100 mm, f/2.8, 7 interfaces (21 ghosts).
    /// The patent says f/2.8; the table's stop semi-aperture (15.0 mm) gives a
    /// paraxial f/2.73 at the d line.
    pub fn tessar() -> LensPrescription {
        shipped(0)
    }

    /// Angenieux double Gauss, US 2,701,982: f = 100 mm, f/1.1, 14 interfaces (91 ghosts).
    /// The patent says f/1.1; the table's stop semi-aperture (25.5 mm) gives a
    /// paraxial f/1.14 at the d line.
    pub fn double_gauss() -> LensPrescription {
        shipped(1)
    }

    /// Tronnier Heliar (Color-Heliar), US 2,645,156 Example 1 scaled to
    /// f = 100 mm, f/3.5, 8 interfaces with one plano glass surface (28 ghosts).
    /// The patent gives no clear apertures: the semi-apertures are chosen for
    /// f/3.5 and a 20° field (the file says how).
    pub fn heliar() -> LensPrescription {
        shipped(2)
    }

    /// Every shipped lens.
    pub fn all() -> Vec<LensPrescription> {
        (0..LENS_FILES.len()).map(shipped).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::glass::Glass;

    #[test]
    fn shipped_files_parse_and_cite_their_patent() {
        for (name, p) in LENS_FILES.iter().zip(builtin::all()) {
            let number = name
                .0
                .rsplit_once("-us")
                .unwrap()
                .1
                .trim_end_matches(".lens");
            // "2854889" must appear as "2,854,889" in the source citation.
            let cited = format!("{},{},{}", &number[..1], &number[1..4], &number[4..]);
            assert!(
                p.source().contains(&cited),
                "{}: source `{}` does not cite {cited}",
                name.0,
                p.source()
            );
            assert_eq!(p.design_focal_length_mm(), Some(100.0));
            // The file's comment header cites the same patent.
            assert!(
                name.1
                    .lines()
                    .take_while(|l| l.starts_with('#'))
                    .any(|l| l.contains(&cited)),
                "{}",
                name.0
            );
        }
    }

    #[test]
    fn tessar_table_is_entered_exactly() {
        // US 2,854,889's example table: first and last rows.
        let p = builtin::tessar();
        let s = p.surfaces();
        assert_eq!(s.len(), 8);
        assert_eq!(s[0].curvature, 1.0 / 42.97);
        assert_eq!(s[0].thickness_after_mm, 9.80);
        assert_eq!(s[3].semi_aperture_mm, 15.0);
        assert!(s[3].is_stop && p.stop_index() == 3);
        assert_eq!(s[7].curvature, 1.0 / -48.91);
        assert_eq!(s[7].thickness_after_mm, 79.831);
        let d = builtin::double_gauss();
        assert_eq!(d.surfaces().len(), 15);
        assert_eq!(d.surfaces()[14].thickness_after_mm, 55.742);
    }

    /// One row of a patent's table: R (`None` = the stop), t, n_d/V_d
    /// (`None` = air), semi-aperture, all in mm.
    type Row = (Option<f64>, f64, Option<(f64, f64)>, f64);

    fn assert_table(p: &LensPrescription, rows: &[Row]) {
        let name = p.name();
        assert_eq!(p.surfaces().len(), rows.len(), "{name}");
        for (k, (s, &(r, t, glass, semi))) in p.surfaces().iter().zip(rows).enumerate() {
            match r {
                None => assert!(s.is_stop && s.curvature == 0.0, "{name} row {k}: the stop"),
                Some(r) => assert!(
                    !s.is_stop && s.curvature == 1.0 / r,
                    "{name} row {k}: R {} vs {r}",
                    s.radius_mm()
                ),
            }
            assert_eq!(s.thickness_after_mm, t, "{name} row {k}: thickness");
            let want = glass.map_or(Glass::Air, |(nd, vd)| Glass::Abbe { nd, vd });
            assert_eq!(s.glass_after, want, "{name} row {k}: medium");
            assert_eq!(s.semi_aperture_mm, semi, "{name} row {k}: semi-aperture");
            assert_eq!(s.coating, None);
        }
    }

    #[test]
    fn shipped_tables_equal_the_patent_tables() {
        // The patents' example tables, entered here a second time,
        // independently of the files: R, t, n_d, V_d, semi-aperture (mm)
        // per row. Brendel Tessar, US 2,854,889:
        let tessar: [Row; 8] = [
            (Some(42.97), 9.80, Some((1.6910, 54.8)), 19.2),
            (Some(-115.33), 2.10, Some((1.5486, 45.4)), 19.2),
            (Some(306.84), 4.16, None, 19.2),
            (None, 4.00, None, 15.0),
            (Some(-59.06), 1.87, Some((1.6398, 34.6)), 17.3),
            (Some(40.93), 10.64, None, 17.3),
            (Some(183.92), 7.05, Some((1.6910, 54.8)), 16.5),
            (Some(-48.91), 79.831, None, 16.5),
        ];
        // Angenieux double Gauss, US 2,701,982:
        let double_gauss: [Row; 15] = [
            (Some(164.12), 10.99, Some((1.673, 32.2)), 54.0),
            (Some(559.28), 0.23, None, 54.0),
            (Some(100.12), 11.45, Some((1.670, 47.1)), 51.0),
            (Some(213.54), 0.23, None, 51.0),
            (Some(58.04), 22.95, Some((1.691, 54.7)), 41.0),
            (Some(2551.0), 2.58, Some((1.673, 32.2)), 41.0),
            (Some(32.39), 15.66, None, 27.0),
            (None, 15.00, None, 25.5),
            (Some(-40.42), 2.74, Some((1.699, 30.1)), 25.0),
            (Some(192.98), 27.92, Some((1.620, 60.3)), 36.0),
            (Some(-55.53), 0.23, None, 36.0),
            (Some(192.98), 7.98, Some((1.691, 54.7)), 35.0),
            (Some(-225.28), 0.23, None, 35.0),
            (Some(175.10), 8.48, Some((1.691, 54.7)), 35.0),
            (Some(-203.54), 55.742, None, 35.0),
        ];
        assert_table(&builtin::tessar(), &tessar);
        assert_table(&builtin::double_gauss(), &double_gauss);
        // The stop semi-apertures give paraxial f/2.73 and f/1.14 (the
        // patents' f/2.8 and f/1.1 are the nominal marks).
        let f = |p: LensPrescription| p.paraxial(crate::glass::LAMBDA_D_NM).unwrap().f_number;
        assert!(
            (f(builtin::tessar()) - 2.73).abs() < 0.005,
            "{}",
            f(builtin::tessar())
        );
        assert!(
            (f(builtin::double_gauss()) - 1.14).abs() < 0.005,
            "{}",
            f(builtin::double_gauss())
        );
    }
}
