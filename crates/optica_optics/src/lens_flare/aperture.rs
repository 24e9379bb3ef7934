//! The shape of the aperture stop, tested at the (interpolated) position where
//! a ray crosses the stop plane — the blog's "position where the ray passed
//! the aperture", which a GPU looks up in an aperture texture per pixel.

use glam::DVec2;

use super::FlareError;
use crate::glass::LAMBDA_D_NM;
use crate::input::{self, Expected, InvalidInput};
use crate::lens::LensPrescription;

/// Most blades an [`Aperture`] may have. Real irises have 5 to 18; with 64
/// the polygon's inradius is within 0.12 % (`1 − cos(π/64)`) of its
/// circumradius, a circle for any purpose, and a per-pixel test over the
/// blades stays cheap.
pub const MAX_APERTURE_BLADES: u32 = 64;

/// Outline of the stop opening.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ApertureShape {
    /// A round iris.
    Circle,
    /// An iris of `blades` blades: a regular polygon with one vertex at
    /// angle `rotation_rad` from +x, whose edges are circular arcs through
    /// the vertices of radius `circumradius / roundness` — straight for
    /// `roundness = 0`, on the circumcircle (a round iris) for 1.
    Blades {
        /// Number of blades, 3..=[`MAX_APERTURE_BLADES`].
        blades: u32,
        /// Rotation of the first vertex, radians.
        rotation_rad: f64,
        /// Curvature of the blade edges times the circumradius, in [0, 1].
        roundness: f64,
    },
}

/// The stop opening: a shape and its circumradius in mm, in the stop plane.
///
/// Built by checked constructors; a radius of 0 is a closed iris, through
/// which nothing passes (an all-black ghost, never NaN).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aperture {
    shape: ApertureShape,
    radius_mm: f64,
    /// For blades: `1/q` of the edge arcs (see [`Aperture::contains`]),
    /// `κ / √(1 − (roundness · sin(π/b))²)` with `κ = roundness / radius`.
    arc_w: f64,
}

impl Aperture {
    /// A round aperture of `radius_mm` (finite, >= 0; 0 is closed).
    pub fn circle(radius_mm: f64) -> Result<Self, InvalidInput> {
        let radius_mm = input::non_negative("aperture radius (mm)", radius_mm)?;
        Ok(Self {
            shape: ApertureShape::Circle,
            radius_mm,
            arc_w: 0.0,
        })
    }

    /// A closed iris: nothing passes.
    pub fn closed() -> Self {
        Self {
            shape: ApertureShape::Circle,
            radius_mm: 0.0,
            arc_w: 0.0,
        }
    }

    /// The prescription's own stop, round (the shape `r_rel` already tests).
    pub fn of_stop(prescription: &LensPrescription) -> Self {
        // A prescription's semi-apertures are finite and > 0.
        Self {
            shape: ApertureShape::Circle,
            radius_mm: prescription.stop_semi_aperture_mm(),
            arc_w: 0.0,
        }
    }

    /// An iris of `blades` straight blades inscribed in `radius_mm`: a
    /// regular polygon, one vertex at `rotation_rad` from +x.
    pub fn polygon(blades: u32, rotation_rad: f64, radius_mm: f64) -> Result<Self, InvalidInput> {
        Self::blades(blades, rotation_rad, 0.0, radius_mm)
    }

    /// An iris of `blades` (3..=[`MAX_APERTURE_BLADES`]) blades whose edges
    /// are arcs of roundness `roundness` (in [0, 1]; see
    /// [`ApertureShape::Blades`]), inscribed in `radius_mm` (finite, >= 0),
    /// one vertex at `rotation_rad` (finite) from +x.
    pub fn blades(
        blades: u32,
        rotation_rad: f64,
        roundness: f64,
        radius_mm: f64,
    ) -> Result<Self, InvalidInput> {
        if !(3..=MAX_APERTURE_BLADES).contains(&blades) {
            let expected = Expected::Range {
                min: 3.0,
                max: MAX_APERTURE_BLADES as f64,
            };
            return Err(InvalidInput::new(
                "aperture blades",
                blades as f64,
                expected,
            ));
        }
        let rotation_rad = input::finite("aperture rotation (rad)", rotation_rad)?;
        let roundness = input::in_range("aperture blade roundness", roundness, 0.0, 1.0)?;
        let radius_mm = input::non_negative("aperture radius (mm)", radius_mm)?;
        let half = std::f64::consts::PI / blades as f64;
        // roundness · sin(π/b) <= sin(π/3) < 1: the root is > 0.5.
        let arc_w = if radius_mm > 0.0 {
            roundness / radius_mm / (1.0 - (roundness * half.sin()).powi(2)).sqrt()
        } else {
            0.0
        };
        Ok(Self {
            shape: ApertureShape::Blades {
                blades,
                rotation_rad,
                roundness,
            },
            radius_mm,
            arc_w,
        })
    }

    /// Outline.
    pub fn shape(&self) -> ApertureShape {
        self.shape
    }

    /// Circumradius in mm, in the stop plane.
    pub fn radius_mm(&self) -> f64 {
        self.radius_mm
    }

    /// `true` when the stop-plane point `p` lies in the opening (boundary
    /// included); a non-finite point is outside.
    ///
    /// Blades: for the edge with outward unit normal `n` (halfway between two
    /// vertices, `h = π/b` from each), the edge is the arc of radius
    /// `ρ = r/roundness` through both vertices, centred at `−(q − r cos h)·n`
    /// with `q = √(ρ² − r² sin² h)`. `|p − centre| <= ρ` rearranges, with
    /// `w = 1/q`, to
    /// `½ w |p|² + (1 − w r cos h) (p·n) <= r cos h − ½ w r² cos 2h`,
    /// which is finite for every roundness: `w = 0` gives the straight edge
    /// `p·n <= r cos h`, and roundness 1 (`w = 1/(r cos h)`) the circle
    /// `|p| <= r`.
    pub fn contains(&self, p: DVec2) -> bool {
        let r = self.radius_mm;
        if r == 0.0 {
            return false;
        }
        match self.shape {
            ApertureShape::Circle => p.length_squared() <= r * r,
            ApertureShape::Blades {
                blades,
                rotation_rad,
                ..
            } => {
                let half = std::f64::consts::PI / blades as f64;
                let (inradius, w) = (r * half.cos(), self.arc_w);
                let (quadratic, bound) = (
                    0.5 * w * p.length_squared(),
                    inradius - 0.5 * w * r * r * (2.0 * half).cos(),
                );
                let linear = 1.0 - w * inradius;
                (0..blades).all(|k| {
                    let a = rotation_rad + (2 * k + 1) as f64 * half;
                    quadratic + linear * (p.x * a.cos() + p.y * a.sin()) <= bound
                })
            }
        }
    }
}

/// The prescription with its stop semi-aperture multiplied by `opening` in
/// (0, 1] — stopping the iris down. Done on the prescription (not only on the
/// aperture test) so that `r_rel` clips every crossing of the stop, including
/// the second and third crossings of a ghost that passes the stop three times.
pub fn stopped_down(
    prescription: &LensPrescription,
    opening: f64,
) -> Result<LensPrescription, FlareError> {
    input::positive("stop opening", opening)?;
    input::in_range("stop opening", opening, 0.0, 1.0)?;
    let stop = prescription.stop_index();
    Ok(prescription.edited(|s| s[stop].semi_aperture_mm *= opening)?)
}

/// The prescription stopped down ([`stopped_down`]) to the paraxial
/// f-number `f_number` at the d line. The f-number is `EFL / (2 · entrance
/// pupil radius)` and the entrance pupil is the stop's paraxial image, so it
/// scales as the inverse of the stop's semi-aperture: the opening is
/// `f_open / f_number`. A lens opens no further than its table's stop: an
/// `f_number` below the paraxial f-number of the table (`f_open`, f/2.73 for
/// the shipped Tessar) is an [`InvalidInput`].
pub fn stopped_to_f_number(
    prescription: &LensPrescription,
    f_number: f64,
) -> Result<LensPrescription, FlareError> {
    let open = prescription.paraxial(LAMBDA_D_NM)?.f_number;
    let f_number = input::in_range("f-number", f_number, open, f64::INFINITY)?;
    stopped_down(prescription, open / f_number)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::builtin;

    #[test]
    fn circle_and_hexagon_by_hand() {
        let c = Aperture::circle(2.0).unwrap();
        assert!(c.contains(DVec2::new(2.0, 0.0)));
        assert!(!c.contains(DVec2::new(1.5, 1.5))); // |p| = 2.12
        // Hexagon of circumradius 2 with a vertex on +x: inradius 2 cos 30° = 1.732.
        let h = Aperture::polygon(6, 0.0, 2.0).unwrap();
        assert!(h.contains(DVec2::new(1.99, 0.0)), "near a vertex");
        assert!(h.contains(DVec2::new(0.0, 1.73)));
        assert!(
            !h.contains(DVec2::new(0.0, 1.74)),
            "beyond the flat edge at y = 1.732"
        );
    }

    #[test]
    fn rounded_blades_lie_between_the_polygon_and_the_circle() {
        // Pentagon of circumradius 2, rotated 0.3 rad: on the edge normal of
        // edge 0 (at 0.3 + π/5), straight blades end at the inradius
        // 2 cos 36° = 1.618; roundness 1 is the circle (2.0); roundness 0.5
        // bulges to the arc of radius 4 through the vertices, whose apex is
        // at 4 − (√(16 − 4 sin² 36°) − 2 cos 36°) = 1.7947 from the centre.
        let (rot, r) = (0.3, 2.0);
        let n = |len: f64| {
            let a = rot + std::f64::consts::PI / 5.0;
            DVec2::new(a.cos(), a.sin()) * len
        };
        let half = 36f64.to_radians();
        let apex = 4.0 - ((16.0 - 4.0 * half.sin().powi(2)).sqrt() - 2.0 * half.cos());
        assert!((apex - 1.7947).abs() < 1e-4, "{apex}");
        for (roundness, edge) in [(0.0, 2.0 * half.cos()), (0.5, apex), (1.0, 2.0)] {
            let a = Aperture::blades(5, rot, roundness, r).unwrap();
            assert!(
                a.contains(n(edge - 1e-9)) && !a.contains(n(edge + 1e-9)),
                "roundness {roundness}: edge at {edge}"
            );
        }
        // Every roundness keeps the vertices on the boundary, and nests:
        // polygon ⊂ rounded ⊂ circle, on a grid of points.
        let shapes = [0.0, 0.5, 1.0].map(|s| Aperture::blades(5, rot, s, r).unwrap());
        let circle = Aperture::circle(r).unwrap();
        for k in 0..5 {
            let a = rot + k as f64 * 2.0 * std::f64::consts::PI / 5.0;
            let v = DVec2::new(a.cos(), a.sin()) * r;
            assert!(
                shapes
                    .iter()
                    .all(|s| s.contains(v * (1.0 - 1e-9)) && !s.contains(v * (1.0 + 1e-9))),
                "vertex {k}"
            );
        }
        for i in -25..=25 {
            for j in -25..=25 {
                let p = DVec2::new(i as f64, j as f64) * 0.08;
                let inside = shapes.map(|s| s.contains(p));
                assert!(!inside[0] || inside[1], "{p}");
                assert!(!inside[1] || inside[2], "{p}");
                assert_eq!(
                    inside[2],
                    circle.contains(p),
                    "roundness 1 is the circle at {p}"
                );
            }
        }
    }

    #[test]
    fn closed_aperture_and_bad_points_pass_nothing() {
        assert!(!Aperture::circle(0.0).unwrap().contains(DVec2::ZERO));
        assert!(!Aperture::closed().contains(DVec2::ZERO));
        assert!(
            !Aperture::polygon(6, 0.0, 0.0)
                .unwrap()
                .contains(DVec2::ZERO)
        );
        assert!(
            !Aperture::circle(1.0)
                .unwrap()
                .contains(DVec2::new(f64::NAN, 0.0))
        );
        assert!(
            !Aperture::blades(7, 0.0, 0.4, 1.0)
                .unwrap()
                .contains(DVec2::new(0.0, f64::INFINITY))
        );
    }

    #[test]
    fn bad_apertures_are_refused_naming_the_number() {
        let what = |e: InvalidInput| e.what;
        assert_eq!(
            Aperture::circle(f64::NAN).map_err(what),
            Err("aperture radius (mm)")
        );
        assert_eq!(
            Aperture::circle(-1.0).map_err(what),
            Err("aperture radius (mm)")
        );
        assert_eq!(
            Aperture::polygon(2, 0.0, 1.0).map_err(what),
            Err("aperture blades")
        );
        assert_eq!(
            Aperture::polygon(MAX_APERTURE_BLADES + 1, 0.0, 1.0).map_err(what),
            Err("aperture blades")
        );
        assert_eq!(
            Aperture::polygon(6, f64::INFINITY, 1.0).map_err(what),
            Err("aperture rotation (rad)")
        );
        assert_eq!(
            Aperture::blades(6, 0.0, 1.5, 1.0).map_err(what),
            Err("aperture blade roundness")
        );
    }

    #[test]
    fn stopped_down_scales_only_the_stop() {
        let p = builtin::tessar();
        let q = stopped_down(&p, 0.5).unwrap();
        assert_eq!(q.surfaces()[3].semi_aperture_mm, 7.5); // stop of US 2,854,889: 15.0 mm
        assert_eq!(q.surfaces()[0].semi_aperture_mm, 19.2);
        for bad in [0.0, -0.5, 1.5, f64::NAN] {
            let e = stopped_down(&p, bad).unwrap_err();
            assert!(
                matches!(e, FlareError::Input(i) if i.what == "stop opening"),
                "{bad}: {e}"
            );
        }
    }

    #[test]
    fn stopping_to_an_f_number_gives_that_f_number() {
        // The Tessar's table stop gives f/2.73; stopped to f/8 and f/32 the
        // paraxial f-number is exactly that (it is linear in 1/semi-aperture).
        let p = builtin::tessar();
        for f in [8.0, 32.0] {
            let q = stopped_to_f_number(&p, f).unwrap();
            assert!((q.paraxial(LAMBDA_D_NM).unwrap().f_number / f - 1.0).abs() < 1e-12);
        }
        let e = stopped_to_f_number(&p, 2.0).unwrap_err();
        assert!(
            matches!(e, FlareError::Input(i) if i.what == "f-number" && i.value == 2.0),
            "{e}"
        );
    }
}
