//! Sequential lens systems: prescriptions as patent tables give them, the
//! lens file format, paraxial optics and real-ray tracing of the primary path
//! and of two-reflection ghost paths (Hullin et al. 2011, blog
//! `hullin-lens-flare-blog.txt`).
//!
//! ```
//! use optica_optics::lens::{self, TracePath};
//! use optica_optics::glass::LAMBDA_D_NM;
//! use optica_optics::ray::Ray;
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
//! | file | what |
//! |---|---|
//! | [`prescription`] | [`LensPrescription`], [`LensSurface`], validation |
//! | [`parse`] | the `.lens` text format: parse, write, load |
//! | [`paraxial`] | y–nu trace, ABCD, EFL/BFL, image plane, entrance pupil |
//! | [`mod@trace`] | real rays: primary and ghost paths, r_rel, stop position, Fresnel throughput |
//! | [`builtin`] | the lenses shipped in `assets/lenses/` |

pub mod paraxial;
pub mod parse;
pub mod prescription;
pub mod trace;

pub use paraxial::{Abcd, ParaxialError, ParaxialProperties, ParaxialRay};
pub use parse::ParseError;
pub use prescription::{LensPrescription, LensSurface, PrescriptionError};
pub use trace::{
    MAX_STOP_CROSSINGS, Pass, PreparedLens, TraceError, TracePath, TraceResult, ghosts, trace, trace_to,
};

/// The lens files shipped in `assets/lenses/`, compiled in: `(file name, text)`.
///
/// They live in the workspace's `assets/` so that examples and users read the
/// same files; compiling them in keeps the built-ins available without a path.
pub const LENS_FILES: &[(&str, &str)] = &[
    ("tessar-us2854889.lens", include_str!("../../lenses/tessar-us2854889.lens")),
    ("double-gauss-us2701982.lens", include_str!("../../lenses/double-gauss-us2701982.lens")),
    ("heliar-us2645156.lens", include_str!("../../lenses/heliar-us2645156.lens")),
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
    /// Semi-apertures are ours (the patent gives none); see the file.
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
            let number = name.0.rsplit_once("-us").unwrap().1.trim_end_matches(".lens");
            // "2854889" must appear as "2,854,889" in the source citation.
            let cited = format!("{},{},{}", &number[..1], &number[1..4], &number[4..]);
            assert!(p.source.contains(&cited), "{}: source `{}` does not cite {cited}", name.0, p.source);
            assert!(p.design_focal_length_mm == Some(100.0));
        }
    }

    #[test]
    fn tessar_table_is_entered_exactly() {
        // REFERENCE.md, US 2,854,889: first and last rows.
        let p = builtin::tessar();
        assert_eq!(p.surfaces.len(), 8);
        assert_eq!(p.surfaces[0].curvature, 1.0 / 42.97);
        assert_eq!(p.surfaces[0].thickness_after_mm, 9.80);
        assert_eq!(p.surfaces[3].semi_aperture_mm, 15.0);
        assert!(p.surfaces[3].is_stop);
        assert_eq!(p.surfaces[7].curvature, 1.0 / -48.91);
        assert_eq!(p.surfaces[7].thickness_after_mm, 79.831);
        let d = builtin::double_gauss();
        assert_eq!(d.surfaces.len(), 15);
        assert_eq!(d.surfaces[14].thickness_after_mm, 55.742);
    }

    /// One row of a REFERENCE.md table: R (`None` = the stop), t, n_d/V_d
    /// (`None` = air), semi-aperture, all in mm.
    type Row = (Option<f64>, f64, Option<(f64, f64)>, f64);

    fn assert_table(p: &LensPrescription, rows: &[Row]) {
        assert_eq!(p.surfaces.len(), rows.len(), "{}", p.name);
        for (k, (s, &(r, t, glass, semi))) in p.surfaces.iter().zip(rows).enumerate() {
            match r {
                None => assert!(s.is_stop && s.curvature == 0.0, "{} row {k}: the stop", p.name),
                Some(r) => assert!(!s.is_stop && s.curvature == 1.0 / r, "{} row {k}: R {} vs {r}", p.name, s.radius_mm()),
            }
            assert_eq!(s.thickness_after_mm, t, "{} row {k}: thickness", p.name);
            let want = glass.map_or(Glass::Air, |(nd, vd)| Glass::Abbe { nd, vd });
            assert_eq!(s.glass_after, want, "{} row {k}: medium", p.name);
            assert_eq!(s.semi_aperture_mm, semi, "{} row {k}: semi-aperture", p.name);
            assert_eq!(s.coating, None);
        }
    }

    #[test]
    fn shipped_tables_equal_the_reference_tables() {
        // Copied from /work/shared/REFERENCE.md ("Lens flare", "Lens
        // prescriptions"): R, t, n_d, V_d, semi-aperture (mm) per row.
        // Brendel Tessar, US 2,854,889:
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
        assert!((f(builtin::tessar()) - 2.73).abs() < 0.005, "{}", f(builtin::tessar()));
        assert!((f(builtin::double_gauss()) - 1.14).abs() < 0.005, "{}", f(builtin::double_gauss()));
    }
}
