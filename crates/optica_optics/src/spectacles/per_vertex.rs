//! Per-vertex ray tracing through the lens (documented on [`LensTrace`]).

use glam::{DVec2, DVec3};
use rayon::prelude::*;
use serde::Serialize;

use super::lens_design::SpectacleLens;
use crate::input::{self, InvalidInput};
use crate::ray::Ray;
use crate::surface::{Refraction, refract};

/// What happened to a ray sent from the eye into the lens.
///
/// Per-vertex ray tracing through the lens (paper §3.1, steps (1) and (3a)):
/// for each lens vertex, the ray from the eye through it, refracted at the
/// back surface (air → glass) and at the front surface (glass → air).
///
/// Outcomes are typed: a ray can exit through the front surface, be totally
/// internally reflected there (thick minus lenses near the rim: critical angle
/// `asin(1/n)` = 37.04° at n = 1.66), leave through the rim (the cylinder
/// `r = blank radius` between the surfaces) before reaching the front
/// surface, or miss the lens. No zero vector stands for TIR (unlike glam's
/// and WGSL's `refract`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub enum LensTrace {
    /// Through both surfaces: the exit point on the front surface and the
    /// unit exit direction (into the scene).
    Exit {
        /// Where the ray entered (back surface).
        back: DVec3,
        /// Where it left (front surface).
        front: DVec3,
        /// Unit direction after the front surface.
        dir: DVec3,
    },
    /// Totally internally reflected at the front surface.
    TotalInternalReflection {
        /// Where the ray entered.
        back: DVec3,
        /// Where it was reflected.
        at: DVec3,
    },
    /// Reached the rim (edge cylinder) before the front surface.
    EdgeExit {
        /// Where the ray entered.
        back: DVec3,
        /// Where it meets the rim. (Documented fallback: the entry point
        /// `back` for a ray running parallel to the axis inside the glass,
        /// which never meets the rim; it cannot miss the front surface of a
        /// designed lens, so this does not occur.)
        at: DVec3,
    },
    /// Did not enter the lens: the ray misses the back surface or meets it
    /// outside the blank.
    Missed,
}

impl LensTrace {
    /// The exit ray (point on the front surface, unit direction), if the ray
    /// got through. (The direction of an `Exit` made by
    /// [`SpectacleLens::trace_from_eye`] is unit; one made by hand must be.)
    pub fn exit_ray(&self) -> Option<Ray> {
        match *self {
            LensTrace::Exit { front, dir, .. } => Some(Ray::from_unit(front, dir)),
            _ => None,
        }
    }

    /// True for [`LensTrace::Exit`].
    pub fn is_exit(&self) -> bool {
        matches!(self, LensTrace::Exit { .. })
    }
}

/// Parameter `s > 0` where `p + s d` meets the cylinder `x² + y² = r²` from
/// inside, or `None` when `d` has no lateral component.
fn rim_crossing(p: DVec3, d: DVec3, r: f64) -> Option<f64> {
    let a = d.x * d.x + d.y * d.y;
    if !(a > 0.0) {
        return None;
    }
    let b = p.x * d.x + p.y * d.y;
    let c = p.x * p.x + p.y * p.y - r * r;
    let disc = b * b - a * c;
    if !(disc >= 0.0) {
        return None;
    }
    // The larger root (−b + √disc)/a, in the cancellation-free form: when
    // b > 0 it is c/q with q = −(b + √disc) (product of the roots is c/a).
    let sq = disc.sqrt();
    let s = if b > 0.0 {
        c / (-(b + sq))
    } else {
        (sq - b) / a
    };
    (s.is_finite() && s >= 0.0).then_some(s)
}

impl SpectacleLens {
    /// Traces `ray` (from the eye side, travelling towards +z) through the
    /// lens: refraction at the back surface (air → glass), then at the front
    /// surface (glass → air). Every outcome is a [`LensTrace`] variant; a
    /// [`Ray`] is always traceable, so there is no error.
    pub fn trace_from_eye(&self, ray: &Ray) -> LensTrace {
        let d = self.decentration_m();
        if d == DVec2::ZERO {
            return self.trace_centred(ray);
        }
        // A decentred lens: the ray in the lens's own frame, the outcome
        // back in the eye's.
        let shift = d.extend(0.0);
        let local = Ray::from_unit(ray.origin() - shift, ray.dir());
        match self.trace_centred(&local) {
            LensTrace::Exit { back, front, dir } => LensTrace::Exit {
                back: back + shift,
                front: front + shift,
                dir,
            },
            LensTrace::TotalInternalReflection { back, at } => LensTrace::TotalInternalReflection {
                back: back + shift,
                at: at + shift,
            },
            LensTrace::EdgeExit { back, at } => LensTrace::EdgeExit {
                back: back + shift,
                at: at + shift,
            },
            LensTrace::Missed => LensTrace::Missed,
        }
    }

    /// [`SpectacleLens::trace_from_eye`] in the lens's own frame.
    fn trace_centred(&self, ray: &Ray) -> LensTrace {
        let (rim, index, back_surface, front_surface) =
            (self.rim_radius_m(), self.index(), self.back(), self.front());
        let r2 = rim * rim;
        let Some(h1) = back_surface.intersect(ray) else {
            return LensTrace::Missed;
        };
        if h1.point.truncate().length_squared() > r2 {
            return LensTrace::Missed;
        }
        let back = h1.point;
        let d1 = match refract(ray.dir(), h1.normal, 1.0, index) {
            Refraction::Transmitted(d) => d,
            // Cannot happen from air into glass (n > 1); reported, not hidden.
            Refraction::TotalInternalReflection => {
                return LensTrace::TotalInternalReflection { back, at: back };
            }
        };
        let inside = Ray::from_unit(back, d1);
        let edge = || {
            let s = rim_crossing(back, d1, rim).unwrap_or(0.0);
            LensTrace::EdgeExit {
                back,
                at: inside.at(s),
            }
        };
        let Some(h2) = front_surface.intersect(&inside) else {
            return edge();
        };
        if h2.point.truncate().length_squared() > r2 {
            return edge();
        }
        match refract(d1, h2.normal, index, 1.0) {
            Refraction::Transmitted(dir) => LensTrace::Exit {
                back,
                front: h2.point,
                dir,
            },
            Refraction::TotalInternalReflection => {
                LensTrace::TotalInternalReflection { back, at: h2.point }
            }
        }
    }

    /// The ray from `eye_point` through `vertex`, traced through the lens.
    /// Give back-surface vertices (the side the eye sees): the ray's first hit
    /// is then the vertex itself.
    ///
    /// Errors: a non-finite eye point or vertex, or a vertex at the eye
    /// point (no direction).
    pub fn trace_through_vertex(
        &self,
        eye_point: DVec3,
        vertex: DVec3,
    ) -> Result<LensTrace, InvalidInput> {
        let eye_point = input::finite_vec3("eye point (m)", eye_point)?;
        let vertex = input::finite_vec3("lens vertex (m)", vertex)?;
        let ray = Ray::new(eye_point, vertex - eye_point).map_err(|e| InvalidInput {
            what: "eye point to lens vertex (m)",
            ..e
        })?;
        Ok(self.trace_from_eye(&ray))
    }
}

/// Per-vertex refraction of a whole set of lens vertices (paper §3.1 step
/// (1)), in parallel: [`SpectacleLens::trace_through_vertex`] for each, in
/// order.
///
/// Errors: a bad eye point, or any vertex that
/// [`SpectacleLens::trace_through_vertex`] refuses; no partial result.
pub fn refract_vertices(
    lens: &SpectacleLens,
    eye_point: DVec3,
    vertices: &[DVec3],
) -> Result<Vec<LensTrace>, InvalidInput> {
    let eye_point = input::finite_vec3("eye point (m)", eye_point)?;
    vertices
        .par_iter()
        .map(|v| lens.trace_through_vertex(eye_point, *v))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::glass::Glass;
    use crate::spectacles::lens_design::{LensDesignParams, Prescription, design_lens};
    use proptest::prelude::*;

    fn lens(s: f64, params: LensDesignParams) -> SpectacleLens {
        design_lens(&Prescription::sphere(s).unwrap(), &params).unwrap()
    }

    /// Centre of rotation 13.5 mm behind the cornea (z = 0).
    const CR: DVec3 = DVec3::new(0.0, 0.0, -0.0135);

    #[test]
    fn per_vertex_axial_ray_is_undeviated() {
        let l = lens(-4.0, LensDesignParams::default());
        let t = l.trace_from_eye(&Ray::new(CR, DVec3::Z).unwrap());
        let LensTrace::Exit { back, front, dir } = t else {
            panic!("{t:?}")
        };
        assert!((back - DVec3::new(0.0, 0.0, 0.012)).length() < 1e-15);
        assert!((front.z - l.front().vertex_z()).abs() < 1e-15);
        assert!((dir - DVec3::Z).length() < 1e-15);
    }

    #[test]
    fn per_vertex_plano_lens_is_a_plate() {
        // A zero-power lens with flat surfaces is a plane-parallel plate: the
        // exit direction equals the entry direction, the ray is shifted.
        let p = LensDesignParams::default()
            .with_base_curve_d(Some(0.0))
            .unwrap();
        let l = lens(0.0, p);
        let d = DVec3::new(0.3, 0.1, 1.0).normalize();
        let LensTrace::Exit { dir, .. } = l.trace_from_eye(&Ray::new(CR, d).unwrap()) else {
            panic!()
        };
        assert!((dir - d).length() < 1e-14);
    }

    #[test]
    fn per_vertex_minus_lens_spreads_plus_lens_gathers() {
        // Prentice's rule direction: a minus lens deviates rays away from the
        // axis (base-out prism off-centre), a plus lens towards it.
        let d = DVec3::new(0.2, 0.0, 1.0).normalize();
        for (s, away) in [(-4.0, true), (4.0, false)] {
            let l = lens(s, LensDesignParams::default());
            let LensTrace::Exit { dir, .. } = l.trace_from_eye(&Ray::new(CR, d).unwrap()) else {
                panic!()
            };
            assert_eq!(dir.x / dir.z > d.x / d.z, away, "S {s}");
        }
    }

    #[test]
    fn per_vertex_tir_at_the_rim_of_a_thick_minus_lens() {
        // A −10 D lens of 50 mm blank at n = 1.66 (critical angle
        // asin(1/1.66) = 37.04°) totally reflects steep rays near the rim.
        // Sweep rays from the pupil (3 mm behind the cornea) and from the
        // centre of rotation, and check every outcome against Snell's law
        // independently of the trace's own refraction: inside the glass the
        // ray runs straight from its back-surface point to the front-surface
        // point, so its direction there is (at − back)/|at − back|, and with
        // the front surface's normal at that point the glass-side incidence
        // angle is acos(|d·n|). TIR must mean incidence beyond the critical
        // angle; an exit, incidence below it.
        let n = 1.66;
        let critical = (1.0f64 / n).asin();
        assert!((critical.to_degrees() - 37.04).abs() < 0.01);
        let l = lens(
            -10.0,
            LensDesignParams::default()
                .with_glass(Glass::Constant(n))
                .unwrap(),
        );
        // The front surface is the sphere of curvature c through the vertex
        // v: centre (0, 0, v + 1/c). c·(p − centre) = (c x, c y, c(z − v) − 1)
        // is its unit normal at p up to sign (no division; |·| = 1 exactly
        // on the sphere, which checks that `at` is on it).
        let c = l.front().curvature();
        assert!(c != 0.0);
        let incidence = |back: DVec3, at: DVec3| {
            let g = DVec3::new(c * at.x, c * at.y, c * (at.z - l.front().vertex_z()) - 1.0);
            assert!(
                (g.length() - 1.0).abs() < 1e-9,
                "{at} not on the front surface"
            );
            let d = (at - back).normalize();
            d.dot(g.normalize()).abs().min(1.0).acos()
        };
        let sweep = |from: DVec3| {
            let (mut tir, mut exits, mut edge) = (0, 0, None);
            for k in 0..=800 {
                let deg = k as f64 * 0.1;
                let a = deg.to_radians();
                match l.trace_from_eye(&Ray::new(from, DVec3::new(a.sin(), 0.0, a.cos())).unwrap())
                {
                    LensTrace::Exit { back, front, dir } => {
                        assert!(dir.is_finite() && front.is_finite());
                        let i = incidence(back, front);
                        assert!(
                            i < critical,
                            "{deg}°: exit at incidence {}° ≥ critical",
                            i.to_degrees()
                        );
                        exits += 1;
                    }
                    LensTrace::TotalInternalReflection { back, at } => {
                        assert!(at.is_finite());
                        let i = incidence(back, at);
                        assert!(
                            i > critical,
                            "{deg}°: TIR at incidence {}° ≤ critical",
                            i.to_degrees()
                        );
                        tir += 1;
                    }
                    LensTrace::EdgeExit { at, .. } => {
                        assert!(((at.truncate().length()) - 0.025).abs() < 1e-12);
                        edge.get_or_insert(deg);
                    }
                    LensTrace::Missed => {}
                }
            }
            (tir, exits, edge)
        };
        // From the pupil both outcomes occur (so both checks above ran), and
        // the rim comes after the TIR zone.
        let (tir, exits, edge) = sweep(DVec3::new(0.0, 0.0, -0.003));
        assert!(tir > 0 && exits > 0, "{tir} TIR, {exits} exits");
        assert!(edge.is_some());
        // From the centre of rotation: every exit and TIR checked the same way.
        let (tir_cr, exits_cr, edge_cr) = sweep(CR);
        assert!(
            exits_cr > 0 && edge_cr.is_some(),
            "{tir_cr} {exits_cr} {edge_cr:?}"
        );
    }

    #[test]
    fn per_vertex_edge_exit_and_miss() {
        // A ray aimed outside the blank misses; the rim-crossing root is on
        // the cylinder.
        let l = lens(-6.0, LensDesignParams::default());
        assert_eq!(
            l.trace_from_eye(&Ray::new(CR, DVec3::new(0.9, 0.0, 0.3)).unwrap()),
            LensTrace::Missed
        );
        assert!(Ray::new(CR, DVec3::new(f64::NAN, 0.0, 1.0)).is_err());
        // A bad eye point or vertex is an error naming it, never a silent miss.
        let v = DVec3::new(0.01, 0.0, 0.012);
        assert_eq!(
            l.trace_through_vertex(DVec3::NAN, v).unwrap_err().what,
            "eye point (m)"
        );
        assert_eq!(
            l.trace_through_vertex(CR, DVec3::new(0.0, f64::INFINITY, 0.0))
                .unwrap_err()
                .what,
            "lens vertex (m)"
        );
        let same = l.trace_through_vertex(v, v).unwrap_err();
        assert_eq!(
            (same.what, same.expected),
            (
                "eye point to lens vertex (m)",
                crate::input::Expected::Direction
            )
        );
        assert_eq!(
            refract_vertices(&l, CR, &[v, DVec3::NAN]).unwrap_err().what,
            "lens vertex (m)"
        );
        assert_eq!(
            refract_vertices(&l, DVec3::NAN, &[]).unwrap_err().what,
            "eye point (m)"
        );
        let both = refract_vertices(&l, CR, &[v, DVec3::new(0.05, 0.0, 0.012)]).unwrap();
        assert!(both[0].is_exit() && both[1] == LensTrace::Missed);
        let p = DVec3::new(0.02, 0.0, 0.01);
        let d = DVec3::new(0.6, 0.8, 0.1).normalize();
        let s = rim_crossing(p, d, 0.025).unwrap();
        assert!(((p + s * d).truncate().length() - 0.025).abs() < 1e-15);
        assert_eq!(rim_crossing(p, DVec3::Z, 0.025), None);
        // A steep ray just inside the rim of a thick-edged lens leaves through the edge.
        let thick = lens(-20.0, LensDesignParams::default());
        let hits: Vec<_> = (0..400)
            .map(|k| {
                let a = (k as f64 * 0.2).to_radians();
                thick.trace_from_eye(&Ray::new(CR, DVec3::new(a.sin(), 0.0, a.cos())).unwrap())
            })
            .collect();
        assert!(hits.iter().any(|t| matches!(t, LensTrace::EdgeExit { .. })));
    }

    proptest! {
        #[test]
        fn per_vertex_finite_in_finite_out(
            s in -12f64..8.0, x in -0.04f64..0.04, y in -0.04f64..0.04,
            ex in -0.005f64..0.005, ez in -0.03f64..0.0,
        ) {
            let l = lens(s, LensDesignParams::default());
            let t = l.trace_through_vertex(DVec3::new(ex, 0.0, ez), DVec3::new(x, y, 0.012)).unwrap();
            match t {
                LensTrace::Exit { back, front, dir } => {
                    prop_assert!(back.is_finite() && front.is_finite() && dir.is_finite());
                    // (dir.z may be <= 0: near the critical angle a strong minus
                    // lens bends the exit ray past 90° from the axis.)
                    prop_assert!((dir.length() - 1.0).abs() < 1e-12);
                    prop_assert!(front.truncate().length() <= l.rim_radius_m() + 1e-12);
                }
                LensTrace::TotalInternalReflection { back, at } | LensTrace::EdgeExit { back, at } => {
                    prop_assert!(back.is_finite() && at.is_finite());
                }
                LensTrace::Missed => {}
            }
        }
    }
}
