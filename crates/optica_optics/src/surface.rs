//! Spherical and flat refracting surfaces in curvature form, a generic sphere
//! intersection, refraction (Snell) and reflection.
//!
//! Conventions: the optical axis is +z. A [`SphericalSurface`] has its vertex on
//! the axis at `vertex_z` and curvature `c = 1/R` (`R > 0`: centre of curvature
//! on the +z side). A flat surface is `c = 0` — never `R = 1e38`, which
//! overflows in `f32` and loses all digits of the sag in `f64`.
//!
//! Relative to the vertex, `q = p - vertex_z·ẑ`, the surface is
//! `F(q) = c|q|² − 2 q_z = 0`; this form is smooth through `c = 0` (the plane
//! `q_z = 0`), and `∇F / 2 = c q − ẑ` is the unit normal on the surface,
//! pointing towards −z at the vertex for every sign of `c`.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::input::{self, Expected, InvalidInput};
use crate::ray::Ray;

/// Hits closer than this along the ray (in the ray's length unit) are treated
/// as "at the origin" and rejected, so a ray leaving a surface does not hit it
/// again through round-off.
pub const T_EPSILON: f64 = 1e-9;

/// A spherical (or, with `curvature == 0`, flat) surface centred on the z
/// axis: its vertex `z` and curvature `c = 1/R`, both finite (checked when
/// it is built).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawSurface")]
pub struct SphericalSurface {
    vertex_z: f64,
    curvature: f64,
}

/// A surface as serialised, checked by [`SphericalSurface::new`] on the way in.
#[derive(Deserialize)]
struct RawSurface {
    vertex_z: f64,
    curvature: f64,
}

impl TryFrom<RawSurface> for SphericalSurface {
    type Error = InvalidInput;

    fn try_from(raw: RawSurface) -> Result<Self, InvalidInput> {
        Self::new(raw.vertex_z, raw.curvature)
    }
}

/// A ray–surface hit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Hit {
    /// Distance along the ray (the ray's `dir` is unit).
    pub t: f64,
    /// The hit point.
    pub point: DVec3,
    /// Unit surface normal at the hit, oriented like [`SphericalSurface::normal_at`]
    /// (towards −z on the vertex cap), not towards the ray.
    pub normal: DVec3,
}

/// Both ray parameters where a line meets a sphere, `t_near <= t_far`.
/// Either may be negative (behind the ray origin).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SphereHits {
    /// The smaller root.
    pub t_near: f64,
    /// The larger root.
    pub t_far: f64,
}

impl SphereHits {
    /// The first root ahead of the origin (`t > eps`), if any.
    pub fn first_forward(&self, eps: f64) -> Option<f64> {
        if self.t_near > eps {
            Some(self.t_near)
        } else if self.t_far > eps {
            Some(self.t_far)
        } else {
            None
        }
    }
}

/// The result of [`refract`]: a transmitted unit direction, or total internal
/// reflection (never a zero vector standing for it).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Refraction {
    /// The unit direction of the refracted ray.
    Transmitted(DVec3),
    /// No transmitted ray exists: `n1 sin i > n2`.
    TotalInternalReflection,
}

impl Refraction {
    /// The transmitted direction, or `None` on total internal reflection.
    pub fn direction(self) -> Option<DVec3> {
        match self {
            Refraction::Transmitted(d) => Some(d),
            Refraction::TotalInternalReflection => None,
        }
    }
}

impl SphericalSurface {
    /// A surface with its vertex at `vertex_z` and curvature `c = 1/R`.
    ///
    /// Errors: a vertex or curvature that is not finite.
    pub fn new(vertex_z: f64, curvature: f64) -> Result<Self, InvalidInput> {
        let vertex_z = input::finite("surface vertex z", vertex_z)?;
        let curvature = input::finite("surface curvature (1/length)", curvature)?;
        Ok(Self {
            vertex_z,
            curvature,
        })
    }

    /// A surface from numbers the crate has already checked (a validated
    /// prescription or spectacle lens).
    pub(crate) fn from_checked(vertex_z: f64, curvature: f64) -> Self {
        debug_assert!(
            vertex_z.is_finite() && curvature.is_finite(),
            "surface z {vertex_z}, c {curvature}"
        );
        Self {
            vertex_z,
            curvature,
        }
    }

    /// A flat surface `z = vertex_z`. Errors: a vertex that is not finite.
    pub fn flat(vertex_z: f64) -> Result<Self, InvalidInput> {
        Self::new(vertex_z, 0.0)
    }

    /// A surface from a radius of curvature as printed in patents and lens
    /// files: `±∞` is flat. Errors: a zero or NaN radius, a vertex that is
    /// not finite.
    pub fn from_radius(vertex_z: f64, radius: f64) -> Result<Self, InvalidInput> {
        if radius.is_nan() || radius == 0.0 {
            return Err(InvalidInput::new(
                "radius of curvature",
                radius,
                Expected::NonZero,
            ));
        }
        // 1/±∞ = 0 exactly, so flat needs no special case.
        Self::new(vertex_z, 1.0 / radius)
    }

    /// z of the vertex (where the surface crosses the axis).
    pub fn vertex_z(&self) -> f64 {
        self.vertex_z
    }

    /// Curvature `c = 1/R`; `0` is flat.
    pub fn curvature(&self) -> f64 {
        self.curvature
    }

    /// The radius of curvature `1/c` (`±∞` when flat).
    pub fn radius(&self) -> f64 {
        if self.curvature == 0.0 {
            f64::INFINITY
        } else {
            1.0 / self.curvature
        }
    }

    /// True for a flat surface (`c == 0`).
    pub fn is_flat(&self) -> bool {
        self.curvature == 0.0
    }

    /// Sag `z − vertex_z` at distance `r` from the axis, in the stable form
    /// `c r² / (1 + √(1 − c² r²))` (no cancellation as `c → 0`); `None` beyond
    /// the sphere's equator (`|c r| > 1`).
    pub fn sag(&self, r: f64) -> Option<f64> {
        let c = self.curvature;
        let cr2 = c * c * r * r;
        if cr2.is_nan() || cr2 > 1.0 {
            return None;
        }
        Some(c * r * r / (1.0 + (1.0 - cr2).sqrt()))
    }

    /// Unit normal at a point `p` on the surface: `c (p − vertex) − ẑ`,
    /// which points towards −z at the vertex whatever the sign of `c`.
    ///
    /// Off the surface the vector is normalised anyway (it is the normal of
    /// the concentric sphere through `p`); a degenerate point falls back to −ẑ.
    pub fn normal_at(&self, p: DVec3) -> DVec3 {
        let q = p - DVec3::new(0.0, 0.0, self.vertex_z);
        let n = self.curvature * q - DVec3::Z;
        n.try_normalize().unwrap_or(DVec3::NEG_Z)
    }

    /// The forward hit of `ray` on the cap of the surface through the vertex.
    ///
    /// A sphere meets a line twice; the lens surface is only the half through
    /// the vertex. The root taken is the one where `∇F·d` has the sign opposite
    /// to `d_z` (for `c > 0` and a ray travelling +z: the entry point; for
    /// `c < 0`: the exit point; mirrored for rays travelling −z), which is the
    /// root nearer the vertex plane and the only one that stays finite as
    /// `c → 0`. It is computed without cancellation: of the two algebraic
    /// forms `(−b − σ√D)/a` and `k/(−b + σ√D)` the one whose terms add is used,
    /// and `D` is evaluated as `1 − c²·(distance from centre to line)²`.
    ///
    /// `None` when the ray misses the sphere, is parallel to a flat surface,
    /// when that hit is behind the origin (`t <= T_EPSILON`), when it lies on
    /// the far cap (beyond the equator), or when the ray or surface is not
    /// finite. `t` is in the unit of the ray's length (the ray's `dir` is
    /// expected unit; a non-unit `dir` is handled, `t` then scales with it).
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let c = self.curvature;
        if !c.is_finite() || !self.vertex_z.is_finite() || !ray.origin().is_finite() {
            return None;
        }
        let len = ray.dir().length();
        if !(len.is_finite() && len > 0.0) {
            return None;
        }
        let d = ray.dir() / len;
        let q = ray.origin() - DVec3::new(0.0, 0.0, self.vertex_z);
        // F(t) = a t² + 2 b t + k with unit d.
        let qd = q.dot(d);
        let b = c * qd - d.z;
        let k = c * q.length_squared() - 2.0 * q.z;
        // Stable discriminant: D = 1 − |c q⊥ − ẑ⊥|², ⊥ taken against d;
        // equals b² − c k but never subtracts two large numbers.
        let q_perp = q - qd * d;
        let z_perp = DVec3::Z - d.z * d;
        let disc = 1.0 - (c * q_perp - z_perp).length_squared();
        if disc.is_nan() || disc < 0.0 {
            return None;
        }
        let sq = disc.sqrt();
        let sigma = if d.z < 0.0 { -1.0 } else { 1.0 };
        let t_unit = if b * sigma > 0.0 {
            // −b and −σ√D share a sign: no cancellation in the numerator.
            // (Here c ≠ 0: with c = 0, b = −d_z has the sign opposite to σ.)
            (-b - sigma * sq) / c
        } else {
            let den = -b + sigma * sq;
            if den == 0.0 {
                return None;
            }
            k / den
        };
        if !t_unit.is_finite() || t_unit <= T_EPSILON * len {
            return None;
        }
        let t = t_unit / len;
        let point = ray.origin() + d * t_unit;
        // On the far cap the normal c q − ẑ points to +z: not this surface.
        if c * (point.z - self.vertex_z) > 1.0 {
            return None;
        }
        Some(Hit {
            t,
            point,
            normal: self.normal_at(point),
        })
    }
}

/// Both roots of `ray` against a sphere (`centre`, `radius`), `t_near <= t_far`,
/// or `None` when the line misses it (or the input is degenerate: zero or
/// non-finite radius or direction). Roots may be behind the origin; see
/// [`SphereHits::first_forward`].
///
/// Stable: the discriminant is `r² − |oc⊥|²` (distance of the line from the
/// centre, no cancellation for far origins, Haines et al., *Ray Tracing Gems*
/// ch. 7) and the roots are `q/a` and `c/q` with `q = −(b + sign(b)√(aD))`.
pub fn intersect_sphere(ray: &Ray, center: DVec3, radius: f64) -> Option<SphereHits> {
    if !radius.is_finite() || radius == 0.0 || !center.is_finite() || !ray.origin().is_finite() {
        return None;
    }
    let d = ray.dir();
    let a = d.length_squared();
    if !(a.is_finite() && a > 0.0) {
        return None;
    }
    let oc = ray.origin() - center;
    let b = oc.dot(d);
    let cterm = oc.length_squared() - radius * radius;
    let perp = oc - (b / a) * d;
    let disc = radius * radius - perp.length_squared();
    if disc.is_nan() || disc < 0.0 {
        return None;
    }
    let s = (a * disc).sqrt();
    let q = -(b + if b < 0.0 { -s } else { s });
    let (t0, t1) = if q == 0.0 {
        (0.0, 0.0)
    } else {
        (cterm / q, q / a)
    };
    if !t0.is_finite() || !t1.is_finite() {
        return None;
    }
    Some(SphereHits {
        t_near: t0.min(t1),
        t_far: t0.max(t1),
    })
}

/// Refract the unit direction `dir` through an interface with unit `normal`
/// (facing either way: it is flipped against `dir`), from index `n1` into `n2`.
///
/// Vector Snell: with `η = n1/n2` and `cos i = −n·d`,
/// `t = η d + (η cos i − √(1 − η²(1 − cos² i))) n`; total internal reflection
/// when the root's argument is negative.
///
/// Documented fallback: invalid input (non-positive or non-finite index, zero
/// or non-finite vector) returns `TotalInternalReflection` — no transmitted
/// ray is produced and no NaN escapes. Use [`try_refract`] to tell the cases apart.
pub fn refract(dir: DVec3, normal: DVec3, n1: f64, n2: f64) -> Refraction {
    try_refract(dir, normal, n1, n2).unwrap_or(Refraction::TotalInternalReflection)
}

/// [`refract`] with a typed error for invalid input.
pub fn try_refract(
    dir: DVec3,
    normal: DVec3,
    n1: f64,
    n2: f64,
) -> Result<Refraction, InvalidInput> {
    input::positive("refractive index", n1)?;
    input::positive("refractive index", n2)?;
    let d = input::direction("refracted direction", dir)?;
    let mut n = input::direction("surface normal", normal)?;
    let mut cos_i = -n.dot(d);
    if cos_i < 0.0 {
        n = -n;
        cos_i = -cos_i;
    }
    let cos_i = cos_i.min(1.0);
    let eta = n1 / n2;
    // cos² t = 1 − η² sin² i, in the form that does not cancel at grazing
    // incidence (see `fresnel::cos_sq_refracted`).
    let cos2_t = crate::fresnel::cos_sq_refracted(cos_i, n1, n2);
    if cos2_t < 0.0 {
        return Ok(Refraction::TotalInternalReflection);
    }
    let cos_t = cos2_t.sqrt();
    let t = eta * d + (eta * cos_i - cos_t) * n;
    // Exactly unit in exact arithmetic; renormalise away round-off.
    Ok(Refraction::Transmitted(t.normalize()))
}

/// Mirror the direction `dir` about a plane with normal `normal` (either
/// facing): `d − 2 (d·n) n`. A zero or non-finite normal returns `dir` unchanged.
pub fn reflect(dir: DVec3, normal: DVec3) -> DVec3 {
    match normal.try_normalize() {
        Some(n) => dir - 2.0 * dir.dot(n) * n,
        None => dir,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn surface_eq(s: &SphericalSurface, p: DVec3) -> f64 {
        let q = p - DVec3::new(0.0, 0.0, s.vertex_z);
        s.curvature * q.length_squared() - 2.0 * q.z
    }

    #[test]
    fn surface_hand_worked_convex_hit() {
        // R = 10 at z = 0, ray parallel to the axis at height 3 from z = −5.
        // Sag = 10 − √(100 − 9) = 0.460608 (also 0.9 / (1 + √0.91)), so
        // t = 5.460608 and the normal is (0, 3, 0.460608 − 10)/10.
        let s = SphericalSurface::from_radius(0.0, 10.0).unwrap();
        let h = s
            .intersect(&Ray::new(DVec3::new(0.0, 3.0, -5.0), DVec3::Z).unwrap())
            .unwrap();
        let sag = 10.0 - 91f64.sqrt();
        assert!((h.t - (5.0 + sag)).abs() < 1e-13);
        assert!((h.point.z - sag).abs() < 1e-13);
        let n = DVec3::new(0.0, 0.3, (sag - 10.0) / 10.0);
        assert!((h.normal - n).length() < 1e-13);
        assert!((s.sag(3.0).unwrap() - sag).abs() < 1e-15);
    }

    #[test]
    fn surface_concave_takes_vertex_cap_both_directions() {
        // R = −10 at z = 0: sphere spans z in [−20, 0]; the cap is z in [−10, 0].
        let s = SphericalSurface::new(0.0, -0.1).unwrap();
        let from_left = s
            .intersect(&Ray::new(DVec3::new(0.0, 3.0, -30.0), DVec3::Z).unwrap())
            .unwrap();
        let sag = -(10.0 - 91f64.sqrt());
        assert!((from_left.point.z - sag).abs() < 1e-12, "{from_left:?}");
        let from_right = s
            .intersect(&Ray::new(DVec3::new(0.0, 3.0, 5.0), DVec3::NEG_Z).unwrap())
            .unwrap();
        assert!((from_right.point.z - sag).abs() < 1e-12);
        // Convex surface hit from the right (a reflected flare ray).
        let s = SphericalSurface::new(0.0, 0.1).unwrap();
        let h = s
            .intersect(&Ray::new(DVec3::new(0.0, 3.0, 30.0), DVec3::NEG_Z).unwrap())
            .unwrap();
        assert!((h.point.z + sag).abs() < 1e-12);
        assert!(h.normal.z < 0.0);
    }

    #[test]
    fn surface_flat_and_misses() {
        let s = SphericalSurface::flat(2.0).unwrap();
        let h = s
            .intersect(&Ray::new(DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 0.6, 0.8)).unwrap())
            .unwrap();
        assert!((h.t - 2.5).abs() < 1e-15);
        assert_eq!(h.normal, DVec3::NEG_Z);
        // Parallel to the plane, behind the origin, and past the sphere.
        assert!(
            s.intersect(&Ray::new(DVec3::ZERO, DVec3::X).unwrap())
                .is_none()
        );
        assert!(
            s.intersect(&Ray::new(DVec3::new(0.0, 0.0, 3.0), DVec3::Z).unwrap())
                .is_none()
        );
        let s = SphericalSurface::new(0.0, 0.1).unwrap();
        assert!(
            s.intersect(&Ray::new(DVec3::new(0.0, 10.5, -5.0), DVec3::Z).unwrap())
                .is_none()
        );
        let e = SphericalSurface::new(0.0, f64::NAN).unwrap_err();
        assert_eq!(
            (e.what, e.expected),
            ("surface curvature (1/length)", Expected::Finite)
        );
        let e = SphericalSurface::from_radius(0.0, 0.0).unwrap_err();
        assert_eq!(
            (e.what, e.value, e.expected),
            ("radius of curvature", 0.0, Expected::NonZero)
        );
        assert_eq!(
            SphericalSurface::flat(f64::INFINITY).unwrap_err().what,
            "surface vertex z"
        );
        assert_eq!(
            SphericalSurface::from_radius(1.0, f64::NEG_INFINITY)
                .unwrap()
                .curvature,
            0.0
        );
    }

    #[test]
    fn surface_near_flat_is_continuous_and_cancellation_free() {
        // Origins 1e-8 before the vertex plane so that t carries the sag to
        // full relative precision; a naive (−b − √D)/a would cancel 1 − 1 and
        // be wrong by ~1e-16, far above the tolerances below.
        // c = 1e-12 (R = 1e12) at height 1: sag = c r²/(1 + √(1 − c²r²)) = 5e-13.
        let ray = Ray::new(DVec3::new(0.0, 1.0, -1e-8), DVec3::Z).unwrap();
        let h = SphericalSurface::new(0.0, 1e-12)
            .unwrap()
            .intersect(&ray)
            .unwrap();
        assert!((h.t - (1e-8 + 5e-13)).abs() < 1e-22, "{}", h.t);
        // The same ray on c = 0 differs by just the sag: continuous at c = 0.
        let h0 = SphericalSurface::flat(0.0)
            .unwrap()
            .intersect(&ray)
            .unwrap();
        assert!((h.t - h0.t - 5e-13).abs() < 1e-22);
        // Near-axis ray (height 1e-9) on c = 1: sag = 5e-19.
        let s = SphericalSurface::new(0.0, 1.0).unwrap();
        let h = s
            .intersect(&Ray::new(DVec3::new(1e-9, 0.0, -1e-8), DVec3::Z).unwrap())
            .unwrap();
        assert!((h.t - (1e-8 + 5e-19)).abs() < 1e-23, "{}", h.t);
        assert!((s.sag(1e-9).unwrap() - 5e-19).abs() < 1e-33);
    }

    #[test]
    fn surface_far_cap_is_rejected() {
        // Ray starting inside the sphere beyond its centre, travelling +z:
        // the vertex cap is behind it.
        let s = SphericalSurface::new(0.0, 0.1).unwrap();
        assert!(
            s.intersect(&Ray::new(DVec3::new(0.0, 0.0, 15.0), DVec3::Z).unwrap())
                .is_none()
        );
    }

    #[test]
    fn sphere_hand_worked_roots() {
        // Unit sphere at (0,0,5), ray from origin along +z: t = 4 and 6.
        let h = intersect_sphere(
            &Ray::new(DVec3::ZERO, DVec3::Z).unwrap(),
            DVec3::new(0.0, 0.0, 5.0),
            1.0,
        )
        .unwrap();
        assert!((h.t_near - 4.0).abs() < 1e-15 && (h.t_far - 6.0).abs() < 1e-15);
        assert_eq!(h.first_forward(T_EPSILON), Some(h.t_near));
        // Far origin (1e8) and small sphere: roots still accurate.
        let h = intersect_sphere(
            &Ray::new(DVec3::new(0.0, 0.5, -1e8), DVec3::Z).unwrap(),
            DVec3::ZERO,
            1.0,
        )
        .unwrap();
        let half = 0.75f64.sqrt();
        assert!((h.t_near - (1e8 - half)).abs() < 1e-7 && (h.t_far - (1e8 + half)).abs() < 1e-7);
        assert!(
            intersect_sphere(
                &Ray::new(DVec3::ZERO, DVec3::Z).unwrap(),
                DVec3::new(0.0, 2.0, 5.0),
                1.0
            )
            .is_none()
        );
        assert!(
            intersect_sphere(&Ray::new(DVec3::ZERO, DVec3::Z).unwrap(), DVec3::ZERO, 0.0).is_none()
        );
    }

    #[test]
    fn refract_hand_worked_and_tir() {
        // 45° from air into n = 1.5: sin t = sin45/1.5 = 0.471405.
        let d = DVec3::new(1.0, 0.0, 1.0).normalize();
        let t = refract(d, DVec3::NEG_Z, 1.0, 1.5).direction().unwrap();
        assert!((t.x - 0.5f64.sqrt() / 1.5).abs() < 1e-15);
        // Same with the normal facing the other way.
        assert_eq!(refract(d, DVec3::Z, 1.0, 1.5), Refraction::Transmitted(t));
        // Glass to air beyond the critical angle (41.8°): TIR, not a zero vector.
        assert_eq!(
            refract(d, DVec3::Z, 1.5, 1.0),
            Refraction::TotalInternalReflection
        );
        assert_eq!(
            try_refract(d, DVec3::Z, f64::NAN, 1.0).unwrap_err().what,
            "refractive index"
        );
        assert_eq!(
            try_refract(DVec3::ZERO, DVec3::Z, 1.0, 1.0)
                .unwrap_err()
                .what,
            "refracted direction"
        );
        assert_eq!(
            try_refract(d, DVec3::ZERO, 1.0, 1.5).unwrap_err().what,
            "surface normal"
        );
        assert_eq!(reflect(d, DVec3::Z), DVec3::new(d.x, 0.0, -d.z));
    }

    fn unit() -> impl Strategy<Value = DVec3> {
        prop::array::uniform3(-1.0f64..1.0)
            .prop_filter_map("non-zero", |a| DVec3::from(a).try_normalize())
    }

    proptest! {
        #[test]
        fn surface_hits_lie_on_surface_and_cap(
            c in prop_oneof![Just(0.0), -0.5f64..0.5, -1e-9f64..1e-9],
            vz in -10f64..10.0,
            o in prop::array::uniform3(-20f64..20.0),
            d in unit(),
        ) {
            let s = SphericalSurface::new(vz, c).unwrap();
            let ray = Ray::new(DVec3::from(o), d).unwrap();
            if let Some(h) = s.intersect(&ray) {
                prop_assert!(h.t.is_finite() && h.t > 0.0);
                prop_assert!(h.point.is_finite() && h.normal.is_finite());
                prop_assert!((h.point - ray.at(h.t)).length() < 1e-9);
                // F(p) = c|q|² − 2 q_z is 0 on the surface (scaled by |q|).
                let scale = 1.0 + (h.point - DVec3::new(0.0, 0.0, vz)).length();
                prop_assert!(surface_eq(&s, h.point).abs() < 1e-12 * scale * scale);
                prop_assert!((h.normal.length() - 1.0).abs() < 1e-12);
                prop_assert!(h.normal.z <= 1e-12, "normal on vertex cap faces -z: {:?}", h);
                // The generic sphere loses digits at huge radii; compare
                // only where it is itself accurate.
                if c.abs() > 1e-3 {
                    let centre = DVec3::new(0.0, 0.0, vz + 1.0 / c);
                    let both = intersect_sphere(&ray, centre, (1.0 / c).abs()).unwrap();
                    let dn = (h.t - both.t_near).abs().min((h.t - both.t_far).abs());
                    prop_assert!(dn < 1e-8 * (1.0 + h.t));
                }
            }
        }

        #[test]
        fn sphere_roots_lie_on_sphere(
            centre in prop::array::uniform3(-10f64..10.0),
            r in 0.01f64..10.0,
            o in prop::array::uniform3(-30f64..30.0),
            d in unit(),
        ) {
            let ray = Ray::new(DVec3::from(o), d).unwrap();
            let c = DVec3::from(centre);
            if let Some(h) = intersect_sphere(&ray, c, r) {
                prop_assert!(h.t_near <= h.t_far);
                for t in [h.t_near, h.t_far] {
                    prop_assert!(((ray.at(t) - c).length() - r).abs() < 1e-9 * (1.0 + r));
                }
            } else {
                // A miss means the line's distance from the centre exceeds r.
                let oc = ray.origin() - c;
                let dist = (oc - oc.dot(d) * d).length();
                prop_assert!(dist >= r * (1.0 - 1e-12));
            }
        }

        #[test]
        fn refract_snell_and_reversible(
            d in unit(),
            nrm in unit(),
            n1 in 1.0f64..2.0,
            n2 in 1.0f64..2.0,
        ) {
            match refract(d, nrm, n1, n2) {
                Refraction::Transmitted(t) => {
                    prop_assert!(t.is_finite() && (t.length() - 1.0).abs() < 1e-12);
                    // Snell: n1 sin i = n2 sin t.
                    let sin_i = d.cross(nrm).length();
                    let sin_t = t.cross(nrm).length();
                    prop_assert!((n1 * sin_i - n2 * sin_t).abs() < 1e-12);
                    // Coplanar with d and n, and on the far side.
                    prop_assert!(t.dot(d.cross(nrm)).abs() < 1e-12);
                    prop_assert!(t.dot(nrm) * d.dot(nrm) >= 0.0);
                    // Reversible: −t through the same interface returns −d,
                    // to 1e-12; at grazing incidence the reverse problem is
                    // ill-conditioned (cos i from cos t amplifies t's own
                    // rounding by ~1/cos i), so allow that much more there.
                    let cos_i = d.dot(nrm).abs();
                    match refract(-t, nrm, n2, n1) {
                        Refraction::Transmitted(back) =>
                            prop_assert!((back + d).length() < 1e-12 + 1e-15 / cos_i, "{:?} vs {:?}", back, -d),
                        Refraction::TotalInternalReflection => prop_assert!(false, "reverse TIR"),
                    }
                }
                Refraction::TotalInternalReflection => {
                    let sin_i = d.cross(nrm).length();
                    prop_assert!(n1 * sin_i > n2 * (1.0 - 1e-12));
                }
            }
            let r = reflect(d, nrm);
            prop_assert!((r.length() - 1.0).abs() < 1e-12);
            prop_assert!((r.dot(nrm) + d.dot(nrm)).abs() < 1e-12);
        }

        #[test]
        fn refract_finite_or_typed(
            d in prop::array::uniform3(-1e3f64..1e3),
            nrm in prop::array::uniform3(-1e3f64..1e3),
            n1 in -2f64..3.0,
            n2 in -2f64..3.0,
        ) {
            match try_refract(DVec3::from(d), DVec3::from(nrm), n1, n2) {
                Ok(Refraction::Transmitted(t)) => prop_assert!(t.is_finite()),
                Ok(Refraction::TotalInternalReflection) => {}
                Err(_) => prop_assert!(n1 <= 0.0 || n2 <= 0.0 || DVec3::from(d).length() == 0.0 || DVec3::from(nrm).length() == 0.0),
            }
        }
    }
}
