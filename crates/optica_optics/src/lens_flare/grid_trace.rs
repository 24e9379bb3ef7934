//! Tracing a regular N×N grid of parallel rays through one ghost at one
//! wavelength: the CPU twin of the plugin's grid-trace shader, documented on
//! [`trace_grid`].

use glam::DVec2;
use rayon::prelude::*;

use super::FlareError;
use super::aperture::Aperture;
use super::intensity::{CellKind, DEFAULT_MAX_GAIN, GridCell, GridRay, cell_intensity};
use super::pupil::{Beam, PupilRect};
use crate::input::{self, Expected, InvalidInput};
use crate::lens::{LensPrescription, MAX_STOP_CROSSINGS, PreparedLens, TracePath};

/// Most rays per side of a grid: 1024² ≈ 10⁶ rays, about 100 MB of
/// [`GridRay`]s and [`GridCell`]s. Hullin et al.'s adaptive resolution goes
/// up to 512² per ghost (the blog's *Adaptive resolution*); 1024 leaves a
/// factor of two for references and convergence studies.
pub const MAX_GRID: usize = 1024;

/// Settings of a grid trace, checked by the functions that take them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridOptions {
    /// z of the sensor plane in the lens frame, mm (finite); `None` = the
    /// table's image plane.
    pub sensor_z: Option<f64>,
    /// Bound `G` on a cell's area gain (finite, >= 1; see [`cell_intensity`]).
    pub max_gain: f64,
}

impl Default for GridOptions {
    fn default() -> Self {
        Self {
            sensor_z: None,
            max_gain: DEFAULT_MAX_GAIN,
        }
    }
}

/// A traced grid: `n × n` rays and `(n−1) × (n−1)` cells, row-major
/// (`u` = column along +x of the pupil, `v` = row along +y). Made by
/// [`trace_grid`]; read-only, so its rays and cells always match its size.
#[derive(Clone, Debug, PartialEq)]
pub struct RayGrid {
    n: usize,
    path: TracePath,
    wavelength_nm: f64,
    cell_pupil_mm2: f64,
    rays: Vec<GridRay>,
    cells: Vec<GridCell>,
}

/// Counts and sums over a grid.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GridStats {
    /// Rays that reached the sensor.
    pub alive_rays: usize,
    /// Cells with four live rays.
    pub alive_cells: usize,
    /// Cells with a caustic fold inside ([`CellKind::Folded`]).
    pub folded_cells: usize,
    /// Live cells whose orientation differs from the majority's: a fold runs
    /// along grid lines between them and their neighbours.
    pub flipped_cells: usize,
    /// Cells where the gain bound was active.
    pub clamped_cells: usize,
    /// `Σ intensity × sensor area` over live cells (before per-pixel clipping).
    pub power: f64,
    /// `Σ A_p · T̄` over live cells: what `power` is without the gain bound.
    pub unclamped_power: f64,
}

impl RayGrid {
    /// This grid turned by `angle_rad` about the axis: every sensor and
    /// stop point rotated (the CPU twin of the plugin's symmetry, which
    /// traces a light turned into the x–z plane and turns the result back
    /// to the light's azimuth; see `Beam::meridional`).
    pub fn turned(&self, angle_rad: f64) -> Self {
        let rot = glam::DVec2::from_angle(angle_rad);
        let rays = self
            .rays
            .iter()
            .map(|r| GridRay {
                sensor: rot.rotate(r.sensor),
                stop_xy: r.stop_xy.map(|p| rot.rotate(p)),
                ..*r
            })
            .collect();
        Self {
            wavelength_nm: self.wavelength_nm,
            ..Self::from_rays(self.n, self.path, self.cell_pupil_mm2, rays)
        }
    }

    /// This grid with every dead ray that has live neighbours replaced by
    /// their straight-line continuation: from each side where the next two
    /// rays of its row or column were traced alive, `2·a − b` of their
    /// sensor points, stop points and `r_rel` (the throughput of `a`),
    /// averaged over those sides, with `r_rel` raised to the stop points'
    /// `|p| / stop_semi_aperture_mm` where that is larger; a ray with no
    /// such side stays dead. The CPU twin of the plugin's fill pass
    /// (`ghost_trace.wgsl`).
    ///
    /// Why: a ray that misses a sphere (no real intersection) or meets
    /// total internal reflection dies, and every cell it is a corner of
    /// goes undrawn, though the part of the cell nearer the live rays
    /// passes. With a coarse grid those cells held much of a ghost's edge:
    /// the double Gauss's ghosts on fitted 9² grids lost 12 % of their
    /// power (3 % at 16²). Continued, the dead corner usually lands beyond
    /// a rim (`r_rel > 1`), and the per-pixel clip cuts the cell where the
    /// light stops (+1.6 % at 9², +0.3 % at 16²). A traced ray's `r_rel`
    /// holds the stop's rim, so that a round iris needs no test of its own
    /// per pixel; a continued one's would not (a straight-line `r_rel` can
    /// fall below its stop point's), hence the raise. Cells are recomputed
    /// with the default gain bound, as [`RayGrid::turned`] does.
    pub fn extrapolated(&self, stop_semi_aperture_mm: f64) -> Self {
        let n = self.n;
        let traced = |i: i64, j: i64| -> Option<&GridRay> {
            let inside = (0..n as i64).contains(&i) && (0..n as i64).contains(&j);
            inside
                .then(|| &self.rays[j as usize * n + i as usize])
                .filter(|r| r.alive)
        };
        let mut rays = self.rays.clone();
        for (k, ray) in rays.iter_mut().enumerate().filter(|(_, r)| !r.alive) {
            let (i, j) = ((k % n) as i64, (k / n) as i64);
            let mut sum: Option<(GridRay, f64)> = None;
            for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1)] {
                let (Some(a), Some(b)) = (traced(i + di, j + dj), traced(i + 2 * di, j + 2 * dj))
                else {
                    continue;
                };
                let (sensor, r_rel) = (2.0 * a.sensor - b.sensor, 2.0 * a.r_rel - b.r_rel);
                let stop: [DVec2; MAX_STOP_CROSSINGS] =
                    std::array::from_fn(|c| 2.0 * a.stop_xy[c] - b.stop_xy[c]);
                sum = Some(match sum {
                    None => (
                        GridRay {
                            alive: true,
                            sensor,
                            r_rel,
                            stop_xy: stop,
                            throughput: a.throughput,
                        },
                        1.0,
                    ),
                    Some((s, w)) => (
                        GridRay {
                            sensor: s.sensor + sensor,
                            r_rel: s.r_rel + r_rel,
                            stop_xy: std::array::from_fn(|c| s.stop_xy[c] + stop[c]),
                            throughput: s.throughput + a.throughput,
                            ..s
                        },
                        w + 1.0,
                    ),
                });
            }
            if let Some((s, w)) = sum {
                let stop_xy = s.stop_xy.map(|p| p / w);
                let at_stop = stop_xy
                    .iter()
                    .map(|p| p.length() / stop_semi_aperture_mm)
                    .fold(0.0, f64::max);
                *ray = GridRay {
                    alive: true,
                    sensor: s.sensor / w,
                    r_rel: (s.r_rel / w).max(at_stop),
                    stop_xy,
                    throughput: s.throughput / w,
                };
            }
        }
        Self {
            wavelength_nm: self.wavelength_nm,
            ..Self::from_rays(self.n, self.path, self.cell_pupil_mm2, rays)
        }
    }

    /// A grid of `n` rays per side from its `n²` rays, computing its cells
    /// (for the crate's own tests of the rasteriser and the estimates).
    pub(crate) fn from_rays(
        n: usize,
        path: TracePath,
        cell_pupil_mm2: f64,
        rays: Vec<GridRay>,
    ) -> Self {
        assert_eq!(rays.len(), n * n);
        let m = n - 1;
        let cells = (0..m * m)
            .map(|k| {
                let (i, j) = (k % m, k / m);
                let at = |a: usize, b: usize| &rays[b * n + a];
                cell_intensity(
                    [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)],
                    cell_pupil_mm2,
                    DEFAULT_MAX_GAIN,
                )
            })
            .collect();
        Self {
            n,
            path,
            wavelength_nm: 550.0,
            cell_pupil_mm2,
            rays,
            cells,
        }
    }

    /// Rays per side.
    pub fn n(&self) -> usize {
        self.n
    }

    /// The path traced.
    pub fn path(&self) -> TracePath {
        self.path
    }

    /// Wavelength, nm.
    pub fn wavelength_nm(&self) -> f64 {
        self.wavelength_nm
    }

    /// Beam cross-section of one cell (pupil cell area × d_z), mm².
    pub fn cell_pupil_mm2(&self) -> f64 {
        self.cell_pupil_mm2
    }

    /// The `n²` rays, row-major.
    pub fn rays(&self) -> &[GridRay] {
        &self.rays
    }

    /// The `(n−1)²` cells, row-major.
    pub fn cells(&self) -> &[GridCell] {
        &self.cells
    }

    /// Ray at column `i`, row `j`; `None` outside the grid.
    pub fn ray(&self, i: usize, j: usize) -> Option<&GridRay> {
        (i < self.n && j < self.n).then(|| &self.rays[j * self.n + i])
    }

    /// Cell at column `i`, row `j`; `None` outside the grid.
    pub fn cell(&self, i: usize, j: usize) -> Option<&GridCell> {
        let m = self.n - 1;
        (i < m && j < m).then(|| &self.cells[j * m + i])
    }

    /// Corners `[00, 10, 11, 01]` of cell `(i, j)`, counter-clockwise on the
    /// pupil; `None` outside the grid.
    pub fn cell_corners(&self, i: usize, j: usize) -> Option<[&GridRay; 4]> {
        let m = self.n - 1;
        (i < m && j < m).then(|| self.corners(i, j))
    }

    /// Every cell with its corners `[00, 10, 11, 01]`, row-major.
    pub fn cells_with_corners(&self) -> impl Iterator<Item = (&GridCell, [&GridRay; 4])> {
        let m = self.n - 1;
        self.cells
            .iter()
            .enumerate()
            .map(move |(k, c)| (c, self.corners(k % m, k / m)))
    }

    /// Corners of cell `(i, j)`, which must be in the grid.
    fn corners(&self, i: usize, j: usize) -> [&GridRay; 4] {
        let at = |a: usize, b: usize| &self.rays[b * self.n + a];
        [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]
    }

    /// Counts and power sums.
    pub fn stats(&self) -> GridStats {
        let mut s = GridStats {
            alive_rays: self.rays.iter().filter(|r| r.alive).count(),
            ..Default::default()
        };
        let (mut pos, mut neg) = (0usize, 0usize);
        for c in &self.cells {
            if c.kind == CellKind::Dead {
                continue;
            }
            s.alive_cells += 1;
            s.power += c.power();
            s.unclamped_power += c.mean_throughput * self.cell_pupil_mm2;
            s.clamped_cells += c.clamped as usize;
            match c.kind {
                CellKind::Folded => s.folded_cells += 1,
                CellKind::Regular => pos += 1,
                CellKind::Mirrored => neg += 1,
                CellKind::Dead => {}
            }
        }
        s.flipped_cells = pos.min(neg);
        s
    }

    /// Throughput-weighted centroid of the live rays on the sensor that pass
    /// `r_rel <= 1`, or `None` when none does.
    pub fn centroid(&self) -> Option<DVec2> {
        let (mut w, mut c) = (0.0, DVec2::ZERO);
        for r in self.rays.iter().filter(|r| r.alive && r.r_rel <= 1.0) {
            w += r.throughput;
            c += r.throughput * r.sensor;
        }
        (w > 0.0).then(|| c / w)
    }
}

/// `n` if it is in `min..=max`, else an [`InvalidInput`] naming `what`.
pub(crate) fn count_in(
    what: &'static str,
    n: usize,
    min: usize,
    max: usize,
) -> Result<usize, InvalidInput> {
    if (min..=max).contains(&n) {
        Ok(n)
    } else {
        Err(InvalidInput::new(
            what,
            n as f64,
            Expected::Range {
                min: min as f64,
                max: max as f64,
            },
        ))
    }
}

/// Traces one ray of a grid; rays that die in the lens become [`GridRay::DEAD`].
pub(crate) fn trace_one(
    lens: &PreparedLens,
    path: TracePath,
    beam: &Beam,
    u: f64,
    v: f64,
    sensor_z: f64,
) -> GridRay {
    match lens.trace_to(beam.grid_ray(u, v), path, sensor_z) {
        Ok(r) if r.position.is_finite() && r.r_rel.is_finite() && r.throughput.is_finite() => {
            GridRay {
                alive: true,
                sensor: r.position.truncate(),
                r_rel: r.r_rel,
                stop_xy: r.stop_xy_all,
                throughput: r.throughput,
            }
        }
        _ => GridRay::DEAD,
    }
}

/// Checks everything a trace needs that does not depend on the ray, once
/// per grid: the path, the sensor z (finite) and the gain bound (finite,
/// >= 1). Returns the sensor z.
pub(crate) fn check_setup(
    lens: &PreparedLens,
    path: TracePath,
    options: &GridOptions,
) -> Result<f64, FlareError> {
    lens.check_path(path)?;
    let sensor_z = input::finite(
        "sensor z (mm)",
        options.sensor_z.unwrap_or(lens.table_sensor_z()),
    )?;
    input::in_range("max gain", options.max_gain, 1.0, f64::INFINITY)?;
    Ok(sensor_z)
}

/// Traces an `n × n` grid (`n` in 2..=[`MAX_GRID`]) of `beam` through
/// `path` of `lens` (at the lens's wavelength) and computes every cell's
/// irradiance. Rays run in parallel (rayon).
///
/// Each ray records its sensor position, `r_rel`, stop-plane positions and
/// throughput ([`GridRay`]); each cell of four neighbouring rays gets its
/// irradiance from its change of area ([`cell_intensity`]). Rays outside a
/// semi-aperture are not discarded (the blog's *Ray-bundle tracing*: rays
/// with `r_rel > 1` are "left as they are", i.e. not discarded in the
/// shader), so the grid stays continuous and the clip happens per pixel.
/// Rays that miss a sphere or meet total internal reflection die: their
/// cells are dead.
pub fn trace_grid(
    lens: &PreparedLens,
    path: TracePath,
    beam: &Beam,
    n: usize,
    options: &GridOptions,
) -> Result<RayGrid, FlareError> {
    count_in("grid rays per side", n, 2, MAX_GRID)?;
    let sensor_z = check_setup(lens, path, options)?;
    let step = 1.0 / (n - 1) as f64;
    let rays: Vec<GridRay> = (0..n * n)
        .into_par_iter()
        .map(|k| {
            trace_one(
                lens,
                path,
                beam,
                (k % n) as f64 * step,
                (k / n) as f64 * step,
                sensor_z,
            )
        })
        .collect();
    let m = n - 1;
    let cell_pupil_mm2 = beam.cross_section_mm2() / (m * m) as f64;
    let at = |i: usize, j: usize| &rays[j * n + i];
    let cells: Vec<GridCell> = (0..m * m)
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k % m, k / m);
            cell_intensity(
                [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)],
                cell_pupil_mm2,
                options.max_gain,
            )
        })
        .collect();
    Ok(RayGrid {
        n,
        path,
        wavelength_nm: lens.wavelength_nm(),
        cell_pupil_mm2,
        rays,
        cells,
    })
}

/// Where the light of a ghost gets through ([`passing_rect`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Passing {
    /// On the beam's pupil plane, mm.
    pub pupil: PupilRect,
    /// Where those rays land on the sensor, mm (the passing rays' extent,
    /// not grown).
    pub sensor: PupilRect,
}

impl Passing {
    /// The smallest rectangles holding both.
    pub fn union(self, other: Self) -> Self {
        Self {
            pupil: self.pupil.union(other.pupil),
            sensor: self.sensor.union(other.sensor),
        }
    }
}

/// Where on the pupil plane the light of `path` gets through: the
/// rectangle holding every ray of an `n × n` grid over `beam`'s square
/// that [passes](GridRay::passes) `aperture`, grown by one grid step on
/// each side (light between a passing ray and its blocked neighbour
/// passes too) and clipped to the square, and where those rays land on the
/// sensor; `None` when no ray passes.
///
/// A ghost's grid traced over this rectangle ([`Beam::within`]) instead of
/// the whole square spends its rays where the ghost is (the blog's
/// *Bundle bounding*, measured instead of bounded: wide open, 15 % of a
/// double Gauss ghost's square passes). A coarse grid can miss a sliver
/// of light narrower than its step.
pub fn passing_rect(
    lens: &PreparedLens,
    path: TracePath,
    beam: &Beam,
    aperture: &Aperture,
    n: usize,
) -> Result<Option<Passing>, FlareError> {
    let grid = trace_grid(lens, path, beam, n, &GridOptions::default())?;
    let step = 1.0 / (n - 1) as f64;
    let mut found: Option<(PupilRect, PupilRect)> = None;
    for (k, ray) in grid.rays().iter().enumerate() {
        if ray.passes(aperture) {
            let at = DVec2::new((k % n) as f64, (k / n) as f64) * step;
            let here = (
                PupilRect { min: at, max: at },
                PupilRect {
                    min: ray.sensor,
                    max: ray.sensor,
                },
            );
            found = Some(match found {
                Some((uv, sensor)) => (uv.union(here.0), sensor.union(here.1)),
                None => here,
            });
        }
    }
    Ok(found.map(|(uv, sensor)| {
        let lo = (uv.min - step).max(DVec2::ZERO);
        let hi = (uv.max + step).min(DVec2::ONE);
        Passing {
            pupil: PupilRect {
                min: beam.pupil_point(lo.x, lo.y),
                max: beam.pupil_point(hi.x, hi.y),
            },
            sensor,
        }
    }))
}

/// [`trace_grid`] at each of `wavelengths_nm` (dispersion: the glass indices
/// and coatings are evaluated per wavelength; the beam is the same).
pub fn trace_grid_spectral(
    prescription: &LensPrescription,
    path: TracePath,
    beam: &Beam,
    n: usize,
    options: &GridOptions,
    wavelengths_nm: &[f64],
) -> Result<Vec<RayGrid>, FlareError> {
    wavelengths_nm
        .iter()
        .map(|&wl| {
            let lens = PreparedLens::new(prescription, wl)?;
            trace_grid(&lens, path, beam, n, options)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fresnel::Coating;
    use crate::glass::{Glass, LAMBDA_D_NM};
    use crate::lens::TraceError;
    use crate::lens::{LensSurface, builtin, ghosts};
    use crate::lens_flare::pupil::{MIN_LIGHT_Z, PupilBounds, light_from_field};
    use glam::DVec3;
    use proptest::prelude::*;

    /// Stop, then a flat slab of n = 1.5 in air (as in lens::trace's tests).
    fn slab() -> LensPrescription {
        LensPrescription::new(
            "slab",
            "hand computation",
            vec![
                LensSurface::stop(5.0, Glass::Air, 20.0),
                LensSurface::new(f64::INFINITY, 10.0, Glass::Constant(1.5), 20.0),
                LensSurface::new(f64::INFINITY, 30.0, Glass::Air, 20.0),
            ],
        )
        .unwrap()
    }

    #[test]
    fn slab_ghost_has_unit_gain_and_hand_throughput() {
        // A ghost of a plane-parallel slab only shifts the beam: every cell
        // keeps its area, so I = T = 0.96² · 0.04² (Fresnel at normal
        // incidence, ((1.5−1)/(1.5+1))² = 0.04) exactly.
        let p = slab();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let bounds = PupilBounds::new(-1.0, DVec2::ZERO, 10.0).unwrap();
        let beam = Beam::new(&p, DVec3::Z, bounds).unwrap();
        let g = trace_grid(
            &lens,
            TracePath::ghost(2, 1),
            &beam,
            9,
            &GridOptions::default(),
        )
        .unwrap();
        let t = 0.96f64.powi(2) * 0.04f64.powi(2);
        for c in g.cells() {
            assert_eq!(c.kind, CellKind::Regular);
            assert!((c.intensity - t).abs() < 1e-15, "{}", c.intensity);
        }
        // Tilted light: a cell's beam cross-section is A cos θ, its sensor
        // area A (a slab translates), so I = T(θ) cos θ.
        let d = light_from_field(30.0, 0.0);
        let beam = Beam::new(&p, d, bounds).unwrap();
        let g = trace_grid(
            &lens,
            TracePath::ghost(2, 1),
            &beam,
            5,
            &GridOptions::default(),
        )
        .unwrap();
        for c in g.cells() {
            assert!((c.intensity - c.mean_throughput * d.z).abs() < 1e-12);
        }
    }

    #[test]
    fn ghost_energy_is_pupil_area_times_mean_throughput_when_nothing_folds() {
        // Coated Tessar, 10° off axis: over every ghost without folds or
        // clamps, Σ I·A_s must equal Σ A_p·T̄ (the area factors cancel), and
        // that equals the beam cross-section of the live cells times their
        // mean throughput. Checked to 1e-9 relative.
        let p = crate::lens_flare::coat_air_interfaces(
            &builtin::tessar(),
            Coating::quarter_wave(1.38, 550.0).unwrap(),
        )
        .unwrap();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let d = light_from_field(10.0, 0.0);
        let mut checked = 0;
        for (i, j) in ghosts(&p) {
            let path = TracePath::ghost(i, j);
            let beam = Beam::for_path(&p, path, d, 550.0).unwrap();
            let g = trace_grid(&lens, path, &beam, 17, &GridOptions::default()).unwrap();
            let s = g.stats();
            if s.folded_cells > 0
                || s.flipped_cells > 0
                || s.clamped_cells > 0
                || s.alive_cells == 0
            {
                continue;
            }
            let mean_t = g
                .cells()
                .iter()
                .filter(|c| c.kind != CellKind::Dead)
                .map(|c| c.mean_throughput)
                .sum::<f64>()
                / s.alive_cells as f64;
            let want = s.alive_cells as f64 * g.cell_pupil_mm2() * mean_t;
            assert!(
                (s.power / want - 1.0).abs() < 1e-9,
                "ghost ({i},{j}): {} vs {want}",
                s.power
            );
            checked += 1;
        }
        assert!(checked >= 5, "only {checked} ghosts without folds");
    }

    #[test]
    fn ghost_image_moves_with_wavelength_only_for_dispersive_glass() {
        // Tessar glasses are n_d/V_d (dispersive): a ghost's centroid must
        // move between 450 and 650 nm. The same lens with every glass
        // replaced by Glass::Constant(n_d) must not move at all.
        let p = builtin::tessar();
        let path = TracePath::ghost(5, 4);
        let d = light_from_field(10.0, 0.0);
        let beam = Beam::for_path(&p, path, d, LAMBDA_D_NM).unwrap();
        let opts = GridOptions::default();
        let grids = trace_grid_spectral(&p, path, &beam, 17, &opts, &[450.0, 650.0]).unwrap();
        let (a, b) = (grids[0].centroid().unwrap(), grids[1].centroid().unwrap());
        assert!(
            (a - b).length() > 1e-3,
            "dispersive ghost moved only {} mm",
            (a - b).length()
        );

        let flat = p
            .edited(|surfaces| {
                for s in surfaces.iter_mut().filter(|s| s.glass_after != Glass::Air) {
                    s.glass_after = Glass::Constant(s.glass_after.nd());
                }
            })
            .unwrap();
        let grids = trace_grid_spectral(&flat, path, &beam, 17, &opts, &[450.0, 650.0]).unwrap();
        for (r, s) in grids[0].rays().iter().zip(grids[1].rays()) {
            assert_eq!(r.alive, s.alive);
            assert!((r.sensor - s.sensor).length() < 1e-12);
        }
    }

    #[test]
    fn bad_inputs_are_typed() {
        let p = builtin::tessar();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let beam = Beam::for_path(&p, TracePath::Primary, DVec3::Z, 550.0).unwrap();
        let o = GridOptions::default();
        let input = |r: Result<RayGrid, FlareError>| match r {
            Err(FlareError::Input(i)) => Some((i.what, i.value)),
            _ => None,
        };
        for n in [0, 1, MAX_GRID + 1] {
            assert_eq!(
                input(trace_grid(&lens, TracePath::Primary, &beam, n, &o)),
                Some(("grid rays per side", n as f64))
            );
        }
        // Surface 3 of the Tessar is the stop: no ghost reflects there.
        assert!(matches!(
            trace_grid(&lens, TracePath::ghost(3, 1), &beam, 4, &o),
            Err(FlareError::Trace(TraceError::InvalidPath {
                first: 3,
                second: 1,
                ..
            }))
        ));
        for g in [0.5, f64::INFINITY] {
            let bad = GridOptions { max_gain: g, ..o };
            assert_eq!(
                input(trace_grid(&lens, TracePath::Primary, &beam, 4, &bad)),
                Some(("max gain", g))
            );
        }
        let bad = GridOptions {
            sensor_z: Some(f64::NEG_INFINITY),
            ..o
        };
        assert_eq!(
            input(trace_grid(&lens, TracePath::Primary, &beam, 4, &bad)),
            Some(("sensor z (mm)", f64::NEG_INFINITY))
        );
        let e = Beam::for_path(
            &p,
            TracePath::Primary,
            DVec3::new(f64::NAN, 0.0, 1.0),
            550.0,
        )
        .unwrap_err();
        assert!(
            matches!(e, FlareError::Input(i) if i.what == "light direction"),
            "{e}"
        );
    }

    #[test]
    fn grid_lookups_are_total() {
        let p = builtin::tessar();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let beam = Beam::for_path(&p, TracePath::ghost(5, 4), DVec3::Z, 550.0).unwrap();
        let g = trace_grid(
            &lens,
            TracePath::ghost(5, 4),
            &beam,
            5,
            &GridOptions::default(),
        )
        .unwrap();
        assert_eq!(
            (g.n(), g.rays().len(), g.cells().len(), g.path()),
            (5, 25, 16, TracePath::ghost(5, 4))
        );
        assert_eq!(g.ray(4, 4), Some(&g.rays()[24]));
        assert_eq!(
            (g.ray(5, 0), g.ray(0, 5), g.cell(4, 0), g.cell(0, 4)),
            (None, None, None, None)
        );
        assert!(g.cell_corners(4, 3).is_none() && g.cell_corners(usize::MAX, 0).is_none());
        // Cell (2, 1) is the 7th, row-major; its corners run 00, 10, 11, 01.
        let (cell, corners) = g.cells_with_corners().nth(4 + 2).unwrap(); // row 1 of 4 cells, column 2
        assert_eq!(Some(cell), g.cell(2, 1));
        let want = [(2, 1), (3, 1), (3, 2), (2, 2)].map(|(i, j)| g.ray(i, j).unwrap());
        assert_eq!(Some(corners), g.cell_corners(2, 1));
        assert_eq!(corners, want);
    }

    #[test]
    fn light_outside_the_field_gives_dead_cells_not_nan() {
        // 80° off axis: the Tessar's front sphere (R = 42.97) turns most rays
        // away; whatever survives is finite.
        let p = builtin::tessar();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let path = TracePath::ghost(2, 0);
        let beam = Beam::for_path(&p, path, light_from_field(80.0, 0.0), 550.0).unwrap();
        let g = trace_grid(&lens, path, &beam, 9, &GridOptions::default()).unwrap();
        assert!(g.rays().iter().any(|r| !r.alive));
        assert!(
            g.cells()
                .iter()
                .all(|c| c.intensity.is_finite() && c.sensor_area_mm2.is_finite())
        );
    }

    /// The power that passes `aperture` (each cell's times the fraction of
    /// its corners that pass, as the ghost estimate counts it) and the
    /// cells whose four corners pass.
    fn passing_power(g: &RayGrid, aperture: &Aperture) -> (f64, usize) {
        let mut power = 0.0;
        let mut cells = 0;
        for (cell, corners) in g.cells_with_corners() {
            let passing = corners.iter().filter(|r| r.passes(aperture)).count();
            power += cell.power() * passing as f64 / 4.0;
            cells += usize::from(passing == 4);
        }
        (power, cells)
    }

    #[test]
    fn continued_dead_rays_give_back_the_light_coarse_grids_lose_at_the_rims() {
        // Ghosts of the double Gauss, 10° off axis, on grids fitted to
        // their passing light: at 9² rays the cells with a corner that
        // missed a sphere held a tenth of the light, which a 97² grid
        // draws. Continued, the dead corners let the per-pixel clip cut
        // those cells where the light stops (measured on every fourth
        // ghost: −13.3 % → −2.0 %).
        use crate::lens_flare::{SensorImage, SensorWindow, rasterise_into};
        let p = builtin::double_gauss();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let aperture = Aperture::of_stop(&p);
        let light = light_from_field(10.0, 0.0);
        let half = p.paraxial(550.0).unwrap().efl_mm * 0.5;
        let window = SensorWindow::new(DVec2::splat(-half), half / 64.0, 128, 128).unwrap();
        let (mut fine, mut coarse, mut continued) = (
            SensorImage::new(window),
            SensorImage::new(window),
            SensorImage::new(window),
        );
        let mut filled = 0;
        for (i, j) in ghosts(&p).into_iter().step_by(4) {
            let path = TracePath::ghost(i, j);
            let (beam, _) = Beam::meridional(&p, path, light, 550.0).unwrap();
            let Some(fit) = passing_rect(&lens, path, &beam, &aperture, 13).unwrap() else {
                continue;
            };
            let beam = beam.within(fit.pupil, true);
            let options = GridOptions::default();
            rasterise_into(
                &trace_grid(&lens, path, &beam, 97, &options).unwrap(),
                &aperture,
                &mut fine,
            );
            let grid = trace_grid(&lens, path, &beam, 9, &options).unwrap();
            let extended = grid.extrapolated(p.stop_semi_aperture_mm());
            filled += extended.stats().alive_rays - grid.stats().alive_rays;
            // A traced ray is never changed; a continued one's r_rel holds
            // the stop's rim, as a traced one's does.
            for (a, b) in grid.rays().iter().zip(extended.rays()) {
                assert!(!a.alive || a == b);
                let at_stop = b.stop_xy.iter().map(|q| q.length()).fold(0.0, f64::max)
                    / p.stop_semi_aperture_mm();
                assert!(!b.alive || b.r_rel >= at_stop - 1e-12, "{b:?}");
            }
            rasterise_into(&grid, &aperture, &mut coarse);
            rasterise_into(&extended, &aperture, &mut continued);
        }
        let want = fine.total();
        let (lost, kept) = (coarse.total() / want - 1.0, continued.total() / want - 1.0);
        eprintln!("9² fitted grids: {lost:+.4} as traced, {kept:+.4} continued ({filled} rays)");
        assert!(filled > 0 && lost < -0.05, "{lost}");
        assert!(kept.abs() < 0.03, "{kept}");
    }

    #[test]
    fn a_lone_dead_ray_is_continued_along_its_row_and_column() {
        // A slab's grid is affine: the continuation of its neighbours is
        // the ray itself.
        let p = slab();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let bounds = PupilBounds::new(-1.0, DVec2::ZERO, 10.0).unwrap();
        let beam = Beam::new(&p, DVec3::new(0.1, 0.05, 1.0).normalize(), bounds).unwrap();
        let grid =
            trace_grid(&lens, TracePath::Primary, &beam, 7, &GridOptions::default()).unwrap();
        let want = *grid.ray(3, 2).unwrap();
        let mut rays = grid.rays().to_vec();
        rays[2 * 7 + 3] = GridRay {
            alive: false,
            ..want
        };
        rays[0] = GridRay {
            alive: false,
            ..rays[0]
        };
        let broken = RayGrid::from_rays(7, TracePath::Primary, grid.cell_pupil_mm2(), rays);
        let fixed = broken.extrapolated(p.stop_semi_aperture_mm());
        let got = fixed.ray(3, 2).unwrap();
        // (r_rel, a distance from the axis, is not affine: not compared.)
        assert!(
            got.alive
                && got.sensor.distance(want.sensor) < 1e-9
                && got.stop_xy[0].distance(want.stop_xy[0]) < 1e-9,
            "{got:?} vs {want:?}"
        );
        assert!(fixed.ray(0, 0).unwrap().alive);
        assert_eq!(fixed.stats().alive_cells, 36);
    }

    #[test]
    fn a_grid_fitted_to_the_passing_light_keeps_it_and_spends_its_rays_there() {
        // Ghosts of the double Gauss wide open, 10° off axis, by symmetry
        // (the plugin's default): every ray that passes on a fine grid over
        // the whole square lies in the fit of a coarse 13² grid, and a 97²
        // grid over the fit carries the light a 385² grid over the whole
        // square does (measured within 0.3 %; 97² over the whole square
        // is off by up to 12 %, its few passing cells too coarse).
        let p = builtin::double_gauss();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let aperture = Aperture::of_stop(&p);
        let light = light_from_field(10.0, 0.0);
        let mut checked = 0;
        for (i, j) in ghosts(&p).into_iter().step_by(5) {
            let path = TracePath::ghost(i, j);
            let (beam, _) = Beam::meridional(&p, path, light, 550.0).unwrap();
            let Some(fit) = passing_rect(&lens, path, &beam, &aperture, 13).unwrap() else {
                continue;
            };
            let whole = trace_grid(&lens, path, &beam, 97, &GridOptions::default()).unwrap();
            for (k, r) in whole.rays().iter().enumerate() {
                if r.passes(&aperture) {
                    let at = beam.pupil_point((k % 97) as f64 / 96.0, (k / 97) as f64 / 96.0);
                    assert!(
                        at.cmpge(fit.pupil.min - 1e-9).all()
                            && at.cmple(fit.pupil.max + 1e-9).all(),
                        "({i}, {j}): {at} outside {fit:?}"
                    );
                }
            }
            let fitted = beam.within(fit.pupil, true);
            assert!(fitted.bounds().half_width() <= beam.bounds().half_width());
            let narrow = trace_grid(&lens, path, &fitted, 97, &GridOptions::default()).unwrap();
            let (p_narrow, c_narrow) = passing_power(&narrow, &aperture);
            let (_, c_whole) = passing_power(&whole, &aperture);
            assert!(
                c_narrow >= c_whole,
                "({i}, {j}): {c_narrow} vs {c_whole} cells"
            );
            if checked < 6 {
                let fine = trace_grid(&lens, path, &beam, 385, &GridOptions::default()).unwrap();
                let (p_fine, _) = passing_power(&fine, &aperture);
                assert!(
                    p_fine > 0.0 && (p_narrow - p_fine).abs() <= 0.01 * p_fine,
                    "({i}, {j}): {p_narrow} vs {p_fine}"
                );
                checked += 1;
            }
        }
        assert_eq!(checked, 6);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(48))]
        #[test]
        fn finite_input_gives_finite_cells_or_typed_error(
            lx in -3.0f64..3.0, ly in -3.0f64..3.0, lz in -0.2f64..1.0,
            n in 2usize..7, g in 0usize..200, which in 0usize..3, wl in 380.0f64..780.0,
            gain in 1.0f64..1e8,
        ) {
            let p = match which { 0 => builtin::tessar(), 1 => builtin::double_gauss(), _ => builtin::heliar() };
            let gh = ghosts(&p);
            let path = if g % 7 == 0 { TracePath::Primary } else { let (i, j) = gh[g % gh.len()]; TracePath::ghost(i, j) };
            let lens = PreparedLens::new(&p, wl).unwrap();
            let light = DVec3::new(lx, ly, lz);
            prop_assume!(light.length() > 1e-6);
            match Beam::for_path(&p, path, light, wl) {
                // Only a light that does not travel into the lens is refused.
                Err(FlareError::LightBehindLens { dir_z }) => {
                    prop_assert!(dir_z <= MIN_LIGHT_Z && (dir_z - light.normalize().z).abs() < 1e-15, "{dir_z}");
                }
                Err(e) => prop_assert!(false, "light {light}: {e:?}"),
                Ok(beam) => {
                    let grid = trace_grid(&lens, path, &beam, n, &GridOptions { sensor_z: None, max_gain: gain }).unwrap();
                    for c in grid.cells() {
                        prop_assert!(c.intensity.is_finite() && c.intensity >= 0.0);
                        prop_assert!(c.intensity <= gain * c.mean_throughput * (1.0 + 1e-12));
                        prop_assert!(c.power() <= grid.cell_pupil_mm2() * c.mean_throughput * (1.0 + 1e-12));
                    }
                    for r in grid.rays() {
                        prop_assert!(r.sensor.is_finite() && r.stop_xy.iter().all(|p| p.is_finite()) && r.r_rel.is_finite());
                    }
                }
            }
        }
    }
}
