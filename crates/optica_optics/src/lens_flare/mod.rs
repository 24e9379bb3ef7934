//! Physically based lens flare, the CPU reference (Hullin, Eisemann, Seidel,
//! Lee: *Physically-Based Real-Time Lens Flare Rendering*, SIGGRAPH 2011, as
//! explained in `papers/hullin-lens-flare-blog.txt`; the blog numbers no
//! equations, so they are cited by its section headings).
//!
//! Light from a source at infinity enters the lens as a collimated beam. A
//! *ghost* is the light that reflects twice inside the lens before reaching
//! the sensor. Each ghost is drawn by tracing a sparse regular grid of rays
//! through its path and rasterising the grid's cells with the irradiance
//! their change of area implies. This module builds that on the lens tracer
//! of [`crate::lens`] (`PreparedLens::trace_to`, `ghosts`), and checks it
//! against a brute-force reference.
//!
//! # The method's equations
//!
//! Optical media (光学媒体), Sellmeier — in [`crate::glass`]:
//! ```text
//! n(λ) = 1 + Σ_{k=1..3} B_k λ² / (λ² − C_k)
//! ```
//! Reflection and transmission (光の反射と透過), unpolarised Fresnel with equal
//! s and p power — in [`crate::fresnel`]:
//! ```text
//! R = ½ ((n1 cosθ1 − n2 cosθ2)/(n1 cosθ1 + n2 cosθ2))² + ½ ((n1 cosθ2 − n2 cosθ1)/(n1 cosθ2 + n2 cosθ1))²,   T = 1 − R
//! ```
//! Anti-reflection coating (反射防止膜): a quarter-wave layer, thickness
//! `λ0 / (4 n_c)` (the blog's `c_thickness = lambda / 4 / n1`); reflectance
//! from the exact single-layer thin-film formula ([`crate::fresnel::Coating`]).
//!
//! Ghost enumeration (ゴーストの列挙): only even numbers of reflections make
//! ghosts; higher than two are ignored, so `n` Fresnel interfaces give
//! ```text
//! N_ghosts = n (n − 1) / 2           (Tessar n = 7: 21; double Gauss n = 14: 91)
//! ```
//! Ray tracing (光束追跡): the sequence of surfaces of a ghost is known, so no
//! acceleration structure; a line meets a sphere where
//! `t² + 2 B t + C = 0` (`B = q·d`, `C = |q|² − r²`, unit `d`), taken on the cap
//! through the vertex. The blog writes that root `t = √(B² − C)·sgn(r·d_z) − B`
//! for light travelling −z (Hullin's convention); here light travels +z, and
//! the same cap is
//! ```text
//! t = √(B² − C)·sgn(−R·d_z) − B      (R > 0, d_z > 0: the nearer root)
//! ```
//! (test `blog_root_in_this_crates_convention`), computed in
//! [`crate::surface`] in a cancellation-free form with curvature `c = 1/R`
//! (flat is `c = 0`). At every hit
//! ```text
//! r_rel ← max(r_rel, r / r_surface)
//! ```
//! and a ray with `r_rel > 1` is *not* discarded: it keeps going on the
//! continued spheres so the grid stays continuous, and is clipped per pixel.
//!
//! Grid and intensity (ラスタライズ・シェーディング, ゴーストの強度計算): rays on a
//! regular grid over the pupil keep their grid neighbours on the sensor; a
//! cell of pupil area `A_p` (beam cross-section) that lands on a quad of
//! area `A_s` has irradiance
//! ```text
//! I = S_base / Σ S_n   →   I_cell = T̄ · A_p / max(A_s, A_p / G)
//! ```
//! with `T̄` the mean throughput of its four rays and `G` the gain bound
//! ([`intensity`] documents folded and degenerate cells, and why we use
//! signed shoelace areas instead of the blog's Bretschneider formula).
//!
//! Per pixel the aperture-plane position (of every stop crossing: three for a
//! ghost reflecting behind and then in front of the stop) and `r_rel` are
//! interpolated over the quad and the pixel is dropped outside the aperture
//! shape at any crossing or where `r_rel > 1` ([`raster`]).
//!
//! Dispersion: everything above is per wavelength — the indices `n(λ)` and
//! the coating reflectance change, so a ghost moves and changes colour
//! ([`trace_grid_spectral`]).
//!
//! Not here: the diffraction textures (starburst by the Fraunhofer integral
//! `I = ∫ (1/(λ z0))² |F[T]|² dλ`, ghost ringing by the fractional Fourier /
//! angular spectrum `H = exp(i 2π w z)`) — they are image-space textures of
//! the plugin, not ray optics; and the paper's speed-ups (beam bounding,
//! adaptive grids, symmetry) other than intensity culling.
//!
//! # Files
//!
//! | file | what |
//! |---|---|
//! | [`pupil`] | light direction, pupil square, the collimated [`Beam`] |
//! | [`grid_trace`] | N×N ray grid through one ghost at one wavelength: [`trace_grid`] |
//! | [`intensity`] | cell irradiance from area change, bounded gain, folds |
//! | [`raster`] | sensor histograms, exact-coverage rasteriser with per-pixel clip |
//! | [`mod@reference`] | brute-force ghost image, image errors |
//! | [`ghosts`] | per-ghost intensity estimates, sorting, culling |
//! | [`aperture`] | stop shape (round or bladed), stopping down |
//! | [`coating`] | AR coating on glass–air surfaces only |
//!
//! # Example
//!
//! ```
//! use optica_optics::lens::{builtin, PreparedLens, TracePath};
//! use optica_optics::lens_flare::*;
//! use optica_optics::fresnel::Coating;
//!
//! let lens = coat_air_interfaces(&builtin::tessar(), Coating::quarter_wave(1.38, 550.0));
//! let light = light_from_field(10.0, 0.0);
//! let aperture = Aperture::of_stop(&lens);
//! // The brightest ghosts first.
//! let ranked = estimate_ghosts(&lens, light, 550.0, &aperture, &EstimateOptions::default()).unwrap();
//! let kept = cull(&ranked, 0.01).unwrap();
//! // Trace and draw the brightest one with a 16×16 grid.
//! let path = kept[0].path;
//! let prepared = PreparedLens::new(&lens, 550.0).unwrap();
//! let beam = Beam::for_path(&lens, path, light, 550.0).unwrap();
//! let grid = trace_grid(&prepared, path, &beam, 16, &GridOptions::default()).unwrap();
//! let window = SensorWindow::new(glam::DVec2::new(-18.0, -12.0), 0.25, 144, 96).unwrap();
//! let image = rasterise(&grid, &aperture, window);
//! assert!(image.power.iter().all(|p| p.is_finite() && *p >= 0.0));
//! ```

pub mod aperture;
pub mod coating;
pub mod error;
pub mod ghosts;
pub mod grid_trace;
pub mod intensity;
pub mod pupil;
pub mod raster;
pub mod reference;

pub use aperture::{Aperture, ApertureShape, stopped_down};
pub use coating::coat_air_interfaces;
pub use error::FlareError;
pub use ghosts::{EstimateOptions, GhostEstimate, cull, estimate_ghost, estimate_ghosts};
pub use grid_trace::{GridOptions, GridStats, MAX_GRID, RayGrid, trace_grid, trace_grid_spectral};
pub use intensity::{CellKind, DEFAULT_MAX_GAIN, GridCell, GridRay, cell_intensity, vertex_intensities};
pub use pupil::{Beam, PupilBounds, light_direction, light_from_field};
pub use raster::{SensorImage, SensorWindow, rasterise, rasterise_into};
pub use reference::{ImageError, ReferenceImage, compare, downsample, reference_image};

#[cfg(test)]
mod tests {
    use crate::ray::Ray;
    use crate::surface::SphericalSurface;
    use glam::DVec3;

    #[test]
    fn blog_root_in_this_crates_convention() {
        // The module docs' root for light travelling +z:
        // t = √(B² − C)·sgn(−R·d_z) − B, with q = origin − centre, B = q·d,
        // C = |q|² − R², against the tracer's cap intersection, for both
        // signs of R and of d_z. (The blog's sgn(R·d_z) picks the other
        // root in every one of these cases.)
        let vertex_z = 2.0;
        for (r, origin, dir) in [
            (40.0, DVec3::new(0.0, 5.0, -10.0), DVec3::new(0.0, 0.05, 1.0)),
            (-40.0, DVec3::new(0.0, 5.0, -10.0), DVec3::new(0.0, -0.05, 1.0)),
            (40.0, DVec3::new(0.0, 5.0, 4.0), DVec3::new(0.0, 0.05, -1.0)),
            (-40.0, DVec3::new(0.0, 5.0, 12.0), DVec3::new(0.0, 0.05, -1.0)),
        ] {
            let ray = Ray::new(origin, dir).unwrap();
            let d = ray.dir();
            let q = ray.origin() - DVec3::new(0.0, 0.0, vertex_z + r);
            let (b, c) = (q.dot(d), q.length_squared() - r * r);
            let root = |sign: f64| (b * b - c).sqrt() * sign - b;
            let hit = SphericalSurface::new(vertex_z, 1.0 / r).intersect(&ray).unwrap();
            let ours = root((-r * d.z).signum());
            assert!((ours - hit.t).abs() < 1e-9, "R = {r}, d_z = {}: {ours} vs {}", d.z, hit.t);
            let blogs = root((r * d.z).signum());
            assert!((blogs - hit.t).abs() > 1.0, "R = {r}: the blog's sign in +z travel is the far root");
        }
    }
}
