//! The thesis's shading path for one view ray (§6.4–6.6): the CPU twin of
//! the compound-eye fragment shader. See [`shade`].

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::ball_lens::{BallFailure, refract_through_ball};
use super::exact_tracer::{MAX_EXACT_LENSES, MAX_WALK_CELLS, trace_exact_capped};
use super::lattice::{Lattice, MAX_SLICES, MIN_COS, PigmentPlaneHit};
use super::lattice_kind::LensCell;
use super::outcome::{PigmentHit, Shade, ShadeFallback};
use crate::ray::Ray;

/// Where `ray` meets the polygon from the front, as the fragment ray (origin
/// on the polygon, same direction), or why it does not. Shared with the
/// exact tracer so both start from the same fragment.
pub(crate) fn polygon_entry(lattice: &Lattice, ray: &Ray) -> Result<Ray, ShadeFallback> {
    let axes = lattice.axes();
    let cos = -ray.dir().dot(axes.normal());
    if !(cos > MIN_COS) {
        return Err(ShadeFallback::PolygonMiss);
    }
    let h0 = axes.depth(ray.origin());
    if h0 > lattice.eps() {
        // The ray starts under the surface: no fragment is drawn for it.
        return Err(ShadeFallback::PolygonMiss);
    }
    let p = ray.at((-h0 / cos).max(0.0));
    if p.is_finite() {
        Ok(Ray::from_unit(p, ray.dir()))
    } else {
        Err(ShadeFallback::Overflow)
    }
}

/// Most lenses the shading path follows one view ray through: the bound of
/// the WGSL loop. Beyond the first lens, each further one is a neighbour the
/// exit ray enters on its way to the pigment plane; with touching lenses of
/// `n = 1.5` the exact tracer (rays from 0° to 89°, 16 azimuths, 12×12
/// points per cell) finds no ray that passes more than three lenses before
/// the pigment.
pub const MAX_LENSES: u32 = 4;

/// How far along an exit ray the neighbour search looks when the ray runs
/// almost parallel to the lens layer, in cell widths (twice the cell
/// inradius): a ray that has not met a lens within four cells of nearly
/// horizontal travel is one that skims the gaps, which the exact tracer
/// resolves and the shader leaves to the pigment plane.
pub const NEIGHBOUR_SPAN_CELLS: f64 = 4.0;

/// The knobs of the shading path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ShadeOptions {
    /// Slice planes of the entry search below the polygon, `K` (clamped to
    /// [`MAX_SLICES`]; 0 = the polygon alone, §6.4). The neighbour search
    /// samples each exit ray at as many points.
    pub slices: u32,
    /// Most lenses a ray is followed through (clamped to `1..=`[`MAX_LENSES`]):
    /// 1 is the thesis's model (one lens, then the pigment plane); more
    /// follows the exit ray into neighbouring lenses, the repeated refraction
    /// the thesis leaves for future work (§6.5). With `exact`, clamped to
    /// `1..=`[`MAX_EXACT_LENSES`].
    pub max_lenses: u32,
    /// Follow the exact tracer's path instead of the slice search: the
    /// view ray walked cell by cell across the whole lens layer, every lens
    /// it can reach tested (spheres entered below their equator too), each
    /// exit ray walked the same way ([`trace_exact_capped`] with
    /// [`MAX_WALK_CELLS`]). `slices` is then unused.
    #[serde(default)]
    pub exact: bool,
}

impl ShadeOptions {
    /// The thesis's model with `slices` slice planes: one lens per ray.
    pub fn thesis(slices: u32) -> Self {
        Self {
            slices,
            max_lenses: 1,
            exact: false,
        }
    }

    /// The physical default: `slices` slice planes, rays followed through up
    /// to [`MAX_LENSES`] lenses.
    pub fn neighbours(slices: u32) -> Self {
        Self {
            slices,
            max_lenses: MAX_LENSES,
            exact: false,
        }
    }

    /// The exact tracer's path through up to `max_lenses` lenses (1: the
    /// thesis's one lens, found exactly).
    pub fn exact(max_lenses: u32) -> Self {
        Self {
            slices: 0,
            max_lenses,
            exact: true,
        }
    }
}

/// Traces `ray` by the thesis's shading path (one lens) with `slices` slice
/// planes below the polygon: [`shade_with`] and [`ShadeOptions::thesis`].
pub fn shade(lattice: &Lattice, ray: &Ray, slices: u32) -> Shade {
    shade_with(lattice, ray, &ShadeOptions::thesis(slices))
}

/// Traces `ray` by the shading path: where it meets the polygon (eq. 6.16),
/// then [`shade_fragment_with`]. A ray that does not reach the polygon from
/// the front is a [`ShadeFallback::PolygonMiss`].
///
/// Written the way the shader is: loops with uniform bounds ([`MAX_SLICES`],
/// [`MAX_LENSES`]), no allocation, no recursion, every branch a defined
/// value. Steps, with the thesis's equation numbers:
///
/// 1. The fragment: the view ray's hit `P` on the polygon and its texture
///    coordinate `(a, b)` (eq. 6.16).
/// 2. For slice `s = 0..=K` at depth `h = s·r/K` (`s = 0`: the polygon
///    itself; the last slice at `h = r`, §6.4): the view ray's point `P_s` on
///    the slice plane, projected back onto the polygon (6.23) and its texture
///    coordinate by least squares (6.24–6.27); the cell holding it
///    (6.17–6.20 for the square lattice, [`super::LatticeKind::cell_of`]),
///    its centre on the polygon (6.21) and the lens centre `S = P' − r·N`
///    (6.22); the first lens the view ray intersects ends the search.
/// 3. Refraction into and out of that lens (6.28). With
///    `max_lenses > 1`, the exit ray is sampled at `max(K, 1)` points through
///    the lens layer (to depth `2r`, or up to the polygon, or at most
///    [`NEIGHBOUR_SPAN_CELLS`] cells); the first point whose cell's lens
///    (not the one just left) the exit ray enters gives the next lens, and so
///    on up to `max_lenses`.
/// 4. The pigment-plane hit and its texture coordinate (6.29).
///
/// No lens found: the unrefracted ray goes on to the pigment plane (§6.4).
///
/// Why the search is exact in the limit: each lens lies inside its own cell's
/// column (`r ≤` the cell's inradius, checked by [`Lattice::with_kind`]), and a
/// straight ray crosses each column once, in order. So a lens picked at a
/// slice that the ray intersects at all is the *first* lens it meets unless
/// the first lens's column lay wholly between two slices; with `K → ∞` the
/// path therefore finds the exact first lens for every ray that is inside
/// that lens's column somewhere between the polygon and the last slice
/// (`0 ≤ h ≤ r`, the lenses' equator plane). Rays that reach their first
/// lens's column only below depth `r` (grazing rays that slip through the
/// gaps between lenses, at cell corners, and cross into the column deep
/// down) stay unresolved at any `K` — that is the method's error floor. Where
/// the ray meets the sphere does not matter: a ray that is in the column
/// above depth `r` is found even when it enters the sphere below its
/// equator.
///
/// Measured against the exact lattice tracer (square lattice: unit facets,
/// touching lenses `r = ½`, `n = 1.5`, `d = 2r`, rays from 0° to 89°): the
/// wrong-lens fraction falls from 42 % at `K = 0` to 4.3 % at `K = 8` and to
/// its floor of 0.05 % from `K = 32` on; a single extra slice at `h = r`
/// (`K = 1`) is *worse* than none in mean texel error at grazing angles,
/// because it jumps past the ray's first lens to a later one. Near-normal
/// rays (≤ 10°) need only `K ≥ 1`.
pub fn shade_with(lattice: &Lattice, ray: &Ray, options: &ShadeOptions) -> Shade {
    match polygon_entry(lattice, ray) {
        Ok(fragment) => shade_fragment_with(lattice, &fragment, options),
        Err(f) => Shade::Fallback(f),
    }
}

/// [`shade_fragment_with`] with [`ShadeOptions::thesis`]`(slices)`.
pub fn shade_fragment(lattice: &Lattice, fragment: &Ray, slices: u32) -> Shade {
    shade_fragment_with(lattice, fragment, &ShadeOptions::thesis(slices))
}

/// The fragment shader's body: `fragment` starts at the fragment's position
/// on the polygon and runs along the view direction (camera → fragment).
/// Steps 2–4 of [`shade_with`]; a fragment ray that does not point into the
/// surface is a [`ShadeFallback::PolygonMiss`].
pub fn shade_fragment_with(lattice: &Lattice, fragment: &Ray, options: &ShadeOptions) -> Shade {
    if options.exact {
        let lenses = options.max_lenses.clamp(1, MAX_EXACT_LENSES);
        return trace_exact_capped(lattice, fragment, lenses, MAX_WALK_CELLS);
    }
    let axes = lattice.axes();
    let lens = lattice.lens();
    let r = lens.radius();
    let (p, dir) = (fragment.origin(), fragment.dir());
    let cos = -dir.dot(axes.normal());
    if !(cos > MIN_COS) {
        return Shade::Fallback(ShadeFallback::PolygonMiss);
    }
    let k = options.slices.min(MAX_SLICES);
    // Step 2: slice-plane search (6.16–6.27).
    let mut found = None;
    for s in 0..=k {
        let h = if k == 0 {
            0.0
        } else {
            r * f64::from(s) / f64::from(k)
        };
        let p_s = p + (h / cos) * dir; // the view ray on the slice plane at depth h
        let uv_s = lattice.slice_uv(p_s, h); // (6.23)–(6.27); s = 0 is (6.16)
        let cell = lattice.cell_of(uv_s); // (6.17)–(6.20)
        let c = lattice.lens_centre(cell.centre_uv); // (6.21)–(6.22)
        if let Some(t) = lattice.lens_entry(fragment, c) {
            found = Some((cell, c, t));
            break;
        }
    }
    let Some((mut cell, mut centre, mut t_entry)) = found else {
        // No lens: straight on to the pigment plane (§6.4, last paragraph).
        return finish(lattice, fragment, None, None, 0, 1.0);
    };
    // Step 3: refraction in and out (6.28), then on into neighbours.
    let first = cell.index;
    let max_lenses = options.max_lenses.clamp(1, MAX_LENSES);
    let mut path = *fragment;
    let mut transmittance = 1.0;
    let mut count = 0;
    loop {
        let entry = Ray::from_unit(path.at(t_entry), path.dir());
        let out = match refract_through_ball(&entry, centre, lens) {
            Ok(out) => out,
            Err(e) => return Shade::Fallback(ball_fallback(e, cell.index)),
        };
        path = out.ray();
        transmittance *= out.transmittance;
        count += 1;
        if count >= max_lenses {
            break;
        }
        match next_lens(lattice, &path, cell.index, k.max(1)) {
            Some((next, c, t)) => (cell, centre, t_entry) = (next, c, t),
            None => break,
        }
    }
    finish(
        lattice,
        &path,
        Some(first),
        Some(cell.index),
        count,
        transmittance,
    )
}

/// Step 3's neighbour search: the lens the exit ray `path` enters next
/// (not `current`, the one it just left), found by sampling the ray at
/// `samples` points through the lens layer: `(cell, centre, t_entry)`.
fn next_lens(
    lattice: &Lattice,
    path: &Ray,
    current: [i64; 2],
    samples: u32,
) -> Option<(LensCell, DVec3, f64)> {
    let axes = lattice.axes();
    let r = lattice.lens().radius();
    let h0 = axes.depth(path.origin());
    let down = -path.dir().dot(axes.normal());
    // Where the ray leaves the layer 0 ≤ depth ≤ 2r, at most a few cells on.
    let span = NEIGHBOUR_SPAN_CELLS * 2.0 * lattice.kind().cell_inradius(axes.u(), axes.v());
    let t_layer = if down > MIN_COS {
        (2.0 * r - h0) / down
    } else if down < -MIN_COS {
        h0 / -down
    } else {
        span
    };
    let t_end = t_layer.min(span);
    if !(t_end > 0.0) {
        return None;
    }
    for s in 1..=samples {
        let t = t_end * f64::from(s) / f64::from(samples);
        let q = path.at(t);
        let cell = lattice.cell_of(lattice.slice_uv(q, axes.depth(q)));
        if cell.index == current {
            continue;
        }
        let centre = lattice.lens_centre(cell.centre_uv);
        if let Some(t_in) = lattice.lens_entry(path, centre) {
            return Some((cell, centre, t_in));
        }
    }
    None
}

/// The shading fallback for a ray that has no exit from the lens `cell`.
pub(crate) fn ball_fallback(e: BallFailure, cell: [i64; 2]) -> ShadeFallback {
    match e {
        BallFailure::ReflectedAtEntry | BallFailure::ReflectedAtExit => {
            ShadeFallback::TotalInternalReflection { lens: cell }
        }
        BallFailure::Overflow => ShadeFallback::Overflow,
    }
}

/// Step 4: along `ray` to the pigment plane (6.29). `first` and `last` are
/// the first and the last lens passed (for the hit and for
/// [`ShadeFallback::Escaped`]), `lenses` how many, `transmittance` the power
/// their surfaces let through.
pub(crate) fn finish(
    lattice: &Lattice,
    ray: &Ray,
    first: Option<[i64; 2]>,
    last: Option<[i64; 2]>,
    lenses: u32,
    transmittance: f64,
) -> Shade {
    match lattice.to_pigment_plane(ray) {
        PigmentPlaneHit::At(point) => {
            let uv: DVec2 = lattice.pigment_uv(point); // (6.29)
            if uv.is_finite() {
                Shade::Pigment(PigmentHit {
                    uv,
                    point,
                    lens: first,
                    lenses,
                    transmittance,
                })
            } else {
                Shade::Fallback(ShadeFallback::Overflow)
            }
        }
        PigmentPlaneHit::Overflow => Shade::Fallback(ShadeFallback::Overflow),
        PigmentPlaneHit::Escapes => match last {
            Some(cell) => Shade::Fallback(ShadeFallback::Escaped {
                lens: cell,
                dir: ray.dir(),
            }),
            // Unreachable for a ray that reached the polygon from the front.
            None => Shade::Fallback(ShadeFallback::PolygonMiss),
        },
    }
}

/// [`shade`] over many rays, in parallel (for the report runner).
#[cfg(feature = "reference")]
pub fn shade_batch(lattice: &Lattice, rays: &[Ray], slices: u32) -> Vec<Shade> {
    use rayon::prelude::*;
    rays.par_iter().map(|r| shade(lattice, r, slices)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::compound_eye::exact_tracer::trace_exact;
    use crate::compound_eye::lattice::LensParams;
    use crate::compound_eye::texture_axes::TextureAxes;
    use glam::DVec3;
    use proptest::prelude::*;

    /// Facets 1×1 on z = 0, outward +z, lenses of radius r.
    pub(crate) fn unit_lattice(r: f64, n: f64, d: f64) -> Lattice {
        let axes = TextureAxes::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z).unwrap();
        Lattice::new(axes, LensParams::new(r, n, d).unwrap()).unwrap()
    }

    /// The view ray that crosses the polygon at `(x, y)` with direction `dir`.
    fn ray_at(x: f64, y: f64, dir: DVec3) -> Ray {
        let dir = dir.normalize();
        Ray::new(DVec3::new(x, y, 0.0) - 2.0 * dir, dir).unwrap()
    }

    #[test]
    fn ray_through_lens_centre_is_undeviated_and_lands_at_the_expected_texel() {
        for d in [1.0, 1.25] {
            let l = unit_lattice(0.5, 1.5, d);
            // Lens (2, −1): centre S = (2.5, −0.5, −0.5). The ray through S with
            // direction ∝ (0.3, 0.2, −1) crosses z = 0 at S + 0.5·(−0.3, −0.2),
            // inside cell (2, −1), and, undeviated, the plane z = −d at
            // S + (d − 0.5)·(0.3, 0.2): uv = (2.5 + 0.3(d−½), −0.5 + 0.2(d−½)).
            let dir = DVec3::new(0.3, 0.2, -1.0);
            let ray = ray_at(2.5 - 0.15, -0.5 - 0.1, dir);
            let want = DVec2::new(2.5 + 0.3 * (d - 0.5), -0.5 + 0.2 * (d - 0.5));
            for got in [
                shade(&l, &ray, 0),
                shade(&l, &ray, 8),
                trace_exact(&l, &ray, 1),
                trace_exact(&l, &ray, 8),
            ] {
                let h = *got.hit().unwrap();
                assert_eq!(h.lens, Some([2, -1]));
                assert!((h.uv - want).length() < 1e-12, "{:?} vs {want:?}", h.uv);
                assert!((h.point.z + d).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn ray_between_lenses_goes_straight_to_the_pigment() {
        // Normal incidence at (0.95, 1.02): 0.636 from the nearest lens axis (> r = 0.5),
        // so no lens; the thesis sends the ray on unrefracted (§6.4).
        let l = unit_lattice(0.5, 1.5, 1.0);
        let ray = ray_at(0.95, 1.02, -DVec3::Z);
        for got in [shade(&l, &ray, 16), trace_exact(&l, &ray, 4)] {
            let h = *got.hit().unwrap();
            assert_eq!((h.lens, h.lenses), (None, 0));
            assert!((h.uv - DVec2::new(0.95, 1.02)).length() < 1e-15);
        }
    }

    #[test]
    fn entering_a_lens_below_its_equator_is_resolved_when_in_its_column_above_r() {
        // The error floor is about the column, not the sphere: this ray starts
        // in the corner of cell (0, 0) at (0.02, 0.02), heads for the lens axis
        // and down (direction ∝ (1, 1, −4)) and stays in column (0, 0) all the
        // way. It is still outside the sphere at depth r (0.502 from the axis)
        // and enters it between depths 0.5 and 0.6, below the equator; the
        // slice at the polygon already picks that lens.
        let l = unit_lattice(0.5, 1.5, 1.0);
        let dir = DVec3::new(1.0, 1.0, -4.0).normalize();
        let ray = ray_at(0.02, 0.02, dir);
        let fragment = polygon_entry(&l, &ray).unwrap();
        let t = l
            .lens_entry(&fragment, l.lens_centre(DVec2::splat(0.5)))
            .unwrap();
        let entry_depth = l.axes().depth(fragment.at(t));
        assert!(
            entry_depth > 0.5 && entry_depth < 0.6,
            "enters at depth {entry_depth}"
        );
        let exact = *trace_exact(&l, &ray, 1).hit().unwrap();
        assert_eq!(exact.lens, Some([0, 0]));
        for k in [0, 1, 8] {
            let got = *shade(&l, &ray, k).hit().unwrap();
            assert_eq!(got.lens, exact.lens, "K = {k}");
            assert!((got.uv - exact.uv).length() < 1e-12);
        }
    }

    #[test]
    fn n_equal_one_is_a_straight_line() {
        let l = unit_lattice(0.5, 1.0, 1.3);
        for k in 0..50 {
            let a = k as f64 * 0.37;
            let dir = DVec3::new(
                a.cos() * (k as f64 * 0.03),
                a.sin() * (k as f64 * 0.02),
                -1.0,
            )
            .normalize();
            let ray = ray_at(0.1 * k as f64, -0.07 * k as f64, dir);
            let straight = ray.at((ray.origin().z + 1.3) / -ray.dir().z);
            for got in [
                shade(&l, &ray, 4),
                trace_exact(&l, &ray, 1),
                trace_exact(&l, &ray, 6),
            ] {
                let h = got.hit().unwrap();
                assert!((h.point - straight).length() < 1e-12, "k {k}");
            }
        }
    }

    #[test]
    fn low_index_lens_gives_total_internal_reflection_fallback() {
        // n = 0.7 (critical angle 44.4°); a 60° ray onto the apex of lens (0, 0) meets
        // the lens at 60° incidence (the apex normal is N).
        let l = unit_lattice(0.5, 0.7, 1.0);
        let dir = DVec3::new(60f64.to_radians().sin(), 0.0, -60f64.to_radians().cos());
        let ray = ray_at(0.5, 0.5, dir);
        let want = Shade::Fallback(ShadeFallback::TotalInternalReflection { lens: [0, 0] });
        assert_eq!(shade(&l, &ray, 4), want);
        assert_eq!(trace_exact(&l, &ray, 1), want);
    }

    #[test]
    fn rays_that_do_not_reach_the_polygon_fall_back() {
        let l = unit_lattice(0.5, 1.5, 1.0);
        let parallel = Ray::new(DVec3::new(0.0, 0.0, 1.0), DVec3::X).unwrap();
        let leaving = Ray::new(DVec3::new(0.0, 0.0, 1.0), DVec3::Z).unwrap();
        let below = Ray::new(DVec3::new(0.0, 0.0, -0.2), -DVec3::Z).unwrap();
        for (ray, want) in [
            (parallel, ShadeFallback::PolygonMiss),
            (leaving, ShadeFallback::PolygonMiss),
            (below, ShadeFallback::PolygonMiss),
        ] {
            assert_eq!(shade(&l, &ray, 4), Shade::Fallback(want));
            assert_eq!(trace_exact(&l, &ray, 4), Shade::Fallback(want));
        }
    }

    #[test]
    fn extreme_but_finite_rays_overflow_instead_of_giving_nan() {
        // 1.5e308 above the polygon at 45°: the distance to it overflows f64.
        let l = unit_lattice(0.5, 1.5, 1.0);
        let far = Ray::new(DVec3::new(0.0, 0.0, 1.5e308), DVec3::new(1.0, 0.0, -1.0)).unwrap();
        let want = Shade::Fallback(ShadeFallback::Overflow);
        assert_eq!(shade(&l, &far, 8), want);
        assert_eq!(trace_exact(&l, &far, 2), want);
        // Straight down from as far: no overflow, the ordinary hit.
        let down = Ray::new(DVec3::new(0.5, 0.5, 1.5e308), -DVec3::Z).unwrap();
        assert_eq!(shade(&l, &down, 8).hit().unwrap().lens, Some([0, 0]));
    }

    #[test]
    fn a_fragment_ray_leaving_the_surface_is_a_polygon_miss() {
        let l = unit_lattice(0.5, 1.5, 1.0);
        let out = Ray::new(DVec3::new(0.5, 0.5, 0.0), DVec3::new(0.0, 0.3, 1.0)).unwrap();
        assert_eq!(
            shade_fragment(&l, &out, 4),
            Shade::Fallback(ShadeFallback::PolygonMiss)
        );
        // A fragment ray pointing in gives what shade gives for the view ray through it.
        let view = ray_at(0.3, 0.6, DVec3::new(0.2, -0.1, -1.0));
        let fragment = Ray::new(DVec3::new(0.3, 0.6, 0.0), view.dir()).unwrap();
        let (a, b) = (shade_fragment(&l, &fragment, 4), shade(&l, &view, 4));
        let (a, b) = (a.hit().unwrap(), b.hit().unwrap());
        assert_eq!((a.lens, a.lenses), (b.lens, b.lenses));
        assert!((a.uv - b.uv).length() < 1e-14, "{a:?} vs {b:?}");
    }

    #[test]
    fn slice_count_is_clamped_to_the_shader_bound() {
        let l = unit_lattice(0.5, 1.5, 1.0);
        let ray = ray_at(0.93, 0.4, DVec3::new(0.9, 0.1, -0.3));
        assert_eq!(shade(&l, &ray, 10_000), shade(&l, &ray, MAX_SLICES));
    }

    #[test]
    fn mirrored_uv_mirrors_the_pigment_hit() {
        // The same triangle with UVs mirrored in a: every pigment texture
        // coordinate mirrors, lens indices map i → −1 − i, and the lenses stay
        // under the surface (the normal follows the winding).
        let p = [
            DVec3::ZERO,
            DVec3::new(3.0, 0.0, 0.0),
            DVec3::new(0.0, 3.0, 0.0),
        ];
        let t = [DVec2::ZERO, DVec2::new(3.0, 0.0), DVec2::new(0.0, 3.0)];
        let tm = t.map(|x| DVec2::new(-x.x, x.y));
        let lens = LensParams::thesis(0.5, 1.5).unwrap();
        let a = Lattice::new(TextureAxes::from_triangle(p, t).unwrap(), lens).unwrap();
        let m = Lattice::new(TextureAxes::from_triangle(p, tm).unwrap(), lens).unwrap();
        assert_eq!(m.axes().handedness(), -1.0);
        for k in 0..200 {
            let f = k as f64;
            let dir =
                DVec3::new((f * 0.7).cos(), (f * 0.7).sin(), -0.2 - (f * 0.013) % 1.5).normalize();
            let ray = ray_at(1.0 + (f * 0.137) % 1.0, 1.0 + (f * 0.291) % 1.0, dir);
            for (sa, sm) in [
                (shade(&a, &ray, 3), shade(&m, &ray, 3)),
                (trace_exact(&a, &ray, 1), trace_exact(&m, &ray, 1)),
            ] {
                match (sa, sm) {
                    (Shade::Pigment(ha), Shade::Pigment(hm)) => {
                        assert!(
                            (ha.uv - DVec2::new(-hm.uv.x, hm.uv.y)).length() < 1e-12,
                            "ray {k}"
                        );
                        assert_eq!(ha.lens.map(|[i, j]| [-1 - i, j]), hm.lens);
                        assert!((ha.point - hm.point).length() < 1e-12);
                    }
                    (fa, fm) => assert_eq!(fa.hit().is_none(), fm.hit().is_none()),
                }
            }
        }
    }

    fn arb_lattice() -> impl Strategy<Value = Lattice> {
        (
            0.05f64..1.0,
            0.3f64..3.0,
            0.0f64..2.0,
            -0.5f64..0.5,
            0.5f64..2.0,
            prop::array::uniform3(-1.0f64..1.0),
        )
            .prop_filter_map("valid lattice", |(r_frac, n, extra, skew, aspect, nrm)| {
                let normal = DVec3::from(nrm).try_normalize()?;
                let (t, b) = normal.any_orthonormal_pair();
                let u = t;
                let v = aspect * (b + skew * t);
                let axes = TextureAxes::from_axes(DVec3::new(0.3, -0.2, 0.1), u, v, normal).ok()?;
                let (hu, hv) = axes.cell_heights();
                let r = r_frac * 0.5 * hu.min(hv);
                Lattice::new(axes, LensParams::new(r, n, 2.0 * r + extra * r).ok()?).ok()
            })
    }

    proptest! {
        #[test]
        fn finite_rays_give_finite_results_or_a_fallback(
            lattice in arb_lattice(),
            o in prop::array::uniform3(-50.0f64..50.0),
            d in prop::array::uniform3(-1.0f64..1.0),
            slices in 0u32..80,
        ) {
            let ray = Ray::new(DVec3::from(o), DVec3::from(d)).unwrap();
            for got in [shade(&lattice, &ray, slices), trace_exact(&lattice, &ray, 1), trace_exact(&lattice, &ray, 5)] {
                prop_assert!(got.is_finite(), "{:?}", got);
                if let Shade::Pigment(h) = got {
                    let depth = lattice.axes().depth(h.point);
                    prop_assert!((depth - lattice.lens().pigment_depth()).abs() < 1e-6 * (1.0 + h.point.length()));
                }
            }
        }
    }
}
