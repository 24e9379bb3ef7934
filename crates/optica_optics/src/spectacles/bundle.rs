//! Ray bundles from the pupil through the lens (paper §4.3, Fig. 7): the
//! building block of the voxel field and of its direct reference.
//!
//! A bundle belongs to one *aim*: the reference ray (基準光線) from the eye's
//! centre of rotation through a point of the lens. Its other rays start on the
//! pupil, a disc of diameter `A` centred on the reference ray and
//! perpendicular to it, and converge (before the lens) on the reference ray
//! at the near point (`V = P_near`) or the far point (`V = P_far`): pupil
//! offset `r` gets direction `a − V·r` (slope `−V r`), so a point at infinity
//! (`V = 0`) and a virtual point behind the eye (`V < 0`) need no special case.
//! Every ray is traced through both lens surfaces.
//!
//! After the lens, each ray `i` is described against the refracted reference
//! ray (origin `O′`, unit direction `a′`) by its height `rᵢ` in the plane
//! through `O′` perpendicular to `a′` and its slope `uᵢ = dᵢ/(dᵢ·a′) − a′`, so
//! that it meets the plane at distance `s` at `rᵢ + s·uᵢ` — the displacement
//! vector of clone `i` at that distance (Fig. 7(c)). The point where the
//! refracted bundle converges best (the corrected near/far point) is found in
//! vergence form, by least squares on `uᵢ ≈ −W rᵢ`:
//!
//! ```text
//! W = −Σ rᵢ·uᵢ / Σ |rᵢ|²        (corrected point at s = 1/W; W ≤ 0: at or beyond infinity)
//! ```
//!
//! For a stigmatic bundle this is exactly the point of convergence; it stays
//! defined for parallel and diverging bundles, where `1/W` does not.
//! Pupil points follow a sunflower (Vogel) spiral with radii
//! `√((k + ½)/S)`: nearly uniform over the disc for any `S`, with the disc's
//! exact second moment (`mean r² = ρ²/2`).

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::lens_design::SpectacleLens;
use crate::ray::Ray;

/// Where the eye sits and how it turns.
///
/// The reference ray of every bundle starts at the centre of rotation; the
/// pupil centre is `pupil_offset_m` along it (the eye turns to look through
/// each lens point, paper §6.2: each voxel gets its own best accommodation).
/// `pupil_offset_m = 0` is the paper's model (pupil disc centred on the
/// viewpoint).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EyePlacement {
    /// Centre of rotation of the eye (m), in the lens frame (cornea at z = 0).
    pub centre_of_rotation: DVec3,
    /// Distance from the centre of rotation to the entrance pupil (m).
    pub pupil_offset_m: f64,
}

impl Default for EyePlacement {
    /// Centre of rotation 13.5 mm behind the cornea, entrance pupil 3 mm
    /// behind it (10.5 mm in front of the centre of rotation): the usual
    /// optometric figures (lens back vertex to centre of rotation ≈ 25.5 mm
    /// at a 12 mm vertex distance).
    fn default() -> Self {
        Self { centre_of_rotation: DVec3::new(0.0, 0.0, -0.0135), pupil_offset_m: 0.0105 }
    }
}

impl EyePlacement {
    /// The paper's model: the viewpoint is the pupil centre, 3 mm behind the
    /// cornea, and the pupil disc is centred on it.
    pub fn paper() -> Self {
        Self { centre_of_rotation: DVec3::new(0.0, 0.0, -0.003), pupil_offset_m: 0.0 }
    }

    /// Pupil centre when looking along the unit direction `aim`.
    pub fn pupil_centre(&self, aim: DVec3) -> DVec3 {
        self.centre_of_rotation + aim * self.pupil_offset_m
    }

    /// True when the numbers are finite and the offset is >= 0.
    pub fn is_valid(&self) -> bool {
        self.centre_of_rotation.is_finite() && self.pupil_offset_m.is_finite() && self.pupil_offset_m >= 0.0
    }
}

/// `count` points on the unit disc, sunflower spiral, radii `√((k + ½)/count)`.
pub fn pupil_samples(count: usize) -> Vec<DVec2> {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    (0..count)
        .map(|k| {
            let r = ((k as f64 + 0.5) / count as f64).sqrt();
            DVec2::from_angle(golden * k as f64) * r
        })
        .collect()
}

/// Two unit vectors completing the unit `a` to a right-handed frame, chosen
/// the same way for every bundle (`e1 = ŷ × a`, `e2 = a × e1`; `x̂` stands in
/// for `ŷ` when `a` is nearly vertical), so that clone `i` of neighbouring
/// bundles points the same way and averaging per voxel keeps the set's shape.
pub fn perpendicular_frame(a: DVec3) -> (DVec3, DVec3) {
    let e1 = DVec3::Y.cross(a).try_normalize().unwrap_or_else(|| DVec3::X.cross(a).normalize_or(DVec3::X));
    (e1, a.cross(e1))
}

/// A bundle after the lens.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TracedBundle {
    /// The refracted reference ray: exit point on the front surface (or the
    /// pupil centre without a lens) and unit direction.
    pub chief: Ray,
    /// `rᵢ`: ray i's offset from the chief in the plane ⟂ `chief.dir` through `chief.origin`.
    pub heights: Vec<DVec3>,
    /// `uᵢ`: how that offset changes per metre along `chief.dir`.
    pub slopes: Vec<DVec3>,
    /// Fitted vergence `W` (D) of the refracted bundle at `chief.origin`.
    pub vergence_d: f64,
}

impl TracedBundle {
    /// Displacement of clone `i` in the plane ⟂ the chief at distance `s`.
    pub fn displacement(&self, i: usize, s: f64) -> DVec3 {
        self.heights[i] + self.slopes[i] * s
    }
}

/// Why a bundle could not be traced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum BundleFailure {
    /// The reference ray missed the lens, left through the rim or was
    /// totally reflected.
    Chief,
    /// One of the pupil rays did.
    PupilRay,
    /// Degenerate input (zero aim, non-finite numbers).
    Degenerate,
}

/// Traces the bundle of aim `aim` (unit, from the centre of rotation) that
/// converges before the lens at vergence `vergence_d` from the pupil, with
/// pupil radius `pupil_radius_m` and pupil points `samples` (unit disc).
pub fn trace_bundle(
    lens: Option<&SpectacleLens>,
    placement: &EyePlacement,
    aim: DVec3,
    pupil_radius_m: f64,
    vergence_d: f64,
    samples: &[DVec2],
) -> Result<TracedBundle, BundleFailure> {
    trace_bundle_counted(lens, placement, aim, pupil_radius_m, vergence_d, samples, &mut 0)
}

/// [`trace_bundle`], adding to `traced` the number of rays actually traced
/// through the lens: the reference ray and the pupil rays up to the first
/// that fails (none without a lens: the naked eye's rays are straight lines).
pub(crate) fn trace_bundle_counted(
    lens: Option<&SpectacleLens>,
    placement: &EyePlacement,
    aim: DVec3,
    pupil_radius_m: f64,
    vergence_d: f64,
    samples: &[DVec2],
    traced: &mut usize,
) -> Result<TracedBundle, BundleFailure> {
    let Some(aim) = aim.try_normalize() else { return Err(BundleFailure::Degenerate) };
    if !(placement.is_valid() && pupil_radius_m.is_finite() && vergence_d.is_finite()) {
        return Err(BundleFailure::Degenerate);
    }
    let pupil = placement.pupil_centre(aim);
    // A pinhole pupil: every ray is the chief, no defocus at all; exact zeros
    // rather than round-off from tracing the same ray S times.
    let pinhole = pupil_radius_m == 0.0;
    let (e1, e2) = perpendicular_frame(aim);
    let mut exit = |ray: Ray| -> Option<Ray> {
        match lens {
            None => Some(ray),
            Some(l) => {
                *traced += 1;
                l.trace_from_eye(&ray).exit_ray()
            }
        }
    };
    let chief_in = Ray::from_unit(placement.centre_of_rotation, aim);
    let chief = match lens {
        None => Ray::from_unit(pupil, aim),
        Some(_) => exit(chief_in).ok_or(BundleFailure::Chief)?,
    };
    let a = chief.dir();
    let mut heights = Vec::with_capacity(samples.len());
    let mut slopes = Vec::with_capacity(samples.len());
    for s in samples {
        let r = (e1 * s.x + e2 * s.y) * pupil_radius_m;
        let ray = Ray::new(pupil + r, aim - r * vergence_d).map_err(|_| BundleFailure::PupilRay)?;
        let out = exit(ray).ok_or(BundleFailure::PupilRay)?;
        let da = out.dir().dot(a);
        if !(da > 1e-9) {
            return Err(BundleFailure::PupilRay);
        }
        let t = (chief.origin() - out.origin()).dot(a) / da;
        if pinhole {
            heights.push(DVec3::ZERO);
            slopes.push(DVec3::ZERO);
        } else {
            heights.push(out.origin() + out.dir() * t - chief.origin());
            slopes.push(out.dir() / da - a);
        }
    }
    let num: f64 = heights.iter().zip(&slopes).map(|(r, u)| r.dot(*u)).sum();
    let den: f64 = heights.iter().map(|r| r.length_squared()).sum();
    // A zero pupil has no heights: no defocus at all, any W will do.
    let vergence_d = if den > 0.0 { -num / den } else { 0.0 };
    if !vergence_d.is_finite() || heights.iter().chain(&slopes).any(|v| !v.is_finite()) {
        return Err(BundleFailure::Degenerate);
    }
    Ok(TracedBundle { chief, heights, slopes, vergence_d })
}

/// Which part of space a point on a chief ray is in, for a bundle pair.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Region {
    /// Nearer than the corrected near point: the near bundle's spread.
    Near,
    /// Between the corrected near and far points: in focus, zero displacement.
    InFocus,
    /// Beyond the corrected far point: the far bundle's spread (point-mirrored).
    Far,
}

/// Region of the point at distance `s > 0` along the chief, from the
/// corrected vergences: near when `s·W_near < 1` (i.e. `1/s > W_near`), far
/// when `s·W_far > 1`, written without dividing so that `W <= 0` (corrected
/// point at or beyond infinity) needs no special case.
pub fn region(s: f64, w_near: f64, w_far: f64) -> Region {
    if s * w_near < 1.0 {
        Region::Near
    } else if s * w_far > 1.0 {
        Region::Far
    } else {
        Region::InFocus
    }
}

/// The displacement set at distance `s` along the chief, for the region's
/// bundle. Far sets are point-mirrored (`−(rᵢ + s uᵢ)`), so that clone `i`
/// always lies on the side of pupil point `i`: the set is still the same disc,
/// and averaging across the focal plane never cancels.
pub fn displacement_set(near: &TracedBundle, far: &TracedBundle, s: f64) -> (Region, Vec<DVec3>) {
    match region(s, near.vergence_d, far.vergence_d) {
        Region::Near => (Region::Near, (0..near.heights.len()).map(|i| near.displacement(i, s)).collect()),
        Region::Far => (Region::Far, (0..far.heights.len()).map(|i| -far.displacement(i, s)).collect()),
        Region::InFocus => (Region::InFocus, vec![DVec3::ZERO; near.heights.len()]),
    }
}

/// Summary of a displacement set: how big the blur is.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    /// Root-mean-square length of the vectors (m); for a uniform disc of
    /// radius ρ, `ρ/√2`.
    pub rms_radius_m: f64,
    /// Longest vector (m).
    pub max_radius_m: f64,
    /// Mean vector (m).
    pub centroid: DVec3,
}

impl Spread {
    /// The spread of `vectors` (all zero for an empty set).
    pub fn of(vectors: impl IntoIterator<Item = DVec3>) -> Self {
        let (mut n, mut ss, mut mx, mut sum) = (0usize, 0.0, 0.0f64, DVec3::ZERO);
        for v in vectors {
            n += 1;
            ss += v.length_squared();
            mx = mx.max(v.length());
            sum += v;
        }
        if n == 0 {
            return Self { rms_radius_m: 0.0, max_radius_m: 0.0, centroid: DVec3::ZERO };
        }
        Self { rms_radius_m: (ss / n as f64).sqrt(), max_radius_m: mx, centroid: sum / n as f64 }
    }

    /// Blur disc diameter of a uniform disc with this RMS radius: `2√2·rms`.
    pub fn disc_diameter_m(&self) -> f64 {
        2.0 * std::f64::consts::SQRT_2 * self.rms_radius_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectacles::eye::Eye;
    use crate::spectacles::lens_design::{LensDesignParams, Prescription, design_lens};

    #[test]
    fn bundle_pupil_samples_have_the_disc_moment() {
        // Midpoint sunflower: mean r² = (1/S)·Σ(k + ½)/S = 1/2 exactly.
        for s in [1, 4, 10, 37] {
            let p = pupil_samples(s);
            let m: f64 = p.iter().map(|v| v.length_squared()).sum::<f64>() / s as f64;
            assert!((m - 0.5).abs() < 1e-15, "{s}");
            assert!(p.iter().all(|v| v.length() < 1.0));
        }
        let (e1, e2) = perpendicular_frame(DVec3::Z);
        assert_eq!((e1, e2), (DVec3::X, DVec3::Y));
        let (e1, e2) = perpendicular_frame(DVec3::Y);
        assert!(e1.dot(DVec3::Y).abs() < 1e-15 && e2.dot(DVec3::Y).abs() < 1e-15 && e1.is_finite());
    }

    #[test]
    fn bundle_naked_eye_reproduces_vergence_and_eq_1() {
        // Without a lens the fitted vergence is the one the bundle was built
        // with, and the spread at distance z is the disc A·z·ΔD of eqs. (1)/(2).
        let eye = Eye::from_near_far(0.5, 1.3, 0.012).unwrap();
        let pl = EyePlacement::paper();
        let samples = pupil_samples(64);
        let aim = DVec3::new(0.1, -0.05, 1.0).normalize();
        let a2 = 0.5 * eye.pupil_diameter_m;
        let near = trace_bundle(None, &pl, aim, a2, eye.near_point_vergence_d(), &samples).unwrap();
        let far = trace_bundle(None, &pl, aim, a2, eye.far_point_vergence_d(), &samples).unwrap();
        assert!((near.vergence_d - 2.0).abs() < 1e-12 && (far.vergence_d - 1.0 / 1.3).abs() < 1e-12);
        for z in [0.1, 0.3, 0.8, 2.0, 6.0] {
            let (_, set) = displacement_set(&near, &far, z);
            let want = eye.blur_disc_diameter_m(z).unwrap();
            assert!((Spread::of(set).disc_diameter_m() - want).abs() < 1e-12, "{z}");
        }
        assert_eq!(region(0.8, near.vergence_d, far.vergence_d), Region::InFocus);
    }

    #[test]
    fn bundle_correcting_lens_moves_far_point_to_infinity() {
        // A −2 D myope, far point 0.5 m from the pupil. The spectacle plane is
        // d = 15 mm in front of the paper-model pupil (12 mm + 3 mm), so the
        // full correction is F = −1/(0.5 − 0.015) = −2.0619 D (effectivity,
        // REFERENCE.md: F/(1 − dF)). Through that lens the far bundle leaves
        // parallel (W ≈ 0), through a −2 D lens still slightly converging.
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let pl = EyePlacement::paper();
        let samples = pupil_samples(16);
        let w = |s: f64| {
            let lens = design_lens(&Prescription::sphere(s).unwrap(), &LensDesignParams::default()).unwrap();
            trace_bundle(Some(&lens), &pl, DVec3::Z, 0.002, eye.far_point_vergence_d(), &samples).unwrap().vergence_d
        };
        let full = -1.0 / (0.5 - 0.015);
        assert!(w(full).abs() < 0.01, "{}", w(full));
        // Residual of the −2 D lens: the far point moves to 1/(0.0619·…) ≈ 16 m.
        let residual = w(-2.0);
        assert!(residual > 0.03 && residual < 0.09, "{residual}");
        // Zero pupil: no heights, W = 0, no blur.
        let b = trace_bundle(None, &pl, DVec3::Z, 0.0, 3.0, &samples).unwrap();
        assert_eq!(b.vergence_d, 0.0);
        assert_eq!(Spread::of((0..16).map(|i| b.displacement(i, 1.0))).rms_radius_m, 0.0);
        assert_eq!(trace_bundle(None, &pl, DVec3::ZERO, 0.002, 1.0, &samples), Err(BundleFailure::Degenerate));
    }
}
