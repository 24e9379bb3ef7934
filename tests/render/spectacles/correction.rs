//! A −3 D myope (age 30, 6 mm pupil) in the paper's room: a book at 30 cm
//! and an eye chart at 5 m. Without glasses the chart is blurred (3 D out
//! of focus: a disc of 1° at the eye); with −3 D glasses it is sharp again
//! and the book stays sharp (the glasses move the near point out to
//! ~11 cm). Measure: SSIM of the whole view against the same view drawn
//! without the eye (sharp; through the same glasses, whose refraction
//! makes the room ~4 % smaller), 1 = the same image. Held: naked below 0.8,
//! with glasses above 0.97 (measured 0.63 and 0.997); goldens of both on
//! lavapipe.

use bevy::prelude::*;
use optica_harness::{Headless, RenderedFrame, assert_golden, metrics};
use optica_spectacles::{Accommodation, CloneDefocus, Eye, Pupil, Spectacles};

use super::{Target, scene};

fn room() -> Vec<Target> {
    vec![
        Target::checker(5.0, 2.4, 12),
        Target {
            offset: Vec2::new(-0.05, -0.04),
            ..Target::checker(0.3, 0.08, 8)
        },
    ]
}

fn myope() -> Eye {
    Eye {
        refractive_error_d: -3.0,
        accommodation: Accommodation::Age { years: 30.0 },
        pupil: Pupil::Diameter { mm: 6.0 },
        ..default()
    }
}

fn view(eye: Option<Eye>, spectacles: Option<Spectacles>) -> RenderedFrame {
    Headless::new(128, 128)
        .frames(4)
        .render(scene(
            room(),
            eye.map(|e| (e, CloneDefocus::default())),
            spectacles,
            0.5,
        ))
        .expect("render")
}

#[test]
fn glasses_sharpen_the_myopes_far_chart() {
    // Each against the same view without the eye: the glasses' own
    // refraction (they make the room ~4 % smaller) is in both.
    let sharp = view(None, None).to_rgba8();
    let sharp_through = view(None, Some(Spectacles::sphere(-3.0))).to_rgba8();
    let naked = view(Some(myope()), None);
    let corrected = view(Some(myope()), Some(Spectacles::sphere(-3.0)));
    let ssim_naked = metrics::ssim(&sharp, &naked.to_rgba8()).unwrap();
    let ssim_corrected = metrics::ssim(&sharp_through, &corrected.to_rgba8()).unwrap();
    eprintln!("SSIM against the sharp view: naked {ssim_naked:.3}, with −3 D glasses {ssim_corrected:.3}");
    assert!(ssim_naked < 0.8, "naked {ssim_naked}");
    assert!(ssim_corrected > 0.97, "corrected {ssim_corrected}");
}

#[test]
fn myope_without_glasses() {
    assert_golden!(&view(Some(myope()), None));
}

#[test]
fn myope_with_glasses() {
    assert_golden!(&view(Some(myope()), Some(Spectacles::sphere(-3.0))));
}
