//! Ghost enumeration with an intensity estimate per ghost, for sorting and
//! culling; the estimate is documented on [`estimate_ghost`].

use glam::DVec2;
use rayon::prelude::*;

use super::FlareError;
use super::aperture::Aperture;
use super::grid_trace::{GridOptions, MAX_GRID, count_in, trace_grid};
use super::intensity::{CellKind, DEFAULT_MAX_GAIN, GridRay};
use super::pupil::{Beam, light_direction};
use crate::input;
use crate::lens::{LensPrescription, PreparedLens, TracePath, ghosts};

/// Default `k` of a `k × k`-cell estimate: the grid the blog finds the best
/// value for its cost when drawing ghosts (*On the number of grid
/// divisions*: "about 16×16 is the best value for the cost"). At this size the estimate of a ghost's
/// power is within 10 % of a 300²-ray reference (test
/// `estimate_power_matches_the_reference`).
pub const DEFAULT_ESTIMATE_SIDE: usize = 16;

/// Default floor `S_min` of the image area, mm²: one (10 µm)² pixel, the
/// size of a large camera pixel. It only keeps a ghost focused to a point
/// finite; a ghost smaller than a pixel is ranked as if it filled one, which
/// is how it is seen.
pub const DEFAULT_MIN_SPREAD_MM2: f64 = 1e-4;

/// The estimate of one ghost.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GhostEstimate {
    /// The path `(i, j)`.
    pub path: TracePath,
    /// `E`: power reaching the sensor at unit irradiance in the beam, mm².
    pub power: f64,
    /// `S`: image area covered by the passing light, mm².
    pub spread_mm2: f64,
    /// `I = E / S`: mean irradiance, the sort key.
    pub intensity: f64,
    /// Throughput-weighted centroid of the passing rays on the sensor (zero
    /// when nothing passed).
    pub centroid: DVec2,
    /// Rays of the estimate that passed.
    pub passed: usize,
}

/// Settings of [`estimate_ghosts`], checked by the functions that take them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimateOptions {
    /// `k`: cells per side of each estimate (`(k+1)²` rays), in
    /// `1..MAX_GRID`.
    pub cells_per_side: usize,
    /// `S_min`, mm² (finite, > 0).
    pub min_spread_mm2: f64,
    /// Sensor plane; `None` = the table's image plane.
    pub sensor_z: Option<f64>,
    /// Gain bound `G` of the cells (finite, >= 1), as [`GridOptions::max_gain`].
    pub max_gain: f64,
}

impl Default for EstimateOptions {
    fn default() -> Self {
        Self {
            cells_per_side: DEFAULT_ESTIMATE_SIDE,
            min_spread_mm2: DEFAULT_MIN_SPREAD_MM2,
            sensor_z: None,
            max_gain: DEFAULT_MAX_GAIN,
        }
    }
}

/// Estimates one ghost for `beam`: how bright its image is, to sort and
/// cull ghosts (the blog's *Ghost enumeration* and *Intensity LOD*: "given
/// the approximate final intensity of each ghost, the number of brightest
/// ghosts evaluated can be adjusted").
///
/// Every two-reflection path `(i, j)` of [`crate::lens::ghosts`]
/// (`n(n−1)/2` of them) gets a cheap estimate from a coarse `k × k`-cell grid
/// of its pupil square (`k` = [`DEFAULT_ESTIMATE_SIDE`] by default), the same
/// cells as the grid method. A corner counts as passing when it is alive,
/// `r_rel <= 1` and inside the aperture at every stop crossing; a cell with
/// `m` of 4 corners passing counts with the fraction `f = m/4`:
///
/// ```text
/// E = Σ_cells f · I_c · A_s         power reaching the sensor (mm², unit beam irradiance)
/// S = max(Σ_cells f · A_s, S_min)   image area the passing light covers (mm²)
/// I = E / S                         mean irradiance of the ghost image
/// ```
///
/// with `I_c = T̄ · A_p / max(A_s, A_p / G)` the cell's bounded irradiance
/// ([`super::cell_intensity`]; `G` = [`EstimateOptions::max_gain`]), so a
/// cell's power `I_c · A_s` is its `A_p · T̄` unless the bound clips it.
///
/// `I` is the irradiance of the ghost averaged over its own image, the
/// quantity that decides whether it is visible: a haze over the whole frame
/// ranks below a small bright spot of the same power. Areas come from the
/// grid cells (not from a spread of the ray positions) so a ghost with only
/// a few passing rays still gets the area those rays' cells cover — a
/// covariance of two or three points is degenerate and would rank a
/// nearly-dark ghost first. `S_min` ([`DEFAULT_MIN_SPREAD_MM2`]) keeps a
/// focused ghost finite. Because `I` is then at most the `A_s`-weighted mean
/// of the cells' `I_c`, the cells' gain bound carries over: `I <= G · T̄_max`
/// (`T̄_max` the largest mean throughput of a counted cell). A ghost the
/// aperture blocks entirely (the blog's *Aperture culling*) gets `E = 0`
/// and is dropped by [`cull`].
pub fn estimate_ghost(
    lens: &PreparedLens,
    path: TracePath,
    beam: &Beam,
    aperture: &Aperture,
    options: &EstimateOptions,
) -> Result<GhostEstimate, FlareError> {
    // k + 1 rays per side, at most MAX_GRID.
    let k = count_in(
        "estimate cells per side",
        options.cells_per_side,
        1,
        MAX_GRID - 1,
    )?;
    let floor = input::positive("minimum ghost image area (mm²)", options.min_spread_mm2)?;
    let grid_options = GridOptions {
        sensor_z: options.sensor_z,
        max_gain: options.max_gain,
    };
    let grid = trace_grid(lens, path, beam, k + 1, &grid_options)?;
    let passes = |r: &GridRay| r.passes(aperture);
    let (mut w, mut m, mut passed) = (0.0, DVec2::ZERO, 0usize);
    for r in grid.rays().iter().filter(|r| passes(r)) {
        w += r.throughput;
        m += r.throughput * r.sensor;
        passed += 1;
    }
    let (mut power, mut area) = (0.0, 0.0);
    for (cell, corners) in grid
        .cells_with_corners()
        .filter(|(c, _)| c.kind != CellKind::Dead)
    {
        let f = corners.iter().filter(|r| passes(r)).count() as f64 / 4.0;
        // The cell's bounded power I_c · A_s (= A_p · T̄ unless clamped).
        power += f * cell.power();
        area += f * cell.sensor_area_mm2;
    }
    let spread = area.max(floor);
    let centroid = if w > 0.0 { m / w } else { DVec2::ZERO };
    let intensity = if power > 0.0 { power / spread } else { 0.0 };
    Ok(GhostEstimate {
        path,
        power,
        spread_mm2: spread,
        intensity,
        centroid,
        passed,
    })
}

/// Estimates every ghost of `prescription` for light along `light` at
/// `wavelength_nm`, each over its own pupil bounds ([`Beam::for_path`]),
/// sorted brightest first (ties by path). Ghosts run in parallel (rayon).
pub fn estimate_ghosts(
    prescription: &LensPrescription,
    light: glam::DVec3,
    wavelength_nm: f64,
    aperture: &Aperture,
    options: &EstimateOptions,
) -> Result<Vec<GhostEstimate>, FlareError> {
    let lens = PreparedLens::new(prescription, wavelength_nm)?;
    // Checked here too, so that a lens without ghosts refuses a bad light as well.
    let light = light_direction(light)?;
    let mut out = ghosts(prescription)
        .into_par_iter()
        .map(|(i, j)| {
            let path = TracePath::ghost(i, j);
            let beam = Beam::for_path(prescription, path, light, wavelength_nm)?;
            estimate_ghost(&lens, path, &beam, aperture, options)
        })
        .collect::<Result<Vec<_>, _>>()?;
    out.sort_by(|a, b| {
        b.intensity
            .total_cmp(&a.intensity)
            .then_with(|| key(a.path).cmp(&key(b.path)))
    });
    Ok(out)
}

fn key(p: TracePath) -> (usize, usize) {
    match p {
        TracePath::Ghost { first, second } => (first, second),
        TracePath::Primary => (0, 0),
    }
}

/// The ghosts whose intensity is at least `relative_threshold` (in [0, 1])
/// × the brightest one's (`0` keeps all with any light, `1` keeps the
/// brightest); ghosts with no light are always dropped. Keeps the input
/// order, so for a ghost budget of `b` ghosts, truncate the result of
/// sorted estimates ([`estimate_ghosts`]) to `b`.
pub fn cull(
    estimates: &[GhostEstimate],
    relative_threshold: f64,
) -> Result<Vec<GhostEstimate>, FlareError> {
    input::in_range("relative cull threshold", relative_threshold, 0.0, 1.0)?;
    let max = estimates.iter().map(|e| e.intensity).fold(0.0, f64::max);
    Ok(estimates
        .iter()
        .filter(|e| e.intensity > 0.0 && e.intensity >= relative_threshold * max)
        .copied()
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fresnel::Coating;
    use crate::lens::builtin;
    use crate::lens_flare::coat_air_interfaces;
    use crate::lens_flare::pupil::light_from_field;
    use glam::DVec3;

    #[test]
    fn ghost_counts_tessar_21_double_gauss_91() {
        // C(n, 2): Tessar (US 2,854,889, 7 interfaces) 21 ghosts, double Gauss (US 2,701,982, 14) 91.
        for (p, n) in [(builtin::tessar(), 21), (builtin::double_gauss(), 91)] {
            let o = EstimateOptions {
                cells_per_side: 4,
                ..Default::default()
            };
            let e = estimate_ghosts(
                &p,
                light_from_field(5.0, 0.0),
                550.0,
                &Aperture::of_stop(&p),
                &o,
            )
            .unwrap();
            assert_eq!(e.len(), n);
            assert!(
                e.windows(2).all(|w| w[0].intensity >= w[1].intensity),
                "sorted brightest first"
            );
            assert!(
                e.iter()
                    .all(|g| g.intensity.is_finite() && g.power.is_finite() && g.power >= 0.0)
            );
        }
    }

    #[test]
    fn coating_dims_every_ghost_and_cull_keeps_the_brightest() {
        let p = builtin::tessar();
        let ap = Aperture::of_stop(&p);
        let o = EstimateOptions {
            cells_per_side: 8,
            ..Default::default()
        };
        let d = light_from_field(5.0, 0.0);
        let bare = estimate_ghosts(&p, d, 550.0, &ap, &o).unwrap();
        let coated = estimate_ghosts(
            &coat_air_interfaces(&p, Coating::quarter_wave(1.38, 550.0).unwrap()).unwrap(),
            d,
            550.0,
            &ap,
            &o,
        )
        .unwrap();
        // A quarter-wave MgF2 layer cuts each glass-air reflectance (~4–6 %
        // → ~1 %), so every ghost's power (two reflections, at least one on
        // a coated surface) drops by far more than 2×.
        for b in &bare {
            let c = coated.iter().find(|c| c.path == b.path).unwrap();
            assert!(
                c.power < 0.5 * b.power || b.power == 0.0,
                "{:?}: {} vs {}",
                b.path,
                c.power,
                b.power
            );
        }
        let kept = cull(&bare, 0.1).unwrap();
        assert!(!kept.is_empty() && kept.len() < bare.len());
        assert_eq!(kept[0], bare[0]);
        assert_eq!(
            cull(&bare, 0.0).unwrap().len(),
            bare.iter().filter(|e| e.intensity > 0.0).count()
        );
        for bad in [1.5, -0.1, f64::NAN] {
            let e = cull(&bare, bad).unwrap_err();
            assert!(
                matches!(e, FlareError::Input(i) if i.what == "relative cull threshold"),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn estimate_power_matches_the_reference() {
        // The 16²-cell estimate of the coated Tessar's ghost (4, 2) on axis
        // against the power of a 300²-ray brute-force reference: within 10 %.
        use crate::lens::PreparedLens;
        use crate::lens_flare::{GridOptions, SensorWindow, reference_image};
        let p = coat_air_interfaces(
            &builtin::tessar(),
            Coating::quarter_wave(1.38, 550.0).unwrap(),
        )
        .unwrap();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let path = TracePath::ghost(4, 2);
        let beam = Beam::for_path(&p, path, DVec3::Z, 550.0).unwrap();
        let ap = Aperture::of_stop(&p);
        let e = estimate_ghost(&lens, path, &beam, &ap, &EstimateOptions::default()).unwrap();
        let w = SensorWindow::new(DVec2::splat(-1.0), 1.0, 2, 2).unwrap();
        let r =
            reference_image(&lens, path, &beam, &ap, w, 300, 3, &GridOptions::default()).unwrap();
        assert!(
            (e.power / r.power - 1.0).abs() < 0.1,
            "{} vs {}",
            e.power,
            r.power
        );
        // On axis the ghost is centred on the axis.
        assert!(e.centroid.length() < 1e-6, "{:?}", e.centroid);
    }

    #[test]
    fn absurd_sizes_and_gains_are_typed_not_overflows() {
        let p = builtin::tessar();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let path = TracePath::ghost(4, 2);
        let beam = Beam::for_path(&p, path, DVec3::Z, 550.0).unwrap();
        let ap = Aperture::of_stop(&p);
        for k in [usize::MAX, usize::MAX - 1, MAX_GRID, 0] {
            let o = EstimateOptions {
                cells_per_side: k,
                ..Default::default()
            };
            let e = estimate_ghost(&lens, path, &beam, &ap, &o).unwrap_err();
            assert!(
                matches!(e, FlareError::Input(i) if i.what == "estimate cells per side" && i.value == k as f64),
                "k = {k}: {e}"
            );
        }
        assert!(
            estimate_ghost(
                &lens,
                path,
                &beam,
                &ap,
                &EstimateOptions {
                    cells_per_side: MAX_GRID - 1,
                    ..Default::default()
                }
            )
            .is_ok()
        );
        for g in [f64::NAN, 0.5] {
            let o = EstimateOptions {
                max_gain: g,
                ..Default::default()
            };
            let e = estimate_ghost(&lens, path, &beam, &ap, &o).unwrap_err();
            assert!(
                matches!(e, FlareError::Input(i) if i.what == "max gain"),
                "{g}: {e}"
            );
        }
        // A bad area floor is refused, not replaced by the default.
        for s in [0.0, f64::NAN] {
            let o = EstimateOptions {
                min_spread_mm2: s,
                ..Default::default()
            };
            let e = estimate_ghost(&lens, path, &beam, &ap, &o).unwrap_err();
            assert!(
                matches!(e, FlareError::Input(i) if i.what == "minimum ghost image area (mm²)"),
                "{s}: {e}"
            );
        }
    }

    #[test]
    fn estimate_obeys_the_gain_bound() {
        // estimate_ghost's docs: I <= G · T̄_max. With G = 1 (no area gain allowed)
        // no ghost may be brighter than its brightest ray's throughput.
        // The double Gauss on axis has ghosts focusing far above it with the
        // default G ((13, 1) ~74×), so the bound is really exercised.
        use crate::lens_flare::grid_trace::trace_grid;
        let p = builtin::double_gauss();
        let lens = PreparedLens::new(&p, 550.0).unwrap();
        let ap = Aperture::of_stop(&p);
        let k = DEFAULT_ESTIMATE_SIDE;
        let (mut focusing, mut lit) = (0, 0);
        for (i, j) in ghosts(&p) {
            let path = TracePath::ghost(i, j);
            let beam = Beam::for_path(&p, path, DVec3::Z, 550.0).unwrap();
            let grid = trace_grid(&lens, path, &beam, k + 1, &GridOptions::default()).unwrap();
            let t_max = grid
                .rays()
                .iter()
                .filter(|r| r.alive)
                .map(|r| r.throughput)
                .fold(0.0, f64::max);
            let free =
                estimate_ghost(&lens, path, &beam, &ap, &EstimateOptions::default()).unwrap();
            let one = EstimateOptions {
                max_gain: 1.0,
                ..Default::default()
            };
            let bound = estimate_ghost(&lens, path, &beam, &ap, &one).unwrap();
            assert!(
                bound.intensity <= t_max * (1.0 + 1e-12),
                "({i},{j}): {} > {t_max}",
                bound.intensity
            );
            assert!(bound.power <= free.power * (1.0 + 1e-12));
            focusing += (free.intensity > 10.0 * t_max) as usize;
            lit += (free.power > 0.0) as usize;
        }
        assert!(
            focusing >= 3 && lit >= 40,
            "{focusing} focusing of {lit} lit ghosts"
        );
    }

    #[test]
    fn closed_aperture_and_bad_light() {
        let p = builtin::tessar();
        let e = estimate_ghosts(
            &p,
            DVec3::Z,
            550.0,
            &Aperture::closed(),
            &EstimateOptions::default(),
        )
        .unwrap();
        assert!(e.len() == 21 && e.iter().all(|g| g.power == 0.0 && g.intensity == 0.0));
        assert!(
            cull(&e, 0.0).unwrap().is_empty(),
            "a closed iris culls every ghost"
        );
        let o = EstimateOptions::default();
        let e = estimate_ghosts(
            &p,
            DVec3::new(f64::NAN, 0.0, 1.0),
            550.0,
            &Aperture::of_stop(&p),
            &o,
        )
        .unwrap_err();
        assert!(
            matches!(e, FlareError::Input(i) if i.what == "light direction"),
            "{e}"
        );
        let e = estimate_ghosts(&p, -DVec3::Z, 550.0, &Aperture::of_stop(&p), &o).unwrap_err();
        assert_eq!(e, FlareError::LightBehindLens { dir_z: -1.0 });
    }
}
