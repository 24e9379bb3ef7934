//! A spectacle lens from a prescription: Vogel's base curve, the thick-lens
//! back surface, a centre thickness that keeps a minimum edge, and the lens
//! placed in the eye's frame.
//!
//! Design, in the optician's frame (light from the object, +z′ towards the
//! eye; front vertex at z′ = 0, back vertex at z′ = t; powers in dioptres,
//! lengths in metres, `n` the index at the d line):
//!
//! ```text
//! M  = S + C/2                                 spherical equivalent
//! F1 = M + 6  (M >= 0),   M/2 + 6  (M < 0)     Vogel's base curve
//! c1 = F1 / (n − 1)                            front curvature
//! F2(θ) = Fv(θ) − F1 / (1 − t·F1/n)            back surface, per principal meridian
//! Fv(θ) = S + C·sin²(θ − axis)                 θ = axis → S, θ = axis + 90° → S + C
//! c2(θ) = F2(θ) / (1 − n)                      back curvature (toric when C ≠ 0)
//! t  = max(t_min, e_min − min_φ(sag2(r, φ) − sag1(r)))     r = blank radius
//! ```
//!
//! (`t` enters `F2` through the thick-lens term, so it is found by fixed-point
//! iteration; it converges in a few steps because the term is small.)
//!
//! In the eye's frame (the one every other module uses: +z from the eye into
//! the scene, cornea at z = 0) the lens is the optician's frame mirrored,
//! `z = d + t − z′` with `d` the vertex distance: the back vertex is at
//! `z = d`, the front vertex at `z = d + t`, and every curvature changes sign.

use std::f64::consts::PI;

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::error::{LensSide, SpectaclesError};
use super::lens_surface::{LensSurface, ToricSurface};
use crate::glass::Glass;
use crate::ray::Ray;
use crate::surface::{SphericalSurface, refract};

/// Largest |power| (D) in any meridian that [`design_lens`] accepts. Real
/// spectacle lenses stop around ±20 D; beyond that lenticular designs are used.
pub const MAX_LENS_POWER_D: f64 = 20.0;

/// A spectacle prescription: sphere, cylinder and axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Prescription {
    /// Sphere `S` (D): the back-vertex power in the axis meridian.
    pub sphere_d: f64,
    /// Cylinder `C` (D), either sign; 0 for a spherical lens.
    pub cylinder_d: f64,
    /// Cylinder axis in degrees, in the lens's x–y plane from +x towards +y.
    pub axis_deg: f64,
}

impl Prescription {
    /// A checked prescription. Errors: non-finite numbers, or a meridian
    /// power beyond ±[`MAX_LENS_POWER_D`].
    pub fn new(sphere_d: f64, cylinder_d: f64, axis_deg: f64) -> Result<Self, SpectaclesError> {
        for (v, name) in [(sphere_d, "sphere"), (cylinder_d, "cylinder"), (axis_deg, "axis")] {
            if !v.is_finite() {
                return Err(SpectaclesError::NonFinite(name));
            }
        }
        for (p, what) in [(sphere_d, "sphere (D)"), (sphere_d + cylinder_d, "sphere + cylinder (D)")] {
            if p.abs() > MAX_LENS_POWER_D {
                return Err(SpectaclesError::OutOfRange { what, value: p, min: -MAX_LENS_POWER_D, max: MAX_LENS_POWER_D });
            }
        }
        Ok(Self { sphere_d, cylinder_d, axis_deg })
    }

    /// A spherical prescription.
    pub fn sphere(sphere_d: f64) -> Result<Self, SpectaclesError> {
        Self::new(sphere_d, 0.0, 0.0)
    }

    /// Power in meridian `θ` (degrees): `S + C·sin²(θ − axis)`.
    pub fn meridian_power_d(&self, theta_deg: f64) -> f64 {
        let s = (theta_deg - self.axis_deg).to_radians().sin();
        self.sphere_d + self.cylinder_d * s * s
    }

    /// Spherical equivalent `S + C/2`.
    pub fn spherical_equivalent_d(&self) -> f64 {
        self.sphere_d + 0.5 * self.cylinder_d
    }
}

/// Vogel's rule for the front (base) curve: `F + 6` for plus, `F/2 + 6` for
/// minus powers `F` (D).
pub fn vogel_base_curve_d(power_d: f64) -> f64 {
    if power_d >= 0.0 { power_d + 6.0 } else { 0.5 * power_d + 6.0 }
}

/// The lens maker's choices besides the prescription.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LensDesignParams {
    /// Lens material; its index at the d line is used.
    pub material: Glass,
    /// Cornea to back vertex (m); 0.012–0.014 is usual.
    pub vertex_distance_m: f64,
    /// Diameter of the round blank (m).
    pub blank_diameter_m: f64,
    /// Thinnest centre allowed (m); minus lenses get exactly this.
    pub min_centre_thickness_m: f64,
    /// Thinnest edge allowed (m); sets the centre of plus lenses.
    pub min_edge_thickness_m: f64,
    /// Front surface power (D); `None` for Vogel's rule on the spherical equivalent.
    pub base_curve_d: Option<f64>,
}

impl Default for LensDesignParams {
    /// CR-39, 12 mm vertex distance, 50 mm blank, 2 mm centre, 1 mm edge, Vogel.
    fn default() -> Self {
        Self {
            material: Glass::Abbe { nd: 1.498, vd: 58.0 },
            vertex_distance_m: 0.012,
            blank_diameter_m: 0.050,
            min_centre_thickness_m: 0.002,
            min_edge_thickness_m: 0.001,
            base_curve_d: None,
        }
    }
}

impl LensDesignParams {
    /// The defaults with a catalog material (`glass.rs` names: "CR-39",
    /// "polycarbonate", "1.67", …).
    pub fn with_material(name: &str) -> Result<Self, SpectaclesError> {
        let material = Glass::catalog(name).ok_or_else(|| SpectaclesError::UnknownMaterial(name.to_string()))?;
        Ok(Self { material, ..Self::default() })
    }

    /// The paper's lens material: n = 1.66 (Fig. 8), without dispersion.
    pub fn paper() -> Self {
        Self { material: Glass::Constant(1.66), ..Self::default() }
    }
}

/// A designed lens placed in the eye's frame.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpectacleLens {
    /// The prescription it was made for.
    pub prescription: Prescription,
    /// The design choices.
    pub params: LensDesignParams,
    /// Refractive index used (material at the d line).
    pub index: f64,
    /// Object-side surface, vertex at `z = d + t`.
    pub front: SphericalSurface,
    /// Eye-side surface, vertex at `z = d`.
    pub back: LensSurface,
    /// Radius of the blank (m).
    pub rim_radius_m: f64,
    /// Centre thickness `t` (m).
    pub centre_thickness_m: f64,
    /// Front surface power `F1` (D).
    pub front_power_d: f64,
    /// Back surface power `F2` (D) in the axis meridian and across it.
    pub back_power_d: [f64; 2],
}

fn sphere_sag(c: f64, r: f64) -> Option<f64> {
    let q = 1.0 - c * c * r * r;
    (q > 0.0).then(|| c * r * r / (1.0 + q.sqrt()))
}

fn check_positive(v: f64, what: &'static str) -> Result<(), SpectaclesError> {
    if !v.is_finite() {
        return Err(SpectaclesError::NonFinite(what));
    }
    if !(v > 0.0) {
        return Err(SpectaclesError::OutOfRange { what, value: v, min: f64::MIN_POSITIVE, max: f64::INFINITY });
    }
    Ok(())
}

/// Rim samples for the edge thickness of a toric back surface.
const RIM_SAMPLES: usize = 180;

/// Designs the lens for `rx` (see the module docs for the equations).
///
/// Errors: a bad prescription or parameter (typed), an unknown index,
/// [`SpectaclesError::SurfaceTooSteep`] when a surface's radius is smaller
/// than the blank radius (e.g. +20 D in CR-39 on a 50 mm blank: F1 = 26 D,
/// R1 = 19.2 mm < 25 mm), [`SpectaclesError::ThickLensPole`],
/// [`SpectaclesError::SurfacesCross`].
pub fn design_lens(rx: &Prescription, params: &LensDesignParams) -> Result<SpectacleLens, SpectaclesError> {
    let rx = Prescription::new(rx.sphere_d, rx.cylinder_d, rx.axis_deg)?;
    if !params.vertex_distance_m.is_finite() {
        return Err(SpectaclesError::NonFinite("vertex distance"));
    }
    if params.vertex_distance_m < 0.0 {
        return Err(SpectaclesError::OutOfRange { what: "vertex distance (m)", value: params.vertex_distance_m, min: 0.0, max: f64::INFINITY });
    }
    check_positive(params.blank_diameter_m, "blank diameter (m)")?;
    check_positive(params.min_centre_thickness_m, "minimum centre thickness (m)")?;
    if !params.min_edge_thickness_m.is_finite() {
        return Err(SpectaclesError::NonFinite("minimum edge thickness"));
    }
    let n = params.material.nd();
    if !(n.is_finite() && n > 1.0) {
        return Err(SpectaclesError::OutOfRange { what: "lens index n_d", value: n, min: 1.0, max: f64::INFINITY });
    }
    let f1 = params.base_curve_d.unwrap_or_else(|| vogel_base_curve_d(rx.spherical_equivalent_d()));
    if !f1.is_finite() {
        return Err(SpectaclesError::NonFinite("base curve"));
    }
    let r = 0.5 * params.blank_diameter_m;
    let c1 = f1 / (n - 1.0);
    let sag1 = sphere_sag(c1, r).ok_or(SpectaclesError::SurfaceTooSteep { side: LensSide::Front, radius_m: 1.0 / c1.abs(), blank_radius_m: r })?;
    let axis = rx.axis_deg.to_radians();
    let fv = [rx.sphere_d, rx.sphere_d + rx.cylinder_d];

    // Back curvatures for thickness t (optician's frame).
    let back_for = |t: f64| -> Result<([f64; 2], [f64; 2]), SpectaclesError> {
        let fac = 1.0 - t * f1 / n;
        if !(fac > 0.0) {
            return Err(SpectaclesError::ThickLensPole { thickness_m: t, front_power_d: f1 });
        }
        let f2 = [fv[0] - f1 / fac, fv[1] - f1 / fac];
        let c2 = [f2[0] / (1.0 - n), f2[1] / (1.0 - n)];
        let cmax = c2[0].abs().max(c2[1].abs());
        if !(cmax * r < 1.0) {
            return Err(SpectaclesError::SurfaceTooSteep { side: LensSide::Back, radius_m: 1.0 / cmax, blank_radius_m: r });
        }
        Ok((f2, c2))
    };
    // min over the rim of sag2 − sag1 (optician's frame).
    let min_rim_gap = |c2: [f64; 2]| -> Result<f64, SpectaclesError> {
        let torus = ToricSurface { vertex_z: 0.0, c_axis: c2[0], c_cross: c2[1], axis_rad: axis };
        let mut m = f64::INFINITY;
        for k in 0..RIM_SAMPLES {
            let phi = 2.0 * PI * k as f64 / RIM_SAMPLES as f64;
            let (s2, _) = torus
                .sag_and_gradient(r * phi.cos(), r * phi.sin())
                .ok_or(SpectaclesError::SurfaceTooSteep { side: LensSide::Back, radius_m: 1.0 / c2[0].abs().max(c2[1].abs()), blank_radius_m: r })?;
            m = m.min(s2 - sag1);
        }
        Ok(m)
    };
    let mut t = params.min_centre_thickness_m;
    let mut converged = false;
    for _ in 0..100 {
        let (_, c2) = back_for(t)?;
        let t_new = params.min_centre_thickness_m.max(params.min_edge_thickness_m - min_rim_gap(c2)?);
        if !t_new.is_finite() {
            return Err(SpectaclesError::Degenerate("centre thickness iteration diverged"));
        }
        let done = (t_new - t).abs() <= 1e-13;
        t = t_new;
        if done {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(SpectaclesError::Degenerate("centre thickness iteration did not converge"));
    }
    let (f2, c2) = back_for(t)?;
    let edge = t + min_rim_gap(c2)?;
    if !(edge > 0.0) {
        return Err(SpectaclesError::SurfacesCross { thickness_m: edge, where_: "edge" });
    }
    let d = params.vertex_distance_m;
    // Mirror into the eye's frame: curvatures change sign.
    let front = SphericalSurface::new(d + t, -c1);
    let back = if rx.cylinder_d == 0.0 {
        LensSurface::Spherical(SphericalSurface::new(d, -c2[0]))
    } else {
        LensSurface::Toric(ToricSurface { vertex_z: d, c_axis: -c2[0], c_cross: -c2[1], axis_rad: axis })
    };
    Ok(SpectacleLens {
        prescription: rx,
        params: *params,
        index: n,
        front,
        back,
        rim_radius_m: r,
        centre_thickness_m: t,
        front_power_d: f1,
        back_power_d: f2,
    })
}

impl SpectacleLens {
    /// Vertex distance `d` (m): z of the back vertex in the eye's frame.
    pub fn vertex_distance_m(&self) -> f64 {
        self.back.vertex_z()
    }

    /// Edge thickness (m) at rim angle `phi` (rad).
    pub fn edge_thickness_m(&self, phi: f64) -> Option<f64> {
        let (x, y) = (self.rim_radius_m * phi.cos(), self.rim_radius_m * phi.sin());
        let zf = self.front.vertex_z + self.front.sag(self.rim_radius_m)?;
        let zb = self.back.vertex_z() + self.back.sag(x, y)?;
        Some(zf - zb)
    }

    /// Back-vertex power (D) in meridian `theta_deg`, measured by tracing a
    /// real ray at 0.1 mm height in that meridian from the object side,
    /// parallel to the axis, through both surfaces (`surface.rs` refraction):
    /// `Fv = −u′/h′` with `u′` the exit slope and `h′` the exit height, both
    /// taken along the meridian, `h′` transferred to the back-vertex plane.
    /// (An independent check of [`design_lens`]'s algebra: it uses only the
    /// placed surfaces.)
    pub fn measured_back_vertex_power_d(&self, theta_deg: f64) -> Result<f64, SpectaclesError> {
        if !theta_deg.is_finite() {
            return Err(SpectaclesError::NonFinite("meridian"));
        }
        let h = 1e-4;
        let m = DVec2::from_angle(theta_deg.to_radians());
        let start = DVec3::new(h * m.x, h * m.y, self.front.vertex_z + 0.1);
        let ray = Ray::from_unit(start, DVec3::NEG_Z);
        let fail = SpectaclesError::Degenerate("paraxial ray missed the lens");
        let h1 = self.front.intersect(&ray).ok_or(fail.clone())?;
        let d1 = refract(ray.dir(), h1.normal, 1.0, self.index).direction().ok_or(fail.clone())?;
        let h2 = self.back.intersect(&Ray::from_unit(h1.point, d1)).ok_or(fail.clone())?;
        let d2 = refract(d1, h2.normal, self.index, 1.0).direction().ok_or(fail)?;
        // Optician's frame: z′ = −z, so the slope is (dx/dz′) = d_xy / (−d_z).
        let slope = d2.truncate() / (-d2.z);
        let delta = self.vertex_distance_m() - h2.point.z; // z′_E − z′_vertex
        let hv = h2.point.truncate() - slope * delta;
        Ok(-slope.dot(m) / hv.dot(m))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn lens_design_back_vertex_power_by_trace() {
        // The brief's oracle: the traced back-vertex power equals S within
        // 0.01 D for ±2, ±6, ±10 D, in CR-39 and in the paper's n = 1.66.
        for params in [LensDesignParams::default(), LensDesignParams::paper()] {
            for s in [-10.0, -6.0, -2.0, 2.0, 6.0, 10.0] {
                let lens = design_lens(&Prescription::sphere(s).unwrap(), &params).unwrap();
                for theta in [0.0, 45.0, 90.0] {
                    let fv = lens.measured_back_vertex_power_d(theta).unwrap();
                    assert!((fv - s).abs() < 0.01, "n {} S {s}: traced {fv}", lens.index);
                }
            }
        }
    }

    #[test]
    fn lens_design_hand_numbers() {
        // −10 D at n = 1.66 (REFERENCE.md's TIR case): Vogel F1 = −5 + 6 = 1 D,
        // R1 = 0.66 m; t = 2 mm: F2 = −10 − 1/(1 − 0.002/1.66) = −11.0012 D,
        // R2 = 0.66/11.0012 = 59.99 mm (≈ 60 mm).
        let lens = design_lens(&Prescription::sphere(-10.0).unwrap(), &LensDesignParams::paper()).unwrap();
        assert!((lens.front_power_d - 1.0).abs() < 1e-15);
        assert!((lens.centre_thickness_m - 0.002).abs() < 1e-15);
        assert!((lens.back_power_d[0] + 11.001_206).abs() < 1e-5, "{:?}", lens.back_power_d);
        let LensSurface::Spherical(b) = lens.back else { panic!() };
        assert!((-1.0 / b.curvature - 0.059_993).abs() < 1e-5, "{}", 1.0 / b.curvature);
        // Eye frame: back vertex at the vertex distance, front t further out;
        // a minus lens's back surface is concave to the eye: its centre of
        // curvature lies 60 mm towards −z, behind the eye (negative curvature).
        assert_eq!(lens.back.vertex_z(), 0.012);
        assert!((lens.front.vertex_z - 0.014).abs() < 1e-15);
        assert!(b.curvature < 0.0);
        // Minus lenses are thick at the edge: 2 mm + sag2 − sag1 at 25 mm.
        let e = lens.edge_thickness_m(0.0).unwrap();
        let s2 = 0.059_993 - (0.059_993f64.powi(2) - 0.025f64.powi(2)).sqrt();
        let s1 = 0.66 - (0.66f64.powi(2) - 0.025f64.powi(2)).sqrt();
        assert!((e - (0.002 + s2 - s1)).abs() < 2e-6, "{e}");
    }

    #[test]
    fn lens_design_plus_lens_keeps_min_edge() {
        // +6 D CR-39: Vogel F1 = 12 D; the centre is whatever gives a 1 mm edge.
        let lens = design_lens(&Prescription::sphere(6.0).unwrap(), &LensDesignParams::default()).unwrap();
        assert!((lens.front_power_d - 12.0).abs() < 1e-15);
        let e = lens.edge_thickness_m(1.0).unwrap();
        assert!((e - 0.001).abs() < 1e-9, "{e}");
        assert!(lens.centre_thickness_m > 0.005, "{}", lens.centre_thickness_m);
    }

    #[test]
    fn lens_design_toric_meridian_powers() {
        // S −2, C −1.5, axis 30°: S + C sin²(θ − 30°) = −2 (30°), −3.5 (120°),
        // −2.75 (75°), −2 − 1.5·sin²(60°) = −3.125 (90°).
        let rx = Prescription::new(-2.0, -1.5, 30.0).unwrap();
        let lens = design_lens(&rx, &LensDesignParams::default()).unwrap();
        assert!(matches!(lens.back, LensSurface::Toric(_)));
        for (theta, want) in [(30.0, -2.0), (120.0, -3.5), (75.0, -2.75), (90.0, -3.125), (210.0, -2.0)] {
            assert!((rx.meridian_power_d(theta) - want).abs() < 1e-12);
            let fv = lens.measured_back_vertex_power_d(theta).unwrap();
            assert!((fv - want).abs() < 0.01, "θ {theta}: {fv} vs {want}");
        }
        // A plus toric: edge minimum holds on the strongest meridian.
        let rx = Prescription::new(3.0, 2.0, 100.0).unwrap();
        let lens = design_lens(&rx, &LensDesignParams::default()).unwrap();
        let min_edge = (0..360).map(|k| lens.edge_thickness_m((k as f64).to_radians()).unwrap()).fold(f64::INFINITY, f64::min);
        assert!((min_edge - 0.001).abs() < 2e-5, "{min_edge}");
        for (theta, want) in [(100.0, 3.0), (10.0, 5.0)] {
            assert!((lens.measured_back_vertex_power_d(theta).unwrap() - want).abs() < 0.01);
        }
    }

    #[test]
    fn lens_design_impossible_prescriptions_are_typed() {
        let p = LensDesignParams::default();
        // +20 D in CR-39 on a 50 mm blank: F1 = 26 D, R1 = 0.498/26 = 19.15 mm
        // < 25 mm — the rim sag would need √(R² − r²) of a negative number.
        match design_lens(&Prescription::sphere(20.0).unwrap(), &p) {
            Err(SpectaclesError::SurfaceTooSteep { side: LensSide::Front, radius_m, blank_radius_m }) => {
                assert!((radius_m - 0.498 / 26.0).abs() < 1e-12 && blank_radius_m == 0.025);
            }
            other => panic!("{other:?}"),
        }
        // On a 36 mm blank it fits (18 mm < 19.15 mm).
        let small = LensDesignParams { blank_diameter_m: 0.036, ..p };
        let lens = design_lens(&Prescription::sphere(20.0).unwrap(), &small).unwrap();
        assert!((lens.measured_back_vertex_power_d(0.0).unwrap() - 20.0).abs() < 0.01);
        // −20 D fits a 50 mm blank (R2 ≈ 31 mm) as a very thick-edged lens.
        let lens = design_lens(&Prescription::sphere(-20.0).unwrap(), &p).unwrap();
        assert!(lens.edge_thickness_m(0.0).unwrap() > 0.015);
        assert!((lens.measured_back_vertex_power_d(0.0).unwrap() + 20.0).abs() < 0.01);
        // Beyond ±20 D, NaN, bad parameters.
        assert!(matches!(Prescription::sphere(-21.0), Err(SpectaclesError::OutOfRange { .. })));
        assert!(matches!(Prescription::new(-19.0, -2.0, 0.0), Err(SpectaclesError::OutOfRange { .. })));
        assert!(matches!(Prescription::new(f64::NAN, 0.0, 0.0), Err(SpectaclesError::NonFinite(_))));
        let raw = Prescription { sphere_d: f64::NAN, cylinder_d: 0.0, axis_deg: 0.0 };
        assert!(design_lens(&raw, &p).is_err());
        assert!(matches!(LensDesignParams::with_material("unobtainium"), Err(SpectaclesError::UnknownMaterial(_))));
        assert!(design_lens(&Prescription::sphere(1.0).unwrap(), &LensDesignParams { blank_diameter_m: 0.0, ..p }).is_err());
        assert!(design_lens(&Prescription::sphere(1.0).unwrap(), &LensDesignParams { material: Glass::Constant(f64::NAN), ..p }).is_err());
        assert!(matches!(
            design_lens(&Prescription::sphere(1.0).unwrap(), &LensDesignParams { base_curve_d: Some(600.0), min_centre_thickness_m: 0.01, blank_diameter_m: 0.001, ..p }),
            Err(SpectaclesError::ThickLensPole { .. })
        ));
        assert_eq!(LensDesignParams::with_material("polycarbonate").unwrap().material.nd(), 1.586);
    }

    proptest! {
        #[test]
        fn lens_design_any_prescription_is_a_lens_or_typed(
            s in -25f64..25.0, c in -6f64..6.0, axis in 0f64..180.0,
            blank in 0.02f64..0.07, mat in 0usize..4,
        ) {
            let material = ["CR-39", "polycarbonate", "1.67", "1.74"][mat];
            let p = LensDesignParams { blank_diameter_m: blank, ..LensDesignParams::with_material(material).unwrap() };
            let Ok(rx) = Prescription::new(s, c, axis) else { return Ok(()) };
            match design_lens(&rx, &p) {
                Ok(lens) => {
                    prop_assert!(lens.centre_thickness_m.is_finite() && lens.centre_thickness_m >= 0.002);
                    let fv = lens.measured_back_vertex_power_d(axis).unwrap();
                    prop_assert!((fv - s).abs() < 0.02, "{} vs {}", fv, s);
                }
                Err(e) => prop_assert!(matches!(e, SpectaclesError::SurfaceTooSteep { .. }), "{:?}", e),
            }
        }
    }
}
