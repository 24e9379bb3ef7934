//! Sensor histograms and the exact-coverage rasteriser of traced grids
//! (reference feature); documented on [`rasterise`] and [`SensorImage`].

use glam::DVec2;

use super::FlareError;
use super::aperture::Aperture;
use super::grid_trace::RayGrid;
use super::grid_trace::count_in;
use super::intensity::{CellKind, GridRay};
use crate::input;
use crate::lens::MAX_STOP_CROSSINGS;

/// Most pixels a window may have: 4096², a 4K frame with room, 134 MB of
/// `f64` power per image.
pub const MAX_PIXELS: usize = 4096 * 4096;

/// Smallest side, mm, of a window made by [`SensorWindow::around`]: 1 µm,
/// below any sensor pixel, so that a ghost focused to a point still gets a
/// window with a positive pixel size.
const MIN_AROUND_SIDE_MM: f64 = 1e-3;

/// A rectangle of the sensor plane divided into square pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SensorWindow {
    min: DVec2,
    pixel_mm: f64,
    width: usize,
    height: usize,
}

impl SensorWindow {
    /// A window of `width × height` pixels of side `pixel_mm` (finite, > 0)
    /// from the lower-left corner `min` (finite), at most [`MAX_PIXELS`].
    pub fn new(min: DVec2, pixel_mm: f64, width: usize, height: usize) -> Result<Self, FlareError> {
        let min = input::finite_vec2("window corner (mm)", min)?;
        let pixel_mm = input::positive("pixel size (mm)", pixel_mm)?;
        count_in("window width (pixels)", width, 1, MAX_PIXELS)?;
        count_in("window pixels", width.saturating_mul(height), 1, MAX_PIXELS)?;
        Ok(Self {
            min,
            pixel_mm,
            width,
            height,
        })
    }

    /// A square window of `pixels × pixels` around the points `pts`
    /// (non-finite ones skipped), widened by `margin` (a finite fraction of
    /// the side, >= 0) on each side; the side is at least 1 µm, so a single
    /// point gets a 1 µm window, and no point at all a 1 µm window at the
    /// origin.
    pub fn around(
        pts: impl IntoIterator<Item = DVec2>,
        margin: f64,
        pixels: usize,
    ) -> Result<Self, FlareError> {
        let margin = input::non_negative("window margin", margin)?;
        count_in("window pixels per side", pixels, 1, MAX_PIXELS)?;
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for p in pts.into_iter().filter(|p| p.is_finite()) {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        if !(lo.x <= hi.x) {
            lo = DVec2::ZERO;
            hi = DVec2::ZERO;
        }
        let full = (hi - lo).max_element().max(MIN_AROUND_SIDE_MM) * (1.0 + 2.0 * margin);
        let center = 0.5 * (lo + hi);
        Self::new(
            center - DVec2::splat(0.5 * full),
            full / pixels as f64,
            pixels,
            pixels,
        )
    }

    /// Lower-left corner (x, y) on the sensor, mm.
    pub fn min(&self) -> DVec2 {
        self.min
    }

    /// Side of a pixel, mm.
    pub fn pixel_mm(&self) -> f64 {
        self.pixel_mm
    }

    /// Pixels along x.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Pixels along y.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Pixel `(ix, iy)` containing `p`, or `None` outside the window.
    pub fn pixel_of(&self, p: DVec2) -> Option<(usize, usize)> {
        let q = (p - self.min) / self.pixel_mm;
        if !(q.x >= 0.0 && q.y >= 0.0) {
            return None;
        }
        let (ix, iy) = (q.x as usize, q.y as usize);
        (ix < self.width && iy < self.height).then_some((ix, iy))
    }

    /// Area of one pixel, mm².
    pub fn pixel_area_mm2(&self) -> f64 {
        self.pixel_mm * self.pixel_mm
    }
}

/// Power per pixel over a [`SensorWindow`], row-major (`iy * width + ix`);
/// read-only, so the pixels always match the window.
///
/// Power, not irradiance: mm² of unit-irradiance beam that lands in the
/// pixel, so that a brute-force histogram of rays and a rasterised grid are
/// directly comparable and the sum of an image is the power reaching the
/// sensor window.
#[derive(Clone, Debug, PartialEq)]
pub struct SensorImage {
    window: SensorWindow,
    power: Vec<f64>,
}

impl SensorImage {
    /// A black image.
    pub fn new(window: SensorWindow) -> Self {
        Self {
            power: vec![0.0; window.width * window.height],
            window,
        }
    }

    /// An image of `power` per pixel, which must have one value per pixel
    /// of `window` (the crate's own reference and tests build these).
    pub(crate) fn from_power(window: SensorWindow, power: Vec<f64>) -> Self {
        debug_assert_eq!(power.len(), window.width * window.height);
        Self { window, power }
    }

    /// The window.
    pub fn window(&self) -> SensorWindow {
        self.window
    }

    /// Power per pixel, row-major (`iy * width + ix`), mm².
    pub fn power(&self) -> &[f64] {
        &self.power
    }

    /// Power per pixel, mutable (the crate's own reference bins into it).
    pub(crate) fn power_mut(&mut self) -> &mut [f64] {
        &mut self.power
    }

    /// Total power in the window.
    pub fn total(&self) -> f64 {
        self.power.iter().sum()
    }

    /// Adds `other` pixel by pixel (same window required; else nothing happens
    /// and `false` is returned).
    pub fn add(&mut self, other: &SensorImage) -> bool {
        if self.window != other.window {
            return false;
        }
        for (a, b) in self.power.iter_mut().zip(&other.power) {
            *a += b;
        }
        true
    }
}

/// Rasterises `grid` into a new image over `window`, clipping per fragment by
/// `r_rel <= 1` and `aperture`.
///
/// Each live cell is drawn as its two triangles (00-10-11 and 00-11-01, the
/// split the cell's area was measured with) with the cell's flat
/// irradiance. Coverage is exact: each triangle is clipped against each
/// pixel square (Sutherland–Hodgman), so a pixel gets `I × overlap area` and
/// a cell deposits exactly its power however small it is. The clip is per
/// fragment (triangle ∩ pixel): `r_rel` and the stop-plane position of every
/// stop crossing are interpolated (barycentric, linear on the triangle) at
/// the fragment's centroid and the fragment is dropped when `r_rel > 1` or
/// the aperture does not contain one of the positions — the CPU twin of a
/// pixel shader that discards by an aperture texture. A ghost `(i, j)` with
/// `j < stop < i` crosses the stop three times and the aperture shape is
/// tested at all three (the first alone would let a bladed stop clip only
/// the first pass, the later ones only by the round `r_rel`).
pub fn rasterise(grid: &RayGrid, aperture: &Aperture, window: SensorWindow) -> SensorImage {
    let mut img = SensorImage::new(window);
    rasterise_into(grid, aperture, &mut img);
    img
}

/// [`rasterise`] adding into `image` (to sum ghosts or wavelengths).
pub fn rasterise_into(grid: &RayGrid, aperture: &Aperture, image: &mut SensorImage) {
    for (cell, [a, b, c, d]) in grid.cells_with_corners() {
        if cell.kind == CellKind::Dead || !(cell.intensity > 0.0) {
            continue;
        }
        triangle(image, [a, b, c], cell.intensity, aperture);
        triangle(image, [a, c, d], cell.intensity, aperture);
    }
}

/// Small fixed-capacity polygon (a triangle clipped by 4 half-planes has at most 7 vertices).
#[derive(Clone, Copy)]
struct Poly {
    v: [DVec2; 8],
    n: usize,
}

impl Poly {
    fn area_and_centroid(&self) -> (f64, DVec2) {
        let (mut a2, mut c) = (0.0, DVec2::ZERO);
        for k in 0..self.n {
            let (p, q) = (self.v[k], self.v[(k + 1) % self.n]);
            let cross = p.perp_dot(q);
            a2 += cross;
            c += (p + q) * cross;
        }
        // Zero, subnormal or non-finite: the centroid's division would
        // overflow or be NaN, and such a fragment carries no power.
        if !a2.is_normal() {
            return (0.0, DVec2::ZERO);
        }
        (0.5 * a2.abs(), c / (3.0 * a2))
    }

    /// Keeps the part with `s·(p[axis]) <= s·bound` (s = ±1).
    fn clip(&self, axis: usize, bound: f64, s: f64) -> Poly {
        let mut out = Poly {
            v: [DVec2::ZERO; 8],
            n: 0,
        };
        let inside = |p: DVec2| s * p[axis] <= s * bound;
        for k in 0..self.n {
            let (p, q) = (self.v[k], self.v[(k + 1) % self.n]);
            let (pin, qin) = (inside(p), inside(q));
            if pin && out.n < 8 {
                out.v[out.n] = p;
                out.n += 1;
            }
            if pin != qin && out.n < 8 {
                let t = (bound - p[axis]) / (q[axis] - p[axis]);
                out.v[out.n] = p + (q - p) * t;
                out.n += 1;
            }
        }
        out
    }
}

fn triangle(image: &mut SensorImage, v: [&GridRay; 3], intensity: f64, aperture: &Aperture) {
    let w = image.window;
    let p = [v[0].sensor, v[1].sensor, v[2].sensor];
    let area2 = (p[1] - p[0]).perp_dot(p[2] - p[0]);
    if !(area2.abs() > 0.0) || !area2.is_finite() {
        return; // no area, no power (see intensity: a degenerate cell deposits nothing)
    }
    let lo = (p[0].min(p[1]).min(p[2]) - w.min) / w.pixel_mm;
    let hi = (p[0].max(p[1]).max(p[2]) - w.min) / w.pixel_mm;
    if hi.x < 0.0 || hi.y < 0.0 || lo.x >= w.width as f64 || lo.y >= w.height as f64 {
        return;
    }
    let (x0, y0) = (lo.x.max(0.0) as usize, lo.y.max(0.0) as usize);
    let (x1, y1) = (
        (hi.x.min(w.width as f64 - 1.0)) as usize,
        (hi.y.min(w.height as f64 - 1.0)) as usize,
    );
    let tri = Poly {
        v: [
            p[0],
            p[1],
            p[2],
            DVec2::ZERO,
            DVec2::ZERO,
            DVec2::ZERO,
            DVec2::ZERO,
            DVec2::ZERO,
        ],
        n: 3,
    };
    let inv = 1.0 / area2;
    let pass = |q: DVec2| {
        // Barycentric weights of q, then linear interpolation of the attributes.
        let l1 = (q - p[0]).perp_dot(p[2] - p[0]) * inv;
        let l2 = (p[1] - p[0]).perp_dot(q - p[0]) * inv;
        let l0 = 1.0 - l1 - l2;
        let r_rel = l0 * v[0].r_rel + l1 * v[1].r_rel + l2 * v[2].r_rel;
        // Every stop crossing (three for a ghost straddling the stop).
        r_rel <= 1.0
            && (0..MAX_STOP_CROSSINGS).all(|k| {
                aperture
                    .contains(l0 * v[0].stop_xy[k] + l1 * v[1].stop_xy[k] + l2 * v[2].stop_xy[k])
            })
    };
    for iy in y0..=y1 {
        let (ya, yb) = (
            w.min.y + iy as f64 * w.pixel_mm,
            w.min.y + (iy + 1) as f64 * w.pixel_mm,
        );
        let row = tri.clip(1, ya, -1.0).clip(1, yb, 1.0);
        if row.n < 3 {
            continue;
        }
        for ix in x0..=x1 {
            let (xa, xb) = (
                w.min.x + ix as f64 * w.pixel_mm,
                w.min.x + (ix + 1) as f64 * w.pixel_mm,
            );
            let frag = row.clip(0, xa, -1.0).clip(0, xb, 1.0);
            if frag.n < 3 {
                continue;
            }
            let (a, c) = frag.area_and_centroid();
            if a > 0.0 && pass(c) {
                image.power[iy * w.width + ix] += intensity * a;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::TracePath;

    fn ray(x: f64, y: f64, r_rel: f64) -> GridRay {
        GridRay {
            alive: true,
            sensor: DVec2::new(x, y),
            r_rel,
            stop_xy: [DVec2::ZERO; 3],
            throughput: 1.0,
        }
    }

    /// One cell with corners `[00, 10, 11, 01]` and a unit pupil area.
    fn one_cell(rays: [GridRay; 4]) -> RayGrid {
        let [a, b, c, d] = rays;
        RayGrid::from_rays(2, TracePath::Primary, 1.0, vec![a, b, d, c]) // row-major: (0,0) (1,0) (0,1) (1,1)
    }

    #[test]
    fn exact_coverage_conserves_power() {
        // A unit pupil cell drawn as a skewed quad over a 10×10 window of
        // 0.37 mm pixels: the image total is exactly A_p · T = 1.
        let g = one_cell([
            ray(0.1, 0.2, 0.0),
            ray(2.3, 0.5, 0.0),
            ray(2.0, 2.9, 0.0),
            ray(0.4, 1.7, 0.0),
        ]);
        let w = SensorWindow::new(DVec2::ZERO, 0.37, 10, 10).unwrap();
        let img = rasterise(&g, &Aperture::circle(1.0).unwrap(), w);
        assert!((img.total() - 1.0).abs() < 1e-12, "{}", img.total());
        // A sub-pixel cell inside one pixel puts everything there.
        let g = one_cell([
            ray(1.01, 1.01, 0.0),
            ray(1.02, 1.01, 0.0),
            ray(1.02, 1.02, 0.0),
            ray(1.01, 1.02, 0.0),
        ]);
        let img = rasterise(&g, &Aperture::circle(1.0).unwrap(), w);
        assert!((img.power()[2 * 10 + 2] - 1.0).abs() < 1e-9);
    }

    #[test]
    fn clip_by_interpolated_r_rel() {
        // r_rel runs 0 → 2 along x over a 2 mm cell: the half x < 1 passes.
        let g = one_cell([
            ray(0.0, 0.0, 0.0),
            ray(2.0, 0.0, 2.0),
            ray(2.0, 2.0, 2.0),
            ray(0.0, 2.0, 0.0),
        ]);
        let w = SensorWindow::new(DVec2::ZERO, 0.1, 20, 20).unwrap();
        let img = rasterise(&g, &Aperture::circle(1.0).unwrap(), w);
        assert!((img.total() - 0.5).abs() < 1e-9, "{}", img.total());
        // A closed aperture passes nothing.
        assert_eq!(rasterise(&g, &Aperture::closed(), w).total(), 0.0);
    }

    #[test]
    fn window_validation_and_lookup() {
        let what = |r: Result<SensorWindow, FlareError>| match r {
            Err(FlareError::Input(i)) => Some(i.what),
            _ => None,
        };
        assert_eq!(
            what(SensorWindow::new(DVec2::ZERO, 0.0, 4, 4)),
            Some("pixel size (mm)")
        );
        assert_eq!(
            what(SensorWindow::new(DVec2::ZERO, 1.0, 0, 4)),
            Some("window width (pixels)")
        );
        assert_eq!(
            what(SensorWindow::new(DVec2::ZERO, 1.0, 4, 0)),
            Some("window pixels")
        );
        assert_eq!(
            what(SensorWindow::new(DVec2::ZERO, 1.0, 4097, 4096)),
            Some("window pixels")
        );
        assert_eq!(
            what(SensorWindow::new(DVec2::new(f64::NAN, 0.0), 1.0, 4, 4)),
            Some("window corner (mm)")
        );
        assert_eq!(
            what(SensorWindow::around([DVec2::ZERO], f64::NAN, 4)),
            Some("window margin")
        );
        assert_eq!(
            what(SensorWindow::around([DVec2::ZERO], 0.1, 0)),
            Some("window pixels per side")
        );
        // No finite point: a 1 µm window at the origin.
        let empty = SensorWindow::around([DVec2::NAN], 0.0, 2).unwrap();
        assert_eq!(
            (empty.min(), empty.pixel_mm(), empty.width(), empty.height()),
            (DVec2::splat(-5e-4), 5e-4, 2, 2)
        );
        let w = SensorWindow::new(DVec2::new(-2.0, -2.0), 1.0, 4, 4).unwrap();
        assert_eq!(w.pixel_of(DVec2::new(-1.5, 1.5)), Some((0, 3)));
        assert_eq!(w.pixel_of(DVec2::new(2.0, 0.0)), None);
        assert_eq!(w.pixel_of(DVec2::new(f64::NAN, 0.0)), None);
        let a = SensorWindow::around(
            [
                DVec2::new(0.0, 0.0),
                DVec2::new(4.0, 2.0),
                DVec2::new(f64::NAN, 1.0),
            ],
            0.25,
            8,
        )
        .unwrap();
        assert!((a.pixel_mm() - 6.0 / 8.0).abs() < 1e-15 && a.min() == DVec2::new(-1.0, -2.0));
    }
}
