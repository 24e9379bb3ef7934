//! The blur the pixels show against the dioptric formula: a small soft
//! white spot (a Gaussian of 1.5 px) on black, straight ahead, drawn sharp and through an eye that
//! cannot focus on it. Blurring adds the clones' spread to the square's
//! own second moment, so the blurred image's second moment about its
//! centroid minus the sharp image's is the clone set's, `ρ²·(½ − |c̄|²)`
//! in pixels² (`ρ` = the blur disc's radius `A·ΔD/2` in radians times the
//! pixels per radian; ½ the sunflower's mean r², `c̄` its centroid). Held
//! within 3 % for a far-point case (a −5 D myope, 2 m: disc radius 6.8 px)
//! and a near-point case (a +2 D hyperope with no accommodation, 0.5 m:
//! 6.0 px), for both shadings. Measured: the clones shaded in full within
//! 0.2 %; reprojected +1.5 % and +1.8 % (its bilinear resampling of the
//! sharp view adds about a third of a pixel² of blur).

use bevy::prelude::*;
use optica_harness::Headless;
use optica_optics::spectacles::pupil_samples;
use optica_spectacles::{Accommodation, CloneDefocus, CloneShading, Eye, Pupil};

use super::{Target, scene_with_background};

const SIZE: u32 = 128;
const FOV: f32 = 0.5;
const CLONES: u32 = 32;

/// Pixels per radian straight ahead.
fn px_per_rad() -> f64 {
    f64::from(SIZE) / (2.0 * f64::from(FOV / 2.0).tan())
}

/// Centroid and second moment (px²) about it of the image's luminance.
fn moments(frame: &optica_harness::RenderedFrame) -> (Vec2, f64) {
    let img = frame.hdr().expect("hdr");
    let (mut w, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
    for (x, y, p) in img.enumerate_pixels() {
        let v = f64::from(p[0] + p[1] + p[2]);
        assert!(v.is_finite());
        w += v;
        sx += v * (f64::from(x) + 0.5);
        sy += v * (f64::from(y) + 0.5);
    }
    let c = (sx / w, sy / w);
    let mut m = 0.0;
    for (x, y, p) in img.enumerate_pixels() {
        let v = f64::from(p[0] + p[1] + p[2]);
        m += v * ((f64::from(x) + 0.5 - c.0).powi(2) + (f64::from(y) + 0.5 - c.1).powi(2));
    }
    (Vec2::new(c.0 as f32, c.1 as f32), m / w)
}

fn render(eye: Option<Eye>, shading: CloneShading, distance: f32) -> optica_harness::RenderedFrame {
    // σ = 1.5 px.
    let spot = Target::spot(distance, (1.5 / px_per_rad()) as f32 * distance);
    let defocus = CloneDefocus {
        clones: CLONES,
        shading,
        ..default()
    };
    Headless::new(SIZE, SIZE)
        .hdr(true)
        .frames(4)
        .render(scene_with_background(
            vec![spot],
            eye.map(|e| (e, defocus)),
            None,
            FOV,
            Color::BLACK,
        ))
        .expect("render")
}

#[test]
fn blur_disc_from_pixels_matches_the_dioptric_formula() {
    let f_px = px_per_rad();
    let samples = pupil_samples(CLONES as usize);
    let centroid = samples.iter().copied().sum::<optica_optics::glam::DVec2>() / CLONES as f64;
    let spread = 0.5 - centroid.length_squared();
    let myope = Eye {
        refractive_error_d: -5.0,
        accommodation: Accommodation::Dioptres(2.0),
        pupil: Pupil::Diameter { mm: 12.0 },
    };
    let hyperope = Eye {
        refractive_error_d: 2.0,
        accommodation: Accommodation::Dioptres(0.0),
        pupil: Pupil::Diameter { mm: 12.0 },
    };
    for (name, eye, z) in [("myope at 2 m", myope, 2.0f32), ("hyperope at 0.5 m", hyperope, 0.5)] {
        let optics = eye.optics().unwrap();
        // The point's distance from the entrance pupil (the camera).
        let dd = optics.defocus_d(f64::from(z)).unwrap();
        let rho_px = 0.5 * optics.pupil_diameter_m() * dd * f_px;
        let want = rho_px * rho_px * spread;
        let (c0, sharp) = moments(&render(None, CloneShading::Full, z));
        for shading in [CloneShading::Reprojected, CloneShading::Full] {
            let (c, blurred) = moments(&render(Some(eye.clone()), shading, z));
            let got = blurred - sharp;
            eprintln!(
                "{name}, {shading:?}: ΔD {dd:.2} D, disc radius {rho_px:.2} px, clone spread {got:.2} px² \
                 (formula {want:.2}), centroid moved {:.2} px",
                (c - c0).length()
            );
            assert!(
                (got - want).abs() < 0.03 * want,
                "{name}, {shading:?}: {got} px² vs {want} px²"
            );
        }
    }
}
