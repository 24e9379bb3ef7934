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
use optica_optics::glam::DVec3;
use optica_optics::spectacles::pupil_samples;
use optica_spectacles::{Accommodation, Astigmatism, CloneDefocus, CloneShading, Eye, LensMaterial, Pupil, Spectacles};

use super::{Target, scene_with_background};

const SIZE: u32 = 128;
const FOV: f32 = 0.5;
const CLONES: u32 = 32;

/// Pixels per radian straight ahead.
fn px_per_rad() -> f64 {
    f64::from(SIZE) / (2.0 * f64::from(FOV / 2.0).tan())
}

/// The second-moment tensor (px², image x right, y down) about the
/// centroid of the image's luminance: `[xx, xy, yy]`.
fn tensor(frame: &optica_harness::RenderedFrame) -> [f64; 3] {
    let img = frame.hdr().expect("hdr");
    let (mut w, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
    for (x, y, p) in img.enumerate_pixels() {
        let v = f64::from(p[0] + p[1] + p[2]);
        w += v;
        sx += v * (f64::from(x) + 0.5);
        sy += v * (f64::from(y) + 0.5);
    }
    let c = (sx / w, sy / w);
    let mut m = [0.0; 3];
    for (x, y, p) in img.enumerate_pixels() {
        let v = f64::from(p[0] + p[1] + p[2]) / w;
        let (dx, dy) = (f64::from(x) + 0.5 - c.0, f64::from(y) + 0.5 - c.1);
        m[0] += v * dx * dx;
        m[1] += v * dx * dy;
        m[2] += v * dy * dy;
    }
    m
}

/// The principal axes of a symmetric tensor `[xx, xy, yy]`: the direction
/// (degrees, from +x towards −y, i.e. counter-clockwise on the screen) of
/// the larger, and both eigenvalues.
fn principal(m: [f64; 3]) -> (f64, f64, f64) {
    let half = 0.5 * (m[0] - m[2]);
    let root = (half * half + m[1] * m[1]).sqrt();
    let mean = 0.5 * (m[0] + m[2]);
    // Angle of the major axis in image coordinates (y down), then flipped
    // to count counter-clockwise as seen on the screen.
    let angle = 0.5 * (2.0 * m[1]).atan2(m[0] - m[2]);
    ((-angle.to_degrees()).rem_euclid(180.0), mean + root, mean - root)
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
    render_through(eye, None, shading, distance)
}

fn render_through(
    eye: Option<Eye>,
    spectacles: Option<Spectacles>,
    shading: CloneShading,
    distance: f32,
) -> optica_harness::RenderedFrame {
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
            spectacles,
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
        ..default()
    };
    let hyperope = Eye {
        refractive_error_d: 2.0,
        accommodation: Accommodation::Dioptres(0.0),
        pupil: Pupil::Diameter { mm: 12.0 },
        ..default()
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

#[test]
fn astigmatic_blur_from_pixels_lies_across_the_cylinder_axis() {
    // On the screen the eye's frame shows as the examiner would see the
    // wearer's eye mirrored: the wearer's left (+x, axis 0°) is the
    // screen's left, up is up, so a meridian at θ° (counter-clockwise as the
    // examiner sees it) shows at 180° − θ counter-clockwise on the screen.
    //
    // 1. A naked eye "plano / −4.00 × 30", no accommodation, 12 mm pupil,
    //    a spot at 1 m: every meridian of the clone set scales the pupil
    //    by 1 − s·V (V = 0 along the axis, 4 D across): the set's tensor,
    //    from the CPU twin, is what the pixels must add to the sharp spot's,
    //    its major axis across the axis (120°), at 60° on the screen.
    // 2. An emmetrope with no accommodation and a 6 mm pupil wearing a
    //    lens "plano / −3.00 × 30" (a lens whose axis is known): its power
    //    lies across its axis, so a spot at 1.5 m blurs into a line across
    //    it, at the screen angle 180° − 120° = 60°, against the set traced
    //    through the lens (the field adds its voxels' averaging).
    let f_px = px_per_rad();
    let samples = pupil_samples(CLONES as usize);
    let sharp = tensor(&render(None, CloneShading::Full, 1.0));
    let astigmat = Eye {
        refractive_error_d: 0.0,
        accommodation: Accommodation::Dioptres(0.0),
        pupil: Pupil::Diameter { mm: 12.0 },
        astigmatism: Astigmatism {
            cylinder_d: -4.0,
            axis_deg: 30.0,
        },
    };
    let optics = astigmat.optics().unwrap();
    let placement = optica_spectacles::twins::eye_placement();
    let point = DVec3::new(0.0, 0.0, 1.0 + f64::from(optica_spectacles::twins::camera_z()));
    let set = optica_optics::spectacles::naked_eye_displacements(&optics, &placement, point, &samples);
    // Pixels per metre at the point, 1 m from the camera.
    let want = set_tensor(&set, f_px / 1.0);
    for shading in [CloneShading::Full, CloneShading::Reprojected] {
        let blurred = tensor(&render(Some(astigmat.clone()), shading, 1.0));
        let got = [blurred[0] - sharp[0], blurred[1] - sharp[1], blurred[2] - sharp[2]];
        let (ga, gbig, gsmall) = principal(got);
        let (wa, wbig, wsmall) = principal(want);
        eprintln!(
            "astigmat −4 × 30, {shading:?}: major axis at {ga:.1}° on screen (set {wa:.1}°), \
             variances {gbig:.2} / {gsmall:.2} px² (set {wbig:.2} / {wsmall:.2})"
        );
        assert!((ga - 60.0).abs() < 2.0 && (wa - 60.0).abs() < 1.0, "{shading:?}: {ga}° / {wa}°");
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 0.04 * wbig, "{shading:?}: {got:?} vs {want:?}");
        }
    }

    let emmetrope = Eye {
        refractive_error_d: 0.0,
        accommodation: Accommodation::Dioptres(0.0),
        pupil: Pupil::Diameter { mm: 6.0 },
        ..default()
    };
    let lens = Spectacles {
        sphere_d: 0.0,
        cylinder_d: -3.0,
        axis_deg: 30.0,
        material: LensMaterial::Cr39,
        ..default()
    };
    // The set the field stores at the spot, traced through the lens: the
    // bundle straight ahead, focused at infinity (no accommodation), at
    // the spot's distance along the refracted chief.
    let z = 1.5;
    let optics = emmetrope.optics().unwrap();
    let designed = lens.design().unwrap();
    let (e1, e2) = optica_optics::spectacles::perpendicular_frame(DVec3::Z);
    let bundle = optica_optics::spectacles::trace_astigmatic_bundle(
        Some(&designed),
        &placement,
        DVec3::Z,
        0.5 * optics.pupil_diameter_m(),
        optics.vergence_matrix(e1, e2, 0.0),
        &samples,
    )
    .unwrap();
    let spot = DVec3::new(0.0, 0.0, z + f64::from(optica_spectacles::twins::camera_z()));
    let along = (spot - bundle.chief().origin()).dot(bundle.chief().dir());
    let want = set_tensor(&bundle.displacements(along).collect::<Vec<_>>(), f_px / z);
    // The lens also minifies the view across its axis (about 4 % for
    // −3 D at 15 mm), so the sharp spot is drawn through it too, by an
    // eye with no pupil, and the set is scaled by the minification
    // measured along the blur between that spot and the naked one.
    let pinhole = Eye {
        pupil: Pupil::Diameter { mm: 0.0 },
        ..emmetrope.clone()
    };
    let naked = tensor(&render(None, CloneShading::Full, z as f32));
    let sharp = tensor(&render_through(Some(pinhole), Some(lens.clone()), CloneShading::Full, z as f32));
    let blurred = tensor(&render_through(Some(emmetrope), Some(lens), CloneShading::Full, z as f32));
    let got = [blurred[0] - sharp[0], blurred[1] - sharp[1], blurred[2] - sharp[2]];
    let (angle, big, small) = principal(got);
    let (wa, _, _) = principal(want);
    let along = |t: [f64; 3]| {
        let a = (-wa).to_radians();
        let (c, s) = (a.cos(), a.sin());
        c * c * t[0] + 2.0 * c * s * t[1] + s * s * t[2]
    };
    let m2 = along(sharp) / along(naked);
    let want = want.map(|w| w * m2);
    let (_, wbig, wsmall) = principal(want);
    eprintln!(
        "lens −3 × 30: major axis at {angle:.1}° on screen (traced set {wa:.1}°), variances \
         {big:.2} / {small:.2} px² (traced set {wbig:.2} / {wsmall:.2}, minified by {:.1} % along it)",
        100.0 * (1.0 - m2.sqrt())
    );
    assert!((angle - 60.0).abs() < 3.0 && (wa - 60.0).abs() < 1.0, "{angle}° / {wa}°");
    assert!(big > 5.0 * small, "{big} / {small}");
    assert!(m2 < 1.0, "a minus lens minifies: {m2}");
    for (g, w) in got.iter().zip(want) {
        assert!((g - w).abs() < 0.05 * wbig, "{got:?} vs {want:?}");
    }
}

/// The covariance `[xx, xy, yy]` of a clone set (m, eye frame) in pixels,
/// `k` pixels per metre at the point: the eye's (x, y) shows on the screen
/// as (−x, −y) in pixel axes (x right, y down), which leaves it as it is.
fn set_tensor(set: &[DVec3], k: f64) -> [f64; 3] {
    let n = set.len() as f64;
    let mean = set.iter().copied().sum::<DVec3>() / n;
    let mut t = [0.0; 3];
    for v in set {
        let d = (*v - mean) * k;
        t[0] += d.x * d.x / n;
        t[1] += d.x * d.y / n;
        t[2] += d.y * d.y / n;
    }
    t
}

