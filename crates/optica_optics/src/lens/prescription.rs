//! The prescription of a sequential lens system, as a patent table gives it,
//! and the checks that make it one.
//!
//! A [`LensPrescription`] is validated when it is built ([`LensPrescription::new`],
//! [`LensPrescription::parse`]) and cannot be changed afterwards except
//! through methods that validate again, so the tracers and the paraxial code
//! never re-check it.

use thiserror::Error;

use crate::fresnel::Coating;
use crate::glass::{Glass, LAMBDA_D_NM, VISIBLE_NM};
use crate::input::{self, InvalidInput};

/// Most surfaces a prescription may have. Photographic zooms reach about 30
/// (the Nikon 28–75 mm class zoom Hullin et al. render has 27 interfaces);
/// 64 leaves room for the stop and larger designs, and bounds the arrays a
/// GPU twin allocates per lens.
pub const MAX_SURFACES: usize = 64;

/// Refractive indices accepted at the d line and over the visible band
/// ([`VISIBLE_NM`], 380–780 nm): from vacuum (1) to well past any optical
/// glass (the densest catalogue glasses stay below 2.1) or coating material.
pub const INDEX_RANGE: (f64, f64) = (1.0, 3.0);

/// The aperture stop must not change the medium; its indices before and
/// after (at the d line) may differ by at most this. It absorbs the
/// round-off of an index written to a lens file and read back, not genuinely
/// different glasses (which differ in the third decimal or earlier).
const STOP_MEDIUM_TOLERANCE: f64 = 1e-12;

/// One row of a lens table: a spherical (or flat) surface and what follows it.
///
/// A row is plain data; it is checked when a [`LensPrescription`] is built
/// from it, where the rows around it are known too.
#[derive(Clone, Debug, PartialEq)]
pub struct LensSurface {
    /// Curvature `c = 1/R` in 1/mm; `0` is flat. Positive: centre of curvature
    /// behind the vertex (+z), like a positive radius in a patent table.
    /// Stored as a curvature so that a flat surface is exactly `c = 0`: the
    /// `R = 1e38` some lens data uses for "flat" overflows in `f32` on the GPU.
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
    pub fn new(
        radius_mm: f64,
        thickness_after_mm: f64,
        glass_after: Glass,
        semi_aperture_mm: f64,
    ) -> Self {
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
        if self.curvature == 0.0 {
            f64::INFINITY
        } else {
            1.0 / self.curvature
        }
    }

    /// `true` when the surface is flat (`c = 0`).
    pub fn is_flat(&self) -> bool {
        self.curvature == 0.0
    }
}

/// `1/R`, with any infinite radius (either sign) mapped to exactly 0 (flat).
pub(crate) fn curvature_of_radius(radius_mm: f64) -> f64 {
    if radius_mm.is_infinite() {
        0.0
    } else {
        1.0 / radius_mm
    }
}

/// A validated sequential lens system: surfaces front to back, with where
/// it came from.
///
/// Convention (the patent-table one): surface `k` is followed by
/// `thickness_after_mm` of `glass_after`; the medium in front of surface 0
/// is air (object space). The vertex of surface 0 is at z = 0, the optical
/// axis is +z and light travels towards +z. Lengths are in mm.
///
/// Every value of this type satisfies the bounds listed on
/// [`PrescriptionError`]: 1 to [`MAX_SURFACES`] surfaces, exactly one flat,
/// uncoated stop that does not change the medium, finite positive
/// semi-apertures, non-negative thicknesses, caps no deeper than a
/// hemisphere, and glasses with an index in [`INDEX_RANGE`] over the visible
/// band. The fields are private; [`Self::new`], [`Self::parse`] and the
/// methods that return a changed copy ([`Self::edited`], [`Self::scaled`],
/// [`Self::with_coating_everywhere`], [`Self::with_design`]) check them.
#[derive(Clone, Debug, PartialEq)]
pub struct LensPrescription {
    name: String,
    source: String,
    surfaces: Vec<LensSurface>,
    design_focal_length_mm: Option<f64>,
    design_f_number: Option<f64>,
    stop: usize,
}

/// Why a prescription is not a usable lens system.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum PrescriptionError {
    /// A number of the lens as a whole (its design focal length or
    /// f-number) that is not finite or out of range.
    #[error(transparent)]
    Input(#[from] InvalidInput),
    /// A number of one surface that is not finite or out of range: its
    /// curvature, thickness (>= 0), semi-aperture (> 0), the refractive index
    /// after it at the d line (in [`INDEX_RANGE`]), or its coating's index
    /// (in [`INDEX_RANGE`]) or thickness (>= 0 nm).
    #[error("surface {surface}: {input}")]
    Surface {
        /// Index of the surface (0-based).
        surface: usize,
        /// The number and what it had to be.
        #[source]
        input: InvalidInput,
    },
    /// Fewer than 1 or more than [`MAX_SURFACES`] surfaces.
    #[error("a lens needs 1..={MAX_SURFACES} surfaces, got {count}")]
    SurfaceCount {
        /// Number of surfaces given.
        count: usize,
    },
    /// Not exactly one aperture stop.
    #[error("a lens needs exactly one aperture stop, got {count}")]
    StopCount {
        /// Number of surfaces marked as stop.
        count: usize,
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
    #[error(
        "surface {surface}: the aperture stop must not change the medium (index {before} before, {after} after)"
    )]
    StopChangesMedium {
        /// Index of the stop.
        surface: usize,
        /// Index before, at the d line.
        before: f64,
        /// Index after, at the d line.
        after: f64,
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
}

impl PrescriptionError {
    /// The surface the error is about, if it is about one.
    pub fn surface(&self) -> Option<usize> {
        use PrescriptionError::*;
        match self {
            Surface { surface, .. }
            | HemispherePlus { surface, .. }
            | IndexOverVisible { surface, .. }
            | StopNotFlat { surface, .. }
            | StopChangesMedium { surface, .. }
            | CoatedStop { surface } => Some(*surface),
            Input(_) | SurfaceCount { .. } | StopCount { .. } | Text { .. } => None,
        }
    }
}

impl LensPrescription {
    /// A prescription of `surfaces` (front to back), named `name` and citing
    /// `source` (normally a patent), if it satisfies every bound listed on
    /// [`PrescriptionError`]; the first violation found (front to back) is
    /// returned otherwise.
    pub fn new(
        name: impl Into<String>,
        source: impl Into<String>,
        surfaces: Vec<LensSurface>,
    ) -> Result<Self, PrescriptionError> {
        let stop = check(&surfaces)?;
        let (name, source) = (name.into(), source.into());
        for (field, text) in [("name", &name), ("source", &source)] {
            if text.contains(['\n', '\r', '#']) {
                return Err(PrescriptionError::Text { field });
            }
        }
        Ok(Self {
            name,
            source,
            surfaces,
            design_focal_length_mm: None,
            design_f_number: None,
            stop,
        })
    }

    /// The same lens with the focal length (mm) and f-number its source
    /// states (`None`: not stated). They are documentation, compared with the
    /// paraxial values by tests; nothing traces with them.
    pub fn with_design(
        mut self,
        focal_length_mm: Option<f64>,
        f_number: Option<f64>,
    ) -> Result<Self, PrescriptionError> {
        if let Some(f) = focal_length_mm {
            input::positive("design focal length (mm)", f)?;
        }
        if let Some(n) = f_number {
            input::positive("design f-number", n)?;
        }
        self.design_focal_length_mm = focal_length_mm;
        self.design_f_number = f_number;
        Ok(self)
    }

    /// Human-readable name ("Brendel Tessar").
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Citation of the source, normally a patent ("US 2,854,889, example table").
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Surfaces front (object side) to back.
    pub fn surfaces(&self) -> &[LensSurface] {
        &self.surfaces
    }

    /// Focal length the source states, in mm, if it states one.
    pub fn design_focal_length_mm(&self) -> Option<f64> {
        self.design_focal_length_mm
    }

    /// f-number the source states, if it states one.
    pub fn design_f_number(&self) -> Option<f64> {
        self.design_f_number
    }

    /// Index of the aperture stop in [`Self::surfaces`].
    pub fn stop_index(&self) -> usize {
        self.stop
    }

    /// Semi-aperture of the aperture stop, mm.
    pub fn stop_semi_aperture_mm(&self) -> f64 {
        self.surfaces[self.stop].semi_aperture_mm
    }

    /// Indices of the Fresnel interfaces: every surface but the stop.
    pub fn interfaces(&self) -> Vec<usize> {
        (0..self.surfaces.len())
            .filter(|&k| k != self.stop)
            .collect()
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
        if k == 0 {
            Some(Glass::Air)
        } else {
            self.surfaces.get(k - 1).map(|s| s.glass_after)
        }
    }

    /// A copy with its surfaces changed by `edit` (name, source and design
    /// values kept), validated again.
    pub fn edited(
        &self,
        edit: impl FnOnce(&mut Vec<LensSurface>),
    ) -> Result<Self, PrescriptionError> {
        let mut surfaces = self.surfaces.clone();
        edit(&mut surfaces);
        let stop = check(&surfaces)?;
        Ok(Self {
            surfaces,
            stop,
            ..self.clone()
        })
    }

    /// The same lens with `coating` on every interface (not on the stop), as
    /// Hullin et al. assume a single quarter-wave layer on every surface. A
    /// coating with an index outside [`INDEX_RANGE`] or a negative thickness
    /// is a [`PrescriptionError::Surface`].
    pub fn with_coating_everywhere(&self, coating: Coating) -> Result<Self, PrescriptionError> {
        let stop = self.stop;
        self.edited(|surfaces| {
            for (k, s) in surfaces.iter_mut().enumerate() {
                if k != stop {
                    s.coating = Some(coating);
                }
            }
        })
    }

    /// The same lens with every length multiplied by `factor` (finite, > 0):
    /// patent tables normalised to F = 1 are scaled to a focal length this way.
    pub fn scaled(&self, factor: f64) -> Result<Self, PrescriptionError> {
        let factor = input::positive("scale factor", factor)?;
        let mut p = self.edited(|surfaces| {
            for s in surfaces {
                s.curvature /= factor;
                s.thickness_after_mm *= factor;
                s.semi_aperture_mm *= factor;
            }
        })?;
        p.design_focal_length_mm = match self.design_focal_length_mm {
            Some(f) => Some(input::positive("design focal length (mm)", f * factor)?),
            None => None,
        };
        Ok(p)
    }
}

/// Checks every bound listed on [`PrescriptionError`] for `surfaces` and
/// returns the index of the stop.
fn check(surfaces: &[LensSurface]) -> Result<usize, PrescriptionError> {
    let count = surfaces.len();
    if !(1..=MAX_SURFACES).contains(&count) {
        return Err(PrescriptionError::SurfaceCount { count });
    }
    let stops = surfaces.iter().filter(|s| s.is_stop).count();
    if stops != 1 {
        return Err(PrescriptionError::StopCount { count: stops });
    }
    let mut index_before = 1.0; // object space is air
    for (k, s) in surfaces.iter().enumerate() {
        let at = |input: InvalidInput| PrescriptionError::Surface { surface: k, input };
        input::finite("curvature (1/mm)", s.curvature).map_err(at)?;
        input::non_negative("thickness (mm)", s.thickness_after_mm).map_err(at)?;
        input::positive("semi-aperture (mm)", s.semi_aperture_mm).map_err(at)?;
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
        let (lo, hi) = INDEX_RANGE;
        input::in_range(
            "refractive index after the surface at the d line",
            index,
            lo,
            hi,
        )
        .map_err(at)?;
        if let Some((wavelength_nm, index)) =
            s.glass_after
                .first_bad_index(VISIBLE_NM.0, VISIBLE_NM.1, lo, hi)
        {
            return Err(PrescriptionError::IndexOverVisible {
                surface: k,
                wavelength_nm,
                index,
            });
        }
        if s.is_stop {
            if s.curvature != 0.0 {
                return Err(PrescriptionError::StopNotFlat {
                    surface: k,
                    curvature: s.curvature,
                });
            }
            if (index - index_before).abs() > STOP_MEDIUM_TOLERANCE {
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
        if let Some(c) = &s.coating {
            // A Coating's own constructor checked the thickness; the index
            // must also lie in the range this module accepts for glass.
            input::in_range("coating index", c.index(), lo, hi).map_err(at)?;
        }
        index_before = index;
    }
    Ok(surfaces
        .iter()
        .position(|s| s.is_stop)
        .expect("exactly one stop, counted above"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::Expected;

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
        assert_eq!(p.stop_index(), 0);
        assert_eq!(p.stop_semi_aperture_mm(), 5.0);
        assert_eq!(p.interfaces(), vec![1, 2]);
        assert_eq!(p.vertex_z(), vec![0.0, 2.0, 6.0]);
        assert_eq!(p.table_image_z(), 51.0);
        assert_eq!(
            (p.name(), p.source(), p.surfaces().len()),
            ("singlet", "test", 3)
        );
    }

    /// The error `LensPrescription::new` gives for the singlet changed by `f`.
    fn error_of(f: impl FnOnce(&mut Vec<LensSurface>)) -> PrescriptionError {
        let mut s = singlet();
        f(&mut s);
        LensPrescription::new("x", "y", s).unwrap_err()
    }

    /// `(surface, what, expected)` of a `PrescriptionError::Surface`.
    fn surface_input(e: &PrescriptionError) -> Option<(usize, &'static str, Expected)> {
        match e {
            PrescriptionError::Surface { surface, input } => {
                Some((*surface, input.what, input.expected))
            }
            _ => None,
        }
    }

    #[test]
    fn bounds_are_enforced() {
        use PrescriptionError as E;
        assert_eq!(error_of(|s| s.clear()), E::SurfaceCount { count: 0 });
        assert_eq!(
            error_of(|s| {
                let last = s[2].clone();
                s.resize(MAX_SURFACES + 1, last);
            }),
            E::SurfaceCount {
                count: MAX_SURFACES + 1
            }
        );
        assert_eq!(
            error_of(|s| s[0].is_stop = false),
            E::StopCount { count: 0 }
        );
        assert_eq!(error_of(|s| s[1].is_stop = true), E::StopCount { count: 2 });
        let range = Expected::Range {
            min: INDEX_RANGE.0,
            max: INDEX_RANGE.1,
        };
        for (edit, want) in [
            (
                Box::new(|s: &mut Vec<LensSurface>| s[1].semi_aperture_mm = 0.0)
                    as Box<dyn Fn(&mut Vec<LensSurface>)>,
                (1, "semi-aperture (mm)", Expected::Positive),
            ),
            (
                Box::new(|s| s[2].thickness_after_mm = -1.0),
                (2, "thickness (mm)", Expected::NonNegative),
            ),
            (
                Box::new(|s| s[1].curvature = f64::NAN),
                (1, "curvature (1/mm)", Expected::Finite),
            ),
            (
                Box::new(|s| s[1].thickness_after_mm = f64::INFINITY),
                (1, "thickness (mm)", Expected::NonNegative),
            ),
            (
                Box::new(|s| s[1].glass_after = Glass::Constant(3.5)),
                (1, "refractive index after the surface at the d line", range),
            ),
            (
                Box::new(|s| s[1].glass_after = Glass::Constant(0.9)),
                (1, "refractive index after the surface at the d line", range),
            ),
            // A layer of index 3.5 is a valid Coating but outside what a lens accepts.
            (
                Box::new(|s| s[1].coating = Some(Coating::new(3.5, 100.0).unwrap())),
                (1, "coating index", range),
            ),
        ] {
            let e = error_of(|s| edit(s));
            assert_eq!(surface_input(&e), Some(want), "{e}");
            assert_eq!(e.surface(), Some(want.0));
        }
        assert!(matches!(
            error_of(|s| s[1].curvature = 1.0 / 9.0),
            E::HemispherePlus { surface: 1, .. }
        ));
        // Fine at the d line (1.5), n(700 nm) = −2.98: rejected, naming the surface.
        assert!(matches!(
            error_of(|s| s[1].glass_after = Glass::Abbe { nd: 1.5, vd: 0.05 }),
            E::IndexOverVisible { surface: 1, .. }
        ));
        assert!(matches!(
            error_of(|s| s[1].glass_after = Glass::Sellmeier { b: [0.3, 0.0, 0.0], c: [0.25, 0.0, 0.0] }),
            E::IndexOverVisible { surface: 1, wavelength_nm, .. } if (wavelength_nm - 500.0).abs() < 1e-9
        ));
        assert!(matches!(
            error_of(|s| s[0].curvature = 0.01),
            E::StopNotFlat { surface: 0, .. }
        ));
        assert!(matches!(
            error_of(|s| s[0].glass_after = Glass::Constant(1.5)),
            E::StopChangesMedium { surface: 0, .. }
        ));
        assert_eq!(
            error_of(|s| s[0].coating = Some(Coating::quarter_wave(1.38, 550.0).unwrap())),
            E::CoatedStop { surface: 0 }
        );
        assert_eq!(
            LensPrescription::new("a\nb", "y", singlet()),
            Err(E::Text { field: "name" })
        );
        assert_eq!(
            LensPrescription::new("a", "#y", singlet()),
            Err(E::Text { field: "source" })
        );
    }

    #[test]
    fn design_values_are_checked() {
        let p = LensPrescription::new("singlet", "test", singlet()).unwrap();
        let q = p.clone().with_design(Some(100.0), None).unwrap();
        assert_eq!(
            (q.design_focal_length_mm(), q.design_f_number()),
            (Some(100.0), None)
        );
        let e = p.clone().with_design(None, Some(-2.0)).unwrap_err();
        assert!(
            matches!(e, PrescriptionError::Input(i) if i.what == "design f-number" && i.value == -2.0),
            "{e}"
        );
        assert_eq!(e.surface(), None);
        assert!(
            matches!(p.with_design(Some(f64::NAN), None), Err(PrescriptionError::Input(i)) if i.what == "design focal length (mm)")
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
    }

    #[test]
    fn hemisphere_exactly_is_allowed() {
        // |R| = semi-aperture is a full hemisphere: the limit, still a cap.
        let mut s = singlet();
        s[1].curvature = 1.0 / 10.0;
        assert!(LensPrescription::new("x", "y", s).is_ok());
    }

    #[test]
    fn changed_copies_are_validated_again() {
        let p = LensPrescription::new("s", "t", singlet())
            .unwrap()
            .with_design(Some(50.0), None)
            .unwrap();
        let q = p.scaled(2.0).unwrap();
        assert_eq!(q.surfaces()[1].radius_mm(), 100.0);
        assert_eq!(q.surfaces()[1].thickness_after_mm, 8.0);
        assert_eq!(q.surfaces()[1].semi_aperture_mm, 20.0);
        assert_eq!(
            q.surfaces()[1].glass_after,
            Glass::Constant(1.5),
            "indices are not lengths"
        );
        assert_eq!(q.design_focal_length_mm(), Some(100.0));
        assert!(
            matches!(p.scaled(0.0), Err(PrescriptionError::Input(i)) if i.what == "scale factor")
        );
        // 1e308 × 45 mm overflows the thickness to +inf: refused, not stored.
        assert!(matches!(
            p.scaled(1e308),
            Err(PrescriptionError::Surface { .. })
        ));
        // Coating: everywhere but the stop; a bad layer is refused naming the first surface.
        let c = p
            .with_coating_everywhere(Coating::quarter_wave(1.38, 550.0).unwrap())
            .unwrap();
        assert_eq!(
            c.surfaces()
                .iter()
                .map(|s| s.coating.is_some())
                .collect::<Vec<_>>(),
            [false, true, true]
        );
        let bad = p
            .with_coating_everywhere(Coating::new(0.5, 100.0).unwrap())
            .unwrap_err();
        assert_eq!(
            surface_input(&bad).map(|(k, what, _)| (k, what)),
            Some((1, "coating index"))
        );
        // edited keeps name and design values, and moves the stop index along.
        let e = p.edited(|s| s.swap(0, 1)).unwrap_err();
        assert!(
            matches!(e, PrescriptionError::StopChangesMedium { surface: 1, .. }),
            "{e}"
        );
        let moved = p
            .edited(|s| s.insert(0, LensSurface::new(f64::INFINITY, 1.0, Glass::Air, 10.0)))
            .unwrap();
        assert_eq!(
            (
                moved.stop_index(),
                moved.name(),
                moved.design_focal_length_mm()
            ),
            (1, "s", Some(50.0))
        );
    }
}
