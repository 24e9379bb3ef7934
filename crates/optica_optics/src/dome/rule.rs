//! How many pieces a segment needs: the paper's visual-angle rule and the
//! chord-gap estimate.
//!
//! * [`SplitRule::visual_angle`] is the paper's rule (§3.2 steps 1–2, D4):
//!   the number of pieces depends on the subtended angle only,
//!   `n = ⌈α / Δ⌉`. It is invariant under camera rotation, which is what lets
//!   primitives fixed around the viewer be pre-subdivided once (§3.1).
//!   [`SplitRule::visual_angle_for_tolerance`] picks Δ so that a tangential
//!   piece at the worst polar angle kept ([`DomeProjection::theta_reach`])
//!   meets a pixel tolerance — everywhere else it over-splits.
//! * [`SplitRule::chord_gap`] uses the image curvature where it is largest on
//!   the arc. The chord gap of a *tangential* piece subtending α at polar
//!   angle θ is (D5)
//!   `s ≈ f·α²·(θ/sin θ − cos θ)/(8 sin θ) = α²·f·g(θ)/8`.
//!   It follows from the curvature of the projected great circle: at its
//!   closest approach θ to the dome axis a great circle, parametrised by its
//!   arc angle β, has `cos θ(β) = cos θ·cos β`, so θ'' = cot θ, and azimuth
//!   speed φ' = 1/sin θ; in the image (r = f·θ, polar coordinates) its
//!   centripetal acceleration is `|r'' − r·φ'²| = f·(θ − sin θ cos θ)/sin²θ
//!   = f·g(θ)`. A curve with normal acceleration N deviates from its chord by
//!   N·β(α − β)/2 to second order, at most N·α²/8. The test
//!   `estimate_matches_exact_measure_for_tangential_pieces` holds D5 to the
//!   exact error (D8) within 1% for 1° pieces from θ = 10° to 85°.
//!   We generalise it to any orientation (D6): for a piece crossing the
//!   meridian at angle ψ the normal acceleration of the image per unit arc
//!   angle is
//!   `N(θ, ψ) = f·sin ψ·[T sin²ψ + K cos²ψ] / √(cos²ψ + (θ/sin θ)² sin²ψ)`
//!   with `T = θ(θ − sin θ cos θ)/sin³θ`, `K = 2(sin θ − θ cos θ)/sin²θ`, and
//!   `s ≈ α²·N/8`. At ψ = 90° this is D5; at ψ = 0 (radial) it is 0, so radial
//!   segments are never split. Along one great circle Clairaut's relation
//!   `sin θ · sin ψ = sin θ₀` (θ₀ the circle's closest approach to the axis,
//!   `sin θ₀ = |axis · pole|`) fixes ψ, and N grows monotonically with θ
//!   (checked numerically against finite differences of the projection while
//!   deriving this, and by the test `normal_acceleration_limits`), so its
//!   maximum on an arc is at the arc's largest θ. Then
//!   `n = ⌈α·√(N_max/(8·tol))⌉`.
//!
//! Where triangles are culled at a guard cone (FOV > 180°), an arc that
//! leaves it also gets pieces of at most
//! [`DomeProjection::guard_piece_rad`] (see [`DomeProjection::theta_reach`]). Both rules cap n at
//! [`MAX_PIECES`] (reported as `capped`).

use std::f64::consts::PI;

use glam::DVec3;

use super::arc::{Arc, canonical_less};
use super::camera::DomeProjection;
use super::error::DomeError;
use super::lens::FisheyeLens;
use crate::input::{self, InvalidInput};

/// Largest number of pieces one edge is split into. Reached only for
/// sub-pixel tolerances on huge edges or for edges near the antipode guard
/// of FOVs close to 360°; the error bound may then not hold.
///
/// Why 1024: a 180° edge (the longest there is) in 1024 pieces has pieces of
/// 0.18°, which by D5 meet 0.01 px at the rim of an 8K 180° frame
/// (f = 2608 px/rad): every tolerance a renderer asks for is reached well
/// below the cap. It bounds the output of one bad edge (a huge tolerance
/// mistake, an FOV next to 360°) to a few thousand vertices.
pub const MAX_PIECES: u32 = 1024;

/// Below this polar angle the curvature factors use their series
/// (T, K, g → 2θ/3), avoiding the 0/0 of the closed forms. The series'
/// relative error is O(θ²), 1e-8 here, while the closed forms lose
/// ~1e-16/θ² of their digits to cancellation (1e-8 here too): the crossover.
const SMALL_THETA: f64 = 1e-4;

/// The curvature N (D6) is evaluated no closer than this to the antipode,
/// where sin θ → 0 and T, K diverge. Arcs that reach further are caught by
/// the guard cone (FOV > 180°) or the view plane (FOV ≤ 180°), so this only
/// keeps N finite for FOVs within ~1e-6 rad of 360°, where
/// [`MAX_PIECES`] caps the pieces anyway.
const CURVATURE_ANTIPODE_GAP_RAD: f64 = 1e-6;

/// A rule giving the number of pieces of an edge, checked when built:
/// [`SplitRule::visual_angle`] (the paper's), [`SplitRule::chord_gap`] (a
/// pixel tolerance) or [`SplitRule::visual_angle_for_tolerance`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SplitRule(Rule);

/// The two rules, with parameters known to be finite and positive.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Rule {
    /// Pieces of at most `max_piece_rad` subtended angle, radians.
    VisualAngle { max_piece_rad: f64 },
    /// Pieces whose estimated chord gap (D5, D6) is at most `tolerance_px`.
    ChordGap { tolerance_px: f64 },
}

/// Number of pieces of one edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pieces {
    /// Pieces (≥ 1).
    pub n: u32,
    /// Whether [`MAX_PIECES`] limited `n`.
    pub capped: bool,
}

/// g(θ) = (θ/sin θ − cos θ)/sin θ = (θ − sin θ cos θ)/sin²θ, the tangential
/// curvature factor of D5 (2θ/3 near the zenith, π/2 on the 180° rim,
/// unbounded towards the antipode).
pub(crate) fn tangential_factor(theta: f64) -> f64 {
    if theta < SMALL_THETA {
        return 2.0 * theta / 3.0;
    }
    let (s, c) = theta.sin_cos();
    (theta - s * c) / (s * s)
}

/// The chord gap (D5) of a tangential piece subtending `alpha` radians at
/// polar angle `theta`, in px for `focal_px` px/rad.
#[cfg(test)]
pub(crate) fn tangential_chord_gap_px(focal_px: f64, alpha: f64, theta: f64) -> f64 {
    focal_px * alpha * alpha * tangential_factor(theta) / 8.0
}

/// Largest subtended angle of a tangential piece at polar angle `theta`
/// whose chord gap (D5) is `tolerance_px`: `√(8·tol/(f·g(θ)))`.
#[cfg(test)]
pub(crate) fn max_tangential_piece_rad(focal_px: f64, theta: f64, tolerance_px: f64) -> f64 {
    (8.0 * tolerance_px / (focal_px * tangential_factor(theta))).sqrt()
}

/// N(θ, ψ) of D6: the normal acceleration, in px per rad², of the image of a
/// great circle crossing polar angle `theta` at angle ψ to the meridian
/// (`sin_psi` = 1 tangential, 0 radial). The chord gap of a piece subtending
/// α is about α²·N/8.
pub(crate) fn normal_acceleration_px(focal_px: f64, theta: f64, sin_psi: f64) -> f64 {
    let sp = sin_psi.clamp(0.0, 1.0);
    if theta < SMALL_THETA {
        return focal_px * sp * 2.0 * theta / 3.0;
    }
    let cos2 = 1.0 - sp * sp;
    let (s, c) = theta.sin_cos();
    let t = theta * (theta - s * c) / (s * s * s);
    let k = 2.0 * (s - theta * c) / (s * s);
    let q = theta / s;
    focal_px * sp * (t * sp * sp + k * cos2) / (cos2 + q * q * sp * sp).sqrt()
}

/// Pieces for `steps` = α/Δ: ⌈steps⌉, at least 1, at most [`MAX_PIECES`].
pub(crate) fn count_pieces(steps: f64) -> Pieces {
    let want = steps.ceil();
    if want.is_nan() || want > f64::from(MAX_PIECES) {
        // The cap is the documented fallback (NaN cannot occur for valid arcs).
        return Pieces {
            n: MAX_PIECES,
            capped: true,
        };
    }
    Pieces {
        n: (want as u32).max(1),
        capped: false,
    }
}

impl SplitRule {
    /// The paper's rule: pieces of at most `max_piece_rad` subtended angle
    /// (D4). Errors: `max_piece_rad` not finite and positive.
    pub fn visual_angle(max_piece_rad: f64) -> Result<Self, InvalidInput> {
        let max_piece_rad = input::positive("maximum piece angle (rad)", max_piece_rad)?;
        Ok(Self(Rule::VisualAngle { max_piece_rad }))
    }

    /// Pieces whose estimated chord gap (D5, D6) is at most `tolerance_px`.
    /// Errors: `tolerance_px` not finite and positive.
    pub fn chord_gap(tolerance_px: f64) -> Result<Self, InvalidInput> {
        let tolerance_px = input::positive("pixel tolerance (px)", tolerance_px)?;
        Ok(Self(Rule::ChordGap { tolerance_px }))
    }

    /// The paper's rule calibrated for a pixel tolerance: Δ such that a
    /// tangential piece at the largest polar angle a kept piece reaches
    /// ([`DomeProjection::theta_reach`]) has chord gap `tolerance_px` (D5),
    /// at most π (no split). 4K/180° and 0.5 px give Δ ≈ 2.53°.
    /// Errors: `tolerance_px` not finite and positive.
    pub fn visual_angle_for_tolerance(
        proj: &DomeProjection,
        tolerance_px: f64,
    ) -> Result<Self, InvalidInput> {
        let tolerance_px = input::positive("pixel tolerance (px)", tolerance_px)?;
        let max_piece_rad = (8.0 * tolerance_px / proj.worst_curvature_px())
            .sqrt()
            .min(PI);
        // A tolerance so small that Δ underflows to 0 gives n = ∞ pieces,
        // which the cap turns into MAX_PIECES: the documented fallback.
        Ok(Self(Rule::VisualAngle { max_piece_rad }))
    }

    /// The largest subtended angle of a piece (radians), for the
    /// visual-angle rule; `None` for the chord-gap rule.
    pub fn max_piece_rad(&self) -> Option<f64> {
        match self.0 {
            Rule::VisualAngle { max_piece_rad } => Some(max_piece_rad),
            Rule::ChordGap { .. } => None,
        }
    }

    /// The pixel tolerance, for the chord-gap rule; `None` for the
    /// visual-angle rule.
    pub fn tolerance_px(&self) -> Option<f64> {
        match self.0 {
            Rule::ChordGap { tolerance_px } => Some(tolerance_px),
            Rule::VisualAngle { .. } => None,
        }
    }

    /// Pieces for the segment a→b (view space) under this rule. Symmetric
    /// in a and b bit for bit (the endpoints are ordered canonically first).
    /// Errors as [`split_segment`](super::split_segment).
    pub fn pieces(&self, proj: &DomeProjection, a: DVec3, b: DVec3) -> Result<Pieces, DomeError> {
        let (p, q) = if canonical_less(b, a) { (b, a) } else { (a, b) };
        let arc = Arc::new(p, q)?;
        Ok(self.pieces_of_arc(proj, &arc))
    }

    /// Whether an arc subtending `alpha` needs one piece wherever it lies:
    /// under the chord gap, if even the worst curvature of the projection
    /// ([`DomeProjection::worst_curvature_px`]) keeps it within the
    /// tolerance (for lenses other than the equidistant, whose worst
    /// curvature is sampled, with a margin of 2); under the visual angle,
    /// if it is within the step; and, where there is a guard cone, if it is
    /// within the guard piece. The full rule gives one piece then too; the
    /// test skips the arc's polar angles and curvature for most edges of
    /// distant geometry. `alpha` must be the arc's subtended angle as
    /// [`split_segment`](super::split_segment) computes it, symmetric in
    /// the endpoints bit for bit, so that both triangles sharing an edge
    /// agree.
    pub(crate) fn is_short(&self, proj: &DomeProjection, alpha: f64) -> bool {
        let short = match self.0 {
            Rule::VisualAngle { max_piece_rad } => alpha <= max_piece_rad,
            Rule::ChordGap { tolerance_px } => {
                alpha * alpha * proj.worst_curvature_px() * Self::margin(proj) <= 8.0 * tolerance_px
            }
        };
        short && proj.guard_piece_rad().is_none_or(|piece| alpha <= piece)
    }

    /// [`Self::is_short`] of an angle bound given squared (a bound on α²
    /// needs no root): whether an arc with α² ≤ `alpha_sq` is surely short.
    pub(crate) fn is_short_squared(&self, proj: &DomeProjection, alpha_sq: f64) -> bool {
        let short = match self.0 {
            Rule::VisualAngle { max_piece_rad } => alpha_sq <= max_piece_rad * max_piece_rad,
            Rule::ChordGap { tolerance_px } => {
                alpha_sq * proj.worst_curvature_px() * Self::margin(proj) <= 8.0 * tolerance_px
            }
        };
        short
            && proj
                .guard_piece_rad()
                .is_none_or(|piece| alpha_sq <= piece * piece)
    }

    /// The short-arc test's margin on the worst curvature: 1 for the
    /// equidistant lens (its worst curvature is known), 2 for the others
    /// (sampled).
    fn margin(proj: &DomeProjection) -> f64 {
        if proj.lens() == FisheyeLens::Equidistant {
            1.0
        } else {
            2.0
        }
    }

    /// Pieces of an arc built in canonical order.
    pub(crate) fn pieces_of_arc(&self, proj: &DomeProjection, arc: &Arc) -> Pieces {
        const WHOLE: Pieces = Pieces {
            n: 1,
            capped: false,
        };
        if arc.is_point() {
            return WHOLE;
        }
        if self.is_short(proj, arc.alpha) {
            return WHOLE;
        }
        let range = arc.theta_range(proj.axis());
        // An arc leaving the guard cone (FOV > 180°, triangles: they are
        // culled per sub-triangle, not clipped) gets pieces of at most the
        // guard piece, so a kept piece cannot reach the antipode and a
        // culled one starts outside the rim. Without
        // this, a radial arc through the antipode (N = 0) stays one piece and
        // its chord jumps across the image.
        let guard_piece = proj
            .guard_piece_rad()
            .filter(|_| range.max > proj.theta_clip());
        let leaves = guard_piece.is_some();
        let guard = guard_piece.map_or(0.0, |piece| arc.alpha / piece);
        let steps = match self.0 {
            Rule::VisualAngle { max_piece_rad } => arc.alpha / max_piece_rad,
            Rule::ChordGap { tolerance_px } => {
                let at = |theta: f64| {
                    let n = arc_normal_acceleration_px(proj, arc, range.min, theta);
                    arc.alpha * (n / (8.0 * tolerance_px)).sqrt()
                };
                if leaves {
                    // Kept pieces end inside the guard cone and bulge past it
                    // by at most half a piece: size the pieces for the guard
                    // angle, then for that angle plus half such a piece (N
                    // grows with θ, so this only shrinks the pieces).
                    let n0 = at(proj.theta_clip()).max(guard).ceil().max(1.0);
                    at((proj.theta_clip() + 0.5 * arc.alpha / n0).min(range.max))
                } else {
                    at(range.max)
                }
            }
        };
        count_pieces(steps.max(guard))
    }
}

/// Polar angles at which a lens other than the equidistant has its
/// curvature N (D10) sampled along an arc, ends included. For the
/// equidistant lens N is known to grow with θ along a great circle, so its
/// largest θ suffices; for the others (equisolid, stereographic,
/// orthographic, polynomial) no such proof is at hand, so the largest of
/// these samples stands for the maximum, and the proptest
/// `every_lens_meets_the_tolerance` holds the result to the exact error.
const LENS_CURVATURE_SAMPLES: u32 = 8;

/// N of D10: the normal acceleration, in px per rad², of the image of a
/// great circle crossing polar angle `theta` at angle ψ to the meridian,
/// for any radial lens r = F(θ) = f·g(θ). With θ' = cos ψ, φ' = sin ψ/sin θ
/// along the circle (unit speed) and the sphere's geodesic equations
/// θ'' = cos θ sin²ψ/sin θ, φ'' = −2 cos θ cos ψ sin ψ/sin²θ, the image
/// (polar: r = F, φ) has velocity (F' cos ψ, F sin ψ/sin θ) and
/// acceleration (F'' cos²ψ + F' θ'' − F φ'², F φ'' + 2F' cos ψ φ'); N is
/// |v × a|/|v|. For the equidistant lens it equals D6.
pub(crate) fn lens_normal_acceleration_px(proj: &DomeProjection, theta: f64, sin_psi: f64) -> f64 {
    let map = proj.map();
    let t = theta.max(SMALL_THETA);
    let sp = sin_psi.clamp(0.0, 1.0);
    let cp = (1.0 - sp * sp).sqrt();
    let (s, c) = t.sin_cos();
    let (f0, f1, f2) = (map.radius(t), map.slope(t), map.bend(t));
    let (vr, vphi) = (f1 * cp, f0 * sp / s);
    let ar = f2 * cp * cp + f1 * c * sp * sp / s - f0 * sp * sp / (s * s);
    let aphi = 2.0 * cp * sp * (f1 / s - f0 * c / (s * s));
    let speed = vr.hypot(vphi);
    if speed > 0.0 {
        proj.focal_px() * (vr * aphi - vphi * ar).abs() / speed
    } else {
        0.0
    }
}

/// Largest N (D6, D10) on an arc whose polar angles span `theta_lo ..=
/// theta_hi`, limited to [`DomeProjection::theta_reach`] (no kept piece
/// goes further).
pub(crate) fn arc_normal_acceleration_px(
    proj: &DomeProjection,
    arc: &Arc,
    theta_lo: f64,
    theta_hi: f64,
) -> f64 {
    let limit = proj.theta_reach().min(PI - CURVATURE_ANTIPODE_GAP_RAD);
    let hi = theta_hi.min(limit);
    let sin_theta0 = arc.pole().dot(proj.axis()).abs();
    let sin_psi = |theta: f64| {
        let s = theta.sin();
        if s > 0.0 {
            (sin_theta0 / s).min(1.0)
        } else {
            1.0
        }
    };
    if proj.lens() == FisheyeLens::Equidistant {
        return normal_acceleration_px(proj.focal_px(), hi, sin_psi(hi));
    }
    let lo = theta_lo.min(hi);
    let at = |theta: f64| lens_normal_acceleration_px(proj, theta, sin_psi(theta));
    let samples = (0..=LENS_CURVATURE_SAMPLES)
        .map(|i| at(lo + (hi - lo) * f64::from(i) / f64::from(LENS_CURVATURE_SAMPLES)))
        .fold(0.0, f64::max);
    // The rim, from both sides: where a continued lens (orthographic,
    // polynomial) changes its second derivative, N jumps.
    let rim = proj.theta_max();
    if (lo..=hi).contains(&rim) {
        samples.max(at(rim)).max(at(rim.next_up()))
    } else {
        samples
    }
}

/// The largest N (D6, D10) of any piece of geometry kept: tangential at
/// [`DomeProjection::theta_reach`] for the equidistant lens (D5); for the
/// other lenses the largest over a grid of polar angles up to it and of
/// orientations.
pub(crate) fn worst_normal_acceleration_px(proj: &DomeProjection) -> f64 {
    let reach = proj.theta_reach().min(PI - CURVATURE_ANTIPODE_GAP_RAD);
    if proj.lens() == FisheyeLens::Equidistant {
        return proj.focal_px() * tangential_factor(reach);
    }
    let mut worst = 0.0f64;
    for i in 1..=64 {
        let theta = reach * f64::from(i) / 64.0;
        for j in 0..=16 {
            worst = worst.max(lens_normal_acceleration_px(
                proj,
                theta,
                f64::from(j) / 16.0,
            ));
        }
    }
    worst
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::input::Expected;

    fn dome(fov: f64) -> DomeProjection {
        crate::dome::test_dome(fov, 0.0, 4096)
    }

    fn chord_gap(tolerance_px: f64) -> SplitRule {
        SplitRule::chord_gap(tolerance_px).unwrap()
    }

    #[test]
    fn chord_gap_numbers_at_the_4k_rim() {
        // D5 at 4K/180°: a 10° tangential edge at the rim is off by ~8 px
        // (7.8; the exact rim sagitta 2048·(1 − cos 5°) is 7.79), and 0.5 px
        // needs ≤ ~2.5° pieces there.
        let f = dome(180.0).focal_px();
        let s = tangential_chord_gap_px(f, 10f64.to_radians(), PI / 2.0);
        assert!((s - 7.8).abs() < 0.1, "s = {s}");
        let d = max_tangential_piece_rad(f, PI / 2.0, 0.5).to_degrees();
        assert!((d - 2.53).abs() < 0.01, "Δ = {d}°");
        // The two limits quoted: f·α²·θ/12 near the centre, (π/16)·f·α² at the rim.
        let a = 0.01;
        assert!(
            (tangential_chord_gap_px(f, a, 1e-3) / (f * a * a * 1e-3 / 12.0) - 1.0).abs() < 1e-6
        );
        assert!(
            (tangential_chord_gap_px(f, a, PI / 2.0) / (PI / 16.0 * f * a * a) - 1.0).abs() < 1e-12
        );
    }

    #[test]
    fn normal_acceleration_limits() {
        let f = 1000.0;
        for theta in [1e-5, 1e-3, 0.3, 1.0, PI / 2.0, 2.0, 2.8] {
            // Tangential: D6 reduces to D5.
            let n = normal_acceleration_px(f, theta, 1.0);
            assert!(
                (n / (f * tangential_factor(theta)) - 1.0).abs() < 1e-6,
                "θ = {theta}"
            );
            // Radial: straight image.
            assert_eq!(normal_acceleration_px(f, theta, 0.0), 0.0);
            // Tangential is the worst orientation.
            for sp in [0.1, 0.5, 0.9, 0.99] {
                assert!(normal_acceleration_px(f, theta, sp) <= n * (1.0 + 1e-12));
            }
        }
        // Monotone in θ along a great circle (Clairaut): closest approach 30°.
        let s0 = 30f64.to_radians().sin();
        let mut prev = 0.0;
        for k in 30..=150 {
            let th = f64::from(k).to_radians();
            let n = normal_acceleration_px(f, th, s0 / th.sin());
            assert!(n >= prev, "θ = {k}°");
            prev = n;
        }
    }

    /// The lenses of the tests: every mapping, a calibrated-looking
    /// polynomial among them.
    pub(crate) const TEST_LENSES: [FisheyeLens; 5] = [
        FisheyeLens::Equidistant,
        FisheyeLens::Equisolid,
        FisheyeLens::Stereographic,
        FisheyeLens::Orthographic,
        FisheyeLens::Polynomial {
            k: [1.0, -0.04, 0.003, -0.0001],
        },
    ];

    #[test]
    fn lens_curvature_is_d6_for_the_equidistant_lens() {
        let p = dome(200.0);
        for theta in [1e-3, 0.3, 1.0, PI / 2.0, 2.0, 2.8] {
            for sp in [0.0, 0.1, 0.5, 0.9, 1.0] {
                let d6 = normal_acceleration_px(p.focal_px(), theta, sp);
                let d10 = lens_normal_acceleration_px(&p, theta, sp);
                assert!(
                    (d10 - d6).abs() <= 1e-9 * d6.max(1.0),
                    "θ {theta}, sin ψ {sp}: {d10} vs {d6}"
                );
            }
        }
    }

    #[test]
    fn lens_curvature_matches_finite_differences_of_the_projection() {
        // Along great circles at several closest approaches, N (D10) against
        // the curvature of the projected pixels (central differences).
        for lens in TEST_LENSES {
            let fov = lens.max_fov_deg().min(240.0);
            let p = crate::dome::test_lens_dome(lens, fov, 0.0, 4096);
            let mut checked = 0;
            for theta0_deg in [5.0, 30.0, 60.0, 85.0] {
                let t0 = f64::to_radians(theta0_deg);
                // The circle through (θ0, φ = 0) perpendicular to the meridian.
                let a = p.from_dome(DVec3::new(t0.sin(), 0.0, t0.cos()));
                let w = p.from_dome(DVec3::Y);
                for k in 0..40 {
                    let beta = f64::from(k) * 0.04;
                    let dir = |b: f64| b.cos() * a + b.sin() * w;
                    let theta = p.theta(dir(beta));
                    if theta > p.theta_max() - 0.01 || theta < 1e-2 {
                        continue;
                    }
                    let h = 1e-4;
                    let px = |b: f64| p.pixel_of_direction(dir(b)).unwrap();
                    let (x0, x1, x2) = (px(beta - h), px(beta), px(beta + h));
                    let v = (x2 - x0) / (2.0 * h);
                    let acc = (x2 - 2.0 * x1 + x0) / (h * h);
                    let fd = v.perp_dot(acc).abs() / v.length();
                    let sin_psi = (t0.sin() / theta.sin()).min(1.0);
                    let n = lens_normal_acceleration_px(&p, theta, sin_psi);
                    assert!(
                        (n - fd).abs() <= 2e-3 * fd.max(n) + 0.05,
                        "{lens:?} θ0 {theta0_deg}° θ {theta}: N {n} vs {fd}"
                    );
                    checked += 1;
                }
            }
            assert!(checked > 40, "{lens:?}: {checked}");
        }
    }

    #[test]
    fn rim_edge_pieces_at_half_pixel() {
        // A 10° tangential edge on the 4K/180° rim at 0.5 px: 10°/2.53° → 4.
        let p = dome(180.0);
        let h = 5f64.to_radians();
        let a = DVec3::new(h.sin(), -h.cos(), 0.0) * 3.0;
        let b = DVec3::new(-h.sin(), -h.cos(), 0.0) * 7.0;
        let rule = chord_gap(0.5);
        assert_eq!(
            rule.pieces(&p, a, b).unwrap(),
            Pieces {
                n: 4,
                capped: false
            }
        );
        let paper = SplitRule::visual_angle_for_tolerance(&p, 0.5).unwrap();
        assert!((paper.max_piece_rad().unwrap().to_degrees() - 2.53).abs() < 0.01);
        assert_eq!(paper.pieces(&p, a, b).unwrap().n, 4);
        assert_eq!(
            SplitRule::visual_angle(0.1)
                .unwrap()
                .pieces(&p, a, b)
                .unwrap()
                .n,
            2
        );
    }

    #[test]
    fn radial_segments_need_no_split() {
        // Any segment in a plane through the dome axis projects to a straight
        // line through the centre (D1: its azimuth is constant): one piece at
        // any tolerance.
        let p = dome(180.0);
        let rule = chord_gap(0.01);
        for phi in [0.0, 0.7, 2.0, 4.0] {
            let (s, c) = f64::sin_cos(phi);
            let a = DVec3::new(c * 0.1, s * 0.1, -1.0);
            let b = DVec3::new(c * 5.0, s * 5.0, -0.01);
            assert_eq!(rule.pieces(&p, a, b).unwrap().n, 1);
        }
    }

    #[test]
    fn bad_parameters_and_caps() {
        let p = dome(180.0);
        let err = SplitRule::chord_gap(0.0).unwrap_err();
        assert_eq!(
            (err.what, err.value, err.expected),
            ("pixel tolerance (px)", 0.0, Expected::Positive)
        );
        assert_eq!(
            SplitRule::chord_gap(f64::NAN).unwrap_err().what,
            "pixel tolerance (px)"
        );
        let err = SplitRule::visual_angle(-1.0).unwrap_err();
        assert_eq!((err.what, err.value), ("maximum piece angle (rad)", -1.0));
        assert_eq!(
            SplitRule::visual_angle_for_tolerance(&p, f64::INFINITY)
                .unwrap_err()
                .value,
            f64::INFINITY
        );
        // Accessors say which rule it is.
        assert_eq!(
            (
                chord_gap(2.0).tolerance_px(),
                chord_gap(2.0).max_piece_rad()
            ),
            (Some(2.0), None)
        );
        let paper = SplitRule::visual_angle(0.25).unwrap();
        assert_eq!(
            (paper.max_piece_rad(), paper.tolerance_px()),
            (Some(0.25), None)
        );
        // A tolerance so large that Δ would exceed π: no split, Δ = π.
        let lax = SplitRule::visual_angle_for_tolerance(&p, f64::MAX).unwrap();
        assert_eq!(lax.max_piece_rad(), Some(PI));
        let tiny = chord_gap(1e-12);
        let pc = tiny
            .pieces(&p, DVec3::new(1.0, 0.0, 0.0), DVec3::new(0.0, 1.0, 0.0))
            .unwrap();
        assert_eq!(
            pc,
            Pieces {
                n: MAX_PIECES,
                capped: true
            }
        );
        // Δ underflowing to 0 is capped too, not NaN.
        let zero = SplitRule::visual_angle_for_tolerance(&p, f64::from_bits(1)).unwrap();
        let pc = zero
            .pieces(&p, DVec3::new(1.0, 0.0, -1.0), DVec3::new(0.0, 1.0, -1.0))
            .unwrap();
        assert_eq!(
            pc,
            Pieces {
                n: MAX_PIECES,
                capped: true
            }
        );
    }
}
