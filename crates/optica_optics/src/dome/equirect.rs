//! Equirectangular (longitude–latitude) panoramas: the whole sphere of
//! directions on a 2:1 image, the other projection Bevy users ask a
//! panoramic camera for. Not in the paper, whose method it borrows: every
//! vertex projected in the vertex stage, edges split until their chords lie
//! within a pixel tolerance of their true image.
//!
//! ## Equations
//!
//! * **E1** — in the frame (x, y, z) = (image right, image up, image
//!   centre's direction) of a point (the dome frame of [`DomeProjection`]
//!   with the axis at the image centre instead of the zenith: at tilt 0 the
//!   camera's −Z is the centre, +Y the north pole), longitude
//!   `λ = atan2(x, z)` ∈ [−π, π] and latitude `φ = atan2(y, √(x² + z²))`.
//!   Pixel `u = W/2 + λ·W/(2π)`, `v = H/2 − φ·H/π`: the image fills its
//!   target, 2:1 or not (a target of another shape stretches it).
//! * **E2** (ours) — the image of a great circle with unit pole n, at unit
//!   direction d with unit tangent t along it (h = cos φ = √(d_x² + d_z²)):
//!   `λ' = n_y/h²`, `λ'' = 2·n_y·d_y·t_y/h⁴`, `φ' = t_y/h`,
//!   `φ'' = d_y·(t_y² − h²)/h³`; the pixel curve has velocity
//!   `(s_u λ', −s_v φ')` and acceleration `(s_u λ'', −s_v φ'')`, and
//!   `N = |v × a|/|v|` is its normal acceleration. Meridians (n_y = 0) and
//!   the equator are straight (N = 0); N grows without bound towards the
//!   poles. The chord-gap rule splits an arc into `⌈α·√(1.1·N_max/(8·tol))⌉`
//!   pieces as for the fisheyes (D6), N_max the largest of N at the arc's
//!   ends, its point nearest a pole and [`CURVATURE_SAMPLES`] points
//!   between, and the factor 1.1 a margin for N's change along a piece.
//!
//! ## Seam and poles
//!
//! A triangle or segment crossing the seam (λ = ±π, the half-plane x = 0,
//! z < 0) would be drawn the long way round, across the whole image. So
//! every primitive is first cut by the planes x = 0 and z = 0 into parts
//! that each lie in one quarter of longitudes (cuts exact: the cut
//! coordinate is set to 0), which also puts any point where a triangle
//! crosses a pole's axis at a corner of its parts. After refinement, a
//! vertex on the seam is moved [`SEAM_NUDGE_RAD`] into its part's side, and
//! a vertex on a pole — a whole row of the image — becomes one vertex per
//! neighbouring longitude, moved that far towards it: the triangle
//! (pole, A, B) becomes the quad (pole at λ_A, A, B, pole at λ_B), the
//! wedge between two meridians that it covers in the image. The moves make
//! the shader's atan2 land on the right side in f32; they shift the image
//! by `SEAM_NUDGE_RAD·W/(2π)` px at most (0.07 px at 4K).

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::arc::Arc;
use super::error::DomeError;
use super::projection::{ImagePoint, Projected};
use super::rule::{Pieces, SplitRule, count_pieces};
use crate::input;

/// Points within this angle of a pole (relative: √(x² + z²) ≤ this·|q|)
/// are [`Projected::Pole`]: their longitude is noise (1e-16/1e-9 = 1e-7
/// rad, 1e-4 px at 4K).
pub const POLE_EPS_RAD: f64 = 1e-9;

/// How far a vertex on the seam or a pole is moved into its part's side, in
/// radians (see the module docs). Large enough to survive the f32 model
/// and view transforms of a vertex shader (~1e-7 relative, so a mesh may lie
/// 100× farther from its own origin than from the camera), small enough to
/// be invisible: 1e-4·W/(2π) px, 0.065 px at 4096 wide.
pub const SEAM_NUDGE_RAD: f64 = 1e-4;

/// Points at which N (E2) is sampled between an arc's ends.
pub const CURVATURE_SAMPLES: u32 = 8;

/// The chord-gap rule sizes pieces for this many times the largest N found:
/// `α²N/8` is the gap of a piece of constant curvature, and near a pole N
/// changes fast along a piece (as 1/h²), so the gap can exceed it. Without
/// the margin the dome report measured edges 0.4% over a 2 px tolerance;
/// 1.1 costs ~5% more pieces.
const CURVATURE_MARGIN: f64 = 1.1;

/// Settings of an equirectangular panorama.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct EquirectSettings {
    /// Width of the image in pixels (360° of longitude), at least 1.
    pub width_px: u32,
    /// Height in pixels (180° of latitude), at least 1; `None`: half the
    /// width.
    #[serde(default)]
    pub height_px: Option<u32>,
    /// Pitch of the image centre below the camera's forward direction, in
    /// degrees (as a dome's tilt: the frame turns about the camera's +X).
    #[serde(default)]
    pub tilt_deg: f64,
}

impl Default for EquirectSettings {
    /// A 4096 × 2048 panorama, untilted.
    fn default() -> Self {
        Self {
            width_px: 4096,
            height_px: None,
            tilt_deg: 0.0,
        }
    }
}

/// A checked equirectangular panorama: E1 forward and back, E2 for the
/// refinement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EquirectProjection {
    settings: EquirectSettings,
    /// Image right, image up (north pole), image centre's direction; view
    /// space, unit.
    right: DVec3,
    up: DVec3,
    forward: DVec3,
    /// px per radian of longitude and of latitude.
    scale: DVec2,
    /// Half the image size (the centre, λ = φ = 0).
    half: DVec2,
}

impl EquirectProjection {
    /// Checks `settings`. Errors ([`DomeError::Input`]): a size of 0 px, a
    /// tilt that is not finite.
    pub fn new(settings: &EquirectSettings) -> Result<Self, DomeError> {
        input::positive("panorama width (px)", f64::from(settings.width_px))?;
        let height = settings.height_px.unwrap_or(settings.width_px.div_ceil(2));
        input::positive("panorama height (px)", f64::from(height))?;
        input::finite("panorama tilt (deg)", settings.tilt_deg)?;
        let (s, c) = settings.tilt_deg.to_radians().sin_cos();
        let size = DVec2::new(f64::from(settings.width_px), f64::from(height));
        Ok(Self {
            settings: *settings,
            right: DVec3::X,
            up: DVec3::new(0.0, c, -s),
            forward: DVec3::new(0.0, -s, -c),
            scale: DVec2::new(size.x / TAU, size.y / PI),
            half: 0.5 * size,
        })
    }

    /// The settings it was built from.
    pub fn settings(&self) -> EquirectSettings {
        self.settings
    }

    /// Image width and height in px.
    pub fn size_px(&self) -> DVec2 {
        2.0 * self.half
    }

    /// px per radian of longitude (x) and latitude (y).
    pub fn scale_px(&self) -> DVec2 {
        self.scale
    }

    /// The image centre's direction in view space (λ = φ = 0).
    pub fn forward(&self) -> DVec3 {
        self.forward
    }

    /// The north pole's direction in view space (the image's top row).
    pub fn up(&self) -> DVec3 {
        self.up
    }

    /// A view-space point in the frame (right, up, forward).
    pub fn to_frame(&self, p: DVec3) -> DVec3 {
        DVec3::new(p.dot(self.right), p.dot(self.up), p.dot(self.forward))
    }

    /// Frame coordinates back to view space.
    pub fn from_frame(&self, q: DVec3) -> DVec3 {
        q.x * self.right + q.y * self.up + q.z * self.forward
    }

    /// Pixel of frame coordinates `q` (E1); `None` on a pole's axis.
    pub fn pixel_of_frame(&self, q: DVec3) -> Option<DVec2> {
        let h = q.x.hypot(q.z);
        if !(h > POLE_EPS_RAD * q.length()) {
            return None;
        }
        let lon = q.x.atan2(q.z);
        let lat = q.y.atan2(h);
        Some(self.half + DVec2::new(self.scale.x * lon, -self.scale.y * lat))
    }

    /// Projects a view-space point (E1). [`Projected::Visible`] for every
    /// direction but the poles ([`Projected::Pole`]); `theta` is the angle
    /// from the image centre's direction.
    pub fn project(&self, p: DVec3) -> Projected {
        if !p.is_finite() {
            return Projected::Invalid;
        }
        if p == DVec3::ZERO {
            return Projected::Origin;
        }
        let q = self.to_frame(p);
        match self.pixel_of_frame(q) {
            None => Projected::Pole,
            Some(pixel) => Projected::Visible(ImagePoint {
                pixel,
                theta: q.x.hypot(q.y).atan2(q.z),
                distance: p.length(),
            }),
        }
    }

    /// Pixel of a view-space direction; `None` at the origin, on a pole or
    /// for non-finite input.
    pub fn pixel_of_direction(&self, d: DVec3) -> Option<DVec2> {
        if !d.is_finite() || d == DVec3::ZERO {
            return None;
        }
        self.pixel_of_frame(self.to_frame(d))
    }

    /// Unit view-space direction seen at a pixel; `None` outside the image
    /// or for non-finite input.
    pub fn unproject(&self, pixel: DVec2) -> Option<DVec3> {
        if !pixel.is_finite() {
            return None;
        }
        let size = self.size_px();
        if pixel.x < 0.0 || pixel.y < 0.0 || pixel.x > size.x || pixel.y > size.y {
            return None;
        }
        let lon = (pixel.x - self.half.x) / self.scale.x;
        let lat = ((self.half.y - pixel.y) / self.scale.y).clamp(-FRAC_PI_2, FRAC_PI_2);
        let (sl, cl) = lon.sin_cos();
        let (sp, cp) = lat.sin_cos();
        Some(self.from_frame(DVec3::new(cp * sl, sp, cp * cl)))
    }

    /// N of E2 at unit frame direction `d` with unit tangent `t` on a great
    /// circle of unit pole `n`, px per rad²; `None` within 1e-6 rad of a
    /// pole, where only a meridian can pass (and is straight).
    fn normal_acceleration(&self, d: DVec3, t: DVec3, n: DVec3) -> Option<f64> {
        let h = d.x.hypot(d.z);
        if h < 1e-6 {
            return None;
        }
        let h2 = h * h;
        let dlon = n.y / h2;
        let ddlon = 2.0 * n.y * d.y * t.y / (h2 * h2);
        let dlat = t.y / h;
        let ddlat = d.y * (t.y * t.y - h2) / (h2 * h);
        let v = DVec2::new(self.scale.x * dlon, -self.scale.y * dlat);
        let a = DVec2::new(self.scale.x * ddlon, -self.scale.y * ddlat);
        let speed = v.length();
        (speed > 0.0).then(|| v.perp_dot(a).abs() / speed)
    }

    /// The largest N (E2) along an arc given in frame coordinates.
    pub(crate) fn arc_curvature_px(&self, arc: &Arc) -> f64 {
        if arc.is_point() {
            return 0.0;
        }
        let n = arc.pole();
        let at = |beta: f64| {
            let (s, c) = beta.sin_cos();
            let d = c * arc.a_hat + s * arc.w_hat;
            let t = -s * arc.a_hat + c * arc.w_hat;
            self.normal_acceleration(d, t, n).unwrap_or(0.0)
        };
        let mut worst = at(0.0).max(at(arc.alpha));
        for i in 1..CURVATURE_SAMPLES {
            worst = worst.max(at(arc.alpha * f64::from(i) / f64::from(CURVATURE_SAMPLES)));
        }
        // Nearest a pole: where d_y = a_y cos β + w_y sin β is extreme.
        let peak = arc.w_hat.y.atan2(arc.a_hat.y);
        for beta in [peak, peak + PI, peak - PI] {
            if beta > 0.0 && beta < arc.alpha {
                worst = worst.max(at(beta));
            }
        }
        worst
    }

    /// Pieces of an arc (frame coordinates, canonical order) under `rule`.
    pub(crate) fn pieces_of_arc(&self, rule: SplitRule, arc: &Arc) -> Pieces {
        if arc.is_point() {
            return Pieces {
                n: 1,
                capped: false,
            };
        }
        let steps = match (rule.max_piece_rad(), rule.tolerance_px()) {
            (Some(piece), _) => arc.alpha / piece,
            (None, Some(tol)) => {
                let n = CURVATURE_MARGIN * self.arc_curvature_px(arc);
                arc.alpha * (n / (8.0 * tol)).sqrt()
            }
            (None, None) => unreachable!("a split rule has a piece angle or a tolerance"),
        };
        count_pieces(steps)
    }
}

/// The exact error of a drawn edge a–b (view space, E1's D8): the largest
/// pixel distance from the image of the 3D segment to the chord between
/// its ends' pixels, by dense sampling. Errors: an end at the origin or on
/// a pole, a segment through the viewer.
#[cfg(feature = "reference")]
pub fn equirect_chord_error_px(
    proj: &EquirectProjection,
    a: DVec3,
    b: DVec3,
) -> Result<f64, DomeError> {
    let arc = Arc::new(a, b)?;
    let p0 = proj.pixel_of_direction(a).ok_or(DomeError::Antipode)?;
    let p1 = proj.pixel_of_direction(b).ok_or(DomeError::Antipode)?;
    if arc.is_point() {
        return Ok(0.0);
    }
    const SAMPLES: u32 = 512;
    let mut worst = 0.0f64;
    for k in 1..SAMPLES {
        let x = proj
            .pixel_of_direction(arc.dir(arc.alpha * f64::from(k) / f64::from(SAMPLES)))
            .ok_or(DomeError::Antipode)?;
        worst = worst.max(super::measure::dist_to_segment(x, p0, p1));
    }
    Ok(worst)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn pano(w: u32) -> EquirectProjection {
        EquirectProjection::new(&EquirectSettings {
            width_px: w,
            ..Default::default()
        })
        .unwrap()
    }

    #[test]
    fn known_directions_land_where_they_belong() {
        let p = pano(4096);
        assert_eq!(p.size_px(), DVec2::new(4096.0, 2048.0));
        let px = |d: DVec3| p.project(d * 3.0).visible_pixel().unwrap();
        // Forward is the centre, right a quarter turn right, up/down the
        // top and bottom rows' ends approached, back on the seam.
        assert!((px(DVec3::NEG_Z) - DVec2::new(2048.0, 1024.0)).length() < 1e-9);
        assert!((px(DVec3::X) - DVec2::new(3072.0, 1024.0)).length() < 1e-9);
        assert!((px(DVec3::NEG_X) - DVec2::new(1024.0, 1024.0)).length() < 1e-9);
        let up45 = px(DVec3::new(0.0, 1.0, -1.0));
        assert!((up45 - DVec2::new(2048.0, 512.0)).length() < 1e-9);
        let back = px(DVec3::new(1e-3, 0.0, 1.0));
        assert!((back.x - 4096.0).abs() < 1.0);
        assert_eq!(p.project(DVec3::Y), Projected::Pole);
        assert_eq!(p.project(DVec3::NEG_Y * 5.0), Projected::Pole);
        assert_eq!(p.project(DVec3::ZERO), Projected::Origin);
        assert_eq!(p.project(DVec3::splat(f64::NAN)), Projected::Invalid);
        assert_eq!(p.unproject(DVec2::new(-1.0, 3.0)), None);
        assert_eq!(p.unproject(DVec2::new(f64::NAN, 3.0)), None);
        // Tilt: the centre looks 20° below forward.
        let t = EquirectProjection::new(&EquirectSettings {
            width_px: 1000,
            tilt_deg: 20.0,
            ..Default::default()
        })
        .unwrap();
        let a = 20f64.to_radians();
        let c = t
            .project(DVec3::new(0.0, -a.sin(), -a.cos()))
            .visible_pixel()
            .unwrap();
        assert!((c - DVec2::new(500.0, 250.0)).length() < 1e-9);
        assert!(
            EquirectProjection::new(&EquirectSettings {
                width_px: 0,
                ..Default::default()
            })
            .is_err()
        );
        assert!(
            EquirectProjection::new(&EquirectSettings {
                tilt_deg: f64::INFINITY,
                ..Default::default()
            })
            .is_err()
        );
    }

    #[test]
    fn curvature_matches_finite_differences_of_the_projection() {
        // E2 against second differences of the pixel curve, away from the
        // seam and poles.
        let p = pano(4096);
        let arc = Arc::new(DVec3::new(-0.8, 0.3, 1.0), DVec3::new(0.9, 0.7, 0.6)).unwrap();
        let px = |beta: f64| p.pixel_of_frame(arc.dir(beta)).unwrap();
        for i in 1..10 {
            let beta = arc.alpha * f64::from(i) / 10.0;
            let h = 1e-4;
            let v = (px(beta + h) - px(beta - h)) / (2.0 * h);
            let a = (px(beta + h) - 2.0 * px(beta) + px(beta - h)) / (h * h);
            let want = v.perp_dot(a).abs() / v.length();
            let (s, c) = beta.sin_cos();
            let t = -s * arc.a_hat + c * arc.w_hat;
            let got = p.normal_acceleration(arc.dir(beta), t, arc.pole()).unwrap();
            assert!(
                (got - want).abs() < 1e-3 * want.max(1.0),
                "β {beta}: {got} vs {want}"
            );
        }
        // Meridians and the equator are straight.
        let meridian = Arc::new(DVec3::new(0.3, -0.9, 1.0), DVec3::new(0.3, 0.9, 1.0)).unwrap();
        assert!(p.arc_curvature_px(&meridian) < 1e-6);
        let equator = Arc::new(DVec3::new(-1.0, 0.0, 1.0), DVec3::new(1.0, 0.0, 1.0)).unwrap();
        assert!(p.arc_curvature_px(&equator) < 1e-6);
    }

    proptest! {
        #[test]
        fn pixel_round_trip(u in 0.0f64..1.0, v in 0.001f64..0.999, tilt in -60.0f64..60.0) {
            let p = EquirectProjection::new(&EquirectSettings {
                width_px: 4096,
                tilt_deg: tilt,
                ..Default::default()
            }).unwrap();
            let px = DVec2::new(u * 4096.0, v * 2048.0);
            let d = p.unproject(px).unwrap();
            prop_assert!((d.length() - 1.0).abs() < 1e-12);
            let back = p.project(d * 7.0).visible_pixel().unwrap();
            // The seam column is both 0 and W.
            let dx = (back.x - px.x).abs();
            prop_assert!(dx.min((dx - 4096.0).abs()) < 1e-7 && (back.y - px.y).abs() < 1e-7,
                "{} vs {}", back, px);
        }

        #[test]
        fn finite_input_never_gives_nan(x in -1e6f64..1e6, y in -1e6f64..1e6, z in -1e6f64..1e6) {
            let p = pano(2048);
            if let Some(ip) = p.project(DVec3::new(x, y, z)).image_point() {
                prop_assert!(ip.pixel.is_finite() && ip.theta.is_finite());
            }
        }
    }
}
