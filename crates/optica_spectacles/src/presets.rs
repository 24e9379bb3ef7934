//! Eyes and glasses people have: the paper's Fig. 8 cases and everyday
//! ones, each with what its wearer sees and why ([`Preset::sight`]).

use optica_optics::glam::{DVec2, DVec3};
use optica_optics::spectacles::{
    self as optics, SpectacleLens, naked_eye_displacements, perpendicular_frame, pupil_samples,
    region_of, set_map, trace_astigmatic_bundle,
};

use crate::Error;
use crate::precompute::{camera_z, eye_placement};
use crate::settings::{Accommodation, Astigmatism, Eye, LensMaterial, Pupil, Spectacles};

/// An eye and the glasses it wears (if any), with a description.
#[derive(Clone, Debug, PartialEq)]
pub struct Preset {
    /// Short name (menus, the example's `--preset`).
    pub name: &'static str,
    /// Who this is, in words.
    pub description: &'static str,
    /// The eye.
    pub eye: Eye,
    /// The glasses, if worn.
    pub spectacles: Option<Spectacles>,
}

/// The paper's pupil (Fig. 8: 12 mm, to exaggerate the blur) and lens
/// index (1.66).
fn paper_eye(near_m: f32, far_m: f32) -> Eye {
    Eye::from_near_far(near_m, far_m, 12.0)
}

fn paper_lens(sphere_d: f32) -> Spectacles {
    Spectacles {
        material: LensMaterial::Paper,
        ..Spectacles::sphere(sphere_d)
    }
}

/// A pupil in an ordinary room (100 cd/m²) for someone of `age`.
fn room_pupil(age: f32) -> Pupil {
    Pupil::Light {
        luminance_cd_m2: 100.0,
        age_years: age,
    }
}

/// Every preset: the paper's Fig. 8 (a)–(d), then everyday eyes with and
/// without their glasses, at a physiological pupil.
pub fn presets() -> Vec<Preset> {
    let myope = Eye {
        refractive_error_d: -3.0,
        accommodation: Accommodation::Age { years: 30.0 },
        pupil: room_pupil(30.0),
        ..Eye::default()
    };
    let presbyope = Eye {
        refractive_error_d: 0.0,
        accommodation: Accommodation::Age { years: 55.0 },
        pupil: room_pupil(55.0),
        ..Eye::default()
    };
    let astigmat = Eye {
        refractive_error_d: -0.5,
        accommodation: Accommodation::Age { years: 30.0 },
        pupil: room_pupil(30.0),
        astigmatism: Astigmatism {
            cylinder_d: -2.0,
            axis_deg: 180.0,
        },
    };
    vec![
        Preset {
            name: "fig8a-emmetrope",
            description: "Paper Fig. 8(a): a normal eye, near point 0.2 m, far point 10 m, 12 mm pupil",
            eye: paper_eye(0.2, 10.0),
            spectacles: None,
        },
        Preset {
            name: "fig8b-myopic-presbyope",
            description: "Paper Fig. 8(b): short-sighted and presbyopic, sharp only from 0.5 m to 1.3 m, 12 mm pupil",
            eye: paper_eye(0.5, 1.3),
            spectacles: None,
        },
        Preset {
            name: "fig8c-concave",
            description: "Paper Fig. 8(c): the same eye with a concave lens (−0.78 D, n 1.66) that puts its far point at infinity; the book blurs",
            eye: paper_eye(0.5, 1.3),
            spectacles: Some(paper_lens(-0.778)),
        },
        Preset {
            name: "fig8d-convex",
            description: "Paper Fig. 8(d): the same eye with a convex reading lens (+1.5 D, n 1.66); near things sharpen, the chart blurs more",
            eye: paper_eye(0.5, 1.3),
            spectacles: Some(paper_lens(1.5)),
        },
        Preset {
            name: "emmetrope",
            description: "A normal eye of 25 in room light (pupil ~3 mm): sharp from 9 cm to infinity",
            eye: Eye {
                pupil: room_pupil(25.0),
                ..Eye::default()
            },
            spectacles: None,
        },
        Preset {
            name: "myope",
            description: "A −3 D myope of 30 without glasses: sharp only nearer than 33 cm",
            eye: myope.clone(),
            spectacles: None,
        },
        Preset {
            name: "myope-glasses",
            description: "The −3 D myope in −3 D CR-39 glasses: sharp again far away, the world a little smaller",
            eye: myope,
            spectacles: Some(Spectacles::sphere(-3.0)),
        },
        Preset {
            name: "presbyope",
            description: "A normal eye of 55 (2 D of accommodation left, near point 50 cm): the book at 30 cm is blurred",
            eye: presbyope.clone(),
            spectacles: None,
        },
        Preset {
            name: "presbyope-readers",
            description: "The presbyope in +2 D reading glasses: the book is sharp, the far wall is not",
            eye: presbyope.clone(),
            spectacles: Some(Spectacles::sphere(2.0)),
        },
        Preset {
            name: "presbyope-progressives",
            description: "The presbyope in plano progressives with a +2.00 add: the far wall sharp straight ahead, the book sharp when looked at through the near zone about 30° below, and either side of the corridor the blur every progressive wearer learns to turn their head away from",
            eye: presbyope,
            spectacles: Some(Spectacles {
                addition_d: 2.0,
                ..Spectacles::sphere(0.0)
            }),
        },
        Preset {
            name: "astigmat",
            description: "An astigmat of 30, −0.50 / −2.00 × 180 (with the rule), without glasses: the vertical meridian is 2 D more myopic, so far points smear into vertical streaks and the chart's horizontal strokes blur before its vertical ones",
            eye: astigmat.clone(),
            spectacles: None,
        },
        Preset {
            name: "astigmat-glasses",
            description: "The astigmat in −0.50 / −2.00 × 180 glasses (a toric lens, its cylinder across the vertical meridian): sharp far away again, the world a little squashed vertically",
            eye: astigmat,
            spectacles: Some(Spectacles {
                sphere_d: -0.5,
                cylinder_d: -2.0,
                axis_deg: 180.0,
                ..Spectacles::sphere(-0.5)
            }),
        },
    ]
}

/// What a wearer sees of a point straight ahead.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sight {
    /// The blur disc's diameter as the eye sees it (arcminutes; 1′ is the
    /// finest detail a good eye resolves, a 20/20 letter is 5′ tall).
    pub blur_arcmin: f64,
}

impl Preset {
    /// What the wearer sees of a point `distance_m` metres ahead, and the
    /// glasses' magnification (%; negative: things look smaller), or why
    /// the settings were refused.
    pub fn sight(&self, distance_m: f64) -> Result<(Sight, f64), Error> {
        self.sight_looking_down(distance_m, 0.0)
    }

    /// [`Preset::sight`] of a point `down_deg` degrees below straight
    /// ahead: a book in the lap, seen through a progressive lens's near
    /// zone.
    pub fn sight_looking_down(
        &self,
        distance_m: f64,
        down_deg: f64,
    ) -> Result<(Sight, f64), Error> {
        let eye = self.eye.optics().map_err(|e| Error::Eye(e.into()))?;
        let lens = match &self.spectacles {
            Some(s) => Some(s.design().map_err(Error::Spectacles)?),
            None => None,
        };
        let blur =
            blur_angle_looking_down_rad(&eye, lens.as_ref(), distance_m, down_deg.to_radians())
                .ok_or(Error::NotSeenThroughLens)?;
        let magnification = lens.as_ref().map_or(0.0, spectacle_magnification_percent);
        Ok((
            Sight {
                blur_arcmin: blur.to_degrees() * 60.0,
            },
            magnification,
        ))
    }
}

/// The blur's angular diameter (rad) of a point `distance_m` ahead of the
/// eye's camera (its entrance pupil), along its longest direction (an
/// astigmat's blur is an ellipse): `A·ΔD` for a stigmatic naked eye;
/// otherwise the set the clones draw, straight ahead — the naked eye's
/// closed form, or the near and far bundles traced through the lens and
/// the field's rule at the point — as the largest radius of its ellipse,
/// doubled, over the point's distance.
pub fn blur_angle_rad(
    eye: &optics::Eye,
    lens: Option<&SpectacleLens>,
    distance_m: f64,
) -> Option<f64> {
    blur_angle_looking_down_rad(eye, lens, distance_m, 0.0)
}

/// [`blur_angle_rad`] of a point `down_rad` below straight ahead, the eye
/// turned towards it (the bundles' aim from the eye's centre of rotation
/// through the point; a lens's prism bends the line of sight by a few
/// degrees, which moves the point the set is taken at by millimetres).
pub fn blur_angle_looking_down_rad(
    eye: &optics::Eye,
    lens: Option<&SpectacleLens>,
    distance_m: f64,
    down_rad: f64,
) -> Option<f64> {
    if distance_m.is_nan() || distance_m <= 0.0 || !down_rad.is_finite() {
        return None;
    }
    let pl = eye_placement();
    let camera = DVec3::new(0.0, 0.0, f64::from(camera_z()));
    let point = camera + DVec3::new(0.0, -down_rad.sin(), down_rad.cos()) * distance_m;
    let Some(lens) = lens else {
        if eye.cylinder_d() == 0.0 && down_rad == 0.0 {
            return eye.blur_angle_rad(distance_m).ok();
        }
        let axes = [DVec2::X, DVec2::Y];
        let m = naked_eye_displacements(eye, &pl, point, &axes);
        let radius = largest_radius([m[0], m[1]]);
        return radius.is_finite().then(|| 2.0 * radius / distance_m);
    };
    let rho = 0.5 * eye.pupil_diameter_m();
    if rho == 0.0 {
        return Some(0.0);
    }
    let samples = pupil_samples(64);
    let aim = (point - pl.centre_of_rotation()).try_normalize()?;
    let (e1, e2) = perpendicular_frame(aim);
    let bundle = |a: f64| {
        trace_astigmatic_bundle(
            Some(lens),
            &pl,
            aim,
            rho,
            eye.vergence_matrix(e1, e2, a),
            &samples,
        )
        .ok()
    };
    let near = bundle(eye.accommodation_d())?;
    let far = bundle(0.0)?;
    // Distance along the refracted chief from its exit on the lens.
    let s = (point - near.chief().origin()).dot(near.chief().dir());
    // Not ahead of the lens (or NaN): nothing to see through it.
    if s.is_nan() || s <= 0.0 {
        return None;
    }
    let region = region_of(&near, &far, s);
    let Some(map) = set_map(&near, &far, region, s, eye.cylinder_d() != 0.0) else {
        return Some(0.0);
    };
    Some(2.0 * largest_radius(map) / distance_m)
}

/// The semi-major axis of the ellipse `x·m_x + y·m_y` over the unit disc:
/// the largest singular value of `[m_x m_y]`.
fn largest_radius(m: [DVec3; 2]) -> f64 {
    let (a, b, c) = (m[0].length_squared(), m[0].dot(m[1]), m[1].length_squared());
    let half = 0.5 * (a - c);
    (0.5 * (a + c) + (half * half + b * b).sqrt()).sqrt()
}

/// Spectacle magnification (%) of a lens seen from the entrance pupil:
/// the power factor `1/(1 − h·F)` (back-vertex power `F`, `h` from the
/// back vertex to the entrance pupil) times the shape factor
/// `1/(1 − t·F1/n)` (centre thickness `t`, front power `F1`, index `n`),
/// minus one. A −3 D lens at 12 mm makes things about 4 % smaller.
pub fn spectacle_magnification_percent(lens: &SpectacleLens) -> f64 {
    let h = lens.vertex_distance_m() - f64::from(camera_z());
    let f = lens.prescription().spherical_equivalent_d();
    let power = 1.0 / (1.0 - h * f);
    let shape = 1.0 / (1.0 - lens.centre_thickness_m() * lens.front_power_d() / lens.index());
    (power * shape - 1.0) * 100.0
}
