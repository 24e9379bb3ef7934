//! Ray bundles from the pupil through the lens (documented on [`trace_bundle`]).

use glam::{DMat2, DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::error::{BlockedRay, SpectaclesError};
use super::lens_design::SpectacleLens;
use crate::input::{self, InvalidInput};
use crate::ray::Ray;

/// Where the eye sits and how it turns.
///
/// The reference ray of every bundle starts at the centre of rotation; the
/// pupil centre is `pupil_offset_m` along it (the eye turns to look through
/// each lens point, so that each voxel gets its own best accommodation, as
/// the paper's §6.2 suggests). `pupil_offset_m = 0` is the paper's model
/// (pupil disc centred on the viewpoint). Built by [`EyePlacement::new`];
/// deserialisation runs the same checks.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawEyePlacement")]
pub struct EyePlacement {
    centre_of_rotation: DVec3,
    pupil_offset_m: f64,
}

/// The serialised form of an [`EyePlacement`], unchecked.
#[derive(Deserialize)]
struct RawEyePlacement {
    centre_of_rotation: DVec3,
    pupil_offset_m: f64,
}

impl TryFrom<RawEyePlacement> for EyePlacement {
    type Error = InvalidInput;

    fn try_from(r: RawEyePlacement) -> Result<Self, InvalidInput> {
        EyePlacement::new(r.centre_of_rotation, r.pupil_offset_m)
    }
}

impl Default for EyePlacement {
    /// Centre of rotation 13.5 mm behind the cornea, entrance pupil 3 mm
    /// behind it (10.5 mm in front of the centre of rotation): the usual
    /// figures of ophthalmic optics (lens back vertex to centre of rotation
    /// ≈ 25.5 mm at a 12 mm vertex distance).
    fn default() -> Self {
        Self {
            centre_of_rotation: DVec3::new(0.0, 0.0, -0.0135),
            pupil_offset_m: 0.0105,
        }
    }
}

impl EyePlacement {
    /// An eye turning about `centre_of_rotation` (m, in the eye's frame:
    /// cornea at z = 0, +z into the scene) with its entrance pupil
    /// `pupil_offset_m` (m) in front of that centre along the line of sight.
    ///
    /// Errors: a non-finite centre, a negative or non-finite offset.
    pub fn new(centre_of_rotation: DVec3, pupil_offset_m: f64) -> Result<Self, InvalidInput> {
        Ok(Self {
            centre_of_rotation: input::finite_vec3("centre of rotation (m)", centre_of_rotation)?,
            pupil_offset_m: input::non_negative(
                "pupil offset from the centre of rotation (m)",
                pupil_offset_m,
            )?,
        })
    }

    /// The paper's model: the pupil disc is centred on the viewpoint, which
    /// does not move; here it is placed 3 mm behind the cornea, at the
    /// entrance pupil of [`EyePlacement::default`].
    pub fn paper() -> Self {
        Self {
            centre_of_rotation: DVec3::new(0.0, 0.0, -0.003),
            pupil_offset_m: 0.0,
        }
    }

    /// Centre of rotation of the eye (m), in the eye's frame.
    pub fn centre_of_rotation(&self) -> DVec3 {
        self.centre_of_rotation
    }

    /// Distance from the centre of rotation to the entrance pupil (m).
    pub fn pupil_offset_m(&self) -> f64 {
        self.pupil_offset_m
    }

    /// Pupil centre when looking along the unit direction `aim`.
    pub fn pupil_centre(&self, aim: DVec3) -> DVec3 {
        self.centre_of_rotation + aim * self.pupil_offset_m
    }
}

/// `count` points on the unit disc, sunflower spiral, radii `√((k + ½)/count)`:
/// the pupil points of a bundle, and so the directions of the `S` clone
/// displacements (scaled by the blur disc's radius for the naked eye).
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
    let e1 = DVec3::Y
        .cross(a)
        .try_normalize()
        .unwrap_or_else(|| DVec3::X.cross(a).normalize_or(DVec3::X));
    (e1, a.cross(e1))
}

/// Smallest cosine between a pupil ray leaving the lens and the refracted
/// reference ray: a ray at or beyond 90° to it never crosses the plane
/// through the reference ray's exit point, and its slope
/// `uᵢ = dᵢ/(dᵢ·a′) − a′` is infinite. 1e-9 refuses only rays within
/// ~6e-8 degrees of perpendicular, where `uᵢ` would exceed 1e9.
const MIN_EXIT_COSINE: f64 = 1e-9;

/// A bundle after the lens, made by [`trace_bundle`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TracedBundle {
    chief: Ray,
    heights: Vec<DVec3>,
    slopes: Vec<DVec3>,
    vergence_d: f64,
    height_map: [DVec3; 2],
    slope_map: [DVec3; 2],
}

impl TracedBundle {
    /// The refracted reference ray: exit point on the front surface (or the
    /// pupil centre without a lens) and unit direction.
    pub fn chief(&self) -> &Ray {
        &self.chief
    }

    /// `rᵢ`: ray i's offset from the chief in the plane ⟂ the chief through
    /// its origin (m), one per pupil sample.
    pub fn heights(&self) -> &[DVec3] {
        &self.heights
    }

    /// `uᵢ`: how that offset changes per metre along the chief.
    pub fn slopes(&self) -> &[DVec3] {
        &self.slopes
    }

    /// Fitted vergence `W` (D) of the refracted bundle at the chief's origin.
    pub fn vergence_d(&self) -> f64 {
        self.vergence_d
    }

    /// The bundle's set at distance `s` (m) along the chief as a linear map
    /// of the pupil: the two vectors `[m_x, m_y]` such that the clone of
    /// pupil point `(x, y)` (unit disc) is displaced by `x·m_x + y·m_y`,
    /// `H + s·U` with `H` and `U` the least-squares fits `rᵢ ≈ H·pᵢ`,
    /// `uᵢ ≈ U·pᵢ` over the bundle's pupil samples `pᵢ`. Exact for the
    /// naked eye and to first order through a lens (what remains is the
    /// lens's aberration across the pupil: 1–2 % of the set's RMS radius on
    /// average, up to 6 % for strong lenses near the rim, measured over
    /// ±8 D at 4–12 mm pupils); an astigmatic bundle gives an elliptical
    /// set. This is what the voxel field stores, so that the number of
    /// clones drawn is free at run time.
    pub fn linear_map(&self, s: f64) -> [DVec3; 2] {
        [
            self.height_map[0] + self.slope_map[0] * s,
            self.height_map[1] + self.slope_map[1] * s,
        ]
    }

    /// Displacements `rᵢ + s·uᵢ` of the clones in the plane ⟂ the chief at
    /// distance `s` (m) along it, one per pupil sample.
    pub fn displacements(&self, s: f64) -> impl ExactSizeIterator<Item = DVec3> + '_ {
        self.heights
            .iter()
            .zip(&self.slopes)
            .map(move |(r, u)| *r + *u * s)
    }
}

/// Traces the bundle of aim `aim` (any length, normalised; from the centre
/// of rotation) that converges before the lens at vergence `vergence_d` (D)
/// from the pupil, with pupil radius `pupil_radius_m` (m) and pupil points
/// `samples` (on the unit disc, e.g. [`pupil_samples`]). `lens = None` is
/// the naked eye (straight rays).
///
/// Ray bundles from the pupil through the lens (paper §4.3, Fig. 7) are the
/// building block of the voxel field and of its direct reference.
///
/// A bundle belongs to one *aim*: the reference ray (the paper's 基準光線)
/// from the eye's centre of rotation through a point of the lens. Its other
/// rays start on the pupil, a disc of diameter `A` centred on the reference
/// ray and perpendicular to it, and converge (before the lens) on the
/// reference ray at the near point (`V = P_near`) or the far point
/// (`V = P_far`): pupil offset `r` gets direction `a − V·r` (slope `−V r`),
/// so a point at infinity (`V = 0`) and a virtual point behind the eye
/// (`V < 0`) need no special case. Every ray is traced through both lens
/// surfaces.
///
/// After the lens, each ray `i` is described against the refracted reference
/// ray (origin `O′`, unit direction `a′`) by its height `rᵢ` in the plane
/// through `O′` perpendicular to `a′` and its slope `uᵢ = dᵢ/(dᵢ·a′) − a′`, so
/// that it meets the plane at distance `s` at `rᵢ + s·uᵢ` — the displacement
/// vector of clone `i` at that distance (Fig. 7(c)). The point where the
/// refracted bundle converges best (the corrected near/far point) is found in
/// vergence form, by least squares on `uᵢ ≈ −W rᵢ`:
///
/// ```text
/// W = −Σ rᵢ·uᵢ / Σ |rᵢ|²        (corrected point at s = 1/W; W ≤ 0: at or beyond infinity)
/// ```
///
/// For a stigmatic bundle this is exactly the point of convergence; it stays
/// defined for parallel and diverging bundles, where `1/W` does not.
/// Pupil points follow a sunflower (Vogel) spiral with radii
/// `√((k + ½)/S)`: nearly uniform over the disc for any `S`, with the disc's
/// exact second moment (`mean r² = ρ²/2`).
///
/// Errors: a zero or non-finite aim, a negative or non-finite radius, a
/// non-finite vergence or sample ([`SpectaclesError::Input`]);
/// [`SpectaclesError::BundleBlocked`] when the reference ray or a pupil ray
/// does not get through the lens; [`SpectaclesError::Degenerate`] if the
/// fit overflows.
pub fn trace_bundle(
    lens: Option<&SpectacleLens>,
    placement: &EyePlacement,
    aim: DVec3,
    pupil_radius_m: f64,
    vergence_d: f64,
    samples: &[DVec2],
) -> Result<TracedBundle, SpectaclesError> {
    let vergence_d = input::finite("bundle vergence (D)", vergence_d)?;
    let vergence = DMat2::IDENTITY * vergence_d;
    trace_astigmatic_bundle(lens, placement, aim, pupil_radius_m, vergence, samples)
}

/// [`trace_bundle`] for an astigmatic eye: the bundle converges (before the
/// lens) at the vergence matrix `vergence` (D, symmetric, in the frame
/// across the aim that [`Eye::vergence_matrix`](super::Eye::vergence_matrix)
/// takes; pupil offset `r` gets direction `a − V·r`). Same errors.
pub fn trace_astigmatic_bundle(
    lens: Option<&SpectacleLens>,
    placement: &EyePlacement,
    aim: DVec3,
    pupil_radius_m: f64,
    vergence: DMat2,
    samples: &[DVec2],
) -> Result<TracedBundle, SpectaclesError> {
    let aim = input::direction("bundle aim", aim)?;
    let rho = input::non_negative("pupil radius (m)", pupil_radius_m)?;
    if !vergence.is_finite() {
        return Err(SpectaclesError::Degenerate("bundle vergence not finite"));
    }
    for s in samples {
        input::finite_vec2("pupil sample", *s)?;
    }
    trace_bundle_counted(lens, placement, aim, rho, vergence, samples, &mut 0)
}


/// [`trace_bundle`] for checked input (unit `aim`, finite values), adding to
/// `traced` the number of rays actually traced through the lens: the
/// reference ray and the pupil rays up to the first that fails (none
/// without a lens: the naked eye's rays are straight lines).
pub(crate) fn trace_bundle_counted(
    lens: Option<&SpectacleLens>,
    placement: &EyePlacement,
    aim: DVec3,
    pupil_radius_m: f64,
    vergence: DMat2,
    samples: &[DVec2],
    traced: &mut usize,
) -> Result<TracedBundle, SpectaclesError> {
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
    let chief = match lens {
        None => Ray::from_unit(pupil, aim),
        Some(_) => exit(Ray::from_unit(placement.centre_of_rotation, aim))
            .ok_or(SpectaclesError::BundleBlocked(BlockedRay::Reference))?,
    };
    let a = chief.dir();
    let blocked = SpectaclesError::BundleBlocked(BlockedRay::Pupil);
    let mut heights = Vec::with_capacity(samples.len());
    let mut slopes = Vec::with_capacity(samples.len());
    for s in samples {
        let r = (e1 * s.x + e2 * s.y) * pupil_radius_m;
        let vr = vergence * (*s * pupil_radius_m);
        // `aim − V·r` has component 1 along the unit aim (r ⟂ aim): never
        // zero, and finite unless V·r overflows.
        let ray = Ray::new(pupil + r, aim - (e1 * vr.x + e2 * vr.y))?;
        let out = exit(ray).ok_or(blocked.clone())?;
        let da = out.dir().dot(a);
        if !(da > MIN_EXIT_COSINE) {
            return Err(blocked);
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
    let (height_map, slope_map) = (
        fit_linear_map(samples, &heights),
        fit_linear_map(samples, &slopes),
    );
    let num: f64 = heights.iter().zip(&slopes).map(|(r, u)| r.dot(*u)).sum();
    let den: f64 = heights.iter().map(|r| r.length_squared()).sum();
    // A zero pupil has no heights: no defocus at all, any W will do.
    let vergence_d = if den > 0.0 { -num / den } else { 0.0 };
    let maps_finite = height_map.iter().chain(&slope_map).all(|v| v.is_finite());
    if !vergence_d.is_finite()
        || !maps_finite
        || heights.iter().chain(&slopes).any(|v| !v.is_finite())
    {
        return Err(SpectaclesError::Degenerate("bundle fit overflowed"));
    }
    Ok(TracedBundle {
        chief,
        heights,
        slopes,
        vergence_d,
        height_map,
        slope_map,
    })
}

/// The least-squares linear map `[m_x, m_y]` with `vᵢ ≈ xᵢ·m_x + yᵢ·m_y`
/// for pupil points `pᵢ = (xᵢ, yᵢ)`: `M = (Σ vᵢ pᵢᵀ) G⁺` with
/// `G = Σ pᵢ pᵢᵀ` and `G⁺` its pseudo-inverse, so that one or two samples
/// (collinear points, a rank-one `G`) still give the minimum-norm fit, and
/// no samples give zero.
pub(crate) fn fit_linear_map(points: &[DVec2], values: &[DVec3]) -> [DVec3; 2] {
    let (mut gxx, mut gxy, mut gyy) = (0.0, 0.0, 0.0);
    let (mut cx, mut cy) = (DVec3::ZERO, DVec3::ZERO);
    for (p, v) in points.iter().zip(values) {
        gxx += p.x * p.x;
        gxy += p.x * p.y;
        gyy += p.y * p.y;
        cx += *v * p.x;
        cy += *v * p.y;
    }
    let det = gxx * gyy - gxy * gxy;
    let trace = gxx + gyy;
    if !(trace > 0.0) {
        return [DVec3::ZERO; 2];
    }
    if det > 1e-12 * trace * trace {
        return [
            (cx * gyy - cy * gxy) / det,
            (cy * gxx - cx * gxy) / det,
        ];
    }
    // Rank one: G = trace·n nᵀ with n the unit direction of the points,
    // G⁺ = n nᵀ / trace.
    let n = if gxx >= gyy {
        DVec2::new(gxx, gxy)
    } else {
        DVec2::new(gxy, gyy)
    }
    .normalize_or(DVec2::X);
    let along = (cx * n.x + cy * n.y) / trace;
    [along * n.x, along * n.y]
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
pub(crate) fn region(s: f64, w_near: f64, w_far: f64) -> Region {
    if s * w_near < 1.0 {
        Region::Near
    } else if s * w_far > 1.0 {
        Region::Far
    } else {
        Region::InFocus
    }
}

/// The linear map (signed) of the set at distance `s` along an aim's chief
/// in `region` (of `region` for the pair's fitted vergences), as the
/// voxel field records it: the near bundle's map nearer than the corrected
/// near point, the far bundle's mirrored beyond the corrected far point;
/// in between `None` (in focus) for a stigmatic eye, and for an
/// `astigmatic` one the map at the accommodation that makes it smallest.
pub fn set_map(
    near: &TracedBundle,
    far: &TracedBundle,
    region: Region,
    s: f64,
    astigmatic: bool,
) -> Option<[DVec3; 2]> {
    match region {
        Region::Near => Some(near.linear_map(s)),
        Region::Far => Some(far.linear_map(s).map(|v| -v)),
        Region::InFocus if astigmatic => Some(accommodated_map(near, far, s)),
        Region::InFocus => None,
    }
}

/// Which region the point at distance `s` along the pair's chief is in.
pub fn region_of(near: &TracedBundle, far: &TracedBundle, s: f64) -> Region {
    region(s, near.vergence_d, far.vergence_d)
}

/// The set at distance `s` between an aim's corrected near and far points,
/// where the eye accommodates to the circle of least confusion: the maps
/// are linear in the accommodation (exactly without a lens, to first order
/// through one), so the eye's best `t ∈ [0, 1]` between the far map `F`
/// and the near map `N` minimises `|F + t·(N − F)|²`. Zero for a stigmatic
/// bundle pair; what is left for an astigmatic one is the astigmatism the
/// lens did not correct. Signed like the near set in the nearer half of
/// the range and like the (mirrored) far set in the farther, so that it
/// joins both regions' sets; in the middle, where it flips, the set is a
/// traceless map whose ellipse is the same either way.
fn accommodated_map(near: &TracedBundle, far: &TracedBundle, s: f64) -> [DVec3; 2] {
    let (f, n) = (far.linear_map(s), near.linear_map(s));
    let (t, sign) = best_accommodation(&f, &n);
    [(f[0] + (n[0] - f[0]) * t) * sign, (f[1] + (n[1] - f[1]) * t) * sign]
}

/// The `t ∈ [0, 1]` that minimises `Σ|fᵢ + t·(nᵢ − fᵢ)|²` between far and
/// near vectors (a map's two, or a set's `S`), and the sign of the blended
/// set ([`accommodated_map`]): +1 in the nearer half, −1 in the farther.
fn best_accommodation(f: &[DVec3], n: &[DVec3]) -> (f64, f64) {
    let num: f64 = f.iter().zip(n).map(|(f, n)| f.dot(*n - *f)).sum();
    let den: f64 = f.iter().zip(n).map(|(f, n)| (*n - *f).length_squared()).sum();
    let t = if den > 0.0 { (-num / den).clamp(0.0, 1.0) } else { 0.0 };
    (t, if t >= 0.5 { 1.0 } else { -1.0 })
}

/// The displacement set at distance `s` along the chief, for the region's
/// bundle. Far sets are point-mirrored (`−(rᵢ + s uᵢ)`), so that clone `i`
/// always lies on the side of pupil point `i`: the set is still the same disc,
/// and averaging across the focal plane never cancels. In focus the set is
/// zero, unless the eye is `astigmatic`: then it is the set at the
/// accommodation between the two bundles that makes it smallest (the
/// field's rule, signed the same way).
#[cfg(feature = "reference")]
pub(crate) fn displacement_set(
    near: &TracedBundle,
    far: &TracedBundle,
    s: f64,
    astigmatic: bool,
) -> (Region, Vec<DVec3>) {
    match region(s, near.vergence_d, far.vergence_d) {
        Region::Near => (Region::Near, near.displacements(s).collect()),
        Region::Far => (Region::Far, far.displacements(s).map(|v| -v).collect()),
        Region::InFocus if astigmatic => {
            let (f, n): (Vec<DVec3>, Vec<DVec3>) =
                (far.displacements(s).collect(), near.displacements(s).collect());
            let (t, sign) = best_accommodation(&f, &n);
            let set = f.iter().zip(&n).map(|(f, n)| (*f + (*n - *f) * t) * sign).collect();
            (Region::InFocus, set)
        }
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
            return Self {
                rms_radius_m: 0.0,
                max_radius_m: 0.0,
                centroid: DVec3::ZERO,
            };
        }
        Self {
            rms_radius_m: (ss / n as f64).sqrt(),
            max_radius_m: mx,
            centroid: sum / n as f64,
        }
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
    fn bundle_corrected_far_point_follows_the_vergence_formula() {
        // A lens of back-vertex power F at distance d in front of the
        // pupil (d = vertex distance + 3 mm) moves the eye's far point
        // (vergence P_far at the pupil) to the object vergence, at the lens,
        //   L_p = −P_far,  L' = L_p / (1 + d·L_p),  V = −(L' − F),
        // (light vergences L, the object's V = −L). The traced bundle's
        // fitted vergence at the lens's exit agrees within 0.03 D (the
        // formula takes a thin lens at its back vertex; the real lens has
        // its thickness and shape).
        let pl = EyePlacement::default();
        let samples = pupil_samples(64);
        for (r, f) in [(-3.0, -3.0), (-3.0, -2.0), (-6.0, -6.0), (-1.0, 0.0), (2.0, 2.5), (1.0, 0.0)] {
            let eye = Eye::new(r, 1.0, 0.004).unwrap();
            let lens =
                design_lens(&Prescription::sphere(f).unwrap(), &LensDesignParams::default())
                    .unwrap();
            let d = lens.vertex_distance_m() - (pl.centre_of_rotation().z + pl.pupil_offset_m());
            let lp = -eye.far_point_vergence_d();
            let l_lens = lp / (1.0 + d * lp);
            let want = -(l_lens - f);
            let b = trace_bundle(Some(&lens), &pl, DVec3::Z, 0.002, eye.far_point_vergence_d(), &samples)
                .unwrap();
            assert!(
                (b.vergence_d() - want).abs() < 0.03,
                "R {r}, F {f}: traced {} vs formula {want}",
                b.vergence_d()
            );
        }
        // A −3 D myope in −3 D glasses sees far: the far point moves to
        // 0.14 D (7 m; a lens 15 mm in front of the pupil is 0.14 D
        // weaker there than at the pupil).
        let eye = Eye::new(-3.0, 1.0, 0.004).unwrap();
        let lens =
            design_lens(&Prescription::sphere(-3.0).unwrap(), &LensDesignParams::default()).unwrap();
        let b = trace_bundle(Some(&lens), &pl, DVec3::Z, 0.002, eye.far_point_vergence_d(), &samples).unwrap();
        assert!(b.vergence_d().abs() < 0.2, "{}", b.vergence_d());
    }

    #[test]
    fn bundle_linear_map_fits_the_set() {
        // Naked eye: the set is exactly linear in the pupil point.
        let eye = Eye::from_near_far(0.5, 1.3, 0.012).unwrap();
        let pl = EyePlacement::default();
        let samples = pupil_samples(10);
        let aim = DVec3::new(0.2, 0.1, 1.0).normalize();
        let near = trace_bundle(None, &pl, aim, 0.006, eye.near_point_vergence_d(), &samples)
            .unwrap();
        for s in [0.1, 0.3, 2.0] {
            let m = near.linear_map(s);
            for (v, p) in near.displacements(s).zip(&samples) {
                assert!((v - (m[0] * p.x + m[1] * p.y)).length() < 1e-15, "{s}");
            }
        }
        // Through a +4 D lens at a 6 mm pupil, 30° off axis: the lens's
        // aberration leaves a small remainder (under 10 % of the RMS).
        let lens =
            design_lens(&Prescription::sphere(4.0).unwrap(), &LensDesignParams::paper()).unwrap();
        let aim = DVec3::new(0.5, 0.0, 0.866).normalize();
        let b = trace_bundle(Some(&lens), &pl, aim, 0.003, 1.0, &samples).unwrap();
        let m = b.linear_map(1.0);
        let (mut res, mut tot) = (0.0, 0.0);
        for (v, p) in b.displacements(1.0).zip(&samples) {
            res += (v - (m[0] * p.x + m[1] * p.y)).length_squared();
            tot += v.length_squared();
        }
        assert!(tot > 0.0 && res < 0.01 * tot, "{res} of {tot}");
        // One sample (rank one): the minimum-norm fit reproduces it; none: zero.
        let p = [DVec2::new(0.6, 0.8)];
        let v = [DVec3::new(1.0, 2.0, 3.0)];
        let m = fit_linear_map(&p, &v);
        assert!((m[0] * p[0].x + m[1] * p[0].y - v[0]).length() < 1e-15);
        assert_eq!(fit_linear_map(&[], &[]), [DVec3::ZERO; 2]);
    }

    #[test]
    fn bundle_naked_eye_reproduces_vergence_and_eq_1() {
        // Without a lens the fitted vergence is the one the bundle was built
        // with, and the spread at distance z is the disc A·z·ΔD of eqs. (1)/(2).
        let eye = Eye::from_near_far(0.5, 1.3, 0.012).unwrap();
        let pl = EyePlacement::paper();
        let samples = pupil_samples(64);
        let aim = DVec3::new(0.1, -0.05, 1.0).normalize();
        let a2 = 0.5 * eye.pupil_diameter_m();
        let near = trace_bundle(None, &pl, aim, a2, eye.near_point_vergence_d(), &samples).unwrap();
        let far = trace_bundle(None, &pl, aim, a2, eye.far_point_vergence_d(), &samples).unwrap();
        assert!(
            (near.vergence_d - 2.0).abs() < 1e-12 && (far.vergence_d - 1.0 / 1.3).abs() < 1e-12
        );
        for z in [0.1, 0.3, 0.8, 2.0, 6.0] {
            let (_, set) = displacement_set(&near, &far, z, false);
            let want = eye.blur_disc_diameter_m(z).unwrap();
            assert!(
                (Spread::of(set).disc_diameter_m() - want).abs() < 1e-12,
                "{z}"
            );
        }
        assert_eq!(
            region(0.8, near.vergence_d, far.vergence_d),
            Region::InFocus
        );
    }

    #[test]
    fn bundle_correcting_lens_moves_far_point_to_infinity() {
        // A −2 D myope, far point 0.5 m from the pupil. The spectacle plane is
        // d = 15 mm in front of the paper-model pupil (12 mm + 3 mm), so the
        // full correction is F = −1/(0.5 − 0.015) = −2.0619 D (the lens's
        // focal point must sit on the far point). Through that lens the far bundle leaves
        // parallel (W ≈ 0), through a −2 D lens still slightly converging.
        let eye = Eye::new(-2.0, 1.0, 0.004).unwrap();
        let pl = EyePlacement::paper();
        let samples = pupil_samples(16);
        let w = |s: f64| {
            let lens = design_lens(
                &Prescription::sphere(s).unwrap(),
                &LensDesignParams::default(),
            )
            .unwrap();
            trace_bundle(
                Some(&lens),
                &pl,
                DVec3::Z,
                0.002,
                eye.far_point_vergence_d(),
                &samples,
            )
            .unwrap()
            .vergence_d
        };
        let full = -1.0 / (0.5 - 0.015);
        assert!(w(full).abs() < 0.01, "{}", w(full));
        // Residual of the −2 D lens: the far point moves to 1/(0.0619·…) ≈ 16 m.
        let residual = w(-2.0);
        assert!(residual > 0.03 && residual < 0.09, "{residual}");
        // Zero pupil: no heights, W = 0, no blur.
        let b = trace_bundle(None, &pl, DVec3::Z, 0.0, 3.0, &samples).unwrap();
        assert_eq!(b.vergence_d, 0.0);
        assert_eq!(b.displacements(1.0).len(), 16);
        assert_eq!(Spread::of(b.displacements(1.0)).rms_radius_m, 0.0);
    }

    #[test]
    fn bundle_bad_input_and_blocked_rays_are_typed() {
        let pl = EyePlacement::default();
        let samples = pupil_samples(16);
        let input_error = |r: Result<TracedBundle, SpectaclesError>| match r {
            Err(SpectaclesError::Input(e)) => e.what,
            other => panic!("{other:?}"),
        };
        assert_eq!(
            input_error(trace_bundle(None, &pl, DVec3::ZERO, 0.002, 1.0, &samples)),
            "bundle aim"
        );
        assert_eq!(
            input_error(trace_bundle(None, &pl, DVec3::Z, -0.002, 1.0, &samples)),
            "pupil radius (m)"
        );
        assert_eq!(
            input_error(trace_bundle(None, &pl, DVec3::Z, 0.002, f64::NAN, &samples)),
            "bundle vergence (D)"
        );
        assert_eq!(
            input_error(trace_bundle(None, &pl, DVec3::Z, 0.002, 1.0, &[DVec2::NAN])),
            "pupil sample"
        );
        // A non-unit aim is normalised, not refused.
        let b = trace_bundle(None, &pl, DVec3::new(0.0, 0.0, 5.0), 0.002, 1.0, &samples).unwrap();
        assert_eq!(b.chief().dir(), DVec3::Z);
        // Through a lens: a reference ray 60° off axis misses the blank; one
        // through the back surface 21 mm off axis gets through, but pupil
        // rays 4 mm off it pass outside the 25 mm blank.
        let lens = design_lens(
            &Prescription::sphere(-2.0).unwrap(),
            &LensDesignParams::default(),
        )
        .unwrap();
        let steep = DVec3::new(60f64.to_radians().sin(), 0.0, 60f64.to_radians().cos());
        assert_eq!(
            trace_bundle(Some(&lens), &pl, steep, 0.002, 1.0, &samples),
            Err(SpectaclesError::BundleBlocked(BlockedRay::Reference))
        );
        let rim = lens.back().point(0.021, 0.0).unwrap() - pl.centre_of_rotation();
        assert_eq!(
            trace_bundle(Some(&lens), &pl, rim, 0.004, 1.0, &samples),
            Err(SpectaclesError::BundleBlocked(BlockedRay::Pupil))
        );
        assert!(trace_bundle(Some(&lens), &pl, rim, 0.0, 1.0, &samples).is_ok());
    }

    #[test]
    fn eye_placement_is_checked() {
        let e = EyePlacement::new(DVec3::new(0.0, f64::NAN, 0.0), 0.01).unwrap_err();
        assert_eq!(e.what, "centre of rotation (m)");
        assert_eq!(
            EyePlacement::new(DVec3::ZERO, -0.01).unwrap_err().what,
            "pupil offset from the centre of rotation (m)"
        );
        let pl = EyePlacement::new(DVec3::new(0.0, 0.0, -0.0135), 0.0105).unwrap();
        assert_eq!(pl, EyePlacement::default());
        assert!((pl.pupil_centre(DVec3::Z) - DVec3::new(0.0, 0.0, -0.003)).length() < 1e-15);
        let mut v = serde_json::to_value(pl).unwrap();
        assert_eq!(
            serde_json::from_value::<EyePlacement>(v.clone()).unwrap(),
            pl
        );
        v["pupil_offset_m"] = serde_json::json!(-1.0);
        assert!(serde_json::from_value::<EyePlacement>(v).is_err());
    }
}
