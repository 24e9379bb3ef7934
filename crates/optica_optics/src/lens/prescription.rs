//! The prescription of a sequential lens system, as a patent table gives it,
//! and its validation.
//!
//! Convention (the patent-table one): surface `k` is followed by
//! `thickness_after_mm` of `glass_after`; the medium in front of surface 0 is
//! air (object space). Vertex of surface 0 is at z = 0, the optical axis is +z
//! and light travels towards +z. Surfaces store curvature `c = 1/R` so that a
//! flat surface is exactly `c = 0` (REFERENCE.md: `R = 1e38` overflows in f32).

use thiserror::Error;

use crate::fresnel::Coating;
use crate::glass::{Glass, LAMBDA_D_NM, VISIBLE_NM};


/// Most surfaces a prescription may have (a zoom has ~30; 64 leaves room).
pub const MAX_SURFACES: usize = 64;

/// Refractive indices accepted at the d line and over the visible band
/// ([`VISIBLE_NM`], 380–780 nm): vacuum to well past any glass.
pub const INDEX_RANGE: (f64, f64) = (1.0, 3.0);

/// One row of a lens table: a spherical (or flat) surface and what follows it.
#[derive(Clone, Debug, PartialEq)]
pub struct LensSurface {
    /// Curvature `c = 1/R` in 1/mm; `0` is flat. Positive: centre of curvature
    /// behind the vertex (+z), like a positive radius in a patent table.
    pub curvature: f64,
    /// Axial distance from this vertex to the next one (or, for the last
    /// surface, to the image plane), in mm.
    pub thickness_after_mm: f64,
    /// The medium between this surface and the next.
    pub glass_after: Glass,
    /// Clear radius of the surface in mm (not the diameter).
    pub semi_aperture_mm: f64,
    /// `true` for the aperture stop: a flat opening that neither refracts nor
    /// reflects.
    pub is_stop: bool,
    /// Anti-reflection coating on this surface, if any.
    pub coating: Option<Coating>,
}

impl LensSurface {
    /// A surface of radius `radius_mm` (`f64::INFINITY` for flat) followed by
    /// `thickness_after_mm` of `glass_after`.
    pub fn new(radius_mm: f64, thickness_after_mm: f64, glass_after: Glass, semi_aperture_mm: f64) -> Self {
        Self {
            curvature: curvature_of_radius(radius_mm),
            thickness_after_mm,
            glass_after,
            semi_aperture_mm,
            is_stop: false,
            coating: None,
        }
    }

    /// The flat aperture stop, followed by `thickness_after_mm` of `medium`
    /// (which must be the medium in front of it).
    pub fn stop(thickness_after_mm: f64, medium: Glass, semi_aperture_mm: f64) -> Self {
        Self {
            curvature: 0.0,
            thickness_after_mm,
            glass_after: medium,
            semi_aperture_mm,
            is_stop: true,
            coating: None,
        }
    }

    /// The same surface with `coating`.
    pub fn with_coating(mut self, coating: Coating) -> Self {
        self.coating = Some(coating);
        self
    }

    /// Radius of curvature in mm; `f64::INFINITY` when flat.
    pub fn radius_mm(&self) -> f64 {
        if self.curvature == 0.0 { f64::INFINITY } else { 1.0 / self.curvature }
    }

    /// `true` when the surface is flat (`c = 0`).
    pub fn is_flat(&self) -> bool {
        self.curvature == 0.0
    }
}

/// `1/R`, with any infinite radius (either sign) mapped to exactly 0 (flat).
pub fn curvature_of_radius(radius_mm: f64) -> f64 {
    if radius_mm.is_infinite() { 0.0 } else { 1.0 / radius_mm }
}

/// A sequential lens system: surfaces front to back, with where it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct LensPrescription {
    /// Human-readable name ("Brendel Tessar").
    pub name: String,
    /// Citation of the source, normally a patent ("US 2,854,889, example table").
    pub source: String,
    /// Surfaces front (object side) to back.
    pub surfaces: Vec<LensSurface>,
    /// Focal length the source states, in mm, if it states one.
    pub design_focal_length_mm: Option<f64>,
    /// f-number the source states, if it states one.
    pub design_f_number: Option<f64>,
}

/// Why a prescription is not a usable lens system.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum PrescriptionError {
    /// Fewer than 1 or more than [`MAX_SURFACES`] surfaces.
    #[error("a lens needs 1..={MAX_SURFACES} surfaces, got {count}")]
    SurfaceCount {
        /// Number of surfaces given.
        count: usize,
    },
    /// A number is NaN or infinite (a flat surface is `c = 0`, never `R = inf` stored).
    #[error("surface {surface}: `{field}` is not a finite number ({value})")]
    NonFinite {
        /// Index of the surface (0-based).
        surface: usize,
        /// Name of the field.
        field: &'static str,
        /// The offending value.
        value: f64,
    },
    /// Not exactly one aperture stop.
    #[error("a lens needs exactly one aperture stop, got {count}")]
    StopCount {
        /// Number of surfaces marked as stop.
        count: usize,
    },
    /// A semi-aperture that is zero or negative.
    #[error("surface {surface}: semi-aperture must be > 0 mm, got {value}")]
    SemiAperture {
        /// Index of the surface.
        surface: usize,
        /// The offending value.
        value: f64,
    },
    /// A negative thickness.
    #[error("surface {surface}: thickness must be >= 0 mm, got {value}")]
    Thickness {
        /// Index of the surface.
        surface: usize,
        /// The offending value.
        value: f64,
    },
    /// |R| smaller than the semi-aperture: the clear aperture would need more
    /// than a hemisphere, which no spherical cap can be.
    #[error(
        "surface {surface}: |R| = {radius_mm} mm is smaller than the semi-aperture {semi_aperture_mm} mm \
         (the cap would be more than a hemisphere, which is impossible)"
    )]
    HemispherePlus {
        /// Index of the surface.
        surface: usize,
        /// |R| in mm.
        radius_mm: f64,
        /// Semi-aperture in mm.
        semi_aperture_mm: f64,
    },
    /// A refractive index outside [`INDEX_RANGE`] (or not finite) at the d line.
    #[error("surface {surface}: refractive index after it is {index} at the d line, outside [1, 3]")]
    Index {
        /// Index of the surface.
        surface: usize,
        /// The index at the d line.
        index: f64,
    },
    /// A glass whose index leaves [`INDEX_RANGE`] (or has none) somewhere in
    /// the visible band [`VISIBLE_NM`] although it is fine at the d line: a
    /// dispersion curve no glass has (an `nd/vd` with an absurd Abbe number,
    /// a Sellmeier pole in the visible).
    #[error(
        "surface {surface}: refractive index after it is {index} at {wavelength_nm} nm, outside [1, 3] \
         (indices must be usable over 380–780 nm)"
    )]
    IndexOverVisible {
        /// Index of the surface.
        surface: usize,
        /// The first wavelength (nm) found where the index is out of range.
        wavelength_nm: f64,
        /// The index there (NaN when the model has none, e.g. at a pole).
        index: f64,
    },
    /// The stop is curved.
    #[error("surface {surface}: the aperture stop must be flat (c = 0), got c = {curvature}")]
    StopNotFlat {
        /// Index of the stop.
        surface: usize,
        /// Its curvature.
        curvature: f64,
    },
    /// The medium after the stop differs from the one before it: the stop
    /// would refract and reflect, which the model says it does not.
    #[error("surface {surface}: the aperture stop must not change the medium (index {before} before, {after} after)")]
    StopChangesMedium {
        /// Index of the stop.
        surface: usize,
        /// Index before, at the d line.
        before: f64,
        /// Index after, at the d line.
        after: f64,
    },
    /// A coating with a non-physical index or thickness.
    #[error("surface {surface}: coating must have a finite index in [1, 3] and thickness >= 0 nm")]
    Coating {
        /// Index of the surface.
        surface: usize,
    },
    /// A coating on the stop, which has no interface to coat.
    #[error("surface {surface}: the aperture stop cannot carry a coating")]
    CoatedStop {
        /// Index of the stop.
        surface: usize,
    },
    /// Name or source with a line break or `#`, which the lens file cannot hold.
    #[error("`{field}` must be one line without `#`")]
    Text {
        /// `name` or `source`.
        field: &'static str,
    },
    /// A design focal length or f-number that is not a positive finite number.
    #[error("`{field}` must be a positive finite number, got {value}")]
    Design {
        /// `focal_length` or `f_number`.
        field: &'static str,
        /// The offending value.
        value: f64,
    },
}

impl PrescriptionError {
    /// The surface the error is about, if it is about one.
    pub fn surface(&self) -> Option<usize> {
        use PrescriptionError::*;
        match self {
            NonFinite { surface, .. }
            | SemiAperture { surface, .. }
            | Thickness { surface, .. }
            | HemispherePlus { surface, .. }
            | Index { surface, .. }
            | IndexOverVisible { surface, .. }
            | StopNotFlat { surface, .. }
            | StopChangesMedium { surface, .. }
            | Coating { surface }
            | CoatedStop { surface } => Some(*surface),
            SurfaceCount { .. } | StopCount { .. } | Text { .. } | Design { .. } => None,
        }
    }
}

impl LensPrescription {
    /// A validated prescription.
    pub fn new(
        name: impl Into<String>,
        source: impl Into<String>,
        surfaces: Vec<LensSurface>,
    ) -> Result<Self, PrescriptionError> {
        let p = Self {
            name: name.into(),
            source: source.into(),
            surfaces,
            design_focal_length_mm: None,
            design_f_number: None,
        };
        p.validate()?;
        Ok(p)
    }

    /// Checks every bound listed on [`PrescriptionError`]; the first
    /// violation found (front to back) is returned.
    pub fn validate(&self) -> Result<(), PrescriptionError> {
        for (field, text) in [("name", &self.name), ("source", &self.source)] {
            if text.contains(['\n', '\r', '#']) {
                return Err(PrescriptionError::Text { field });
            }
        }
        for (field, value) in [("focal_length", self.design_focal_length_mm), ("f_number", self.design_f_number)] {
            if let Some(v) = value
                && !(v.is_finite() && v > 0.0)
            {
                return Err(PrescriptionError::Design { field, value: v });
            }
        }
        let count = self.surfaces.len();
        if !(1..=MAX_SURFACES).contains(&count) {
            return Err(PrescriptionError::SurfaceCount { count });
        }
        let stops = self.surfaces.iter().filter(|s| s.is_stop).count();
        if stops != 1 {
            return Err(PrescriptionError::StopCount { count: stops });
        }
        let mut index_before = 1.0; // object space is air
        for (k, s) in self.surfaces.iter().enumerate() {
            for (field, value) in [
                ("curvature", s.curvature),
                ("thickness", s.thickness_after_mm),
                ("semi_aperture", s.semi_aperture_mm),
            ] {
                if !value.is_finite() {
                    return Err(PrescriptionError::NonFinite { surface: k, field, value });
                }
            }
            if s.semi_aperture_mm <= 0.0 {
                return Err(PrescriptionError::SemiAperture { surface: k, value: s.semi_aperture_mm });
            }
            if s.thickness_after_mm < 0.0 {
                return Err(PrescriptionError::Thickness { surface: k, value: s.thickness_after_mm });
            }
            // |R| >= h  <=>  |c| h <= 1; written this way so c = 0 needs no special case.
            if s.curvature.abs() * s.semi_aperture_mm > 1.0 {
                return Err(PrescriptionError::HemispherePlus {
                    surface: k,
                    radius_mm: s.radius_mm().abs(),
                    semi_aperture_mm: s.semi_aperture_mm,
                });
            }
            // try_index: `index` would hide a bad glass behind its fallback of 1.
            let index = s.glass_after.try_index(LAMBDA_D_NM).unwrap_or(f64::NAN);
            if !(index.is_finite() && (INDEX_RANGE.0..=INDEX_RANGE.1).contains(&index)) {
                return Err(PrescriptionError::Index { surface: k, index });
            }
            if let Some((wavelength_nm, index)) =
                s.glass_after.first_bad_index(VISIBLE_NM.0, VISIBLE_NM.1, INDEX_RANGE.0, INDEX_RANGE.1)
            {
                return Err(PrescriptionError::IndexOverVisible { surface: k, wavelength_nm, index });
            }
            if s.is_stop {
                if s.curvature != 0.0 {
                    return Err(PrescriptionError::StopNotFlat { surface: k, curvature: s.curvature });
                }
                // Compared at the d line with a tolerance for the round trip of
                // the index through a file, not for genuinely different glasses.
                if (index - index_before).abs() > 1e-12 {
                    return Err(PrescriptionError::StopChangesMedium {
                        surface: k,
                        before: index_before,
                        after: index,
                    });
                }
                if s.coating.is_some() {
                    return Err(PrescriptionError::CoatedStop { surface: k });
                }
            }
            if let Some(c) = &s.coating
                && !(c.index.is_finite()
                    && (INDEX_RANGE.0..=INDEX_RANGE.1).contains(&c.index)
                    && c.thickness_nm.is_finite()
                    && c.thickness_nm >= 0.0)
            {
                return Err(PrescriptionError::Coating { surface: k });
            }
            index_before = index;
        }
        Ok(())
    }

    /// Index of the aperture stop in [`Self::surfaces`] (a validated
    /// prescription has exactly one; an unvalidated one may have none).
    pub fn stop_index(&self) -> Option<usize> {
        self.surfaces.iter().position(|s| s.is_stop)
    }

    /// Indices of the Fresnel interfaces: every surface but the stop.
    pub fn interfaces(&self) -> Vec<usize> {
        (0..self.surfaces.len()).filter(|&k| !self.surfaces[k].is_stop).collect()
    }

    /// z of every vertex: surface 0 at 0, then the running sum of thicknesses.
    pub fn vertex_z(&self) -> Vec<f64> {
        let mut z = 0.0;
        self.surfaces
            .iter()
            .map(|s| {
                let here = z;
                z += s.thickness_after_mm;
                here
            })
            .collect()
    }

    /// z of the plane at the last surface plus its thickness: the image plane
    /// of the table (for patent tables, the back focal distance).
    pub fn table_image_z(&self) -> f64 {
        self.surfaces.iter().map(|s| s.thickness_after_mm).sum()
    }

    /// Medium in front of surface `k`: air for `k = 0`, the image-space
    /// medium for `k = surfaces.len()`, `None` beyond.
    pub fn glass_before(&self, k: usize) -> Option<Glass> {
        if k == 0 { Some(Glass::Air) } else { self.surfaces.get(k - 1).map(|s| s.glass_after) }
    }

    /// The same lens with `coating` on every interface (not on the stop), as
    /// Hullin et al. assume a single quarter-wave layer on every surface.
    pub fn with_coating_everywhere(mut self, coating: Coating) -> Self {
        for s in self.surfaces.iter_mut().filter(|s| !s.is_stop) {
            s.coating = Some(coating);
        }
        self
    }

    /// The same lens with every length multiplied by `factor` (> 0): patent
    /// tables normalised to F = 1 are scaled to a focal length this way.
    pub fn scaled(mut self, factor: f64) -> Self {
        for s in &mut self.surfaces {
            s.curvature /= factor;
            s.thickness_after_mm *= factor;
            s.semi_aperture_mm *= factor;
        }
        self.design_focal_length_mm = self.design_focal_length_mm.map(|f| f * factor);
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn air() -> Glass {
        Glass::Air
    }

    fn singlet() -> Vec<LensSurface> {
        vec![
            LensSurface::stop(2.0, air(), 5.0),
            LensSurface::new(50.0, 4.0, Glass::Constant(1.5), 10.0),
            LensSurface::new(-50.0, 45.0, air(), 10.0),
        ]
    }

    #[test]
    fn valid_singlet_passes() {
        let p = LensPrescription::new("singlet", "test", singlet()).unwrap();
        assert_eq!(p.stop_index(), Some(0));
        assert_eq!(p.interfaces(), vec![1, 2]);
        assert_eq!(p.vertex_z(), vec![0.0, 2.0, 6.0]);
        assert_eq!(p.table_image_z(), 51.0);
    }

    #[test]
    fn bounds_are_enforced() {
        let check = |f: &dyn Fn(&mut Vec<LensSurface>), want: fn(&PrescriptionError) -> bool| {
            let mut s = singlet();
            f(&mut s);
            let e = LensPrescription::new("x", "y", s).unwrap_err();
            assert!(want(&e), "unexpected error {e}");
        };
        check(&|s| s.clear(), |e| matches!(e, PrescriptionError::SurfaceCount { count: 0 }));
        check(
            &|s| {
                let last = s[2].clone();
                s.resize(65, last);
            },
            |e| matches!(e, PrescriptionError::SurfaceCount { count: 65 }),
        );
        check(&|s| s[0].is_stop = false, |e| matches!(e, PrescriptionError::StopCount { count: 0 }));
        check(&|s| s[1].is_stop = true, |e| matches!(e, PrescriptionError::StopCount { count: 2 }));
        check(&|s| s[1].semi_aperture_mm = 0.0, |e| matches!(e, PrescriptionError::SemiAperture { surface: 1, .. }));
        check(&|s| s[2].thickness_after_mm = -1.0, |e| matches!(e, PrescriptionError::Thickness { surface: 2, .. }));
        check(
            &|s| s[1].curvature = f64::NAN,
            |e| matches!(e, PrescriptionError::NonFinite { surface: 1, field: "curvature", .. }),
        );
        check(&|s| s[1].curvature = 1.0 / 9.0, |e| matches!(e, PrescriptionError::HemispherePlus { surface: 1, .. }));
        check(&|s| s[1].glass_after = Glass::Constant(3.5), |e| matches!(e, PrescriptionError::Index { surface: 1, .. }));
        check(&|s| s[1].glass_after = Glass::Constant(0.9), |e| matches!(e, PrescriptionError::Index { surface: 1, .. }));
        // Fine at the d line (1.5), n(700 nm) = −2.98: rejected, naming the surface.
        check(
            &|s| s[1].glass_after = Glass::Abbe { nd: 1.5, vd: 0.05 },
            |e| matches!(e, PrescriptionError::IndexOverVisible { surface: 1, .. }),
        );
        check(
            &|s| s[1].glass_after = Glass::Sellmeier { b: [0.3, 0.0, 0.0], c: [0.25, 0.0, 0.0] },
            |e| matches!(e, PrescriptionError::IndexOverVisible { surface: 1, wavelength_nm, .. } if (*wavelength_nm - 500.0).abs() < 1e-9),
        );
        check(&|s| s[0].curvature = 0.01, |e| matches!(e, PrescriptionError::StopNotFlat { surface: 0, .. }));
        check(
            &|s| s[0].glass_after = Glass::Constant(1.5),
            |e| matches!(e, PrescriptionError::StopChangesMedium { surface: 0, .. }),
        );
        check(
            &|s| s[1].coating = Some(Coating { index: f64::NAN, thickness_nm: 100.0 }),
            |e| matches!(e, PrescriptionError::Coating { surface: 1 }),
        );
    }

    #[test]
    fn glass_before_is_total() {
        let p = LensPrescription::new("singlet", "test", singlet()).unwrap();
        assert_eq!(p.glass_before(0), Some(Glass::Air));
        assert_eq!(p.glass_before(2), Some(Glass::Constant(1.5)));
        assert_eq!(p.glass_before(3), Some(Glass::Air), "image space");
        assert_eq!(p.glass_before(4), None);
        assert_eq!(p.glass_before(usize::MAX), None);
        let empty = LensPrescription { surfaces: vec![], ..p };
        assert_eq!(empty.glass_before(0), Some(Glass::Air));
        assert_eq!(empty.glass_before(1), None);
    }

    #[test]
    fn hemisphere_exactly_is_allowed() {
        // |R| = semi-aperture is a full hemisphere: the limit, still a cap.
        let mut s = singlet();
        s[1].curvature = 1.0 / 10.0;
        assert!(LensPrescription::new("x", "y", s).is_ok());
    }

    #[test]
    fn scaling_scales_lengths_not_indices() {
        let p = LensPrescription::new("s", "t", singlet()).unwrap().scaled(2.0);
        assert_eq!(p.surfaces[1].radius_mm(), 100.0);
        assert_eq!(p.surfaces[1].thickness_after_mm, 8.0);
        assert_eq!(p.surfaces[1].semi_aperture_mm, 20.0);
        assert!(p.validate().is_ok());
    }
}
