//! A smooth 2 × 2 block of grid cells drawn as one cell: the CPU twin of
//! `merged_block` in the flare plugin's cell pass. A large ghost's cells
//! are smaller than the pixels it is added up at, and its draw costs by
//! the cell; where four neighbouring cells map the pupil to the sensor
//! almost affinely, one cell over their outline, carrying their power,
//! draws the same image.

use glam::DVec2;

use super::aperture::Aperture;
use super::intensity::{GridRay, gain_bound, triangle_signed_area};

/// The signed areas of the cell a, b, c, d's triangles (a, b, c) and
/// (a, c, d).
fn halves(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> [f64; 2] {
    [triangle_signed_area(a, b, c), triangle_signed_area(a, c, d)]
}

/// The irradiance of the 2 × 2 cells on the rays `rays[row][column]`
/// drawn as one cell (with corners `rays[0][0]`, `rays[0][2]`,
/// `rays[2][2]`, `rays[2][0]`): their power over the area the one cell
/// covers, at most the brightest cell's irradiance (as
/// [`cell_intensity`](super::cell_intensity), per unit irradiance in a
/// beam of `pupil_mm2` per cell). `None` where the block is not smooth
/// enough to merge:
///
/// * a ray that does not pass (dead, outside a rim, or outside
///   `aperture` at a crossing of the stop plane,
///   [`GridRay::passes`]): a clipped edge runs through the block;
/// * a triangle of any cell, or of the one cell, turned against the
///   others (a fold, a caustic);
/// * a cell at the gain bound `max_gain` (its irradiance is capped);
/// * the largest of the four irradiances more than `1 + spread` times the
///   smallest;
/// * the one cell's area off the four cells' by more than `spread / 10`
///   of theirs (the map bends inside the block);
/// * `spread` not positive and finite, or `pupil_mm2` not.
pub fn merged_block(
    rays: [[&GridRay; 3]; 3],
    aperture: &Aperture,
    pupil_mm2: f64,
    max_gain: f64,
    spread: f64,
) -> Option<f64> {
    if !(spread > 0.0 && spread.is_finite() && pupil_mm2 > 0.0 && pupil_mm2.is_finite()) {
        return None;
    }
    if !rays.iter().flatten().all(|r| r.passes(aperture)) {
        return None;
    }
    let p = |row: usize, col: usize| rays[row][col].sensor;
    let t = |row: usize, col: usize| rays[row][col].throughput;
    // The four cells, row by row, each from its first corner (row, col).
    let firsts = [(0, 0), (0, 1), (1, 0), (1, 1)];
    let cell_halves =
        firsts.map(|(r, c)| halves(p(r, c), p(r, c + 1), p(r + 1, c + 1), p(r + 1, c)));
    let one = halves(p(0, 0), p(0, 2), p(2, 2), p(2, 0));
    let orientation = cell_halves[0][0].signum();
    if cell_halves
        .iter()
        .chain([&one])
        .flatten()
        .any(|h| !(h * orientation > 0.0))
    {
        return None;
    }
    let floor = pupil_mm2 / gain_bound(max_gain);
    let (mut lo, mut hi, mut power, mut area) = (f64::INFINITY, 0.0f64, 0.0, 0.0);
    for ((r, c), h) in firsts.into_iter().zip(cell_halves) {
        let a = orientation * (h[0] + h[1]);
        if a < floor {
            return None;
        }
        let mean_t = 0.25 * (t(r, c) + t(r, c + 1) + t(r + 1, c + 1) + t(r + 1, c));
        let e = mean_t * pupil_mm2 / a;
        lo = lo.min(e);
        hi = hi.max(e);
        power += mean_t * pupil_mm2;
        area += a;
    }
    let one_area = orientation * (one[0] + one[1]);
    if hi > lo * (1.0 + spread) || (one_area - area).abs() > 0.1 * spread * area {
        return None;
    }
    Some((power / one_area).min(hi)).filter(|e| e.is_finite())
}

#[cfg(test)]
mod tests {
    use super::super::intensity::{DEFAULT_MAX_GAIN, test_ray as ray};
    use super::*;

    /// The 3 × 3 rays of `map` at pupil points (col, row) ∈ {0, 1, 2}².
    fn block(map: impl Fn(f64, f64) -> (DVec2, f64)) -> [[GridRay; 3]; 3] {
        std::array::from_fn(|r| {
            std::array::from_fn(|c| {
                let (p, t) = map(c as f64, r as f64);
                ray(p.x, p.y, t)
            })
        })
    }

    /// A round iris far wider than the test rays' stop points (at 0).
    fn wide_iris() -> Aperture {
        Aperture::circle(10.0).expect("a circle")
    }

    fn merged(b: &[[GridRay; 3]; 3], spread: f64) -> Option<f64> {
        let refs = [0, 1, 2].map(|r| [0, 1, 2].map(|c| &b[r][c]));
        merged_block(refs, &wide_iris(), 1.0, DEFAULT_MAX_GAIN, spread)
    }

    #[test]
    fn an_affine_block_merges_to_its_cells_irradiance() {
        // Pupil cells of 1 mm² mapped to 0.5 × 0.25 mm, sheared and
        // mirrored: every cell's irradiance is 8 · T.
        let b = block(|u, v| (DVec2::new(-0.5 * u + 0.1 * v, 0.25 * v), 0.6));
        let e = merged(&b, 0.1).expect("an affine block merges");
        assert!((e - 0.6 * 8.0).abs() < 1e-12, "{e}");
    }

    #[test]
    fn the_merged_cell_carries_the_four_cells_power() {
        // A gentle bend and throughput slope: the one cell's irradiance
        // times its area is the four cells' power.
        let map = |u: f64, v: f64| {
            let p = DVec2::new(u + 0.01 * v * v, v + 0.02 * u * v);
            (p, 0.5 + 0.01 * u)
        };
        let b = block(map);
        let e = merged(&b, 0.5).expect("a gentle block merges");
        let refs = [0, 1, 2].map(|r| [0, 1, 2].map(|c| &b[r][c]));
        let corners = [refs[0][0], refs[0][2], refs[2][2], refs[2][0]].map(|r| r.sensor);
        let one: f64 = halves(corners[0], corners[1], corners[2], corners[3])
            .iter()
            .sum();
        let mut power = 0.0;
        for (r, c) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
            let cell = super::super::cell_intensity(
                [
                    refs[r][c],
                    refs[r][c + 1],
                    refs[r + 1][c + 1],
                    refs[r + 1][c],
                ],
                1.0,
                DEFAULT_MAX_GAIN,
            );
            power += cell.intensity * cell.sensor_area_mm2;
        }
        assert!(
            (e * one - power).abs() < 1e-12 * power,
            "{} vs {power}",
            e * one
        );
    }

    #[test]
    fn a_block_that_is_not_smooth_stays_four_cells() {
        let flat = |u: f64, v: f64| (DVec2::new(u, v), 1.0);
        assert!(merged(&block(flat), 0.5).is_some());
        // No spread, or a bad one: never.
        for spread in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(merged(&block(flat), spread), None, "spread {spread}");
        }
        // A dead ray, a ray past a rim, a NaN r_rel.
        for edit in [
            (|r: &mut GridRay| r.alive = false) as fn(&mut GridRay),
            |r| r.r_rel = 1.01,
            |r| r.r_rel = f64::NAN,
        ] {
            let mut b = block(flat);
            edit(&mut b[1][2]);
            assert_eq!(merged(&b, 0.5), None);
        }
        // A fold: the middle ray pushed past its neighbour.
        let mut b = block(flat);
        b[1][1].sensor = DVec2::new(2.5, 1.0);
        assert_eq!(merged(&b, 0.5), None);
        // Irradiances 1 and 2 side by side: merged at a spread of 1.5, not 0.5.
        let ramp = |u: f64, v: f64| (DVec2::new(if u > 1.5 { 1.5 } else { u }, v), 1.0);
        let b = block(ramp);
        assert_eq!(merged(&b, 0.5), None);
        assert!(merged(&b, 1.5).is_some());
        // A blade edge between the rays at the stop: one ray's crossing
        // outside a hexagonal iris.
        let mut b = block(flat);
        b[2][0].stop_xy = [DVec2::new(0.0, 0.99); 3];
        let refs = [0, 1, 2].map(|r| [0, 1, 2].map(|c| &b[r][c]));
        let hexagon = Aperture::polygon(6, 0.0, 1.0).expect("a hexagon");
        assert_eq!(
            merged_block(refs, &hexagon, 1.0, DEFAULT_MAX_GAIN, 0.5),
            None
        );
        assert!(merged_block(refs, &wide_iris(), 1.0, DEFAULT_MAX_GAIN, 0.5).is_some());
        // A cell at the gain bound.
        let tiny = |u: f64, v: f64| (DVec2::new(1e-4 * u, 1e-4 * v), 1.0);
        assert_eq!(merged(&block(tiny), 0.5), None);
    }
}
