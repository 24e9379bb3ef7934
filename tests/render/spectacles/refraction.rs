//! The lens's refraction of the view (the paper's §3) against an exact
//! per-pixel trace through the same lens: a plane 2 m ahead whose texture
//! encodes its own coordinates (red = x, green = y, linear floats, unlit),
//! seen through −4 D and +4 D lenses. For every pixel the colour read back
//! says which point of the plane the pixel shows; the CPU traces the ray
//! from the eye through that pixel's centre through both lens surfaces to
//! the plane (`SpectacleLens::trace_from_eye`), and the two points'
//! distance, over the pixel's footprint on the plane, is the displacement
//! in pixels of the scene seen through the lens. Held: mean under 0.1 px,
//! every pixel under 0.5 px at the paper's tessellation (24 × 64; measured
//! at 128²: mean 0.02 / 0.03 px, worst 0.09 / 0.10 px for −4 / +4 D), and
//! the view magnified or minified as the lens does (the spectacle
//! magnification's sign). Vertices totally reflected at the rim of a thick
//! minus lens are drawn dark, not as a wrong view.

use bevy::prelude::*;
use optica_harness::Headless;
use optica_optics::glass::{LAMBDA_C_NM, LAMBDA_F_NM};
use optica_optics::glam::DVec3;
use optica_optics::spectacles::plane_seen_through_lens;
use optica_spectacles::Spectacles;
use optica_spectacles::twins::camera_z;

const SIZE: u32 = 128;
const FOV: f32 = 0.8;
const PLANE_Z: f32 = 2.0;
const PLANE_HALF: f32 = 2.0;

/// The texture's channels: red = x, green = y, blue = 1.
const XY1: [usize; 3] = [0, 1, 2];
/// Blue = x, green = y, red = 1.
const BLUE_X: [usize; 3] = [2, 1, 0];

fn render(spectacles: Option<Spectacles>) -> optica_harness::RenderedFrame {
    render_at(spectacles, FOV, XY1)
}

fn render_at(spectacles: Option<Spectacles>, fov: f32, channels: [usize; 3]) -> optica_harness::RenderedFrame {
    Headless::new(SIZE, SIZE)
        .hdr(true)
        .frames(4)
        // Not the lens's dark edge (0.02 grey) in the background.
        .render(optica_report::fixtures::coordinate_plane(
            spectacles,
            fov,
            PLANE_Z,
            PLANE_HALF,
            channels,
            Color::linear_rgb(0.3, 0.0, 0.0),
        ))
        .expect("render")
}

/// The plane point (x, y) a pixel shows, from its colour; `None` where the
/// pixel shows no plane.
fn seen(frame: &optica_harness::RenderedFrame, x: u32, y: u32) -> Option<(f64, f64)> {
    seen_in(frame, x, y, XY1)
}

fn seen_in(frame: &optica_harness::RenderedFrame, x: u32, y: u32, ch: [usize; 3]) -> Option<(f64, f64)> {
    let p = frame.hdr().unwrap().get_pixel(x, y).0;
    (p[ch[2]] > 0.5).then(|| (f64::from(p[ch[0]]), f64::from(p[ch[1]])))
}

/// The exact plane points of every pixel through `lens` at a wavelength.
fn exact_at(lens: &optica_optics::spectacles::SpectacleLens, nm: Option<f64>) -> Vec<Option<optica_optics::glam::DVec2>> {
    let lens = nm.map_or(*lens, |nm| lens.at_wavelength(nm));
    let plane_z = f64::from(PLANE_Z) + f64::from(camera_z());
    plane_seen_through_lens(Some(&lens), f64::from(camera_z()), f64::from(FOV), SIZE, plane_z)
}

/// Pixels per metre on the plane straight ahead.
fn px_per_m() -> f64 {
    f64::from(SIZE) / (2.0 * f64::from(FOV / 2.0).tan() * f64::from(PLANE_Z))
}

/// Displacements (px) of every pixel (away from the view's edge) whose
/// exact ray meets the plane, and the view's scale against the naked eye's.
fn displacements(s: &Spectacles) -> (Vec<f64>, f64) {
    let lens = s.design().unwrap();
    let frame = render(Some(s.clone()));
    let naked = render(None);
    let px_per_m = px_per_m();
    // Green (y) is refracted as the d line, red (x) as the C line.
    let exact = exact_at(&lens, None);
    let exact_red = exact_at(&lens, s.chromatic_aberration.then_some(LAMBDA_C_NM));
    let mut d = Vec::new();
    let (mut spread_lens, mut spread_naked) = (0.0, 0.0);
    for y in 8..SIZE - 8 {
        for x in 8..SIZE - 8 {
            let (Some(hit), Some(red)) = (exact[(y * SIZE + x) as usize], exact_red[(y * SIZE + x) as usize])
            else {
                continue;
            };
            // The plane's x is Bevy's x: the eye frame's −x.
            let want = (-red.x, hit.y);
            let (Some(got), Some(bare)) = (seen(&frame, x, y), seen(&naked, x, y)) else {
                continue;
            };
            d.push(((got.0 - want.0).powi(2) + (got.1 - want.1).powi(2)).sqrt() * px_per_m);
            spread_lens += got.0.abs() + got.1.abs();
            spread_naked += bare.0.abs() + bare.1.abs();
        }
    }
    (d, spread_lens / spread_naked)
}

/// The plain view shows the plane where straight rays meet it (the
/// encoding's own check): displacements under 0.1 px.
fn naked_check() {
    let frame = render(None);
    let tan = f64::from(FOV / 2.0).tan();
    let px_per_m = f64::from(SIZE) / (2.0 * tan * f64::from(PLANE_Z));
    let mut worst = 0.0f64;
    for y in 8..SIZE - 8 {
        for x in 8..SIZE - 8 {
            let dir = (
                (2.0 * (f64::from(x) + 0.5) / f64::from(SIZE) - 1.0) * tan,
                (1.0 - 2.0 * (f64::from(y) + 0.5) / f64::from(SIZE)) * tan,
            );
            let want = (dir.0 * f64::from(PLANE_Z), dir.1 * f64::from(PLANE_Z));
            let got = seen(&frame, x, y).expect("the plane fills the view");
            worst = worst.max(((got.0 - want.0).powi(2) + (got.1 - want.1).powi(2)).sqrt() * px_per_m);
        }
    }
    eprintln!("no lens: worst displacement {worst:.3} px");
    assert!(worst < 0.1, "{worst}");
}

#[test]
fn refraction_matches_an_exact_trace_per_pixel() {
    naked_check();
    for (power, magnifies) in [(-4.0f32, false), (4.0, true)] {
        let (mut d, scale) = displacements(&Spectacles::sphere(power));
        assert!(d.len() > 10_000, "{} pixels compared", d.len());
        d.sort_by(f64::total_cmp);
        let mean = d.iter().sum::<f64>() / d.len() as f64;
        let p99 = d[d.len() * 99 / 100];
        eprintln!(
            "{power:+} D: {} pixels, displacement mean {mean:.3} px, 99th percentile {p99:.3} px, max {:.3} px; \
             the view spans {scale:.3} of the naked eye's",
            d.len(),
            d[d.len() - 1]
        );
        assert!(mean < 0.1 && d[d.len() - 1] < 0.5, "{power} D: mean {mean}, p99 {p99}");
        // A minus lens shows more of the plane (things smaller), a plus lens less.
        assert_eq!(scale < 1.0, magnifies, "{power} D: {scale}");
    }
}

/// Rays totally reflected at the rim of a −10 D lens (n = 1.66, 70 mm
/// blank) are masked: through a 150° view its outer part shows the lens's
/// dark edge; a +2 D lens of the same blank masks only the rays that leave
/// through its thin rim, several times fewer.
#[test]
fn total_internal_reflection_at_the_rim_is_drawn_dark() {
    let lens = |power: f32| Spectacles {
        material: optica_spectacles::LensMaterial::Paper,
        blank_diameter_mm: 70.0,
        ..Spectacles::sphere(power)
    };
    let trace = |power: f32| {
        optica_spectacles::twins::trace_lens(&lens(power).design().unwrap(), DVec3::ZERO, 24, 64, true).unwrap()
    };
    let (minus_trace, plus_trace) = (trace(-10.0), trace(2.0));
    assert!(minus_trace.masked > 2 * plus_trace.masked, "{} {}", minus_trace.masked, plus_trace.masked);
    let dark = |power: f32| {
        let frame = render_at(Some(lens(power)), 2.6, XY1);
        let img = frame.hdr().unwrap();
        // The lens's edge: 0.02 grey (linear) in every channel.
        img.pixels()
            .filter(|p| p.0[..3].iter().all(|c| (c - 0.02).abs() < 0.003))
            .count()
    };
    let (minus, plus) = (dark(-10.0), dark(2.0));
    eprintln!(
        "lens vertices masked of {}: −10 D {}, +2 D {}; dark pixels through −10 D {minus}, +2 D {plus}",
        minus_trace.vertices.len(),
        minus_trace.masked,
        plus_trace.masked
    );
    assert!(minus > 1000 && plus * 3 < minus, "{minus} {plus}");
}

/// The lens's chromatic aberration: a −8 D polycarbonate lens (V = 30)
/// refracts red as the C line and blue as the F line. Two renders read
/// where each colour takes the plane from (x in red, then x in blue);
/// each is held to the exact per-pixel trace at its own wavelength
/// (mean under 0.1 px), and the colours' parting, which grows towards the
/// rim as the lens's prism over V, is the exact one's to within 10 % of
/// its mean where it exceeds 0.1 px. Without it, red and blue coincide.
#[test]
fn chromatic_aberration_parts_the_colours_by_the_abbe_number() {
    let lens = |chromatic: bool| Spectacles {
        material: optica_spectacles::LensMaterial::Polycarbonate,
        chromatic_aberration: chromatic,
        ..Spectacles::sphere(-8.0)
    };
    let designed = lens(true).design().unwrap();
    let (red_ref, blue_ref) = (exact_at(&designed, Some(LAMBDA_C_NM)), exact_at(&designed, Some(LAMBDA_F_NM)));
    let k = px_per_m();
    for chromatic in [true, false] {
        let red = render_at(Some(lens(chromatic)), FOV, XY1);
        let blue = render_at(Some(lens(chromatic)), FOV, BLUE_X);
        let (mut err_red, mut err_blue, mut n) = (0.0, 0.0, 0usize);
        let (mut parted, mut parted_ref, mut wide) = (0.0, 0.0, 0usize);
        let mut apart = 0.0f64;
        for y in 8..SIZE - 8 {
            for x in 8..SIZE - 8 {
                let i = (y * SIZE + x) as usize;
                let (Some(r_ref), Some(b_ref)) = (red_ref[i], blue_ref[i]) else {
                    continue;
                };
                let (Some(r), Some(b)) = (seen_in(&red, x, y, XY1), seen_in(&blue, x, y, BLUE_X)) else {
                    continue;
                };
                // Bevy's x is the eye frame's −x; the parting is along x
                // and y, but only x is read in both colours.
                let (rx, bx) = (r.0, b.0);
                apart = apart.max((rx - bx).abs() * k);
                if !chromatic {
                    continue;
                }
                err_red += (rx + r_ref.x).abs() * k;
                err_blue += (bx + b_ref.x).abs() * k;
                n += 1;
                let want = (b_ref.x - r_ref.x) * k;
                if want.abs() > 0.1 {
                    parted += (rx - bx) * want.signum() * k;
                    parted_ref += want.abs();
                    wide += 1;
                }
            }
        }
        if chromatic {
            let (er, eb) = (err_red / n as f64, err_blue / n as f64);
            let (got, want) = (parted / wide as f64, parted_ref / wide as f64);
            eprintln!(
                "−8 D polycarbonate: {n} pixels, x error red {er:.3} px (C line), blue {eb:.3} px (F line); \
                 where the exact colours part by more than 0.1 px ({wide} pixels) they part by {got:.3} px \
                 (exact {want:.3} px), at most {apart:.3} px"
            );
            assert!(n > 10_000 && wide > 1_000, "{n} {wide}");
            assert!(er < 0.1 && eb < 0.1, "{er} {eb}");
            assert!((got / want - 1.0).abs() < 0.1, "{got} vs {want}");
        } else {
            eprintln!("without chromatic aberration: red and blue part by at most {apart:.4} px");
            assert!(apart < 0.01, "{apart}");
        }
    }
}
