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
//! let ray = Ray::new(DVec3::new(0.0, 5.0, -10.0), DVec3::Z);
//! let hit = lens::trace(&tessar, ray, LAMBDA_D_NM, TracePath::ghost(i, j)).unwrap();
//! assert!(hit.throughput < 0.01);
//! ```
//!
//! | file | what |
//! |---|---|
//! | [`prescription`] | [`LensPrescription`], [`LensSurface`], validation |
//! | [`parse`] | the `.lens` text format: parse, write, load |
//! | [`paraxial`] | y–nu trace, ABCD, EFL/BFL, image plane, entrance pupil |
//! | [`trace`] | real rays: primary and ghost paths, r_rel, stop position, Fresnel throughput |
//! | [`builtin`] | the lenses shipped in `assets/lenses/` |

pub mod paraxial;
pub mod parse;
pub mod prescription;
pub mod trace;

pub use paraxial::{Abcd, ParaxialError, ParaxialProperties, ParaxialRay};
pub use parse::ParseError;
pub use prescription::{LensPrescription, LensSurface, PrescriptionError};
pub use trace::{Pass, PreparedLens, TraceError, TracePath, TraceResult, ghosts, trace, trace_to};

/// The lens files shipped in `assets/lenses/`, compiled in: `(file name, text)`.
///
/// They live in the workspace's `assets/` so that examples and users read the
/// same files; compiling them in keeps the built-ins available without a path.
pub const LENS_FILES: &[(&str, &str)] = &[
    ("tessar-us2854889.lens", include_str!("../../../../assets/lenses/tessar-us2854889.lens")),
    ("double-gauss-us2701982.lens", include_str!("../../../../assets/lenses/double-gauss-us2701982.lens")),
    ("heliar-us2645156.lens", include_str!("../../../../assets/lenses/heliar-us2645156.lens")),
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
    pub fn tessar() -> LensPrescription {
        shipped(0)
    }

    /// Angenieux double Gauss, US 2,701,982: f = 100 mm, f/1.1, 14 interfaces (91 ghosts).
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
}
