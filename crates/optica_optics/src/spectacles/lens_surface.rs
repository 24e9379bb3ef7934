//! The kinds of spectacle-lens surface: spherical, toric, and toric with
//! a progressive addition.

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use crate::input::{self, InvalidInput};
use crate::ray::Ray;
use crate::surface::{Hit, SphericalSurface, T_EPSILON};

/// A toric surface (for a cylinder in the prescription), vertex on the z
/// axis.
///
/// A toric surface has curvature `c_axis` in the meridian along the cylinder
/// axis (direction `ξ = (cos a, sin a)` in the x–y plane) and `c_cross` in the
/// meridian across it (`η`). It is the circle of curvature `c_cross` in the
/// η–z plane, swept round an axis parallel to η at `z = 1/c_axis` — the
/// surface a toric lap grinds. With `s(η) = c_cross η²/(1 + √(1 − c_cross² η²))`
/// (the circle's sag) and `u = 1 − c_axis s`, the sag is
///
/// ```text
/// z − z_v = (1 − √(u² − c_axis² ξ²)) / c_axis
///         = [s (2 − c_axis s) + c_axis ξ²] / (1 + √(u² − c_axis² ξ²))
/// ```
///
/// written in the second form so that it stays exact as `c_axis → 0` (a
/// cylinder) and for a flat surface. Equal curvatures give the sphere.
/// Conventions as [`SphericalSurface`]: +z optical axis, normal towards −z
/// at the vertex.
///
/// Built by [`ToricSurface::new`] from finite numbers; deserialisation runs
/// the same check.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawToricSurface")]
pub struct ToricSurface {
    vertex_z: f64,
    c_axis: f64,
    c_cross: f64,
    axis_rad: f64,
}

/// The serialised form of a [`ToricSurface`], unchecked.
#[derive(Deserialize)]
struct RawToricSurface {
    vertex_z: f64,
    c_axis: f64,
    c_cross: f64,
    axis_rad: f64,
}

impl TryFrom<RawToricSurface> for ToricSurface {
    type Error = InvalidInput;

    fn try_from(r: RawToricSurface) -> Result<Self, InvalidInput> {
        ToricSurface::new(r.vertex_z, r.c_axis, r.c_cross, r.axis_rad)
    }
}

/// Most Newton steps [`ToricSurface::intersect`] takes. From the mean
/// sphere's hit the iteration converges quadratically in 3–5 steps for any
/// spectacle lens; 50 leaves room for grazing rays before giving up.
const TORIC_NEWTON_MAX_STEPS: usize = 50;

/// Newton's iteration stops when a step is below this, relative to
/// `1 + |ray origin|` (m): a few ulps of the coordinates.
const TORIC_NEWTON_STEP_TOLERANCE: f64 = 1e-15;

/// A converged point is a hit only when its distance from the surface
/// (along z) is below this, relative to `1 + |ray origin|` (m): 1 pm on a
/// lens metres from the origin, far below any rendering scale, and well
/// above the round-off of the sag (~1e-16).
const TORIC_HIT_TOLERANCE: f64 = 1e-12;

/// Sag, its gradient, in local (ξ, η) coordinates; `None` off the surface.
fn toric_local(c_axis: f64, c_cross: f64, xi: f64, eta: f64) -> Option<(f64, DVec2)> {
    let q = 1.0 - c_cross * c_cross * eta * eta;
    if !(q >= 0.0) {
        return None;
    }
    let rq = q.sqrt();
    let s = c_cross * eta * eta / (1.0 + rq);
    let u = 1.0 - c_axis * s;
    let w2 = u * u - c_axis * c_axis * xi * xi;
    if !(u > 0.0 && w2 >= 0.0) {
        return None;
    }
    let w = w2.sqrt();
    let z = (s * (2.0 - c_axis * s) + c_axis * xi * xi) / (1.0 + w);
    if w == 0.0 || rq == 0.0 {
        // On the surface's equator the slope is infinite: no usable normal.
        return None;
    }
    let ds = c_cross * eta / rq;
    Some((z, DVec2::new(c_axis * xi / w, u * ds / w)))
}

impl ToricSurface {
    /// A torus with vertex at `z = vertex_z` (m), curvature `c_axis` (1/m)
    /// in the meridian along the axis, `c_cross` (1/m) across it, and the
    /// axis at `axis_rad` from +x towards +y.
    ///
    /// Errors: a non-finite number.
    pub fn new(
        vertex_z: f64,
        c_axis: f64,
        c_cross: f64,
        axis_rad: f64,
    ) -> Result<Self, InvalidInput> {
        Ok(Self {
            vertex_z: input::finite("toric vertex z (m)", vertex_z)?,
            c_axis: input::finite("toric curvature along the axis (1/m)", c_axis)?,
            c_cross: input::finite("toric curvature across the axis (1/m)", c_cross)?,
            axis_rad: input::finite("toric axis (rad)", axis_rad)?,
        })
    }

    /// z of the vertex (m).
    pub fn vertex_z(&self) -> f64 {
        self.vertex_z
    }

    /// Curvature (1/m) in the meridian along the axis.
    pub fn c_axis(&self) -> f64 {
        self.c_axis
    }

    /// Curvature (1/m) in the meridian perpendicular to the axis.
    pub fn c_cross(&self) -> f64 {
        self.c_cross
    }

    /// Axis angle (rad), from +x towards +y.
    pub fn axis_rad(&self) -> f64 {
        self.axis_rad
    }

    fn rotate_in(&self, x: f64, y: f64) -> (f64, f64) {
        let (s, c) = self.axis_rad.sin_cos();
        (x * c + y * s, -x * s + y * c)
    }

    /// Sag `z − vertex_z` and its gradient `(∂z/∂x, ∂z/∂y)` at `(x, y)`;
    /// `None` where the surface does not reach (beyond its equator).
    pub fn sag_and_gradient(&self, x: f64, y: f64) -> Option<(f64, DVec2)> {
        let (xi, eta) = self.rotate_in(x, y);
        let (z, g) = toric_local(self.c_axis, self.c_cross, xi, eta)?;
        let (s, c) = self.axis_rad.sin_cos();
        Some((z, DVec2::new(g.x * c - g.y * s, g.x * s + g.y * c)))
    }

    /// Unit normal at `(x, y)` on the surface, towards −z (`(∇z, −1)`
    /// normalised). Documented fallback: beyond the surface's equator, where
    /// it has no normal, `−ẑ` (as `SphericalSurface::normal_at` for a
    /// degenerate point); the meshes and traces of this module only ask for
    /// points on the surface.
    pub fn normal_at(&self, p: DVec3) -> DVec3 {
        match self.sag_and_gradient(p.x, p.y) {
            Some((_, g)) => DVec3::new(g.x, g.y, -1.0).normalize(),
            None => DVec3::NEG_Z,
        }
    }

    /// The forward hit of `ray`, by Newton's method on
    /// `f(t) = z(t) − z_v − sag(x(t), y(t))` from the hit on the sphere of
    /// mean curvature (a good start: the two differ by the astigmatic part of
    /// the sag only). `None` when the ray misses, the iteration leaves the
    /// surface or does not converge in 50 steps,
    /// or the hit is behind the origin (`t <= T_EPSILON`).
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mean =
            SphericalSurface::from_checked(self.vertex_z, 0.5 * (self.c_axis + self.c_cross));
        newton_hit(ray, self.vertex_z, &mean, |x, y| self.sag_and_gradient(x, y))
    }
}

/// The forward hit of `ray` on the surface `z = vertex_z + sag(x, y)`, by
/// Newton's method on `f(t) = z(t) − z_v − sag(x(t), y(t))` from the hit on
/// `start` (a sphere near the surface). `None` when the ray misses, the
/// iteration leaves the surface or does not converge in 50 steps, or the
/// hit is behind the origin (`t <= T_EPSILON`).
fn newton_hit(
    ray: &Ray,
    vertex_z: f64,
    start: &SphericalSurface,
    sag_and_gradient: impl Fn(f64, f64) -> Option<(f64, DVec2)>,
) -> Option<Hit> {
    let mut t = match start.intersect(ray) {
        Some(h) => h.t,
        None if ray.dir().z != 0.0 => (vertex_z - ray.origin().z) / ray.dir().z,
        None => return None,
    };
    if !t.is_finite() {
        return None;
    }
    let scale = 1.0 + ray.origin().length();
    for _ in 0..TORIC_NEWTON_MAX_STEPS {
        let p = ray.at(t);
        let (sag, g) = sag_and_gradient(p.x, p.y)?;
        let f = p.z - vertex_z - sag;
        let df = ray.dir().z - g.x * ray.dir().x - g.y * ray.dir().y;
        if df == 0.0 || !df.is_finite() {
            return None;
        }
        let step = f / df;
        t -= step;
        if !t.is_finite() {
            return None;
        }
        if step.abs() <= TORIC_NEWTON_STEP_TOLERANCE * scale {
            break;
        }
    }
    let point = ray.at(t);
    let (sag, g) = sag_and_gradient(point.x, point.y)?;
    if (point.z - vertex_z - sag).abs() > TORIC_HIT_TOLERANCE * scale || t <= T_EPSILON {
        return None;
    }
    Some(Hit {
        t,
        point,
        normal: DVec3::new(g.x, g.y, -1.0).normalize(),
    })
}

/// The width `w` (m) over which a [`ProgressiveAddition`]'s lateral terms
/// fade.
pub const PROGRESSIVE_LATERAL_WIDTH_M: f64 = 0.008;

/// A progressive addition: the sag a progressive surface adds to its
/// base, growing from nothing at the fitting point (`y = 0`, where the
/// wearer looks straight ahead) to a sphere of curvature `kappa` (1/m)
/// below `y = −length` (the near zone), along a vertical corridor.
///
/// Along the corridor's line `x = 0` the surface must be umbilic (equal
/// curvature in every direction, so the wearer sees sharply down it):
///
/// ```text
/// δz(x, y) = κ(y)·f(x) + Φ(y),    Φ'' = κ,   Φ(0) = Φ'(0) = 0
/// κ(y)     = kappa · s(t),         t = −y / length,  s = 6t⁵ − 15t⁴ + 10t³ on [0, 1]
/// f(x)     = ½ x² · exp(−x² / 2w²),  w = 8 mm
/// ```
///
/// so that `∂²δz/∂x² = ∂²δz/∂y² = κ(y)` and `∂²δz/∂x∂y = 0` at `x = 0`
/// (the quintic `s` is twice continuously differentiable, so the power
/// changes smoothly). Off the corridor the surface cannot stay umbilic
/// (Minkwitz's theorem): `∂²δz/∂x∂y = κ'·f'(x)`, an astigmatism growing
/// with the distance from the corridor at the rate the power changes
/// along it (twice that rate in dioptres per millimetre at first) — the
/// blurred zones either side of every progressive lens's corridor. The
/// lateral factor `exp(−x²/2w²)` (a width of our choosing, not a
/// commercial design) bounds it: far from the corridor the surface is
/// `Φ(y)` alone, a cylinder of the local addition. The near zone's inset
/// towards the nose is left out (the corridor is vertical).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ProgressiveAddition {
    kappa: f64,
    length_m: f64,
}

impl ProgressiveAddition {
    /// An addition of curvature `kappa` (1/m) reached `length_m` below
    /// the fitting point. Errors: a non-finite curvature, a length that is
    /// not finite and positive.
    pub fn new(kappa: f64, length_m: f64) -> Result<Self, InvalidInput> {
        Ok(Self {
            kappa: input::finite("progressive addition curvature (1/m)", kappa)?,
            length_m: input::positive("progressive corridor length (m)", length_m)?,
        })
    }

    /// The near zone's added curvature (1/m).
    pub fn kappa(&self) -> f64 {
        self.kappa
    }

    /// The corridor's length (m).
    pub fn length_m(&self) -> f64 {
        self.length_m
    }

    /// The same addition with its curvature's sign changed (the surface
    /// seen from its other side).
    pub fn mirrored(&self) -> Self {
        Self {
            kappa: -self.kappa,
            ..*self
        }
    }

    /// `δz` and its gradient at `(x, y)`.
    pub fn sag_and_gradient(&self, x: f64, y: f64) -> (f64, DVec2) {
        let (k, l) = (self.kappa, self.length_m);
        let t = -y / l;
        // κ/kappa, dκ/dt / kappa, and Φ, dΦ/dt over kappa·l².
        let (s, ds, phi, dphi) = if t <= 0.0 {
            (0.0, 0.0, 0.0, 0.0)
        } else if t < 1.0 {
            let (t3, t4, t5) = (t * t * t, t * t * t * t, t * t * t * t * t);
            (
                6.0 * t5 - 15.0 * t4 + 10.0 * t3,
                30.0 * t4 - 60.0 * t3 + 30.0 * t * t,
                t5 * t * t / 7.0 - 0.5 * t5 * t + 0.5 * t5,
                t5 * t - 3.0 * t5 + 2.5 * t4,
            )
        } else {
            let u = t - 1.0;
            (1.0, 0.0, 1.0 / 7.0 + 0.5 * u + 0.5 * u * u, 0.5 + u)
        };
        let kappa_y = k * s;
        // d/dy = −(1/l) d/dt.
        let dkappa_dy = -k * ds / l;
        let phi_y = k * l * l * phi;
        let dphi_dy = -k * l * dphi;
        let w2 = PROGRESSIVE_LATERAL_WIDTH_M * PROGRESSIVE_LATERAL_WIDTH_M;
        let taper = (-0.5 * x * x / w2).exp();
        let f = 0.5 * x * x * taper;
        let df = x * taper * (1.0 - 0.5 * x * x / w2);
        (
            kappa_y * f + phi_y,
            DVec2::new(kappa_y * df, dkappa_dy * f + dphi_dy),
        )
    }
}

/// A toric (or spherical) surface with a progressive addition: the back
/// surface of a progressive-addition lens.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ProgressiveSurface {
    base: ToricSurface,
    addition: ProgressiveAddition,
}

impl ProgressiveSurface {
    /// `base` with `addition` on it.
    pub fn new(base: ToricSurface, addition: ProgressiveAddition) -> Self {
        Self { base, addition }
    }

    /// The surface without its addition.
    pub fn base(&self) -> &ToricSurface {
        &self.base
    }

    /// The addition.
    pub fn addition(&self) -> &ProgressiveAddition {
        &self.addition
    }

    /// Sag and gradient: the base's plus the addition's.
    pub fn sag_and_gradient(&self, x: f64, y: f64) -> Option<(f64, DVec2)> {
        let (z, g) = self.base.sag_and_gradient(x, y)?;
        let (dz, dg) = self.addition.sag_and_gradient(x, y);
        Some((z + dz, g + dg))
    }

    /// The forward hit of `ray`, by Newton's method from the base's mean
    /// sphere with half the addition (the addition is at most a few
    /// hundred micrometres of sag across a spectacle lens).
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let b = &self.base;
        let mean = SphericalSurface::from_checked(
            b.vertex_z,
            0.5 * (b.c_axis + b.c_cross) + 0.5 * self.addition.kappa,
        );
        newton_hit(ray, b.vertex_z, &mean, |x, y| self.sag_and_gradient(x, y))
    }
}

/// A spectacle-lens surface: spherical, toric, or progressive.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum LensSurface {
    /// A sphere (or plane) in curvature form.
    Spherical(SphericalSurface),
    /// A torus for an astigmatic correction.
    Toric(ToricSurface),
    /// A torus (or sphere) with a progressive addition.
    Progressive(ProgressiveSurface),
}

impl LensSurface {
    /// z of the vertex.
    pub fn vertex_z(&self) -> f64 {
        match self {
            LensSurface::Spherical(s) => s.vertex_z(),
            LensSurface::Toric(t) => t.vertex_z,
            LensSurface::Progressive(p) => p.base.vertex_z,
        }
    }

    /// Sag `z − vertex_z` at `(x, y)`, `None` beyond the surface's equator.
    pub fn sag(&self, x: f64, y: f64) -> Option<f64> {
        match self {
            LensSurface::Spherical(s) => {
                let r = (x * x + y * y).sqrt();
                // Exactly at the equator the normal is undefined: treat as off.
                if (s.curvature() * r).abs() >= 1.0 {
                    return None;
                }
                s.sag(r)
            }
            LensSurface::Toric(t) => t.sag_and_gradient(x, y).map(|(z, _)| z),
            LensSurface::Progressive(p) => p.sag_and_gradient(x, y).map(|(z, _)| z),
        }
    }

    /// The point of the surface above `(x, y)`.
    pub fn point(&self, x: f64, y: f64) -> Option<DVec3> {
        self.sag(x, y)
            .map(|s| DVec3::new(x, y, self.vertex_z() + s))
    }

    /// Unit normal at a surface point, towards −z (fallbacks as
    /// [`ToricSurface::normal_at`] and `SphericalSurface::normal_at`).
    pub fn normal_at(&self, p: DVec3) -> DVec3 {
        match self {
            LensSurface::Spherical(s) => s.normal_at(p),
            LensSurface::Toric(t) => t.normal_at(p),
            LensSurface::Progressive(s) => match s.sag_and_gradient(p.x, p.y) {
                Some((_, g)) => DVec3::new(g.x, g.y, -1.0).normalize(),
                None => DVec3::NEG_Z,
            },
        }
    }

    /// The forward hit of `ray` on the surface.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        match self {
            LensSurface::Spherical(s) => s.intersect(ray),
            LensSurface::Toric(t) => t.intersect(ray),
            LensSurface::Progressive(p) => p.intersect(ray),
        }
    }

    /// Largest and smallest curvature (1/m) over the meridians.
    pub fn curvature_range(&self) -> (f64, f64) {
        match self {
            LensSurface::Spherical(s) => (s.curvature(), s.curvature()),
            LensSurface::Toric(t) => (t.c_axis.min(t.c_cross), t.c_axis.max(t.c_cross)),
            LensSurface::Progressive(p) => {
                let (b, k) = (&p.base, p.addition.kappa);
                let (lo, hi) = (b.c_axis.min(b.c_cross), b.c_axis.max(b.c_cross));
                (lo.min(lo + k), hi.max(hi + k))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn toric_equal_curvatures_is_the_sphere() {
        // A torus whose two radii are equal is the sphere: same sag, normal
        // and hit as surface.rs.
        let c = -1.0 / 0.06;
        let t = ToricSurface::new(0.012, c, c, 0.7).unwrap();
        let s = SphericalSurface::new(0.012, c).unwrap();
        for (x, y) in [
            (0.0f64, 0.0f64),
            (0.01, 0.0),
            (0.007, -0.013),
            (0.02, 0.015),
        ] {
            let r = (x * x + y * y).sqrt();
            let (z, _) = t.sag_and_gradient(x, y).unwrap();
            assert!((z - s.sag(r).unwrap()).abs() < 1e-16, "{x} {y}");
            let p = DVec3::new(x, y, 0.012 + z);
            assert!((t.normal_at(p) - s.normal_at(p)).length() < 1e-12);
        }
        let ray = Ray::new(DVec3::new(0.0, 0.0, -0.0135), DVec3::new(0.3, -0.2, 1.0)).unwrap();
        let (ht, hs) = (t.intersect(&ray).unwrap(), s.intersect(&ray).unwrap());
        assert!((ht.point - hs.point).length() < 1e-14 && (ht.t - hs.t).abs() < 1e-14);
    }

    #[test]
    fn toric_principal_sections_are_circles() {
        // Along the axis meridian the section is the circle of c_axis; across
        // it the circle of c_cross (hand: sag of R = 0.1 at 0.02 is
        // 0.1 − √(0.01 − 0.0004) = 0.00202062).
        let a = 30f64.to_radians();
        let t = ToricSurface::new(0.0, 10.0, -1.0 / 0.05, a).unwrap();
        let along = DVec2::new(a.cos(), a.sin()) * 0.02;
        let across = DVec2::new(-a.sin(), a.cos()) * 0.02;
        let (z1, _) = t.sag_and_gradient(along.x, along.y).unwrap();
        assert!((z1 - (0.1 - (0.01f64 - 0.0004).sqrt())).abs() < 1e-15);
        let (z2, _) = t.sag_and_gradient(across.x, across.y).unwrap();
        assert!((z2 + (0.05 - (0.0025f64 - 0.0004).sqrt())).abs() < 1e-15);
        // A cylinder (c_axis = 0): no sag along the axis.
        let cyl = ToricSurface::new(0.0, 0.0, t.c_cross(), a).unwrap();
        assert!(cyl.sag_and_gradient(along.x, along.y).unwrap().0.abs() < 1e-20);
    }

    #[test]
    fn toric_new_refuses_non_finite() {
        let e = ToricSurface::new(0.0, f64::NAN, 1.0, 0.0).unwrap_err();
        assert_eq!(
            (e.what, e.expected),
            (
                "toric curvature along the axis (1/m)",
                crate::input::Expected::Finite
            )
        );
        assert_eq!(
            ToricSurface::new(0.0, 1.0, 1.0, f64::INFINITY)
                .unwrap_err()
                .what,
            "toric axis (rad)"
        );
        let t = ToricSurface::new(0.012, -20.0, -25.0, 0.3).unwrap();
        let v = serde_json::to_value(t).unwrap();
        assert_eq!(serde_json::from_value::<ToricSurface>(v).unwrap(), t);
    }

    proptest! {
        #[test]
        fn toric_hits_lie_on_surface(
            ca in -30f64..30.0, cc in -30f64..30.0, a in 0f64..3.2,
            ox in -0.01f64..0.01, oy in -0.01f64..0.01,
            dx in -0.8f64..0.8, dy in -0.8f64..0.8,
        ) {
            let t = ToricSurface::new(0.012, ca, cc, a).unwrap();
            let ray = Ray::new(DVec3::new(ox, oy, -0.01), DVec3::new(dx, dy, 1.0)).unwrap();
            if let Some(h) = t.intersect(&ray) {
                prop_assert!(h.point.is_finite() && h.t > 0.0);
                let (z, g) = t.sag_and_gradient(h.point.x, h.point.y).unwrap();
                prop_assert!((h.point.z - 0.012 - z).abs() < 1e-12);
                prop_assert!((h.normal.length() - 1.0).abs() < 1e-12 && h.normal.z < 0.0);
                // Normal ⟂ the surface: compare with a finite-difference gradient.
                let e = 1e-7;
                let zx = t.sag_and_gradient(h.point.x + e, h.point.y).map(|v| v.0);
                let zx0 = t.sag_and_gradient(h.point.x - e, h.point.y).map(|v| v.0);
                if let (Some(a1), Some(a0)) = (zx, zx0) {
                    prop_assert!(((a1 - a0) / (2.0 * e) - g.x).abs() < 1e-5 * (1.0 + g.x.abs()));
                }
            }
        }
    }
}
