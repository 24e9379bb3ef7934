//! The pseudopupil on a curved eye: facet frames and the dark-centre test.

use glam::DVec3;

use super::error::CompoundEyeError;
use super::lattice::{Lattice, LensParams};
use super::shading_path::shade;
use super::texture_axes::TextureAxes;
use crate::input;
use crate::ray::Ray;

/// The lattice of one facet of a curved eye: the tangent plane at `centre`
/// with outward `axis` (any length), facets `facet` mesh units square, cell
/// `(0, 0)` centred on `centre` (so its lens's apex is `centre`).
///
/// On one flat triangle every lens has the same axis `N`, so the pseudopupil
/// only appears across a curved eye, where each facet has its own axis; this
/// builds one facet's lattice of such an eye.
///
/// Errors: [`CompoundEyeError::Input`] for a non-finite `centre`, a zero or
/// non-finite `axis`, or a `facet` that is not finite and positive, and
/// [`Lattice::new`]'s errors for the lens.
pub fn facet_lattice(
    centre: DVec3,
    axis: DVec3,
    facet: f64,
    lens: LensParams,
) -> Result<Lattice, CompoundEyeError> {
    let centre = input::finite_vec3("facet centre (mesh units)", centre)?;
    let axis = input::direction("facet axis", axis)?;
    let facet = input::positive("facet size (mesh units)", facet)?;
    let (u_hat, _) = axis.any_orthonormal_pair();
    // Right-handed (U, V, N) regardless of the helper's choice.
    let v_hat = axis.cross(u_hat);
    let u = facet * u_hat;
    let v = facet * v_hat;
    let origin = centre - 0.5 * (u + v);
    Lattice::new(TextureAxes::from_axes(origin, u, v, axis)?, lens)
}

/// The view ray from `viewer` to the apex of the facet's own lens (the
/// centre of cell `(0, 0)` on the polygon), or `None` when the viewer is at
/// the apex, on or behind the facet's plane.
pub fn ray_to_facet(lattice: &Lattice, viewer: DVec3) -> Option<Ray> {
    let apex = lattice
        .axes()
        .point_of(lattice.kind().centre_of_index([0, 0]));
    let ray = Ray::new(viewer, apex - viewer).ok()?;
    (ray.dir().dot(lattice.axes().normal()) < 0.0).then_some(ray)
}

/// `true` when `viewer` sees this facet's dark centre: the thesis-model
/// pigment hit for [`ray_to_facet`] lies within `dark_radius` facets of the
/// lens's own cell centre ([`super::PigmentHit::on_own_centre`]). That is
/// the principal pseudopupil: the dark patch of ommatidia whose axes point
/// at the viewer, which moves with the viewpoint (D. G. Stavenga,
/// "Pseudopupils of compound eyes", in *Handbook of Sensory Physiology*
/// VII/6A, Springer, 1979).
///
/// The ray meets the polygon at the apex, where it touches the facet's own
/// lens, so the slice search's first candidate (the polygon, `K = 0`) is
/// already the first lens the ray really meets: for any viewer not within
/// ~1e-9 rad of the facet's plane, the shading path here gives what the
/// exact lattice tracer gives.
pub fn shows_dark_centre(lattice: &Lattice, viewer: DVec3, dark_radius: f64) -> bool {
    ray_to_facet(lattice, viewer).is_some_and(|ray| {
        shade(lattice, &ray, 0)
            .hit()
            .is_some_and(|h| h.on_own_centre(lattice.kind(), dark_radius))
    })
}

/// Where the principal pseudopupil is in an image: the darkness-weighted
/// centroid, in pixels (`(0.5, 0.5)` is the centre of the top-left pixel),
/// of the connected region around the darkest spot whose darkness,
/// averaged over a `(2·half + 1)²` box (about one facet), is at least half
/// its peak. `darkness` is row-major, `width × height`, with values in
/// `0..=1` (`1 − c_t`) and 0 off the eye. Averaging over a facet lets the
/// patch of many dark facets stand out from single dark facets elsewhere
/// (secondary pseudopupils, aliased distant facets), and keeping to the
/// region connected to the peak keeps those out of the centroid. `None` for
/// an image with no darkness. For tests and reports (cargo feature
/// `reference`).
#[cfg(feature = "reference")]
pub fn dark_patch_centroid(
    darkness: &[f64],
    width: usize,
    height: usize,
    half: usize,
) -> Option<glam::DVec2> {
    if darkness.len() != width * height || width == 0 || height == 0 {
        return None;
    }
    // Summed-area table, so the box average is O(1) per pixel.
    let mut sat = vec![0.0f64; (width + 1) * (height + 1)];
    for y in 0..height {
        let mut row = 0.0;
        for x in 0..width {
            let d = darkness[y * width + x];
            row += if d.is_finite() { d } else { 0.0 };
            sat[(y + 1) * (width + 1) + x + 1] = sat[y * (width + 1) + x + 1] + row;
        }
    }
    let boxed = |x: usize, y: usize| {
        let (x0, y0) = (x.saturating_sub(half), y.saturating_sub(half));
        let (x1, y1) = ((x + half + 1).min(width), (y + half + 1).min(height));
        let sum =
            sat[y1 * (width + 1) + x1] - sat[y0 * (width + 1) + x1] - sat[y1 * (width + 1) + x0]
                + sat[y0 * (width + 1) + x0];
        sum / ((x1 - x0) * (y1 - y0)) as f64
    };
    let blurred: Vec<f64> = (0..width * height)
        .map(|k| boxed(k % width, k / width))
        .collect();
    let (top, peak) = blurred
        .iter()
        .cloned()
        .enumerate()
        .fold((0, 0.0), |a, (k, b)| if b > a.1 { (k, b) } else { a });
    if !(peak > 0.0) {
        return None;
    }
    // Flood fill (4-connected) from the peak over pixels at least half as dark.
    let mut seen = vec![false; width * height];
    let mut stack = vec![top];
    seen[top] = true;
    let (mut sum, mut weight) = (glam::DVec2::ZERO, 0.0);
    while let Some(k) = stack.pop() {
        let (x, y) = (k % width, k / width);
        let b = blurred[k];
        sum += b * glam::DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
        weight += b;
        let neighbours = [
            (x > 0).then(|| k - 1),
            (x + 1 < width).then(|| k + 1),
            (y > 0).then(|| k - width),
            (y + 1 < height).then(|| k + width),
        ];
        for n in neighbours.into_iter().flatten() {
            if !seen[n] && blurred[n] >= 0.5 * peak {
                seen[n] = true;
                stack.push(n);
            }
        }
    }
    Some(sum / weight)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dark_patch_outweighs_single_dark_pixels() {
        // A 3×3 dark patch at (10..13, 4..7) and scattered single dark pixels.
        let (w, h) = (24, 12);
        let mut d = vec![0.0; w * h];
        for y in 4..7 {
            for x in 10..13 {
                d[y * w + x] = 0.9;
            }
        }
        for k in [3, 40, 77, 150, 201, 260] {
            d[k] = 0.9;
        }
        let c = dark_patch_centroid(&d, w, h, 1).unwrap();
        assert!((c - glam::DVec2::new(11.5, 5.5)).length() < 0.2, "{c}");
        assert_eq!(dark_patch_centroid(&vec![0.0; w * h], w, h, 1), None);
        assert_eq!(dark_patch_centroid(&d, w + 1, h, 1), None);
    }
    use crate::compound_eye::exact_tracer::trace_exact;
    use crate::input::Expected;

    /// A hemispherical eye of radius 20 facets: facet axes on a grid of
    /// tilts, every 2.5° up to 40° about x and y.
    fn eye(lens: LensParams) -> Vec<(DVec3, Lattice)> {
        let radius = 20.0;
        let mut facets = Vec::new();
        for i in -16..=16 {
            for j in -16..=16 {
                let (a, b) = ((i as f64 * 2.5).to_radians(), (j as f64 * 2.5).to_radians());
                let axis = DVec3::new(a.tan(), b.tan(), 1.0).normalize();
                facets.push((axis, facet_lattice(radius * axis, axis, 1.0, lens).unwrap()));
            }
        }
        facets
    }

    fn dir_from(polar_deg: f64, azimuth_deg: f64) -> DVec3 {
        let (t, p) = (polar_deg.to_radians(), azimuth_deg.to_radians());
        DVec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    }

    /// (dark axes, largest dark angle, smallest bright angle) for a viewer far along `w`.
    fn dark_set(eye: &[(DVec3, Lattice)], w: DVec3, rho: f64) -> (Vec<DVec3>, f64, f64) {
        let viewer = 1e5 * w;
        let (mut dark, mut max_dark, mut min_bright) = (Vec::new(), 0f64, f64::INFINITY);
        for (axis, lattice) in eye {
            let angle = axis.angle_between(w).to_degrees();
            let ray = ray_to_facet(lattice, viewer).unwrap();
            // The shading path at K = 0 (what shows_dark_centre uses) agrees
            // with the exact tracer on these apex rays: an apex ray always
            // enters its own lens first.
            let e = trace_exact(lattice, &ray, 1);
            for k in [0, 4] {
                let s = shade(lattice, &ray, k);
                assert_eq!(e.hit().unwrap().lens, Some([0, 0]));
                assert!((e.uv().unwrap() - s.uv().unwrap()).length() < 1e-9);
            }
            if shows_dark_centre(lattice, viewer, rho) {
                dark.push(*axis);
                max_dark = max_dark.max(angle);
            } else {
                min_bright = min_bright.min(angle);
            }
        }
        (dark, max_dark, min_bright)
    }

    #[test]
    fn pseudopupil_is_the_facets_facing_the_viewer_and_moves_with_it() {
        let lens = LensParams::thesis(0.5, 1.5).unwrap();
        let eye = eye(lens);
        let rho = 0.15;
        let mut centroids = Vec::new();
        for w in [dir_from(10.0, 30.0), dir_from(25.0, 200.0)] {
            let (dark, max_dark, min_bright) = dark_set(&eye, w, rho);
            // Exactly the facets within some angle of the viewer are dark:
            // the dark set is a cap around the viewer's direction.
            assert!(!dark.is_empty());
            assert!(
                max_dark < min_bright,
                "dark up to {max_dark}°, bright from {min_bright}°"
            );
            // Paraxial estimate of the cap: offset ≈ 2rθ/n = ρ → θ ≈ 12.9°
            // (r = 0.5, n = 1.5, ρ = 0.15 facet); the exact cap is near it.
            assert!((8.0..16.0).contains(&max_dark), "cap {max_dark}°");
            let centroid = dark.iter().copied().sum::<DVec3>().normalize();
            assert!(
                centroid.angle_between(w).to_degrees() < 1.5,
                "centroid off the viewer by {}°",
                centroid.angle_between(w).to_degrees()
            );
            centroids.push((centroid, dark.len()));
        }
        // It moved with the viewer: by the viewer's angle, to within 2°.
        let moved = centroids[0].0.angle_between(centroids[1].0).to_degrees();
        let viewer_moved = dir_from(10.0, 30.0)
            .angle_between(dir_from(25.0, 200.0))
            .to_degrees();
        assert!(
            (moved - viewer_moved).abs() < 2.0,
            "pupil moved {moved}°, viewer {viewer_moved}°"
        );
    }

    #[test]
    fn facet_lattice_centres_its_lens_on_the_facet() {
        let lens = LensParams::thesis(0.5, 1.5).unwrap();
        let axis = DVec3::new(0.2, -0.3, 1.0).normalize();
        let l = facet_lattice(5.0 * axis, axis, 1.0, lens).unwrap();
        let s = l.lens_centre(glam::DVec2::splat(0.5));
        assert!((s - (5.0 * axis - 0.5 * axis)).length() < 1e-14);
        assert_eq!(l.axes().handedness(), 1.0);
        assert!(ray_to_facet(&l, -10.0 * axis).is_none());
    }

    /// `(what, expected)` of the input error `r` holds, or a panic.
    fn input_error(r: Result<Lattice, CompoundEyeError>) -> (&'static str, Expected) {
        match r {
            Err(CompoundEyeError::Input(e)) => (e.what, e.expected),
            other => panic!("expected an input error, got {other:?}"),
        }
    }

    #[test]
    fn facet_lattice_reports_the_right_error() {
        let lens = LensParams::thesis(0.5, 1.5).unwrap();
        let (c, a) = (DVec3::new(0.0, 0.0, 5.0), DVec3::Z);
        // A NaN, infinite or zero axis has no direction.
        for axis in [
            DVec3::new(f64::NAN, 0.0, 1.0),
            DVec3::new(0.0, f64::INFINITY, 1.0),
            DVec3::ZERO,
        ] {
            assert_eq!(
                input_error(facet_lattice(c, axis, 1.0, lens)),
                ("facet axis", Expected::Direction)
            );
        }
        let centre = ("facet centre (mesh units)", Expected::FiniteVector);
        assert_eq!(
            input_error(facet_lattice(DVec3::splat(f64::NAN), a, 1.0, lens)),
            centre
        );
        let facet = ("facet size (mesh units)", Expected::Positive);
        for size in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert_eq!(
                input_error(facet_lattice(c, a, size, lens)),
                facet,
                "facet {size}"
            );
        }
        // Facets too small for the lenses.
        assert!(matches!(
            facet_lattice(c, a, 0.9, lens),
            Err(CompoundEyeError::LensesOverlap { .. })
        ));
        assert!(facet_lattice(c, a, 1.0, lens).is_ok());
    }
}
