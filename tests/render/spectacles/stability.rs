//! Stiff and extreme settings: every one renders without a panic or a
//! non-finite pixel, and a refused one says why in `SpectaclesStatus`
//! and falls back as documented (a refused eye: the view stays sharp; a
//! refused lens: the eye is seen naked).

use std::sync::{Arc, Mutex};

use bevy::prelude::*;
use optica_harness::Headless;
use optica_spectacles::twins::LensRefraction;
use optica_spectacles::{
    Accommodation, CloneDefocus, Error, Eye, LensMaterial, Pupil, Spectacles, SpectaclesStatus,
};

use super::{Target, scene};

struct Case {
    name: &'static str,
    eye: Eye,
    spectacles: Option<Spectacles>,
    /// The refusal expected in `SpectaclesStatus::error`, if any: which
    /// component's, and part of its words.
    refused: Option<(Refused, &'static str)>,
}

/// Which [`Error`] variant a case expects.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Refused {
    Eye,
    Spectacles,
}

fn eye(r: f32, amp: f32, mm: f32) -> Eye {
    Eye {
        refractive_error_d: r,
        accommodation: Accommodation::Dioptres(amp),
        pupil: Pupil::Diameter { mm },
        ..default()
    }
}

fn cases() -> Vec<Case> {
    let lens = |s: f32| Some(Spectacles::sphere(s));
    vec![
        Case {
            name: "−20 D myope in −20 D glasses",
            eye: eye(-20.0, 1.0, 8.0),
            spectacles: lens(-20.0),
            refused: None,
        },
        Case {
            name: "+20 D in CR-39 on a 50 mm blank (front surface closes before the rim)",
            eye: eye(20.0, 1.0, 4.0),
            spectacles: lens(20.0),
            refused: Some((Refused::Spectacles, "smaller than the blank radius")),
        },
        Case {
            name: "+20 D on a 36 mm blank",
            eye: eye(20.0, 1.0, 4.0),
            spectacles: Some(Spectacles {
                blank_diameter_mm: 36.0,
                ..Spectacles::sphere(20.0)
            }),
            refused: None,
        },
        Case {
            name: "total internal reflection at the rim of a −10 D lens, n 1.66, 70 mm blank",
            eye: eye(-10.0, 1.0, 12.0),
            spectacles: Some(Spectacles {
                material: LensMaterial::Paper,
                blank_diameter_mm: 70.0,
                ..Spectacles::sphere(-10.0)
            }),
            refused: None,
        },
        Case {
            name: "zero pupil",
            eye: eye(-3.0, 1.0, 0.0),
            spectacles: None,
            refused: None,
        },
        Case {
            name: "zero pupil through a lens",
            eye: eye(-3.0, 1.0, 0.0),
            spectacles: lens(-3.0),
            refused: None,
        },
        Case {
            name: "near point = far point",
            eye: eye(-2.0, 0.0, 6.0),
            spectacles: None,
            refused: None,
        },
        Case {
            name: "hyperope, far point behind the eye",
            eye: eye(4.0, 0.0, 6.0),
            spectacles: None,
            refused: None,
        },
        Case {
            name: "hyperope in +4 D glasses",
            eye: eye(4.0, 0.0, 6.0),
            spectacles: lens(4.0),
            refused: None,
        },
        Case {
            name: "lens on the cornea (vertex distance 0)",
            eye: eye(-3.0, 1.0, 6.0),
            spectacles: Some(Spectacles {
                vertex_distance_mm: 0.0,
                ..Spectacles::sphere(-3.0)
            }),
            refused: None,
        },
        Case {
            name: "lens behind the cornea",
            eye: eye(-3.0, 1.0, 6.0),
            spectacles: Some(Spectacles {
                vertex_distance_mm: -5.0,
                ..Spectacles::sphere(-3.0)
            }),
            refused: Some((Refused::Spectacles, "vertex distance")),
        },
        Case {
            name: "NaN refractive error",
            eye: eye(f32::NAN, 1.0, 6.0),
            spectacles: None,
            refused: Some((Refused::Eye, "refractive error")),
        },
        Case {
            name: "infinite pupil",
            eye: eye(-1.0, 1.0, f32::INFINITY),
            spectacles: None,
            refused: Some((Refused::Eye, "pupil")),
        },
        Case {
            name: "NaN cylinder axis",
            eye: eye(-3.0, 1.0, 6.0),
            spectacles: Some(Spectacles {
                cylinder_d: -1.0,
                axis_deg: f32::NAN,
                ..Spectacles::sphere(-3.0)
            }),
            refused: Some((Refused::Spectacles, "axis")),
        },
        Case {
            name: "−6 D decentred about 8 mm (5 mm in, 6 mm down): refracts and blurs from where it sits",
            eye: eye(-6.0, 1.0, 6.0),
            spectacles: Some(Spectacles {
                decentration_mm: Vec2::new(5.0, -6.0),
                ..Spectacles::sphere(-6.0)
            }),
            refused: None,
        },
        Case {
            name: "decentred 30 mm on a 50 mm blank (the eye's axis off the lens)",
            eye: eye(-3.0, 1.0, 4.0),
            spectacles: Some(Spectacles {
                decentration_mm: Vec2::new(30.0, 0.0),
                ..Spectacles::sphere(-3.0)
            }),
            refused: Some((Refused::Spectacles, "lens decentration (mm) = 30")),
        },
    ]
}

#[test]
fn extreme_eyes_and_lenses_render_finite() {
    let targets = vec![
        Target::checker(3.0, 2.0, 6),
        Target {
            offset: Vec2::new(0.03, 0.0),
            ..Target::checker(0.15, 0.06, 4)
        },
    ];
    for case in cases() {
        // The status, and whether the lens's refraction is drawn.
        let status: Arc<Mutex<Option<(SpectaclesStatus, bool)>>> = Arc::default();
        let sink = status.clone();
        let frame = Headless::new(48, 48)
            .hdr(true)
            .frames(4)
            .render(|app: &mut App| {
                scene(
                    targets.clone(),
                    Some((
                        case.eye.clone(),
                        CloneDefocus {
                            clones: 6,
                            ..default()
                        },
                    )),
                    case.spectacles.clone(),
                    1.0,
                )(app);
                app.add_systems(
                    Last,
                    move |s: Query<(&SpectaclesStatus, Has<LensRefraction>)>| {
                        if let Ok((s, refracted)) = s.single() {
                            *sink.lock().unwrap() = Some((s.clone(), refracted));
                        }
                    },
                );
            })
            .unwrap_or_else(|e| panic!("{}: {e}", case.name));
        let img = frame.hdr().unwrap();
        assert!(
            img.pixels().all(|p| p.0.iter().all(|c| c.is_finite())),
            "{}: a non-finite pixel",
            case.name
        );
        let status = status.lock().unwrap().clone();
        let error = status.as_ref().and_then(|s| s.0.error.clone());
        let refracted = status.as_ref().is_some_and(|s| s.1);
        eprintln!(
            "{}: {}",
            case.name,
            error.as_ref().map_or("ok".into(), |e| e.to_string())
        );
        match case.refused {
            Some((part, why)) => assert!(
                match &error {
                    Some(Error::Eye(e)) => part == Refused::Eye && e.to_string().contains(why),
                    Some(Error::Spectacles(e)) => {
                        part == Refused::Spectacles && e.to_string().contains(why)
                    }
                    _ => false,
                },
                "{}: expected a {part:?} refusal naming `{why}`, got {error:?}",
                case.name
            ),
            None => assert!(error.is_none(), "{}: refused: {error:?}", case.name),
        }
        // A refused lens is not drawn either: the eye is seen naked; a
        // worn one is.
        if matches!(case.refused, Some((Refused::Spectacles, _))) {
            assert!(!refracted, "{}: a refused lens is refracted", case.name);
        } else if case.spectacles.as_ref().is_some_and(|s| s.refraction) {
            assert!(refracted, "{}: the lens is not refracted", case.name);
        }
    }
}
