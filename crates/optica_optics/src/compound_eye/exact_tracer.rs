//! The exact lattice tracer: the reference the shading path is measured
//! against.

use glam::{DVec2, DVec3};

use super::ball_lens::refract_through_ball;
use super::lattice::Lattice;
use super::lattice_kind::WALK_CORNERS;
use super::outcome::{Shade, ShadeFallback};
use super::shading_path::{ball_fallback, finish, polygon_entry};
use crate::ray::Ray;

/// Most cells one walk visits before giving up with
/// [`ShadeFallback::TraversalLimit`]. A ray with `−dir·N = δ` crosses the
/// lens layer (`2r`, one facet for touching lenses) over about `1/δ` facets
/// and `√2/δ` cells: ~600 at 89.9° from the normal. `2^16` binds only below
/// `δ ≈ 2e-5` (89.9987°), far beyond the sweep's 89.5°, and bounds the walk
/// of a ray that skims the surface between the lenses.
pub const MAX_CELLS: u32 = 1 << 16;

/// The thesis's model: the first lens only, then the pigment plane.
pub const THESIS_MAX_LENSES: u32 = 1;

/// Cells one walk visits in the shader's exact path ([`ShadeOptions::exact`](super::ShadeOptions::exact))
/// before the ray is given up as a fallback: a ray crossing the lens layer
/// at `θ` from the normal walks about `2·tan θ` facets, 11 at 80°; 64 cells
/// bind only beyond about 88°, where a pixel spans many facets anyway.
pub const MAX_WALK_CELLS: u32 = 64;

/// Most lenses the shader's exact path follows a ray through: rays seen
/// obliquely pass through several lenses before they reach the pigment or
/// leave the eye.
pub const MAX_EXACT_LENSES: u32 = 16;

/// Traces `ray` exactly through the lattice: the first lens it really meets
/// (searched over every reachable lens), both refractions, then on through at
/// most `max_lenses` lenses in all (`1` = the thesis's model; `0` = no lens,
/// a straight line to the pigment plane), then the pigment plane. The
/// reference [`shade`](super::shade) is measured against (cargo feature
/// `reference`).
///
/// The view ray is walked cell by cell across the lens layer (depths
/// `0..2r`) with a 2-D Amanatides–Woo walk (J. Amanatides and A. Woo, "A
/// fast voxel traversal algorithm for ray tracing", Eurographics 1987) over
/// the unit cells of the lattice coordinates ([`super::LatticeKind::to_lattice`]:
/// the square cells themselves, or the parallelograms of the hexagonal
/// lattice's axial coordinates), and at each cell it is tested against every
/// lens whose cell can hold a point of it (the 3×3 block; the parallelogram's
/// corners and their neighbours); the nearest entry wins. Because a lens lies
/// inside its own cell's column, every lens the ray can reach is tested
/// before the walk passes it, and the walk stops as soon as the nearest hit
/// lies within the cell being left.
/// The ray is refracted in and out (eq. 6.28 for both normals) and goes on to
/// the pigment plane (6.29). With `max_lenses > 1` it is followed into further
/// lenses on its way — the repeated refraction the thesis leaves for future
/// work (§6.5).
pub fn trace_exact(lattice: &Lattice, ray: &Ray, max_lenses: u32) -> Shade {
    trace_exact_capped(lattice, ray, max_lenses, MAX_CELLS)
}

/// [`trace_exact`] with each walk across the lens layer cut off after
/// `max_cells` cells (a [`ShadeFallback::TraversalLimit`]): the shader's
/// exact path, with [`MAX_WALK_CELLS`].
pub fn trace_exact_capped(lattice: &Lattice, ray: &Ray, max_lenses: u32, max_cells: u32) -> Shade {
    let mut path = match polygon_entry(lattice, ray) {
        Ok(fragment) => fragment,
        Err(f) => return Shade::Fallback(f),
    };
    let mut first = None;
    let mut last = None;
    let mut count = 0;
    let mut transmittance = 1.0;
    while count < max_lenses {
        let (cell, centre, t) = match first_lens(lattice, &path, last, max_cells) {
            Ok(Some(hit)) => hit,
            Ok(None) => break,
            Err(f) => return Shade::Fallback(f),
        };
        let entry = Ray::from_unit(path.at(t), path.dir());
        match refract_through_ball(&entry, centre, lattice.lens()) {
            Ok(out) => {
                path = out.ray();
                transmittance *= out.transmittance;
            }
            Err(e) => return Shade::Fallback(ball_fallback(e, cell)),
        }
        first = first.or(Some(cell));
        last = Some(cell);
        count += 1;
    }
    finish(lattice, &path, first, last, count, transmittance)
}

/// [`trace_exact`] over many rays, in parallel.
#[cfg(feature = "reference")]
pub fn trace_exact_batch(lattice: &Lattice, rays: &[Ray], max_lenses: u32) -> Vec<Shade> {
    use rayon::prelude::*;
    rays.par_iter()
        .map(|r| trace_exact(lattice, r, max_lenses))
        .collect()
}

/// The nearest lens `view` enters while in the lens layer, skipping the lens
/// `exclude` (the one it just left): `(cell, centre, t_entry)`; a
/// [`ShadeFallback::TraversalLimit`] after `max_cells` cells.
pub(crate) fn first_lens(
    lattice: &Lattice,
    view: &Ray,
    exclude: Option<[i64; 2]>,
    max_cells: u32,
) -> Result<Option<([i64; 2], DVec3, f64)>, ShadeFallback> {
    let (origin, dir) = (view.origin(), view.dir());
    let axes = lattice.axes();
    let eps = lattice.eps();
    let r = lattice.lens().radius();
    // The t-range in which the ray is inside the layer −eps ≤ depth ≤ 2r + eps.
    let h0 = axes.depth(origin);
    let down = -dir.dot(axes.normal());
    let (lo, hi) = (-eps, 2.0 * r + eps);
    let (t_start, t_end) = if down > 0.0 {
        (((lo - h0) / down).max(0.0), (hi - h0) / down)
    } else if down < 0.0 {
        (((hi - h0) / down).max(0.0), (lo - h0) / down)
    } else if (lo..=hi).contains(&h0) {
        (0.0, f64::INFINITY)
    } else {
        return Ok(None);
    };
    if !(t_end >= t_start) {
        return Ok(None);
    }
    // 2-D Amanatides–Woo in lattice coordinates, from the layer entry.
    let kind = lattice.kind();
    let uv0 = kind.to_lattice(axes.uv_of(origin + t_start * dir));
    let duv = kind.lattice_rate(axes.uv_rate(dir));
    if !uv0.is_finite() || !duv.is_finite() {
        return Err(ShadeFallback::Overflow);
    }
    let mut cell = uv0.floor();
    let step = DVec2::new(sign(duv.x), sign(duv.y));
    let next = |c: f64, u: f64, d: f64| -> f64 {
        if d > 0.0 {
            t_start + (c + 1.0 - u) / d
        } else if d < 0.0 {
            t_start + (c - u) / d
        } else {
            f64::INFINITY
        }
    };
    let mut t_max = DVec2::new(next(cell.x, uv0.x, duv.x), next(cell.y, uv0.y, duv.y));
    let t_delta = DVec2::new(inv_abs(duv.x), inv_abs(duv.y));
    let mut best: Option<([i64; 2], DVec3, f64)> = None;
    for _ in 0..max_cells {
        for [di, dj] in WALK_CORNERS {
            let index = [cell.x as i64 + di, cell.y as i64 + dj];
            if Some(index) == exclude {
                continue;
            }
            let centre = lattice.lens_centre(kind.centre_of_index(index));
            if let Some(t) = lattice.lens_entry(view, centre)
                && best.is_none_or(|b| t < b.2)
            {
                best = Some((index, centre, t));
            }
        }
        let t_exit = t_max.x.min(t_max.y);
        // Every lens entered before t_exit has been tested (lenses stay
        // within their columns), so the nearest hit so far is final.
        if let Some(b) = best
            && b.2 <= t_exit
        {
            return Ok(best);
        }
        if t_exit >= t_end {
            return Ok(best);
        }
        if t_max.x < t_max.y {
            cell.x += step.x;
            t_max.x += t_delta.x;
        } else {
            cell.y += step.y;
            t_max.y += t_delta.y;
        }
    }
    Err(ShadeFallback::TraversalLimit)
}

fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

fn inv_abs(x: f64) -> f64 {
    if x != 0.0 {
        1.0 / x.abs()
    } else {
        f64::INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compound_eye::lattice::LensParams;
    use crate::compound_eye::lattice_kind::LatticeKind;
    use crate::compound_eye::shading_path::{MAX_LENSES, ShadeOptions, shade, shade_with};
    use crate::compound_eye::texture_axes::TextureAxes;
    use proptest::prelude::*;

    fn unit_lattice(r: f64, n: f64, d: f64) -> Lattice {
        let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z).unwrap();
        Lattice::new(axes, LensParams::new(r, n, d).unwrap()).unwrap()
    }

    fn ray_at(x: f64, y: f64, polar_deg: f64, azimuth_deg: f64) -> Ray {
        let (t, p) = (polar_deg.to_radians(), azimuth_deg.to_radians());
        let dir = DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), -t.cos());
        Ray::new(DVec3::new(x, y, 0.0) - dir, dir).unwrap()
    }

    /// A set of rays over one cell: `m × m` points, 8 azimuths, at `polar_deg`.
    fn rays(polar_deg: f64, m: usize) -> Vec<Ray> {
        let mut out = Vec::new();
        for i in 0..m {
            for j in 0..m {
                for k in 0..8 {
                    let (x, y) = ((i as f64 + 0.5) / m as f64, (j as f64 + 0.37) / m as f64);
                    out.push(ray_at(x, y, polar_deg, 7.0 + 45.0 * k as f64));
                }
            }
        }
        out
    }

    /// (mean |Δuv|, fraction of rays whose first lens differs) of the shading path vs the exact tracer.
    fn compare(l: &Lattice, rays: &[Ray], slices: u32) -> (f64, f64) {
        let (mut sum, mut wrong, mut n) = (0.0, 0usize, 0usize);
        for ray in rays {
            if let (Shade::Pigment(s), Shade::Pigment(e)) =
                (shade(l, ray, slices), trace_exact(l, ray, 1))
            {
                sum += (s.uv - e.uv).length();
                wrong += usize::from(s.lens != e.lens);
                n += 1;
            }
        }
        (sum / n as f64, wrong as f64 / rays.len() as f64)
    }

    #[test]
    fn grazing_ray_enters_a_neighbours_lens() {
        // Hits the polygon at (0.9, 0.5) in cell (0, 0), heading +x at 80°: it
        // passes over lens (0, 0) (whose top is 0.2 deep 0.4 off its axis, the
        // ray only 0.018 deep at the cell edge) and enters lens (1, 0) near
        // x ≈ 1.25 (hand computation with r = 0.5).
        let l = unit_lattice(0.5, 1.5, 1.0);
        let ray = ray_at(0.9, 0.5, 80.0, 0.0);
        let exact = *trace_exact(&l, &ray, 1).hit().unwrap();
        assert_eq!(exact.lens, Some([1, 0]));
        // One estimate at the polygon (K = 0) tries lens (0, 0), misses, and
        // goes straight on: a measurably different texel.
        let k0 = *shade(&l, &ray, 0).hit().unwrap();
        assert_eq!(k0.lens, None);
        assert!(
            (k0.uv - exact.uv).length() > 0.3,
            "{:?} vs {:?}",
            k0.uv,
            exact.uv
        );
        // Slices at depth r/8 already see the ray in cell (1, 0).
        let k8 = *shade(&l, &ray, 8).hit().unwrap();
        assert_eq!(k8.lens, Some([1, 0]));
        assert!((k8.uv - exact.uv).length() < 1e-12);
    }

    #[test]
    fn near_normal_rays_agree_and_grazing_rays_differ() {
        let l = unit_lattice(0.5, 1.5, 1.0);
        for polar in [0.0, 3.0, 6.0, 10.0] {
            let (mean, wrong) = compare(&l, &rays(polar, 12), 2);
            assert!(
                mean < 1e-12 && wrong == 0.0,
                "{polar}°: mean {mean}, wrong {wrong}"
            );
        }
        for polar in [75.0, 80.0, 85.0] {
            let (mean, wrong) = compare(&l, &rays(polar, 12), 2);
            assert!(
                mean > 0.02 && wrong > 0.02,
                "{polar}°: mean {mean}, wrong {wrong}"
            );
        }
    }

    #[test]
    fn slice_search_error_falls_with_the_slice_count() {
        // Nested slice sets (K = 1, 2, 4, …): once a ray's lens is right it stays
        // right, so the wrong-lens fraction cannot grow.
        let l = unit_lattice(0.5, 1.5, 1.0);
        let rays: Vec<Ray> = [50.0, 70.0, 80.0]
            .iter()
            .flat_map(|&p| rays(p, 10))
            .collect();
        let mut last = (f64::INFINITY, f64::INFINITY);
        for k in [0, 1, 2, 4, 8, 16, 32, 64] {
            let (mean, wrong) = compare(&l, &rays, k);
            assert!(
                wrong <= last.1 + 1e-15,
                "K {k}: wrong {wrong} after {}",
                last.1
            );
            last = (mean, wrong);
        }
        let (m0, _) = compare(&l, &rays, 0);
        assert!(last.0 < 0.2 * m0, "K = 64 mean {} vs K = 0 {m0}", last.0);
    }

    #[test]
    fn repeated_refraction_only_matters_off_normal() {
        let l = unit_lattice(0.5, 1.5, 1.0);
        for ray in rays(0.0, 8) {
            assert_eq!(trace_exact(&l, &ray, 1), trace_exact(&l, &ray, 8));
        }
        let grazing = rays(70.0, 8);
        let changed = grazing
            .iter()
            .filter(|r| trace_exact(&l, r, 1) != trace_exact(&l, r, 8))
            .count();
        assert!(
            changed > grazing.len() / 20,
            "only {changed} of {} changed",
            grazing.len()
        );
    }

    /// Brute force: the nearest lens entry over a 61 × 61 block of lenses.
    fn brute_first_lens(l: &Lattice, ray: &Ray) -> Option<([i64; 2], f64)> {
        let view = polygon_entry(l, ray).ok()?;
        brute_next_lens(l, &view, None)
    }

    /// Brute force from a point already past the polygon, skipping `exclude`:
    /// over a 61 × 61 block of lenses round the lens left (a long exit walk
    /// goes further than 30 lenses from the first: found by this test with
    /// a hexagonal walk whose 16th lens was [32, −16]).
    fn brute_next_lens(
        l: &Lattice,
        view: &Ray,
        exclude: Option<[i64; 2]>,
    ) -> Option<([i64; 2], f64)> {
        let mut best: Option<([i64; 2], f64)> = None;
        let [ci, cj] = exclude.unwrap_or([0, 0]);
        for i in ci - 30..=ci + 30 {
            for j in cj - 30..=cj + 30 {
                if Some([i, j]) == exclude {
                    continue;
                }
                let c = l.lens_centre(l.kind().centre_of_index([i, j]));
                if let Some(t) = l.lens_entry(view, c)
                    && best.is_none_or(|b| t < b.1)
                {
                    best = Some(([i, j], t));
                }
            }
        }
        best
    }

    /// The lenses `ray` passes, found by the walk or by brute force.
    fn lens_sequence(l: &Lattice, ray: &Ray, brute: bool) -> Vec<[i64; 2]> {
        let mut path = polygon_entry(l, ray).unwrap();
        let mut seen = Vec::new();
        while seen.len() < MAX_EXACT_LENSES as usize {
            let last = seen.last().copied();
            let hit = if brute {
                brute_next_lens(l, &path, last)
                    .map(|(c, t)| (c, l.lens_centre(l.kind().centre_of_index(c)), t))
            } else {
                first_lens(l, &path, last, MAX_CELLS).unwrap()
            };
            let Some((cell, centre, t)) = hit else { break };
            let Ok(out) =
                refract_through_ball(&Ray::from_unit(path.at(t), path.dir()), centre, l.lens())
            else {
                break;
            };
            path = out.ray();
            seen.push(cell);
        }
        seen
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(1000))]
        #[test]
        fn cell_walk_finds_the_brute_force_first_lens(
            x in 0.0f64..1.0, y in 0.0f64..1.0,
            polar in 0.0f64..86.0, azimuth in 0.0f64..360.0,
            skew in -0.9f64..0.9, r_frac in 0.05f64..1.0, stretch in 0.3f64..3.0,
        ) {
            // A skewed, stretched lattice: cells are parallelograms.
            let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X * stretch, DVec3::new(skew, 1.0, 0.0), DVec3::Z).unwrap();
            for kind in [LatticeKind::Square, LatticeKind::Hexagonal] {
                let r = r_frac * kind.cell_inradius(axes.u(), axes.v());
                let l = Lattice::with_kind(axes, LensParams::thesis(r, 1.5).unwrap(), kind).unwrap();
                let ray = ray_at(x, y, polar, azimuth);
                let fragment = polygon_entry(&l, &ray).unwrap();
                let walk = first_lens(&l, &fragment, None, MAX_CELLS).unwrap();
                let brute = brute_first_lens(&l, &ray);
                prop_assert_eq!(walk.map(|w| w.0), brute.map(|b| b.0), "{:?}", kind);
                if let (Some(w), Some(b)) = (walk, brute) {
                    prop_assert!((w.2 - b.1).abs() < 1e-12);
                }
            }
        }

        #[test]
        fn exit_ray_walks_find_the_brute_force_lenses(
            x in 0.0f64..1.0, y in 0.0f64..1.0,
            polar in 30.0f64..86.0, azimuth in 0.0f64..360.0,
            skew in -0.6f64..0.6, r_frac in 0.5f64..1.0, index in 1.2f64..1.8,
        ) {
            // Exit rays start on a sphere, anywhere in the layer, and may
            // climb out of it: every lens they meet, in order, up to the cap.
            let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::new(skew, 1.0, 0.0), DVec3::Z).unwrap();
            for kind in [LatticeKind::Square, LatticeKind::Hexagonal] {
                let r = r_frac * kind.cell_inradius(axes.u(), axes.v());
                let l = Lattice::with_kind(axes, LensParams::thesis(r, index).unwrap(), kind).unwrap();
                let ray = ray_at(x, y, polar, azimuth);
                prop_assert_eq!(lens_sequence(&l, &ray, false), lens_sequence(&l, &ray, true), "{:?}", kind);
            }
        }
    }

    /// (mean |Δuv|, fraction of rays whose lens differs) of the shading path
    /// with `options` against the exact tracer through `max_lenses` lenses.
    fn compare_with(
        l: &Lattice,
        rays: &[Ray],
        options: &ShadeOptions,
        max_lenses: u32,
    ) -> (f64, f64) {
        let (mut sum, mut wrong, mut n) = (0.0, 0usize, 0usize);
        for ray in rays {
            match (shade_with(l, ray, options), trace_exact(l, ray, max_lenses)) {
                (Shade::Pigment(s), Shade::Pigment(e)) => {
                    sum += (s.uv - e.uv).length();
                    wrong += usize::from(s.lens != e.lens || s.lenses != e.lenses);
                    n += 1;
                }
                (a, b) => wrong += usize::from(a.hit().is_some() != b.hit().is_some()),
            }
        }
        (sum / n.max(1) as f64, wrong as f64 / rays.len() as f64)
    }

    #[test]
    fn hexagonal_slice_search_converges_to_the_exact_tracer() {
        let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z).unwrap();
        let l = Lattice::with_kind(
            axes,
            LensParams::thesis(0.5, 1.5).unwrap(),
            LatticeKind::Hexagonal,
        )
        .unwrap();
        let rays: Vec<Ray> = [0.0, 40.0, 70.0].iter().flat_map(|&p| rays(p, 8)).collect();
        let (m0, w0) = compare_with(&l, &rays, &ShadeOptions::thesis(0), 1);
        let (m32, w32) = compare_with(&l, &rays, &ShadeOptions::thesis(32), 1);
        assert!(
            w32 < 0.02 && w32 < w0,
            "wrong-lens fraction {w0} at K = 0, {w32} at K = 32"
        );
        assert!(
            m32 < 0.2 * m0,
            "mean texel error {m0} at K = 0, {m32} at K = 32"
        );
        // Normal incidence through a lens axis lands on it, in both lattices.
        let c = l.kind().centre_of_index([3, -2]);
        let ray = Ray::new(DVec3::new(c.x, c.y, 1.0), -DVec3::Z).unwrap();
        let hit = *trace_exact(&l, &ray, 1).hit().unwrap();
        assert_eq!(hit.lens, Some([3, -2]));
        assert!((hit.uv - c).length() < 1e-12);
    }

    #[test]
    fn following_neighbours_approaches_the_exact_multi_lens_trace() {
        let l = unit_lattice(0.5, 1.5, 1.0);
        let rays: Vec<Ray> = [50.0, 70.0, 80.0]
            .iter()
            .flat_map(|&p| rays(p, 10))
            .collect();
        let (_, thesis) = compare_with(&l, &rays, &ShadeOptions::thesis(32), MAX_LENSES);
        let (_, follow) = compare_with(&l, &rays, &ShadeOptions::neighbours(32), MAX_LENSES);
        // The thesis's one-lens path misses the second lens of many grazing
        // rays; following the exit ray finds most of them.
        assert!(
            thesis > 0.05,
            "one-lens path against {MAX_LENSES}-lens trace: {thesis}"
        );
        assert!(
            follow < 0.5 * thesis,
            "followed: {follow}, thesis: {thesis}"
        );
        let passed_two = rays
            .iter()
            .filter(|r| {
                shade_with(&l, r, &ShadeOptions::neighbours(32))
                    .hit()
                    .is_some_and(|h| h.lenses >= 2)
            })
            .count();
        assert!(passed_two > 0);
    }

    #[test]
    fn lens_surfaces_transmit_the_fresnel_remainder() {
        // Through the axis at normal incidence: R = ((n−1)/(n+1))² = 0.04 at
        // each surface for n = 1.5, so T = 0.96² = 0.9216.
        let l = unit_lattice(0.5, 1.5, 1.0);
        let ray = ray_at(0.5, 0.5, 0.0, 0.0);
        for got in [shade(&l, &ray, 4), trace_exact(&l, &ray, 3)] {
            let h = got.hit().unwrap();
            assert!(
                (h.transmittance - 0.9216).abs() < 1e-12,
                "{}",
                h.transmittance
            );
        }
        // n = 1: nothing reflected; no lens: nothing either.
        let one = unit_lattice(0.5, 1.0, 1.0);
        assert!((trace_exact(&one, &ray, 2).hit().unwrap().transmittance - 1.0).abs() < 1e-15);
        let between = ray_at(0.95, 1.02, 0.0, 0.0);
        assert_eq!(shade(&l, &between, 4).hit().unwrap().transmittance, 1.0);
        // Off axis the loss grows; it stays in (0, 1].
        for got in rays(70.0, 6).iter().map(|r| trace_exact(&l, r, MAX_LENSES)) {
            if let Some(h) = got.hit() {
                assert!(h.transmittance > 0.0 && h.transmittance <= 1.0, "{h:?}");
            }
        }
    }
}
