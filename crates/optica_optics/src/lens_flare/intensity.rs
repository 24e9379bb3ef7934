//! Irradiance of a grid cell from the change of its area (the blog's
//! *Computing ghost intensity*); the method is documented on
//! [`cell_intensity`].

use glam::DVec2;

use super::aperture::Aperture;
use crate::lens::MAX_STOP_CROSSINGS;

/// Default bound `G` on a cell's area gain `A_p / A_s` (see
/// [`cell_intensity`]).
///
/// 10⁶ means the bound acts only on cells squeezed by more than 1000× in
/// each direction: a 2.5 mm cell (a 40 mm pupil on a 16² grid) must shrink
/// below 2.5 µm, smaller than a sensor pixel, before any of its energy is
/// dropped. No cell reached it for any ghost of the three shipped lenses at
/// 0°, 10° and 20° with N = 33 ([`super::GridStats::clamped_cells`] = 0),
/// while a caustic point (area → 0) still gets a finite irradiance.
pub const DEFAULT_MAX_GAIN: f64 = 1e6;

/// What one traced ray of the grid brings to the sensor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridRay {
    /// `false` when the ray died in the lens (missed a sphere or met total
    /// internal reflection where it had to refract); the other fields are then 0.
    pub alive: bool,
    /// (x, y) on the sensor plane, mm.
    pub sensor: DVec2,
    /// Largest `r / semi_aperture` along the path; > 1 means blocked
    /// (kept unclipped so the grid stays continuous, clipped per pixel).
    pub r_rel: f64,
    /// (x, y) of every crossing of the stop plane, mm, first first (three
    /// for a ghost straddling the stop; for one crossing all three entries
    /// are that crossing), as [`crate::lens::TraceResult::stop_xy_all`].
    pub stop_xy: [DVec2; MAX_STOP_CROSSINGS],
    /// Fresnel throughput of the path (coated where the prescription says).
    pub throughput: f64,
}

impl GridRay {
    /// A ray that died in the lens.
    pub const DEAD: GridRay = GridRay {
        alive: false,
        sensor: DVec2::ZERO,
        r_rel: 0.0,
        stop_xy: [DVec2::ZERO; MAX_STOP_CROSSINGS],
        throughput: 0.0,
    };

    /// `true` when the ray reached the sensor, inside every semi-aperture
    /// (`r_rel <= 1`) and inside `aperture` at every stop crossing.
    pub fn passes(&self, aperture: &Aperture) -> bool {
        self.alive && self.r_rel <= 1.0 && self.stop_xy.iter().all(|&p| aperture.contains(p))
    }
}

/// How a cell maps to the sensor.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CellKind {
    /// A corner ray died: not drawn.
    Dead,
    /// Same orientation as the pupil cell.
    Regular,
    /// Consistently mirrored (the ghost image is inverted here).
    Mirrored,
    /// The two triangles have opposite orientations: a caustic fold runs
    /// through the cell.
    Folded,
}

/// One cell of a traced grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridCell {
    /// Orientation class.
    pub kind: CellKind,
    /// `true` when the gain bound was active (`A_s < A_p / G`).
    pub clamped: bool,
    /// Irradiance on the sensor at unit irradiance in the beam (≤ G · T̄).
    pub intensity: f64,
    /// Area the cell covers on the sensor, `|s1| + |s2|`, mm².
    pub sensor_area_mm2: f64,
    /// Signed quad area `s1 + s2` (shoelace), mm².
    pub signed_area_mm2: f64,
    /// Mean throughput of the four corner rays.
    pub mean_throughput: f64,
}

impl GridCell {
    /// A dead cell.
    pub const DEAD: GridCell = GridCell {
        kind: CellKind::Dead,
        clamped: false,
        intensity: 0.0,
        sensor_area_mm2: 0.0,
        signed_area_mm2: 0.0,
        mean_throughput: 0.0,
    };

    /// The power the cell deposits on the sensor: `intensity × sensor area`
    /// (= `A_p · T̄` unless clamped), before per-pixel clipping.
    pub fn power(&self) -> f64 {
        self.intensity * self.sensor_area_mm2
    }
}

/// Signed area of the triangle (a, b, c): positive when counter-clockwise.
pub(super) fn triangle_signed_area(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    0.5 * (b - a).perp_dot(c - a)
}

/// The gain bound `max_gain` where it is usable (finite, at least 1), else
/// [`DEFAULT_MAX_GAIN`].
pub(super) fn gain_bound(max_gain: f64) -> f64 {
    if max_gain.is_finite() && max_gain >= 1.0 {
        max_gain
    } else {
        DEFAULT_MAX_GAIN
    }
}

/// The cell with corners `[c00, c10, c11, c01]` (counter-clockwise on the
/// pupil), beam cross-section `pupil_mm2` and gain bound `max_gain`.
///
/// A cell of the regular pupil grid carries the power `P = A_p · T̄`, with
/// `A_p` its beam cross-section (pupil cell area × d_z, unit irradiance
/// normal to the beam) and `T̄` the mean Fresnel throughput of its four
/// rays. On the sensor it covers the quad of its four ray hits, of area
/// `A_s`, so its irradiance is
///
/// ```text
/// I = A_p / A_s · T̄                      (energy: I · A_s = A_p · T̄)
/// ```
///
/// — the blog's `I = S_base / Σ S_n` (light squeezed into a smaller area is
/// brighter), the brightness rule of the caustics in Evan Wallace's WebGL
/// Water demo, which the blog cites.
///
/// The blog measures a quad with Bretschneider's formula
/// `S = √((s−a)(s−b)(s−c)(s−d) − abcd·C)`, `C = cos((θ1+θ2)/2)`; the formula
/// itself has `cos²` there, and it is blind to orientation (a folded,
/// self-crossing quad gives a negative radicand, i.e. NaN). We split the
/// quad along its 00–11 diagonal into two triangles and take their signed
/// (shoelace) areas `s1, s2`:
/// - `s1, s2 > 0`: a regular cell; both `< 0`: a mirrored cell (a ghost
///   image that is inverted there) — both are fine, `A_s = |s1 + s2|`;
/// - `s1 · s2 < 0`: the cell straddles a caustic fold (the map from pupil to
///   sensor changes orientation inside it). Its quad crosses itself; we take
///   `A_s = |s1| + |s2|`, the area the rasteriser covers with it (the two
///   triangles), so the cell's energy is still `A_p · T̄`;
/// - in all cases `A_s = |s1| + |s2|`, and the **gain is bounded**:
///   `I = T̄ · A_p / max(A_s, A_p / G)` with `G = max_gain`, so `I <= G · T̄`.
///   A degenerate cell (`A_s -> 0`, a caustic point, or every ray on one
///   point) gets `I = G · T̄` and, having no area, deposits at most its own
///   energy `A_p · T̄`: the bound never adds energy, it only drops the part
///   of a cell squeezed below `A_p / G` ([`DEFAULT_MAX_GAIN`] says why 10⁶);
/// - a cell with a dead ray (missed a sphere, total internal reflection), a
///   non-finite corner or a `pupil_mm2` that is not finite and > 0 is dead:
///   `I = 0`, not drawn.
///
/// `max_gain` is checked where options enter ([`super::trace_grid`]);
/// called directly with one that is not finite and >= 1, this takes
/// [`DEFAULT_MAX_GAIN`] instead (documented fallback, never NaN).
pub fn cell_intensity(corners: [&GridRay; 4], pupil_mm2: f64, max_gain: f64) -> GridCell {
    if corners.iter().any(|r| !r.alive) || !(pupil_mm2 > 0.0 && pupil_mm2.is_finite()) {
        return GridCell::DEAD;
    }
    let g = gain_bound(max_gain);
    let [a, b, c, d] = corners.map(|r| r.sensor);
    let s1 = triangle_signed_area(a, b, c);
    let s2 = triangle_signed_area(a, c, d);
    let mean_throughput = 0.25 * corners.iter().map(|r| r.throughput).sum::<f64>();
    if !(s1.is_finite() && s2.is_finite() && mean_throughput.is_finite()) {
        return GridCell::DEAD;
    }
    let area = s1.abs() + s2.abs();
    let kind = if s1 * s2 < 0.0 {
        CellKind::Folded
    } else if s1 + s2 >= 0.0 {
        CellKind::Regular
    } else {
        CellKind::Mirrored
    };
    let floor = pupil_mm2 / g;
    let clamped = area < floor;
    let intensity = mean_throughput * pupil_mm2 / area.max(floor);
    GridCell {
        kind,
        clamped,
        intensity,
        sensor_area_mm2: area,
        signed_area_mm2: s1 + s2,
        mean_throughput,
    }
}

/// Smooth-shading value at every grid vertex (the blog's *Smooth shading*:
/// "store the average of the neighbours at each vertex and Gouraud-shade"):
/// the power of the alive cells around the vertex over their sensor area,
/// with the same bound, `I_v = Σ P_c / max(Σ A_c, Σ A_p / G)`; 0 where no
/// alive cell touches. `cells` is `(n−1)²` row-major for `n` rays per side;
/// any other length gives all zeros. `max_gain` as in [`cell_intensity`].
pub fn vertex_intensities(cells: &[GridCell], n: usize, pupil_mm2: f64, max_gain: f64) -> Vec<f64> {
    let g = gain_bound(max_gain);
    let m = n.saturating_sub(1);
    let mut out = vec![0.0; n * n];
    if cells.len() != m * m {
        return out;
    }
    for j in 0..n {
        for i in 0..n {
            let (mut p, mut a, mut k) = (0.0, 0.0, 0usize);
            for (ci, cj) in [
                (i.wrapping_sub(1), j.wrapping_sub(1)),
                (i, j.wrapping_sub(1)),
                (i.wrapping_sub(1), j),
                (i, j),
            ] {
                if ci < m && cj < m {
                    let c = &cells[cj * m + ci];
                    if c.kind != CellKind::Dead {
                        p += c.mean_throughput * pupil_mm2;
                        a += c.sensor_area_mm2;
                        k += 1;
                    }
                }
            }
            if k > 0 {
                out[j * n + i] = p / a.max(k as f64 * pupil_mm2 / g);
            }
        }
    }
    out
}

/// A live ray at sensor point (x, y) with throughput `t`, inside every
/// rim: the unit tests' grid point.
#[cfg(test)]
pub(super) fn test_ray(x: f64, y: f64, t: f64) -> GridRay {
    GridRay {
        alive: true,
        sensor: DVec2::new(x, y),
        r_rel: 0.5,
        stop_xy: [DVec2::ZERO; MAX_STOP_CROSSINGS],
        throughput: t,
    }
}

#[cfg(test)]
mod tests {
    use super::test_ray as ray;
    use super::*;

    #[test]
    fn halved_cell_quadruples_intensity() {
        // Unit pupil cell mapped to a 0.5 × 0.5 square: gain 4, T̄ = (1+2+3+2)/4 = 2 → 8.
        let c = [
            ray(0.0, 0.0, 1.0),
            ray(0.5, 0.0, 2.0),
            ray(0.5, 0.5, 3.0),
            ray(0.0, 0.5, 2.0),
        ];
        let cell = cell_intensity([&c[0], &c[1], &c[2], &c[3]], 1.0, DEFAULT_MAX_GAIN);
        assert_eq!(cell.kind, CellKind::Regular);
        assert!((cell.intensity - 8.0).abs() < 1e-15);
        assert!((cell.power() - 2.0).abs() < 1e-15, "power = A_p · T̄");
    }

    #[test]
    fn mirrored_cell_is_regular_in_magnitude() {
        let c = [
            ray(0.0, 0.0, 1.0),
            ray(-2.0, 0.0, 1.0),
            ray(-2.0, 2.0, 1.0),
            ray(0.0, 2.0, 1.0),
        ];
        let cell = cell_intensity([&c[0], &c[1], &c[2], &c[3]], 1.0, DEFAULT_MAX_GAIN);
        assert_eq!(cell.kind, CellKind::Mirrored);
        assert!((cell.intensity - 0.25).abs() < 1e-15);
        assert!((cell.signed_area_mm2 + 4.0).abs() < 1e-15);
    }

    #[test]
    fn folded_and_degenerate_cells_are_finite_and_bounded() {
        // Bow-tie: 11 and 01 swapped, the quad crosses itself; shoelace area 0.
        let c = [
            ray(0.0, 0.0, 0.5),
            ray(1.0, 0.0, 0.5),
            ray(0.0, 1.0, 0.5),
            ray(1.0, 1.0, 0.5),
        ];
        let cell = cell_intensity([&c[0], &c[1], &c[2], &c[3]], 1.0, 100.0);
        assert_eq!(cell.kind, CellKind::Folded);
        assert!(cell.intensity.is_finite() && cell.intensity <= 100.0 * 0.5);
        assert!(
            (cell.power() - 0.5).abs() < 1e-12,
            "folded cell keeps its energy"
        );
        // All four rays on one point: area 0 → the bound, G · T̄, and no energy.
        let p = [ray(3.0, 3.0, 0.5); 4];
        let cell = cell_intensity([&p[0], &p[1], &p[2], &p[3]], 1.0, 100.0);
        assert!(cell.clamped && cell.intensity == 50.0 && cell.power() == 0.0);
        // Nearly collinear: tiny area, clamped, power below A_p T̄.
        let q = [
            ray(0.0, 0.0, 1.0),
            ray(1.0, 0.0, 1.0),
            ray(2.0, 1e-9, 1.0),
            ray(3.0, 0.0, 1.0),
        ];
        let cell = cell_intensity([&q[0], &q[1], &q[2], &q[3]], 1.0, 100.0);
        assert!(cell.clamped && cell.intensity <= 100.0 && cell.power() <= 1.0);
        // A dead corner or a NaN position kills the cell, never NaN.
        let mut dead = c;
        dead[2] = GridRay::DEAD;
        assert_eq!(
            cell_intensity([&dead[0], &dead[1], &dead[2], &dead[3]], 1.0, 100.0),
            GridCell::DEAD
        );
        let mut nan = c;
        nan[1].sensor.x = f64::NAN;
        assert_eq!(
            cell_intensity([&nan[0], &nan[1], &nan[2], &nan[3]], 1.0, 100.0),
            GridCell::DEAD
        );
    }

    #[test]
    fn vertex_intensity_of_a_uniform_grid_is_the_cell_intensity() {
        // 3×3 rays on a uniform 2× magnified lattice: every cell and vertex has 0.25·T.
        let n = 3;
        let rays: Vec<GridRay> = (0..9)
            .map(|k| ray(2.0 * (k % 3) as f64, 2.0 * (k / 3) as f64, 0.8))
            .collect();
        let cells: Vec<GridCell> = (0..4)
            .map(|c| {
                let (i, j) = (c % 2, c / 2);
                let at = |a: usize, b: usize| &rays[b * n + a];
                cell_intensity(
                    [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)],
                    1.0,
                    DEFAULT_MAX_GAIN,
                )
            })
            .collect();
        for v in vertex_intensities(&cells, n, 1.0, DEFAULT_MAX_GAIN) {
            assert!((v - 0.2).abs() < 1e-15);
        }
    }
}
