//! Lens design from a prescription (documented on [`design_lens`]).

use std::f64::consts::PI;

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::error::{LensSide, SpectaclesError};
use super::lens_surface::{LensSurface, ProgressiveAddition, ProgressiveSurface, ToricSurface};
use crate::glass::Glass;
use crate::input::{self, Expected, InvalidInput};
use crate::ray::Ray;
use crate::surface::{SphericalSurface, refract};

/// Largest |power| (D) in any meridian that [`Prescription::new`] accepts.
/// Real spectacle lenses stop around ±20 D; beyond that lenticular designs
/// are used.
pub const MAX_LENS_POWER_D: f64 = 20.0;

/// A spectacle prescription: sphere, cylinder and axis.
///
/// Built by [`Prescription::new`]; deserialisation runs the same checks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawPrescription")]
pub struct Prescription {
    sphere_d: f64,
    cylinder_d: f64,
    axis_deg: f64,
    add_d: f64,
}

/// The serialised form of a [`Prescription`], unchecked.
#[derive(Deserialize)]
struct RawPrescription {
    sphere_d: f64,
    cylinder_d: f64,
    axis_deg: f64,
    #[serde(default)]
    add_d: f64,
}

impl TryFrom<RawPrescription> for Prescription {
    type Error = InvalidInput;

    fn try_from(r: RawPrescription) -> Result<Self, InvalidInput> {
        Prescription::new(r.sphere_d, r.cylinder_d, r.axis_deg)?.with_addition(r.add_d)
    }
}

/// Largest near addition (D) [`Prescription::with_addition`] accepts:
/// additions run from +0.75 to about +3.50 D.
pub const MAX_ADDITION_D: f64 = 4.0;

impl Prescription {
    /// A prescription of sphere `S` (D, the back-vertex power in the axis
    /// meridian), cylinder `C` (D, either sign; 0 for a spherical lens) and
    /// axis (degrees, in the lens's x–y plane from +x towards +y: the
    /// optometric TABO convention, see the `spectacles` module docs).
    ///
    /// Errors: non-finite numbers, or `S` or `S + C` beyond
    /// ±[`MAX_LENS_POWER_D`].
    pub fn new(sphere_d: f64, cylinder_d: f64, axis_deg: f64) -> Result<Self, InvalidInput> {
        let m = MAX_LENS_POWER_D;
        let sphere_d = input::in_range("sphere (D)", sphere_d, -m, m)?;
        let cylinder_d = input::finite("cylinder (D)", cylinder_d)?;
        input::in_range("sphere + cylinder (D)", sphere_d + cylinder_d, -m, m)?;
        let axis_deg = input::finite("cylinder axis (deg)", axis_deg)?;
        Ok(Self {
            sphere_d,
            cylinder_d,
            axis_deg,
            add_d: 0.0,
        })
    }

    /// The same prescription with a near addition `add_d` (D, `0..=`
    /// `MAX_ADDITION_D` = 4 D; 0 for a single-vision lens): the lens becomes a
    /// progressive-addition lens, its power growing by `add_d` down a
    /// corridor ([`LensDesignParams::with_corridor_m`]) into a near zone.
    /// Errors: an addition outside that range, or one that takes a
    /// meridian beyond ±[`MAX_LENS_POWER_D`].
    pub fn with_addition(self, add_d: f64) -> Result<Self, InvalidInput> {
        let add_d = input::in_range("near addition (D)", add_d, 0.0, MAX_ADDITION_D)?;
        let m = MAX_LENS_POWER_D;
        input::in_range("sphere + addition (D)", self.sphere_d + add_d, -m, m)?;
        input::in_range(
            "sphere + cylinder + addition (D)",
            self.sphere_d + self.cylinder_d + add_d,
            -m,
            m,
        )?;
        Ok(Self { add_d, ..self })
    }

    /// Near addition (D); 0 for a single-vision lens.
    pub fn add_d(&self) -> f64 {
        self.add_d
    }

    /// A spherical prescription.
    pub fn sphere(sphere_d: f64) -> Result<Self, InvalidInput> {
        Self::new(sphere_d, 0.0, 0.0)
    }

    /// Sphere `S` (D).
    pub fn sphere_d(&self) -> f64 {
        self.sphere_d
    }

    /// Cylinder `C` (D).
    pub fn cylinder_d(&self) -> f64 {
        self.cylinder_d
    }

    /// Cylinder axis (degrees).
    pub fn axis_deg(&self) -> f64 {
        self.axis_deg
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
    if power_d >= 0.0 {
        power_d + 6.0
    } else {
        0.5 * power_d + 6.0
    }
}

/// Refractive indices (at the d line) a lens material may have. 1.3 lies
/// below every solid optical material (fluoride glasses start near 1.43)
/// and keeps away from `n = 1`, where a surface has no power at any
/// curvature; 3.0 is the bound the lens-system validation of this crate
/// uses for optical media.
pub const LENS_INDEX_RANGE: (f64, f64) = (1.3, 3.0);

/// The lens maker's choices besides the prescription.
///
/// Start from [`LensDesignParams::default`] or [`LensDesignParams::paper`]
/// and change what differs with the checked `with_*` methods;
/// deserialisation runs the same checks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawLensDesignParams")]
pub struct LensDesignParams {
    material: Glass,
    vertex_distance_m: f64,
    blank_diameter_m: f64,
    min_centre_thickness_m: f64,
    min_edge_thickness_m: f64,
    base_curve_d: Option<f64>,
    corridor_m: f64,
}

/// The serialised form of [`LensDesignParams`], unchecked.
#[derive(Deserialize)]
struct RawLensDesignParams {
    material: Glass,
    vertex_distance_m: f64,
    blank_diameter_m: f64,
    min_centre_thickness_m: f64,
    min_edge_thickness_m: f64,
    base_curve_d: Option<f64>,
    #[serde(default = "default_corridor_m")]
    corridor_m: f64,
}

/// The default progressive corridor (m): 14 mm from the fitting point to
/// the full addition, a common "regular" corridor (short ones are ~11 mm).
fn default_corridor_m() -> f64 {
    0.014
}

impl TryFrom<RawLensDesignParams> for LensDesignParams {
    type Error = InvalidInput;

    fn try_from(r: RawLensDesignParams) -> Result<Self, InvalidInput> {
        LensDesignParams::default()
            .with_glass(r.material)?
            .with_vertex_distance_m(r.vertex_distance_m)?
            .with_blank_diameter_m(r.blank_diameter_m)?
            .with_min_centre_thickness_m(r.min_centre_thickness_m)?
            .with_min_edge_thickness_m(r.min_edge_thickness_m)?
            .with_base_curve_d(r.base_curve_d)?
            .with_corridor_m(r.corridor_m)
    }
}

impl Default for LensDesignParams {
    /// CR-39 (n_d = 1.498, V_d = 58), 12 mm vertex distance, 50 mm blank,
    /// 2 mm minimum centre, 1 mm minimum edge, Vogel's base curve: a typical
    /// plastic lens as dispensed.
    fn default() -> Self {
        Self {
            material: Glass::Abbe {
                nd: 1.498,
                vd: 58.0,
            },
            vertex_distance_m: 0.012,
            blank_diameter_m: 0.050,
            min_centre_thickness_m: 0.002,
            min_edge_thickness_m: 0.001,
            base_curve_d: None,
            corridor_m: default_corridor_m(),
        }
    }
}

impl LensDesignParams {
    /// The paper's lens material: n = 1.66 (Fig. 8, "glass"), without
    /// dispersion; the other choices as [`LensDesignParams::default`].
    pub fn paper() -> Self {
        Self {
            material: Glass::Constant(1.66),
            ..Self::default()
        }
    }

    /// These choices with a catalog material (names of
    /// [`Glass::catalog`]: "CR-39", "polycarbonate", "1.67", …).
    ///
    /// Errors: [`SpectaclesError::UnknownMaterial`] for a name the catalog
    /// does not know, [`SpectaclesError::Input`] for one whose index is
    /// outside [`LENS_INDEX_RANGE`] ("air").
    pub fn with_material(self, name: &str) -> Result<Self, SpectaclesError> {
        let glass = Glass::catalog(name)
            .ok_or_else(|| SpectaclesError::UnknownMaterial(name.to_string()))?;
        Ok(self.with_glass(glass)?)
    }

    /// These choices with lens material `glass`; its index at the d line is
    /// used. Errors: an index outside [`LENS_INDEX_RANGE`].
    pub fn with_glass(self, glass: Glass) -> Result<Self, InvalidInput> {
        input::in_range(
            "lens index n_d",
            glass.nd(),
            LENS_INDEX_RANGE.0,
            LENS_INDEX_RANGE.1,
        )?;
        Ok(Self {
            material: glass,
            ..self
        })
    }

    /// These choices with the cornea-to-back-vertex distance `d` (m; 0.012–0.014
    /// is usual). Errors: a negative or non-finite distance.
    pub fn with_vertex_distance_m(self, d: f64) -> Result<Self, InvalidInput> {
        Ok(Self {
            vertex_distance_m: input::non_negative("vertex distance (m)", d)?,
            ..self
        })
    }

    /// These choices with a round blank of diameter `diameter` (m). Errors:
    /// a diameter that is not finite and positive.
    pub fn with_blank_diameter_m(self, diameter: f64) -> Result<Self, InvalidInput> {
        Ok(Self {
            blank_diameter_m: input::positive("blank diameter (m)", diameter)?,
            ..self
        })
    }

    /// These choices with the thinnest centre allowed (m); minus lenses get
    /// exactly this. Errors: a thickness that is not finite and positive.
    pub fn with_min_centre_thickness_m(self, t: f64) -> Result<Self, InvalidInput> {
        Ok(Self {
            min_centre_thickness_m: input::positive("minimum centre thickness (m)", t)?,
            ..self
        })
    }

    /// These choices with the thinnest edge allowed (m); it sets the centre
    /// of plus lenses. Errors: a thickness that is not finite and positive.
    pub fn with_min_edge_thickness_m(self, e: f64) -> Result<Self, InvalidInput> {
        Ok(Self {
            min_edge_thickness_m: input::positive("minimum edge thickness (m)", e)?,
            ..self
        })
    }

    /// These choices with a progressive corridor of `length` (m): from the
    /// fitting point (where the wearer looks straight ahead, the lens's
    /// centre) down to where the addition is full. Used only for a
    /// prescription with an addition. Errors: a length that is not finite
    /// and positive.
    pub fn with_corridor_m(self, length: f64) -> Result<Self, InvalidInput> {
        Ok(Self {
            corridor_m: input::positive("progressive corridor (m)", length)?,
            ..self
        })
    }

    /// The progressive corridor's length (m).
    pub fn corridor_m(&self) -> f64 {
        self.corridor_m
    }

    /// These choices with front surface power `F1` (D), or `None` for
    /// Vogel's rule on the spherical equivalent. Errors: a non-finite power
    /// (a finite one the blank cannot carry is
    /// [`SpectaclesError::SurfaceTooSteep`] or
    /// [`SpectaclesError::ThickLensPole`] from [`design_lens`]).
    pub fn with_base_curve_d(self, base_curve_d: Option<f64>) -> Result<Self, InvalidInput> {
        if let Some(f1) = base_curve_d {
            input::finite("base curve (D)", f1)?;
        }
        Ok(Self {
            base_curve_d,
            ..self
        })
    }

    /// Lens material.
    pub fn material(&self) -> Glass {
        self.material
    }

    /// Cornea to back vertex (m).
    pub fn vertex_distance_m(&self) -> f64 {
        self.vertex_distance_m
    }

    /// Diameter of the round blank (m).
    pub fn blank_diameter_m(&self) -> f64 {
        self.blank_diameter_m
    }

    /// Thinnest centre allowed (m).
    pub fn min_centre_thickness_m(&self) -> f64 {
        self.min_centre_thickness_m
    }

    /// Thinnest edge allowed (m).
    pub fn min_edge_thickness_m(&self) -> f64 {
        self.min_edge_thickness_m
    }

    /// Front surface power (D); `None` for Vogel's rule.
    pub fn base_curve_d(&self) -> Option<f64> {
        self.base_curve_d
    }
}

/// A designed lens placed in the eye's frame, made by [`design_lens`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SpectacleLens {
    prescription: Prescription,
    params: LensDesignParams,
    index: f64,
    front: SphericalSurface,
    back: LensSurface,
    rim_radius_m: f64,
    centre_thickness_m: f64,
    front_power_d: f64,
    back_power_d: [f64; 2],
    /// Where the optical centre sits off the eye's axis (m, eye frame x
    /// and y); zero as designed.
    decentration_m: DVec2,
}

fn sphere_sag(c: f64, r: f64) -> Option<f64> {
    let q = 1.0 - c * c * r * r;
    (q > 0.0).then(|| c * r * r / (1.0 + q.sqrt()))
}

/// Rim samples for the edge thickness of a toric back surface: every 2°.
/// Round the rim the toric part of the sag varies as `A·cos 2φ` (A: half
/// the sag difference of the principal meridians), and the true minimum is
/// at most 1° from a sample, so it is missed by at most `A·(1 − cos 2°)` ≈
/// 6e-4·A: under 1 µm for a 4 D cylinder in CR-39 on a 50 mm blank
/// (A = 1.25 mm).
const RIM_SAMPLES: usize = 180;

/// Most fixed-point steps of the centre thickness. Each step changes `F2`
/// by the thick-lens term, a factor `t·F1/n` (below 0.02 for any lens that
/// fits a blank) smaller than the last: a few steps converge; 100 only
/// bounds the loop.
const THICKNESS_MAX_STEPS: usize = 100;

/// The centre thickness has converged when a step changes it by at most
/// this (m): 0.1 pm, where the back power changes by ~F1²/n·1e-13 ≈ 1e-10 D.
const THICKNESS_TOLERANCE_M: f64 = 1e-13;

/// Height (m) of the probe ray of [`SpectacleLens::measured_back_vertex_power_d`]:
/// 0.1 mm, small enough that the lens's aberrations (which grow as the
/// height squared) change the measured power by less than 1e-5 D, large
/// enough that the exit slope, ~F·h, keeps ten significant digits.
const PARAXIAL_PROBE_HEIGHT_M: f64 = 1e-4;

/// How far in front of the front vertex (m) the probe ray starts: anywhere
/// outside the lens works for a ray parallel to the axis; 10 cm clears the
/// sag of any spectacle lens (at most a few centimetres).
const PARAXIAL_PROBE_START_M: f64 = 0.1;

/// Designs the lens for `rx`: Vogel's base curve, the thick-lens back
/// surface, a centre thickness that keeps a minimum edge, and the lens
/// placed in the eye's frame.
///
/// Design, in the optician's frame (light from the object, +z′ towards the
/// eye; front vertex at z′ = 0, back vertex at z′ = t; powers in dioptres,
/// lengths in metres, `n` the index at the d line):
///
/// ```text
/// M  = S + C/2                                 spherical equivalent
/// F1 = M + 6  (M >= 0),   M/2 + 6  (M < 0)     Vogel's rule for the base curve
/// c1 = F1 / (n − 1)                            front curvature
/// F2(θ) = Fv(θ) − F1 / (1 − t·F1/n)            back surface, per principal meridian
/// Fv(θ) = S + C·sin²(θ − axis)                 θ = axis → S, θ = axis + 90° → S + C
/// c2(θ) = F2(θ) / (1 − n)                      back curvature (toric when C ≠ 0)
/// t  = max(t_min, e_min − min_φ(sag2(r, φ) − sag1(r)))     r = blank radius
/// ```
///
/// `F2` is the back-vertex power of a thick lens, `Fv = F1/(1 − (t/n)·F1) + F2`,
/// solved for `F2`. Vogel's rule is the optician's rule of thumb for a base
/// curve near the best form (little oblique astigmatism) for each power.
/// `t` enters `F2` through the thick-lens term, so it is found by fixed-point
/// iteration; it converges in a few steps because the term is small.
///
/// In the eye's frame (the one every other part of the module uses: +z from
/// the eye into the scene, cornea at z = 0) the lens is the optician's frame
/// mirrored, `z = d + t − z′` with `d` the vertex distance: the back vertex
/// is at `z = d`, the front vertex at `z = d + t`, and every curvature
/// changes sign.
///
/// Errors: [`SpectaclesError::SurfaceTooSteep`] when a surface's radius is
/// smaller than the blank radius (e.g. +20 D in CR-39 on a 50 mm blank:
/// F1 = 26 D, R1 = 19.2 mm < 25 mm), [`SpectaclesError::ThickLensPole`],
/// [`SpectaclesError::SurfacesCross`], and [`SpectaclesError::Degenerate`]
/// if the thickness iteration does not settle.
pub fn design_lens(
    rx: &Prescription,
    params: &LensDesignParams,
) -> Result<SpectacleLens, SpectaclesError> {
    let n = params.material.nd();
    let f1 = params
        .base_curve_d
        .unwrap_or_else(|| vogel_base_curve_d(rx.spherical_equivalent_d()));
    let r = 0.5 * params.blank_diameter_m;
    let c1 = f1 / (n - 1.0);
    let sag1 = sphere_sag(c1, r).ok_or(SpectaclesError::SurfaceTooSteep {
        side: LensSide::Front,
        radius_m: 1.0 / c1.abs(),
        blank_radius_m: r,
    })?;
    let axis = rx.axis_deg.to_radians();
    let fv = [rx.sphere_d, rx.sphere_d + rx.cylinder_d];
    // A progressive addition on the back surface, in the eye's frame: the
    // back surface's power F2 = (1 − n)·c2 in the optician's frame grows by
    // the add, c2 by add/(1 − n), the eye frame's curvature by add/(n − 1).
    let addition = if rx.add_d > 0.0 {
        Some(ProgressiveAddition::new(
            rx.add_d / (n - 1.0),
            params.corridor_m,
        )?)
    } else {
        None
    };

    // Back curvatures for thickness t (optician's frame).
    let back_for = |t: f64| -> Result<([f64; 2], [f64; 2]), SpectaclesError> {
        let fac = 1.0 - t * f1 / n;
        if !(fac > 0.0) {
            return Err(SpectaclesError::ThickLensPole {
                thickness_m: t,
                front_power_d: f1,
            });
        }
        let f2 = [fv[0] - f1 / fac, fv[1] - f1 / fac];
        let c2 = [f2[0] / (1.0 - n), f2[1] / (1.0 - n)];
        let cmax = c2[0].abs().max(c2[1].abs());
        if !(cmax * r < 1.0) {
            return Err(SpectaclesError::SurfaceTooSteep {
                side: LensSide::Back,
                radius_m: 1.0 / cmax,
                blank_radius_m: r,
            });
        }
        Ok((f2, c2))
    };
    // min over the rim of sag2 − sag1 (optician's frame).
    let min_rim_gap = |c2: [f64; 2]| -> Result<f64, SpectaclesError> {
        let too_steep = SpectaclesError::SurfaceTooSteep {
            side: LensSide::Back,
            radius_m: 1.0 / c2[0].abs().max(c2[1].abs()),
            blank_radius_m: r,
        };
        let torus = ToricSurface::new(0.0, c2[0], c2[1], axis)?;
        let mut m = f64::INFINITY;
        for k in 0..RIM_SAMPLES {
            let phi = 2.0 * PI * k as f64 / RIM_SAMPLES as f64;
            let (x, y) = (r * phi.cos(), r * phi.sin());
            let (s2, _) = torus.sag_and_gradient(x, y).ok_or(too_steep.clone())?;
            // The addition in this frame (curvatures mirrored).
            let add = addition.map_or(0.0, |a| a.mirrored().sag_and_gradient(x, y).0);
            m = m.min(s2 + add - sag1);
        }
        Ok(m)
    };
    let mut t = params.min_centre_thickness_m;
    let mut converged = false;
    for _ in 0..THICKNESS_MAX_STEPS {
        let (_, c2) = back_for(t)?;
        let t_new = params
            .min_centre_thickness_m
            .max(params.min_edge_thickness_m - min_rim_gap(c2)?);
        if !t_new.is_finite() {
            return Err(SpectaclesError::Degenerate(
                "centre thickness iteration diverged",
            ));
        }
        let done = (t_new - t).abs() <= THICKNESS_TOLERANCE_M;
        t = t_new;
        if done {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(SpectaclesError::Degenerate(
            "centre thickness iteration did not converge",
        ));
    }
    let (f2, c2) = back_for(t)?;
    let edge = t + min_rim_gap(c2)?;
    if !(edge > 0.0) {
        return Err(SpectaclesError::SurfacesCross {
            edge_thickness_m: edge,
        });
    }
    let d = params.vertex_distance_m;
    // Mirror into the eye's frame: curvatures change sign.
    let front = SphericalSurface::new(d + t, -c1)?;
    let back = match addition {
        Some(a) => LensSurface::Progressive(ProgressiveSurface::new(
            ToricSurface::new(d, -c2[0], -c2[1], axis)?,
            a,
        )),
        None if rx.cylinder_d == 0.0 => LensSurface::Spherical(SphericalSurface::new(d, -c2[0])?),
        None => LensSurface::Toric(ToricSurface::new(d, -c2[0], -c2[1], axis)?),
    };
    Ok(SpectacleLens {
        prescription: *rx,
        params: *params,
        index: n,
        front,
        back,
        rim_radius_m: r,
        centre_thickness_m: t,
        front_power_d: f1,
        back_power_d: f2,
        decentration_m: DVec2::ZERO,
    })
}

impl SpectacleLens {
    /// The prescription it was made for.
    pub fn prescription(&self) -> &Prescription {
        &self.prescription
    }

    /// The design choices.
    pub fn params(&self) -> &LensDesignParams {
        &self.params
    }

    /// Refractive index used (the material at the d line, unless
    /// [`SpectacleLens::at_wavelength`] chose another).
    pub fn index(&self) -> f64 {
        self.index
    }

    /// The same lens — its surfaces as designed for the d line — as light
    /// of `wavelength_nm` meets it: the material's index there
    /// ([`Glass::index`]; a [`Glass::Constant`] material has no
    /// dispersion). Tracing the same ray at the C and F lines
    /// (656.3 / 486.1 nm) gives the lens's chromatic aberration: off the
    /// optical centre the prism `c·F` (Prentice, `c` in cm) spreads the
    /// colours over `c·F/V` prism dioptres, `V` the Abbe number.
    pub fn at_wavelength(&self, wavelength_nm: f64) -> SpectacleLens {
        SpectacleLens {
            index: self.params.material().index(wavelength_nm),
            ..*self
        }
    }

    /// The same lens with its optical centre moved `decentration_m` (m, in
    /// the eye frame's x and y) off the eye's axis, as a frame fitted
    /// off-centre wears it: [`SpectacleLens::trace_from_eye`] and everything
    /// built on it (bundles, the defocus field) then see it there, a prism
    /// of `c·F` (Prentice) before the eye. The surfaces
    /// ([`SpectacleLens::front`], [`SpectacleLens::back`]) stay in the
    /// lens's own frame, centred.
    ///
    /// Errors: a non-finite offset, or one that puts the eye's axis off
    /// the blank (at least its radius).
    pub fn decentred(self, decentration_m: DVec2) -> Result<Self, InvalidInput> {
        let d = input::finite_vec2("lens decentration (m)", decentration_m)?;
        if !(d.length() < self.rim_radius_m) {
            return Err(InvalidInput::new(
                "lens decentration (m)",
                d.length(),
                Expected::Range {
                    min: 0.0,
                    max: self.rim_radius_m,
                },
            ));
        }
        Ok(Self {
            decentration_m: d,
            ..self
        })
    }

    /// Where the optical centre sits off the eye's axis (m, eye frame x
    /// and y): zero unless [`SpectacleLens::decentred`].
    pub fn decentration_m(&self) -> DVec2 {
        self.decentration_m
    }

    /// Object-side surface, vertex at `z = d + t`.
    pub fn front(&self) -> &SphericalSurface {
        &self.front
    }

    /// Eye-side surface, vertex at `z = d`.
    pub fn back(&self) -> &LensSurface {
        &self.back
    }

    /// Radius of the blank (m).
    pub fn rim_radius_m(&self) -> f64 {
        self.rim_radius_m
    }

    /// Centre thickness `t` (m).
    pub fn centre_thickness_m(&self) -> f64 {
        self.centre_thickness_m
    }

    /// Front surface power `F1` (D).
    pub fn front_power_d(&self) -> f64 {
        self.front_power_d
    }

    /// Back surface power `F2` (D) in the axis meridian and across it.
    pub fn back_power_d(&self) -> [f64; 2] {
        self.back_power_d
    }

    /// Vertex distance `d` (m): z of the back vertex in the eye's frame.
    pub fn vertex_distance_m(&self) -> f64 {
        self.back.vertex_z()
    }

    /// Edge thickness (m) at rim angle `phi` (rad, from +x towards +y).
    ///
    /// Errors: a non-finite angle. (Both surfaces of a designed lens reach
    /// the rim; [`SpectaclesError::SurfaceTooSteep`] would say otherwise.)
    pub fn edge_thickness_m(&self, phi: f64) -> Result<f64, SpectaclesError> {
        let phi = input::finite("rim angle (rad)", phi)?;
        let (x, y) = (self.rim_radius_m * phi.cos(), self.rim_radius_m * phi.sin());
        let zf = self.front.vertex_z()
            + self
                .front
                .sag(self.rim_radius_m)
                .ok_or(self.not_to_rim(LensSide::Front))?;
        let zb =
            self.back.vertex_z() + self.back.sag(x, y).ok_or(self.not_to_rim(LensSide::Back))?;
        Ok(zf - zb)
    }

    /// The error for a surface that does not reach the rim (which design
    /// rules out).
    pub(crate) fn not_to_rim(&self, side: LensSide) -> SpectaclesError {
        let c = match side {
            LensSide::Front => self.front.curvature().abs(),
            LensSide::Back => {
                let (lo, hi) = self.back.curvature_range();
                lo.abs().max(hi.abs())
            }
        };
        SpectaclesError::SurfaceTooSteep {
            side,
            radius_m: 1.0 / c,
            blank_radius_m: self.rim_radius_m,
        }
    }

    /// Back-vertex power (D) in meridian `theta_deg`, measured as a
    /// lensmeter does: real rays ±0.1 mm from the centre in that meridian,
    /// from the object side, parallel to the axis, refracted through both
    /// surfaces: `Fv = −Δu′/Δh′` with `u′` the exit slope and `h′` the exit
    /// height, both taken along the meridian, `h′` transferred to the
    /// back-vertex plane ([`SpectacleLens::measured_power_at_d`] at the
    /// centre). It uses only the placed surfaces, so it checks
    /// [`design_lens`]'s algebra independently.
    ///
    /// Errors: a non-finite meridian; [`SpectaclesError::Degenerate`] if the
    /// probe does not get through (which a designed lens rules out).
    pub fn measured_back_vertex_power_d(&self, theta_deg: f64) -> Result<f64, SpectaclesError> {
        self.measured_power_at_d(0.0, 0.0, theta_deg)
    }

    /// The power (D) in meridian `theta_deg` at the point `(x, y)` (m) of
    /// the lens, as a lensmeter measures it there (how an optician checks a
    /// progressive lens's near zone): two rays parallel to the axis from
    /// the object side, ±0.1 mm from the point along the meridian; the
    /// power is the change of their exit slope over the change of their
    /// height at the back-vertex plane.
    ///
    /// Errors: a non-finite input; [`SpectaclesError::Degenerate`] if a
    /// probe does not get through.
    pub fn measured_power_at_d(
        &self,
        x: f64,
        y: f64,
        theta_deg: f64,
    ) -> Result<f64, SpectaclesError> {
        let theta = input::finite("meridian (deg)", theta_deg)?;
        let at = input::finite_vec2("lens point (m)", DVec2::new(x, y))?;
        let m = DVec2::from_angle(theta.to_radians());
        let fail = SpectaclesError::Degenerate("lensmeter ray did not get through the lens");
        let probe = |p: DVec2| -> Result<(DVec2, DVec2), SpectaclesError> {
            let start = DVec3::new(p.x, p.y, self.front.vertex_z() + PARAXIAL_PROBE_START_M);
            let ray = Ray::from_unit(start, DVec3::NEG_Z);
            let h1 = self.front.intersect(&ray).ok_or(fail.clone())?;
            let d1 = refract(ray.dir(), h1.normal, 1.0, self.index)
                .direction()
                .ok_or(fail.clone())?;
            let h2 = self
                .back
                .intersect(&Ray::from_unit(h1.point, d1))
                .ok_or(fail.clone())?;
            let d2 = refract(d1, h2.normal, self.index, 1.0)
                .direction()
                .ok_or(fail.clone())?;
            let slope = d2.truncate() / (-d2.z);
            let delta = self.vertex_distance_m() - h2.point.z;
            Ok((slope, h2.point.truncate() - slope * delta))
        };
        let h = PARAXIAL_PROBE_HEIGHT_M;
        let (sa, ha) = probe(at + m * h)?;
        let (sb, hb) = probe(at - m * h)?;
        Ok(-(sa - sb).dot(m) / (ha - hb).dot(m))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::Expected;
    use proptest::prelude::*;

    #[test]
    fn lens_design_back_vertex_power_by_trace() {
        // The traced back-vertex power (a lensmeter's measurement) equals S within
        // 0.01 D for ±2, ±6, ±10 D, in CR-39 and in the paper's n = 1.66.
        for params in [LensDesignParams::default(), LensDesignParams::paper()] {
            for s in [-10.0, -6.0, -2.0, 2.0, 6.0, 10.0] {
                let lens = design_lens(&Prescription::sphere(s).unwrap(), &params).unwrap();
                for theta in [0.0, 45.0, 90.0] {
                    let fv = lens.measured_back_vertex_power_d(theta).unwrap();
                    assert!(
                        (fv - s).abs() < 0.01,
                        "n {} S {s}: traced {fv}",
                        lens.index()
                    );
                }
            }
        }
    }

    #[test]
    fn lens_design_hand_numbers() {
        // −10 D at n = 1.66 (the total-internal-reflection case of the
        // per-vertex tests): Vogel F1 = −5 + 6 = 1 D,
        // R1 = 0.66 m; t = 2 mm: F2 = −10 − 1/(1 − 0.002/1.66) = −11.0012 D,
        // R2 = 0.66/11.0012 = 59.99 mm (≈ 60 mm).
        let lens = design_lens(
            &Prescription::sphere(-10.0).unwrap(),
            &LensDesignParams::paper(),
        )
        .unwrap();
        assert!((lens.front_power_d() - 1.0).abs() < 1e-15);
        assert!((lens.centre_thickness_m() - 0.002).abs() < 1e-15);
        assert!(
            (lens.back_power_d()[0] + 11.001_206).abs() < 1e-5,
            "{:?}",
            lens.back_power_d()
        );
        let LensSurface::Spherical(b) = *lens.back() else {
            panic!()
        };
        assert!(
            (-1.0 / b.curvature() - 0.059_993).abs() < 1e-5,
            "{}",
            1.0 / b.curvature()
        );
        // Eye frame: back vertex at the vertex distance, front t further out;
        // a minus lens's back surface is concave to the eye: its centre of
        // curvature lies 60 mm towards −z, behind the eye (negative curvature).
        assert_eq!(lens.back().vertex_z(), 0.012);
        assert!((lens.front().vertex_z() - 0.014).abs() < 1e-15);
        assert!(b.curvature() < 0.0);
        // Minus lenses are thick at the edge: 2 mm + sag2 − sag1 at 25 mm.
        let e = lens.edge_thickness_m(0.0).unwrap();
        let s2 = 0.059_993 - (0.059_993f64.powi(2) - 0.025f64.powi(2)).sqrt();
        let s1 = 0.66 - (0.66f64.powi(2) - 0.025f64.powi(2)).sqrt();
        assert!((e - (0.002 + s2 - s1)).abs() < 2e-6, "{e}");
    }

    #[test]
    fn lens_design_plus_lens_keeps_min_edge() {
        // +6 D CR-39: Vogel F1 = 12 D; the centre is whatever gives a 1 mm edge.
        let lens = design_lens(
            &Prescription::sphere(6.0).unwrap(),
            &LensDesignParams::default(),
        )
        .unwrap();
        assert!((lens.front_power_d() - 12.0).abs() < 1e-15);
        let e = lens.edge_thickness_m(1.0).unwrap();
        assert!((e - 0.001).abs() < 1e-9, "{e}");
        assert!(
            lens.centre_thickness_m() > 0.005,
            "{}",
            lens.centre_thickness_m()
        );
    }

    #[test]
    fn lens_design_toric_meridian_powers() {
        // S −2, C −1.5, axis 30°: S + C sin²(θ − 30°) = −2 (30°), −3.5 (120°),
        // −2.75 (75°), −2 − 1.5·sin²(60°) = −3.125 (90°).
        let rx = Prescription::new(-2.0, -1.5, 30.0).unwrap();
        let lens = design_lens(&rx, &LensDesignParams::default()).unwrap();
        assert!(matches!(lens.back(), LensSurface::Toric(_)));
        for (theta, want) in [
            (30.0, -2.0),
            (120.0, -3.5),
            (75.0, -2.75),
            (90.0, -3.125),
            (210.0, -2.0),
        ] {
            assert!((rx.meridian_power_d(theta) - want).abs() < 1e-12);
            let fv = lens.measured_back_vertex_power_d(theta).unwrap();
            assert!((fv - want).abs() < 0.01, "θ {theta}: {fv} vs {want}");
        }
        // A plus toric: edge minimum holds on the strongest meridian.
        let rx = Prescription::new(3.0, 2.0, 100.0).unwrap();
        let lens = design_lens(&rx, &LensDesignParams::default()).unwrap();
        let min_edge = (0..360)
            .map(|k| lens.edge_thickness_m((k as f64).to_radians()).unwrap())
            .fold(f64::INFINITY, f64::min);
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
            Err(SpectaclesError::SurfaceTooSteep {
                side: LensSide::Front,
                radius_m,
                blank_radius_m,
            }) => {
                assert!((radius_m - 0.498 / 26.0).abs() < 1e-12 && blank_radius_m == 0.025);
            }
            other => panic!("{other:?}"),
        }
        // On a 36 mm blank it fits (18 mm < 19.15 mm).
        let small = p.with_blank_diameter_m(0.036).unwrap();
        let lens = design_lens(&Prescription::sphere(20.0).unwrap(), &small).unwrap();
        assert!((lens.measured_back_vertex_power_d(0.0).unwrap() - 20.0).abs() < 0.01);
        // −20 D fits a 50 mm blank (R2 ≈ 31 mm) as a very thick-edged lens.
        let lens = design_lens(&Prescription::sphere(-20.0).unwrap(), &p).unwrap();
        assert!(lens.edge_thickness_m(0.0).unwrap() > 0.015);
        assert!((lens.measured_back_vertex_power_d(0.0).unwrap() + 20.0).abs() < 0.01);
        // A front power of 600 D on a 10 mm thick centre: t·F1/n = 3.6 >= 1.
        let pole = p
            .with_base_curve_d(Some(600.0))
            .and_then(|p| p.with_min_centre_thickness_m(0.01))
            .and_then(|p| p.with_blank_diameter_m(0.001))
            .unwrap();
        assert!(matches!(
            design_lens(&Prescription::sphere(1.0).unwrap(), &pole),
            Err(SpectaclesError::ThickLensPole { .. })
        ));
    }

    #[test]
    fn lens_design_bad_input_is_refused_where_it_enters() {
        // Beyond ±20 D, in the sphere or in sphere + cylinder.
        let e = Prescription::sphere(-21.0).unwrap_err();
        assert_eq!(
            (e.what, e.expected),
            (
                "sphere (D)",
                Expected::Range {
                    min: -20.0,
                    max: 20.0
                }
            )
        );
        assert_eq!(
            Prescription::new(-19.0, -2.0, 0.0).unwrap_err().what,
            "sphere + cylinder (D)"
        );
        assert_eq!(
            Prescription::new(f64::NAN, 0.0, 0.0).unwrap_err().what,
            "sphere (D)"
        );
        assert_eq!(
            Prescription::new(-1.0, 0.0, f64::INFINITY)
                .unwrap_err()
                .what,
            "cylinder axis (deg)"
        );
        let rx = Prescription::new(-2.0, -0.5, 170.0).unwrap();
        assert_eq!(
            (rx.sphere_d(), rx.cylinder_d(), rx.axis_deg()),
            (-2.0, -0.5, 170.0)
        );
        // Design parameters.
        let p = LensDesignParams::default();
        assert!(
            matches!(p.with_material("unobtainium"), Err(SpectaclesError::UnknownMaterial(name)) if name == "unobtainium")
        );
        assert!(
            matches!(p.with_material("air"), Err(SpectaclesError::Input(e)) if e.what == "lens index n_d")
        );
        assert_eq!(
            p.with_material("polycarbonate").unwrap().material().nd(),
            1.586
        );
        assert_eq!(
            p.with_glass(Glass::Constant(f64::NAN)).unwrap_err().what,
            "lens index n_d"
        );
        assert_eq!(
            p.with_blank_diameter_m(0.0).unwrap_err().expected,
            Expected::Positive
        );
        assert_eq!(
            p.with_vertex_distance_m(-0.01).unwrap_err().what,
            "vertex distance (m)"
        );
        assert_eq!(
            p.with_min_centre_thickness_m(f64::NAN).unwrap_err().what,
            "minimum centre thickness (m)"
        );
        assert_eq!(
            p.with_min_edge_thickness_m(0.0).unwrap_err().what,
            "minimum edge thickness (m)"
        );
        assert_eq!(
            p.with_base_curve_d(Some(f64::INFINITY)).unwrap_err().what,
            "base curve (D)"
        );
        assert_eq!(
            p.with_base_curve_d(Some(4.0)).unwrap().base_curve_d(),
            Some(4.0)
        );
        // The edge and the meridian of a designed lens.
        let lens = design_lens(&rx, &p).unwrap();
        assert!(
            matches!(lens.edge_thickness_m(f64::NAN), Err(SpectaclesError::Input(e)) if e.what == "rim angle (rad)")
        );
        assert!(
            matches!(lens.measured_back_vertex_power_d(f64::NAN), Err(SpectaclesError::Input(e)) if e.what == "meridian (deg)")
        );
    }

    #[test]
    fn lens_design_deserialisation_is_checked() {
        use serde_json::json;
        let rx = Prescription::new(-2.0, -0.5, 170.0).unwrap();
        let v = serde_json::to_value(rx).unwrap();
        assert_eq!(serde_json::from_value::<Prescription>(v).unwrap(), rx);
        let too_strong = json!({ "sphere_d": -25.0, "cylinder_d": 0.0, "axis_deg": 0.0 });
        assert!(
            serde_json::from_value::<Prescription>(too_strong)
                .unwrap_err()
                .to_string()
                .contains("sphere (D)")
        );
        let p = LensDesignParams::paper();
        let mut v = serde_json::to_value(p).unwrap();
        assert_eq!(
            serde_json::from_value::<LensDesignParams>(v.clone()).unwrap(),
            p
        );
        v["blank_diameter_m"] = json!(-0.05);
        assert!(
            serde_json::from_value::<LensDesignParams>(v)
                .unwrap_err()
                .to_string()
                .contains("blank diameter (m)")
        );
    }

    proptest! {
        #[test]
        fn lens_design_any_prescription_is_a_lens_or_typed(
            s in -25f64..25.0, c in -6f64..6.0, axis in 0f64..180.0,
            blank in 0.02f64..0.07, mat in 0usize..4,
        ) {
            let material = ["CR-39", "polycarbonate", "1.67", "1.74"][mat];
            let p = LensDesignParams::default().with_material(material).unwrap().with_blank_diameter_m(blank).unwrap();
            let Ok(rx) = Prescription::new(s, c, axis) else { return Ok(()) };
            match design_lens(&rx, &p) {
                Ok(lens) => {
                    prop_assert!(lens.centre_thickness_m().is_finite() && lens.centre_thickness_m() >= 0.002);
                    let fv = lens.measured_back_vertex_power_d(axis).unwrap();
                    prop_assert!((fv - s).abs() < 0.02, "{} vs {}", fv, s);
                }
                Err(e) => prop_assert!(matches!(e, SpectaclesError::SurfaceTooSteep { .. }), "{:?}", e),
            }
        }
    }

    #[test]
    fn lens_chromatic_aberration_follows_prentice_over_abbe() {
        // A ray from the eye through the lens 5 mm off its optical centre
        // meets a prism that deviates it by δ (Prentice: about c·F prism
        // dioptres, c in cm, 1/100 rad each), and a prism parts the C and F
        // lines by δ/V: traced, within 10 %.
        use crate::glass::{LAMBDA_C_NM, LAMBDA_F_NM};
        use crate::spectacles::LensTrace;
        for (f, nd, vd) in [(-6.0, 1.498, 58.0), (-6.0, 1.586, 30.0), (4.0, 1.586, 30.0)] {
            let params = LensDesignParams::default()
                .with_glass(Glass::Abbe { nd, vd })
                .unwrap();
            let lens = design_lens(&Prescription::sphere(f).unwrap(), &params).unwrap();
            let eye = DVec3::new(0.0, 0.0, -0.003);
            let back = lens.back().point(0.005, 0.0).unwrap();
            let dir = |l: &SpectacleLens| match l.trace_through_vertex(eye, back).unwrap() {
                LensTrace::Exit { dir, .. } => dir,
                other => panic!("{other:?}"),
            };
            let (dc, dd, df) = (
                dir(&lens.at_wavelength(LAMBDA_C_NM)),
                dir(&lens),
                dir(&lens.at_wavelength(LAMBDA_F_NM)),
            );
            let incoming = (back - eye).normalize();
            let deviation = incoming.angle_between(dd);
            let spread = dc.angle_between(df);
            let prentice = 0.5 * f.abs() / 100.0;
            assert!(
                deviation > 0.8 * prentice && deviation < 1.5 * prentice,
                "{f} D: {deviation} rad"
            );
            let want = deviation / vd;
            assert!(
                (spread / want - 1.0).abs() < 0.1,
                "{f} D, V {vd}: {spread} rad vs {want}"
            );
            // Blue bends more: for a minus lens away from the centre, more outwards.
            assert!(lens.at_wavelength(LAMBDA_F_NM).index() > lens.index());
        }
        // No dispersion in a constant-index material.
        let paper = design_lens(
            &Prescription::sphere(-6.0).unwrap(),
            &LensDesignParams::paper(),
        )
        .unwrap();
        assert_eq!(paper.at_wavelength(LAMBDA_F_NM).index(), paper.index());
    }

    #[test]
    fn lens_design_progressive_addition_by_lensmeter() {
        // A plano lens with a +2.00 add and a 14 mm corridor, CR-39: the
        // lensmeter reads plano at and above the fitting point, +2.00 in
        // both meridians in the near zone (within 0.1 D: the lensmeter's
        // rays are parallel to the axis, the zone's tilt adds a little),
        // half the add half-way down the corridor, and beside the corridor
        // the astigmatism no progressive surface avoids (Minkwitz).
        let params = LensDesignParams::default();
        let rx = Prescription::sphere(0.0)
            .unwrap()
            .with_addition(2.0)
            .unwrap();
        let lens = design_lens(&rx, &params).unwrap();
        assert!(matches!(lens.back(), LensSurface::Progressive(_)));
        let power = |x: f64, y: f64| {
            (
                lens.measured_power_at_d(x, y, 0.0).unwrap(),
                lens.measured_power_at_d(x, y, 90.0).unwrap(),
            )
        };
        for (x, y, want) in [
            (0.0, 0.004, 0.0),
            (0.0, 0.0, 0.0),
            (0.0, -0.007, 1.0),
            (0.0, -0.018, 2.0),
        ] {
            let (h, v) = power(x, y);
            assert!(
                (h - want).abs() < 0.1 && (v - want).abs() < 0.1,
                "({x}, {y}): {h} / {v} vs {want}"
            );
        }
        // Beside the corridor, half-way down, the astigmatism from the
        // oblique terms: the cylinder from the powers at 0°, 45° and 90°.
        let cylinder = |x: f64, y: f64| {
            let f = |t: f64| lens.measured_power_at_d(x, y, t).unwrap();
            let (a, c) = (f(0.0), f(90.0));
            let b = f(45.0) - 0.5 * (a + c);
            2.0 * (0.25 * (a - c) * (a - c) + b * b).sqrt()
        };
        let (on, beside) = (cylinder(0.0, -0.007), cylinder(0.008, -0.007));
        eprintln!(
            "progressive +2.00: cylinder on the corridor {on:.2} D, 8 mm beside it {beside:.2} D"
        );
        assert!(on < 0.1 && beside > 1.0 && beside < 4.0, "{on} {beside}");
        // The centre's power is the sphere's, as without an add.
        assert!(lens.measured_back_vertex_power_d(0.0).unwrap().abs() < 0.01);
        // Bad additions.
        assert!(
            Prescription::sphere(0.0)
                .unwrap()
                .with_addition(-1.0)
                .is_err()
        );
        assert!(
            Prescription::sphere(19.0)
                .unwrap()
                .with_addition(2.0)
                .is_err()
        );
        assert!(params.with_corridor_m(0.0).is_err());
    }
}
