//! Physically based lens flare, the CPU twin of the lens-flare plugin and
//! its reference.
//!
//! The method is Hullin, Eisemann, Seidel and Lee, "Physically-Based
//! Real-Time Lens Flare Rendering", *ACM Transactions on Graphics* 30(4)
//! (SIGGRAPH 2011), article 108, as explained and implemented in the web
//! article by AngularSpectrumMTD, "Physically-Based Real-Time Lens Flare
//! Rendering (Matthias B. Hullin et al., Max Planck Institute for
//! Informatics, ACM, 2011)", Qiita, 25 August 2021 (in Japanese),
//! <https://qiita.com/AngularSpectrumMTD/items/aeea1046c0ec5d4dd1d5> — "the
//! blog" below. The blog numbers no equations, so it is cited by its section
//! headings, translated.
//!
//! Light from a source at infinity enters the lens as a collimated beam. A
//! *ghost* is the light that reflects twice inside the lens before reaching
//! the sensor. Each ghost is drawn by tracing a sparse regular grid of rays
//! through its path and rasterising the grid's cells with the irradiance
//! their change of area implies. This module builds that on the lens tracer
//! of [`crate::lens`] ([`PreparedLens::trace_to`], [`crate::lens::ghosts`]).
//! Lengths are in mm, wavelengths in nm, in the lens frame of
//! [`crate::lens`] (+z from object to sensor).
//!
//! # The method's equations
//!
//! *Optical media*: Sellmeier's dispersion formula, in [`crate::glass`]:
//! ```text
//! n(λ) = 1 + Σ_{k=1..3} B_k λ² / (λ² − C_k)
//! ```
//! *Reflection and transmission of light (the Fresnel equations)*:
//! unpolarised, with equal s and p power, in [`crate::fresnel`]:
//! ```text
//! R = ½ ((n1 cosθ1 − n2 cosθ2)/(n1 cosθ1 + n2 cosθ2))² + ½ ((n1 cosθ2 − n2 cosθ1)/(n1 cosθ2 + n2 cosθ1))²,   T = 1 − R
//! ```
//! *Anti-reflection coating*: a quarter-wave layer, thickness `λ0 / (4 n_c)`
//! (the blog's `c_thickness = lambda / 4 / n1`); its reflectance is the exact
//! single-layer thin-film formula ([`Coating`]), not the two-beam sum of the
//! paper's supplement, which squares one interface's transmission
//! coefficient, `R = (r01 − t01² r12)²`, where the round trip through the
//! layer is `t01 · t10`, and so overestimates the reflectance.
//!
//! *Ghost enumeration*: only even numbers of reflections make ghosts, and
//! those of more than two are too faint to draw, so `n` Fresnel interfaces
//! give
//! ```text
//! N_ghosts = n (n − 1) / 2           (Tessar n = 7: 21; double Gauss n = 14: 91)
//! ```
//! *Ray-bundle tracing*: the sequence of surfaces of a ghost is known, so no
//! acceleration structure; a line meets a sphere where
//! `t² + 2 B t + C = 0` (`B = q·d`, `C = |q|² − r²`, unit `d`), taken on the
//! cap through the vertex. The blog writes that root
//! `t = √(B² − C)·sgn(r·d_z) − B` for light travelling −z (Hullin's
//! convention); here light travels +z, and the same cap is
//! ```text
//! t = √(B² − C)·sgn(−R·d_z) − B      (R > 0, d_z > 0: the nearer root)
//! ```
//! computed in [`crate::surface`] in a cancellation-free form with
//! curvature `c = 1/R` (flat is `c = 0`). At every hit
//! ```text
//! r_rel ← max(r_rel, r / r_surface)
//! ```
//! and a ray with `r_rel > 1` is *not* discarded: it keeps going on the
//! continued spheres so the grid stays continuous, and is clipped per pixel.
//!
//! *Rasterisation and shading*, *Computing ghost intensity*: rays on a
//! regular grid over the pupil keep their grid neighbours on the sensor; a
//! cell of pupil area `A_p` (beam cross-section) that lands on a quad of
//! area `A_s` has irradiance
//! ```text
//! I = S_base / Σ S_n   →   I_cell = T̄ · A_p / max(A_s, A_p / G)
//! ```
//! with `T̄` the mean throughput of its four rays and `G` the gain bound
//! ([`cell_intensity`] documents folded and degenerate cells, and why we use
//! signed shoelace areas instead of the blog's Bretschneider formula).
//!
//! Per pixel the aperture-plane position (of every stop crossing: three for a
//! ghost reflecting behind and then in front of the stop) and `r_rel` are
//! interpolated over the quad and the pixel is dropped outside the aperture
//! shape ([`Aperture`]: blades, rotation, roundness; [`stopped_to_f_number`])
//! at any crossing or where `r_rel > 1`.
//!
//! Dispersion: everything above is per wavelength — the indices `n(λ)` and
//! the coating reflectance change, so a ghost moves and changes colour
//! ([`trace_grid_spectral`]). A few wavelengths carry the whole band's
//! light through per-ghost gains ([`GhostSpectrum`]).
//!
//! # What the plugin runs, and what it adds
//!
//! The plugin's compute shader is the twin of [`trace_grid`]; it enumerates
//! ghosts with [`crate::lens::ghosts`], ranks and culls them with
//! [`estimate_ghosts`] and [`cull`] (the blog's *Intensity LOD* and
//! *Aperture culling*), and bounds each ghost's beam with
//! [`PupilBounds::for_path`] (*Bundle bounding*). The paper's other
//! speed-ups — a grid size per ghost (*Adaptive resolution*, 16² to 512²)
//! and tracing at one azimuth of an axially symmetric lens (*Symmetry*) —
//! are the plugin's; a grid here has one size and is traced at the light's
//! azimuth. The diffraction textures (the starburst by the Fraunhofer
//! integral `I = ∫ (1/(λ z0))² |F[T]|² dλ`, ghost ringing by the angular
//! spectrum `H = exp(i 2π w z)`) are image-space textures of the plugin,
//! not ray optics.
//!
//! With the `reference` feature: a brute-force image of a ghost
//! (`reference_image`), the exact-coverage rasteriser of a grid
//! (`rasterise`) and image errors (`compare`), which the tests and the
//! report runner hold the grid method to.
//!
//! # Example
//!
//! ```
//! use optica_optics::lens::builtin;
//! use optica_optics::lens_flare::*;
//!
//! let lens = coat_air_interfaces(&builtin::tessar(), Coating::quarter_wave(1.38, 550.0).unwrap()).unwrap();
//! let light = light_from_field(10.0, 0.0);
//! let aperture = Aperture::blades(6, 0.0, 0.3, lens.stop_semi_aperture_mm()).unwrap();
//! // The brightest ghosts first; keep those above 1 % of the brightest.
//! let ranked = estimate_ghosts(&lens, light, 550.0, &aperture, &EstimateOptions::default()).unwrap();
//! let kept = cull(&ranked, 0.01).unwrap();
//! // Trace the brightest one with a 16×16 grid.
//! let path = kept[0].path;
//! let prepared = PreparedLens::new(&lens, 550.0).unwrap();
//! let beam = Beam::for_path(&lens, path, light, 550.0).unwrap();
//! let grid = trace_grid(&prepared, path, &beam, 16, &GridOptions::default()).unwrap();
//! let stats = grid.stats();
//! assert!(stats.alive_cells > 0 && stats.power.is_finite());
//! ```

mod adaptive;
mod aperture;
mod coating;
mod diffraction;
mod error;
mod ghosts;
mod grid_trace;
mod intensity;
mod merge;
mod pupil;
#[cfg(feature = "reference")]
mod raster;
#[cfg(feature = "reference")]
mod reference;
mod spectrum;

pub use adaptive::{grid_sizes_by_power, interpolation_error_mm};
pub use aperture::{
    Aperture, ApertureShape, MAX_APERTURE_BLADES, stopped_down, stopped_to_f_number,
};
pub use coating::coat_air_interfaces;
pub use diffraction::{
    LensDirt, MAX_DIFFRACTION_SIDE, PupilImage, Starburst, fraunhofer, pupil_image, ringing,
    starburst,
};
pub use error::FlareError;
pub use ghosts::{
    DEFAULT_ESTIMATE_SIDE, DEFAULT_MIN_SPREAD_MM2, EstimateOptions, GhostEstimate, cull,
    estimate_ghost, estimate_ghosts,
};
pub use grid_trace::{
    GridOptions, GridStats, MAX_GRID, Passing, RayGrid, passing_rect, trace_grid,
    trace_grid_spectral,
};
pub use intensity::{
    CellKind, DEFAULT_MAX_GAIN, GridCell, GridRay, cell_intensity, vertex_intensities,
};
pub use merge::merged_block;
pub use pupil::{
    Beam, ENTRANCE_PUPIL_MARGIN, MIN_LIGHT_Z, PupilBounds, PupilRect, light_direction,
    light_from_field,
};
#[cfg(feature = "reference")]
pub use raster::{MAX_PIXELS, SensorImage, SensorWindow, rasterise, rasterise_into};
#[cfg(feature = "reference")]
pub use reference::{
    ImageError, MAX_REFERENCE_SIDE, ReferenceImage, compare, downsample, reference_image,
};
pub use spectrum::{
    BAND_NM, BAND_POINTS, GhostSpectrum, MAX_SPECTRAL_GAIN, SINGLE_SAMPLE_NM, SPECTRUM_RAYS,
    SPECTRUM_SAMPLES, band_wavelengths, spectral_weight, spectrum_lenses,
};

// The types this module's signatures use, so that `lens_flare::*` is enough to call it.
pub use crate::fresnel::Coating;
pub use crate::input::InvalidInput;
pub use crate::lens::{
    LensPrescription, ParaxialError, PreparedLens, PrescriptionError, TraceError, TracePath,
};
pub use crate::ray::Ray;

#[cfg(test)]
mod tests {
    use crate::ray::Ray;
    use crate::surface::SphericalSurface;
    use glam::DVec3;

    #[test]
    fn blog_root_in_this_crates_convention() {
        // The root in the module docs, for light travelling +z:
        // t = √(B² − C)·sgn(−R·d_z) − B, with q = origin − centre, B = q·d,
        // C = |q|² − R², against the tracer's cap intersection, for both
        // signs of R and of d_z. (The blog's sgn(R·d_z) picks the other
        // root in every one of these cases.)
        let vertex_z = 2.0;
        for (r, origin, dir) in [
            (
                40.0,
                DVec3::new(0.0, 5.0, -10.0),
                DVec3::new(0.0, 0.05, 1.0),
            ),
            (
                -40.0,
                DVec3::new(0.0, 5.0, -10.0),
                DVec3::new(0.0, -0.05, 1.0),
            ),
            (40.0, DVec3::new(0.0, 5.0, 4.0), DVec3::new(0.0, 0.05, -1.0)),
            (
                -40.0,
                DVec3::new(0.0, 5.0, 12.0),
                DVec3::new(0.0, 0.05, -1.0),
            ),
        ] {
            let ray = Ray::new(origin, dir).unwrap();
            let d = ray.dir();
            let q = ray.origin() - DVec3::new(0.0, 0.0, vertex_z + r);
            let (b, c) = (q.dot(d), q.length_squared() - r * r);
            let root = |sign: f64| (b * b - c).sqrt() * sign - b;
            let hit = SphericalSurface::new(vertex_z, 1.0 / r)
                .unwrap()
                .intersect(&ray)
                .unwrap();
            let ours = root((-r * d.z).signum());
            assert!(
                (ours - hit.t).abs() < 1e-9,
                "R = {r}, d_z = {}: {ours} vs {}",
                d.z,
                hit.t
            );
            let blogs = root((r * d.z).signum());
            assert!(
                (blogs - hit.t).abs() > 1.0,
                "R = {r}: the blog's sign in +z travel is the far root"
            );
        }
    }
}
