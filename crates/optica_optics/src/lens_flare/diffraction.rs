//! The diffraction textures of the blog's *Diffraction* section: the
//! starburst, the Fraunhofer pattern of the aperture (with the lens's dust
//! and scratches drawn into it), summed over wavelengths with the 1/λ
//! scale; and the ringing of a ghost, the aperture's field carried a
//! distance by the angular spectrum method.
//!
//! Both start from a [`PupilImage`]: the aperture's transmission sampled on
//! a square grid twice its diameter (the zero padding keeps the FFT's
//! periodic copies apart), each pixel the covered fraction of 4×4 samples.
//!
//! ```text
//! starburst:  I(θ) = Σ_λ w_λ (λ_ref/λ)² |F[T]|²(θ/λ)          (Fraunhofer, energy per λ kept)
//! ringing:    I(x) = |F⁻¹[F[T] · exp(i 2π (w − 1/λ) z)]|²,  w = √(1/λ² − u² − v²)
//! ```
//! The ringing's distance is given as a Fresnel number `N_F = r² / (λ z)`
//! (r the aperture radius): few fringes for small numbers, many fine ones
//! for large. The carrier `exp(i 2π z / λ)`, a constant phase, is taken
//! out so that the phase stays small and exact in `f64`.

use std::f64::consts::PI;

use rustfft::FftPlanner;
use rustfft::num_complex::Complex64;

use super::Aperture;
use crate::input::{self, Expected, InvalidInput};

/// Largest side of a diffraction texture (its FFT is side² · log side).
pub const MAX_DIFFRACTION_SIDE: usize = 2048;

/// Dust and scratches on the front element, drawn into the pupil image as
/// opaque specks and thin opaque lines at places a seed fixes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct LensDirt {
    /// Round specks, each 1–4 % of the aperture radius across.
    pub specks: u32,
    /// Straight scratches, 30–100 % of the radius long, 0.5 % wide.
    pub scratches: u32,
    /// Where they fall.
    pub seed: u64,
}

/// The aperture's transmission on a square grid, row-major, the stop's
/// centre at pixel `(side/2, side/2)`.
#[derive(Clone, Debug, PartialEq)]
pub struct PupilImage {
    /// Pixels per side.
    pub side: usize,
    /// Pixel pitch in the stop plane, mm (the aperture's diameter spans
    /// half the side).
    pub pixel_mm: f64,
    /// Transmission per pixel, in [0, 1].
    pub transmission: Vec<f64>,
}

/// A shape that blocks light: a speck (a disc) or a scratch (a segment
/// with a half-width), in the stop plane, mm.
#[derive(Clone, Copy, Debug)]
enum Blot {
    Speck {
        x: f64,
        y: f64,
        r: f64,
    },
    Scratch {
        ax: f64,
        ay: f64,
        bx: f64,
        by: f64,
        half_width: f64,
    },
}

impl Blot {
    fn blocks(&self, x: f64, y: f64) -> bool {
        match *self {
            Blot::Speck { x: cx, y: cy, r } => (x - cx).powi(2) + (y - cy).powi(2) <= r * r,
            Blot::Scratch {
                ax,
                ay,
                bx,
                by,
                half_width,
            } => {
                let (dx, dy) = (bx - ax, by - ay);
                let t = (((x - ax) * dx + (y - ay) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
                (x - ax - t * dx).powi(2) + (y - ay - t * dy).powi(2) <= half_width * half_width
            }
        }
    }
}

/// SplitMix64: the dirt's places from its seed, here without the
/// `reference` feature's generators.
fn split_mix(state: &mut u64) -> f64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
}

fn blots(dirt: &LensDirt, radius: f64) -> Vec<Blot> {
    let mut state = dirt.seed;
    let mut next = || split_mix(&mut state);
    let mut blots = Vec::new();
    for _ in 0..dirt.specks {
        let (a, rho) = (2.0 * PI * next(), radius * next().sqrt());
        blots.push(Blot::Speck {
            x: rho * a.cos(),
            y: rho * a.sin(),
            r: radius * (0.005 + 0.015 * next()),
        });
    }
    for _ in 0..dirt.scratches {
        let (a, rho) = (2.0 * PI * next(), radius * next().sqrt());
        let (heading, length) = (PI * next(), radius * (0.3 + 0.7 * next()));
        let (cx, cy) = (rho * a.cos(), rho * a.sin());
        let (hx, hy) = (0.5 * length * heading.cos(), 0.5 * length * heading.sin());
        blots.push(Blot::Scratch {
            ax: cx - hx,
            ay: cy - hy,
            bx: cx + hx,
            by: cy + hy,
            half_width: 0.0025 * radius,
        });
    }
    blots
}

fn check_side(side: usize) -> Result<(), InvalidInput> {
    if !(16..=MAX_DIFFRACTION_SIDE).contains(&side) || !side.is_multiple_of(2) {
        return Err(InvalidInput::new(
            "diffraction texture side (even)",
            side as f64,
            Expected::Range {
                min: 16.0,
                max: MAX_DIFFRACTION_SIDE as f64,
            },
        ));
    }
    Ok(())
}

/// The transmission of `aperture` with `dirt` on a `side`² grid (even,
/// 16..=[`MAX_DIFFRACTION_SIDE`]).
pub fn pupil_image(
    aperture: &Aperture,
    side: usize,
    dirt: &LensDirt,
) -> Result<PupilImage, InvalidInput> {
    check_side(side)?;
    let radius = input::finite("aperture radius (mm)", aperture.radius_mm())?;
    // A closed iris still gets a scale: its image is all zero.
    let scale = if radius > 0.0 { radius } else { 1.0 };
    let pixel_mm = 4.0 * scale / side as f64;
    let blots = blots(dirt, scale);
    const SUB: usize = 4;
    let centre = side as f64 / 2.0;
    let mut transmission = vec![0.0; side * side];
    for (k, t) in transmission.iter_mut().enumerate() {
        let (i, j) = (k % side, k / side);
        let mut inside = 0;
        for s in 0..SUB * SUB {
            let x = (i as f64 - centre + ((s % SUB) as f64 + 0.5) / SUB as f64) * pixel_mm;
            let y = (j as f64 - centre + ((s / SUB) as f64 + 0.5) / SUB as f64) * pixel_mm;
            let p = glam::DVec2::new(x, y);
            if aperture.contains(p) && !blots.iter().any(|b| b.blocks(x, y)) {
                inside += 1;
            }
        }
        *t = f64::from(inside) / (SUB * SUB) as f64;
    }
    Ok(PupilImage {
        side,
        pixel_mm,
        transmission,
    })
}

/// The 2D FFT of a square `side`² array in place (`inverse` for the
/// unnormalised inverse).
fn fft_2d(data: &mut [Complex64], side: usize, inverse: bool) {
    let mut planner = FftPlanner::new();
    let fft = if inverse {
        planner.plan_fft_inverse(side)
    } else {
        planner.plan_fft_forward(side)
    };
    fft.process(data);
    let mut column = vec![Complex64::default(); side];
    for i in 0..side {
        for (j, c) in column.iter_mut().enumerate() {
            *c = data[j * side + i];
        }
        fft.process(&mut column);
        for (j, c) in column.iter().enumerate() {
            data[j * side + i] = *c;
        }
    }
}

/// The spectrum of the pupil, `F[T]`, with the aperture's centre as the
/// origin (so that the spectrum's phase is that of a centred aperture).
fn spectrum(pupil: &PupilImage) -> Vec<Complex64> {
    let side = pupil.side;
    // Put the centre at index 0 (ifftshift) before transforming.
    let mut data = vec![Complex64::default(); side * side];
    for (k, &t) in pupil.transmission.iter().enumerate() {
        let (i, j) = ((k % side + side / 2) % side, (k / side + side / 2) % side);
        data[j * side + i] = Complex64::new(t, 0.0);
    }
    fft_2d(&mut data, side, false);
    data
}

/// The Fraunhofer pattern `|F[T]|²` of the pupil, the zero frequency at
/// pixel `(side/2, side/2)`, normalised to sum 1 (all zero for a closed
/// aperture). Bin `k` from the centre is the spatial frequency
/// `k / (side · pixel_mm)` cycles per mm, seen at the angle `λ` times that.
pub fn fraunhofer(pupil: &PupilImage) -> Vec<f64> {
    let side = pupil.side;
    let data = spectrum(pupil);
    let mut power = vec![0.0; side * side];
    for (k, c) in data.iter().enumerate() {
        let (i, j) = ((k % side + side / 2) % side, (k / side + side / 2) % side);
        power[j * side + i] = c.norm_sqr();
    }
    let total: f64 = power.iter().sum();
    if total > 0.0 {
        power.iter_mut().for_each(|p| *p /= total);
    }
    power
}

/// `values` (a `side`² image) at the fractional pixel `(x, y)`, bilinear,
/// zero outside.
fn bilinear(values: &[f64], side: usize, x: f64, y: f64) -> f64 {
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let at = |i: f64, j: f64| {
        if i < 0.0 || j < 0.0 || i >= side as f64 || j >= side as f64 {
            0.0
        } else {
            values[j as usize * side + i as usize]
        }
    };
    (1.0 - fy) * ((1.0 - fx) * at(x0, y0) + fx * at(x0 + 1.0, y0))
        + fy * ((1.0 - fx) * at(x0, y0 + 1.0) + fx * at(x0 + 1.0, y0 + 1.0))
}

/// A starburst: the Fraunhofer pattern summed over wavelengths, in RGB.
#[derive(Clone, Debug, PartialEq)]
pub struct Starburst {
    /// Texels per side; the light's direction at texel `(side/2, side/2)`.
    pub side: usize,
    /// RGB per texel, row-major; each channel sums to its wavelengths'
    /// summed weights (the light that falls inside the texture).
    pub rgb: Vec<[f32; 3]>,
    /// Angle per texel at the reference wavelength, radians, for a pupil
    /// of the image's pixel pitch: `λ_ref / (side · pixel_mm)`.
    pub texel_rad: f64,
}

/// The starburst of `pupil` for light of the given wavelengths (nm) and
/// RGB weights: at each wavelength the Fraunhofer pattern is sampled at
/// `θ / λ` (larger for red) and scaled by `(λ_ref / λ)²` so that each
/// wavelength keeps its energy (the blog's `(1 / (λ z0))²` factor). Give
/// the shortest wavelength as the reference: the pattern is then only
/// ever stretched, which bilinear sampling does without losing energy
/// (shrinking the sharp Airy core would not be).
pub fn starburst(
    pupil: &PupilImage,
    samples: &[(f64, [f64; 3])],
    reference_nm: f64,
) -> Result<Starburst, InvalidInput> {
    let reference_nm = input::positive("reference wavelength (nm)", reference_nm)?;
    for &(wl, _) in samples {
        input::positive("wavelength (nm)", wl)?;
    }
    let side = pupil.side;
    let power = fraunhofer(pupil);
    let centre = (side / 2) as f64;
    let mut rgb = vec![[0f32; 3]; side * side];
    for &(wl, weight) in samples {
        let s = reference_nm / wl;
        for (k, texel) in rgb.iter_mut().enumerate() {
            let (i, j) = ((k % side) as f64 - centre, (k / side) as f64 - centre);
            let p = bilinear(&power, side, centre + i * s, centre + j * s) * s * s;
            for c in 0..3 {
                texel[c] += (p * weight[c]) as f32;
            }
        }
    }
    Ok(Starburst {
        side,
        rgb,
        texel_rad: reference_nm * 1e-6 / (side as f64 * pupil.pixel_mm),
    })
}

/// The intensity of the aperture's field carried the distance of Fresnel
/// number `fresnel_number` (`r² / (λ z)`, > 0) by the angular spectrum
/// method, on the pupil's grid, normalised to a mean of 1 over the open
/// pixels (1 inside, 0 outside in the limit of a large number).
pub fn ringing(
    pupil: &PupilImage,
    wavelength_nm: f64,
    fresnel_number: f64,
) -> Result<Vec<f64>, InvalidInput> {
    let wl_mm = input::positive("wavelength (nm)", wavelength_nm)? * 1e-6;
    let fresnel_number = input::positive("Fresnel number", fresnel_number)?;
    let side = pupil.side;
    let radius = pupil.pixel_mm * side as f64 / 4.0;
    let z = radius * radius / (wl_mm * fresnel_number);
    let mut data = spectrum(pupil);
    let df = 1.0 / (side as f64 * pupil.pixel_mm);
    let k = 1.0 / wl_mm;
    for (idx, c) in data.iter_mut().enumerate() {
        // Frequencies in FFT order: 0, 1, …, side/2 − 1, −side/2, …, −1.
        let signed = |i: usize| {
            if i < side / 2 {
                i as f64
            } else {
                i as f64 - side as f64
            }
        };
        let (u, v) = (signed(idx % side) * df, signed(idx / side) * df);
        let q = u * u + v * v;
        // w − 1/λ without cancellation; evanescent waves are dropped.
        let phase = if q <= k * k {
            2.0 * PI * z * (-q / (k + (k * k - q).sqrt()))
        } else {
            *c = Complex64::default();
            continue;
        };
        *c *= Complex64::from_polar(1.0, phase);
    }
    fft_2d(&mut data, side, true);
    let mut out = vec![0.0; side * side];
    for (idx, c) in data.iter().enumerate() {
        let (i, j) = (
            (idx % side + side / 2) % side,
            (idx / side + side / 2) % side,
        );
        out[j * side + i] = c.norm_sqr();
    }
    let open: f64 = pupil.transmission.iter().sum();
    let total: f64 = out.iter().sum();
    if open > 0.0 && total > 0.0 {
        // The field's energy is kept (Parseval); spread it over the open area.
        let scale = open / total;
        out.iter_mut().for_each(|v| *v *= scale);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn round(side: usize) -> PupilImage {
        pupil_image(&Aperture::circle(5.0).unwrap(), side, &LensDirt::default()).unwrap()
    }

    #[test]
    fn the_pupil_covers_the_aperture_area() {
        let pupil = round(128);
        let area: f64 = pupil.transmission.iter().sum::<f64>() * pupil.pixel_mm.powi(2);
        let want = PI * 25.0;
        assert!((area - want).abs() < 0.005 * want, "{area} vs {want}");
        let dirty = pupil_image(
            &Aperture::circle(5.0).unwrap(),
            128,
            &LensDirt {
                specks: 20,
                scratches: 5,
                seed: 7,
            },
        )
        .unwrap();
        let dirty_area: f64 = dirty.transmission.iter().sum::<f64>() * dirty.pixel_mm.powi(2);
        assert!(dirty_area < area && dirty_area > 0.9 * area, "{dirty_area}");
    }

    /// The Airy pattern of a round pupil: its first dark ring at
    /// 1.22 λ / D, i.e. 1.22 · side / (2 · side/2) = 1.22 × 2 bins for a
    /// pupil of half the side; 84 % of the light inside it.
    #[test]
    fn a_round_pupil_gives_the_airy_pattern() {
        let side = 256;
        let power = fraunhofer(&round(side));
        let c = side / 2;
        // Diameter D = side/2 pixels: the first zero at 1.22 · side / D = 2.44 bins.
        let ring = |r: f64| {
            (0..side * side)
                .filter(|k| {
                    let (i, j) = ((k % side) as f64 - c as f64, (k / side) as f64 - c as f64);
                    (i * i + j * j).sqrt() <= r
                })
                .map(|k| power[k])
                .sum::<f64>()
        };
        let inside = ring(2.44);
        assert!(
            (inside - 0.84).abs() < 0.06,
            "{inside} inside the first zero"
        );
        assert!((power.iter().sum::<f64>() - 1.0).abs() < 1e-9);
        // Symmetric about the centre.
        assert!((power[c * side + c + 3] - power[c * side + c - 3]).abs() < 1e-12);
    }

    /// Six straight blades spread light into six spikes (the edges'
    /// normals, both ways): far out, the pattern along a spike is much
    /// brighter than between spikes.
    #[test]
    fn blades_make_spikes() {
        let side = 256;
        let hex = pupil_image(
            &Aperture::blades(6, 0.0, 0.0, 5.0).unwrap(),
            side,
            &LensDirt::default(),
        )
        .unwrap();
        let power = fraunhofer(&hex);
        let c = (side / 2) as f64;
        // Edge normals of a hexagon with a vertex at 0°: 30°, 90°, ….
        let along = |deg: f64, r: f64| {
            let a = deg.to_radians();
            bilinear(&power, side, c + r * a.cos(), c + r * a.sin())
        };
        let (spike, gap): (f64, f64) = (20..60)
            .map(|r| (along(90.0, f64::from(r)), along(60.0, f64::from(r))))
            .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
        assert!(spike > 10.0 * gap, "spike {spike} vs gap {gap}");
    }

    #[test]
    fn the_starburst_keeps_each_wavelengths_energy_and_grows_with_it() {
        let pupil = round(256);
        let blue = starburst(&pupil, &[(450.0, [1.0, 0.0, 0.0])], 450.0).unwrap();
        let red = starburst(&pupil, &[(650.0, [1.0, 0.0, 0.0])], 450.0).unwrap();
        let sum = |s: &Starburst| s.rgb.iter().map(|t| f64::from(t[0])).sum::<f64>();
        assert!((sum(&blue) - 1.0).abs() < 0.02, "{}", sum(&blue));
        // Stretching by 650/450 with bilinear sampling: +2.2 % measured.
        assert!((sum(&red) - 1.0).abs() < 0.03, "{}", sum(&red));
        // Red spreads wider: less of it in the centre texel.
        let c = 128 * 256 + 128;
        assert!(red.rgb[c][0] < blue.rgb[c][0]);
        let ratio = f64::from(blue.rgb[c][0] / red.rgb[c][0]);
        let want = (650.0f64 / 450.0).powi(2);
        assert!((ratio - want).abs() < 0.05 * want, "{ratio} vs {want}");
    }

    /// Near the aperture (a large Fresnel number) the field is the
    /// aperture with fine ripples at the edge; at a small number it has
    /// spread out. Energy is kept and nothing is negative or NaN.
    #[test]
    fn ringing_shows_fringes_near_the_edge() {
        let side = 256;
        let pupil = round(side);
        let near = ringing(&pupil, 550.0, 200.0).unwrap();
        let far = ringing(&pupil, 550.0, 2.0).unwrap();
        for img in [&near, &far] {
            assert!(img.iter().all(|v| v.is_finite() && *v >= 0.0));
        }
        let c = side / 2;
        // The centre is lit near the aperture, outside is dark.
        assert!(
            (near[c * side + c] - 1.0).abs() < 0.3,
            "{}",
            near[c * side + c]
        );
        assert!(near[c * side + 5] < 0.05);
        // Ripples: along a radius inside the aperture the intensity goes up
        // and down (several local maxima near the edge).
        let row: Vec<f64> = (c..c + side / 4).map(|i| near[c * side + i]).collect();
        let peaks = row
            .windows(3)
            .filter(|w| w[1] > w[0] && w[1] > w[2] && w[1] > 0.5)
            .count();
        assert!(peaks >= 3, "{peaks} fringes: {row:?}");
        // Far: the light has spread past the geometric edge.
        let edge_out = c + side / 4 + 8;
        assert!(far[c * side + edge_out] > near[c * side + edge_out]);
    }

    #[test]
    fn bad_sides_and_wavelengths_are_refused() {
        let a = Aperture::circle(5.0).unwrap();
        assert!(pupil_image(&a, 15, &LensDirt::default()).is_err());
        assert!(pupil_image(&a, 4096, &LensDirt::default()).is_err());
        let p = round(32);
        assert!(starburst(&p, &[(f64::NAN, [1.0; 3])], 550.0).is_err());
        assert!(ringing(&p, 550.0, 0.0).is_err());
        assert!(ringing(&p, -1.0, 10.0).is_err());
        // A closed iris: all zero, no NaN.
        let closed =
            pupil_image(&Aperture::circle(0.0).unwrap(), 32, &LensDirt::default()).unwrap();
        let s = starburst(&closed, &[(550.0, [1.0; 3])], 550.0).unwrap();
        assert!(s.rgb.iter().all(|t| t.iter().all(|v| *v == 0.0)));
        assert!(
            ringing(&closed, 550.0, 10.0)
                .unwrap()
                .iter()
                .all(|v| *v == 0.0)
        );
    }
}
