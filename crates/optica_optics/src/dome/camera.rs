//! The dome camera's settings and the validated frame they define.
//!
//! Conventions (Bevy view space: the camera looks along −Z, +Y is up, +X right):
//!
//! * Mount the camera like a fisheye lens pointing at the zenith of an
//!   untilted dome, its up vector (+Y) towards the back of the theatre. Then
//!   view −Z is the dome axis (zenith, image centre) and view −Y is the
//!   audience front on the horizon, which the domemaster puts at the bottom
//!   centre of the frame. This is also Blender's fisheye camera convention
//!   (axis −Z, image up +Y), so a Cycles equidistant render of the same scene
//!   is a reference image without any rotation.
//! * `tilt_deg` leans the dome forward (towards the audience front, view −Y)
//!   by τ: dome axis `a = (0, −sin τ, −cos τ)`, image up `u = (0, cos τ, −sin τ)`,
//!   image right `e = (1, 0, 0)`. At τ = 90° the axis is the horizontal front.
//! * Domemaster frame (the common domemaster convention, as in Paul Bourke's
//!   notes on fisheye domemaster images): a square of `size_px`, the image
//!   circle inscribed, centre at (size/2, size/2). Pixel coordinates are continuous, origin at the
//!   top-left corner, +u right, +v down (pixel (i, j) covers [i, i+1)×[j, j+1)).
//! * Equidistant: r = f·θ with f = (size/2)/(FOV/2) px per radian, θ the angle
//!   from the dome axis (D1, D3 in the module docs).

use std::f64::consts::PI;

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::error::DomeError;
use super::lens::{FisheyeLens, RadialMap};
use crate::input;

/// Smallest field of view accepted, in degrees. Below it the scale
/// f = (size/2)/(FOV/2) is so large that it says nothing useful (at 1e-320°
/// it is ∞ and every projection NaN); at this bound and 2³² px it is still
/// ~5·10¹⁷ px/rad, finite, and so is every projected pixel (≤ f·π).
pub const MIN_FOV_DEG: f64 = 1e-6;

/// How far past the rim a triangle cut at the view plane reaches, at
/// least, in degrees of polar angle (see [`DomeProjection::rim_skirt_rad`]):
/// 23 px at 4K/180°, 1.4 px at 256 px.
pub const RIM_MARGIN_DEG: f64 = 1.0;

/// Fields of view must be below this, in degrees: at 360° the antipode of the
/// dome axis, where the projection is singular, would lie on the rim.
const FOV_LIMIT_DEG: f64 = 360.0;

/// User-facing settings of a fisheye dome camera (domemaster output).
///
/// A plain settings struct (a Bevy component can mirror it field by field);
/// it is checked once by [`DomeProjection::new`], the only way to get a frame
/// the projection and refinement functions accept.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DomeSettings {
    /// Full field of view of the fisheye in degrees, at least
    /// [`MIN_FOV_DEG`] and below 360: 180 is the standard dome, 210–250 are
    /// wide fisheyes.
    pub fov_deg: f64,
    /// Forward tilt of the dome in degrees (typical tilted domes: 10–30).
    /// Any finite value.
    pub tilt_deg: f64,
    /// Width of the image in pixels, and its height too unless
    /// `height_px` says otherwise (square domemasters: 2048, 4096, 8192),
    /// at least 1.
    pub size_px: u32,
    /// Height of the image in pixels when it is not square, at least 1.
    /// The image circle fits the shorter side, centred.
    #[serde(default)]
    pub height_px: Option<u32>,
    /// The radial mapping (equidistant by default).
    #[serde(default)]
    pub lens: FisheyeLens,
}

impl Default for DomeSettings {
    /// A 4K, 180°, untilted dome: the common domemaster.
    fn default() -> Self {
        Self {
            fov_deg: 180.0,
            tilt_deg: 0.0,
            size_px: 4096,
            height_px: None,
            lens: FisheyeLens::Equidistant,
        }
    }
}

/// θ_max = FOV/2 in radians.
fn theta_max(fov_deg: f64) -> f64 {
    0.5 * fov_deg.to_radians()
}

/// A validated dome camera with its frame and scale precomputed; all the
/// projection, clipping and refinement functions take this.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DomeProjection {
    camera: DomeSettings,
    /// Dome axis (zenith, image centre) in view space, unit.
    axis: DVec3,
    /// Image up in view space, unit, ⟂ axis.
    up: DVec3,
    /// Image right in view space, unit (= +X).
    right: DVec3,
    /// Half the field of view, radians (the rim's polar angle).
    theta_max: f64,
    /// f in px per unit of g (px per radian for the equidistant lens).
    focal_px: f64,
    /// Half the width and height in px: the image centre.
    half: DVec2,
    /// The rim's radius in px: half the shorter side.
    rim_px: f64,
    /// The lens's mapping g, checked for this field of view.
    map: RadialMap,
    /// The largest image curvature N (D6, D10) of any kept piece, px/rad²:
    /// an edge short enough for it needs no split, whatever its place.
    worst_curvature_px: f64,
}

impl DomeProjection {
    /// Checks `camera` and builds its frame. Errors ([`DomeError::Input`]):
    /// a field of view that is not finite, below [`MIN_FOV_DEG`] or not below
    /// 360° (180° included for the orthographic lens); a tilt that is not
    /// finite; a size of 0 px; a polynomial lens with a coefficient that is
    /// not finite or k₁ ≤ 0. [`DomeError::LensFolds`]: a polynomial whose
    /// radius stops rising inside the field of view.
    pub fn new(camera: &DomeSettings) -> Result<Self, DomeError> {
        const FOV: &str = "dome field of view (deg)";
        input::in_range(FOV, camera.fov_deg, MIN_FOV_DEG, FOV_LIMIT_DEG.next_down())?;
        input::finite("dome tilt (deg)", camera.tilt_deg)?;
        input::positive("domemaster size (px)", f64::from(camera.size_px))?;
        let height = camera.height_px.unwrap_or(camera.size_px);
        input::positive("domemaster height (px)", f64::from(height))?;
        let theta_max = theta_max(camera.fov_deg);
        let map = RadialMap::new(camera.lens, camera.fov_deg, theta_max)?;
        let rim_px = 0.5 * f64::from(camera.size_px.min(height));
        let focal_px = rim_px / map.g_max();
        // The FOV bound keeps f finite (≤ ~5·10¹⁷ px/rad at 2³² px, see
        // MIN_FOV_DEG), hence every pixel finite.
        debug_assert!(focal_px.is_finite());
        let camera = *camera;
        let tau = camera.tilt_deg.to_radians();
        let (s, c) = tau.sin_cos();
        let mut proj = Self {
            camera,
            axis: DVec3::new(0.0, -s, -c),
            up: DVec3::new(0.0, c, -s),
            right: DVec3::X,
            theta_max,
            focal_px,
            half: 0.5 * DVec2::new(f64::from(camera.size_px), f64::from(height)),
            rim_px,
            map,
            worst_curvature_px: 0.0,
        };
        proj.worst_curvature_px = super::rule::worst_normal_acceleration_px(&proj);
        Ok(proj)
    }

    /// The largest image curvature N of any piece of geometry kept, px per
    /// rad² (see [`SplitRule`](super::SplitRule)): the tangential D5 at
    /// [`Self::theta_reach`] for the equidistant lens, the largest of a grid
    /// of places and orientations (D10) for the others.
    pub fn worst_curvature_px(&self) -> f64 {
        self.worst_curvature_px
    }

    /// The radial mapping.
    pub fn lens(&self) -> FisheyeLens {
        self.map.lens()
    }

    /// The lens's mapping, checked for this field of view.
    pub(crate) fn map(&self) -> &RadialMap {
        &self.map
    }

    /// The settings this projection was built from.
    pub fn settings(&self) -> DomeSettings {
        self.camera
    }

    /// Dome axis (zenith, image centre) in view space, unit.
    pub fn axis(&self) -> DVec3 {
        self.axis
    }

    /// Image up (towards the top of the frame) in view space, unit.
    pub fn up(&self) -> DVec3 {
        self.up
    }

    /// Image right in view space, unit.
    pub fn right(&self) -> DVec3 {
        self.right
    }

    /// The rim's polar angle θ_max = FOV/2 in radians.
    pub fn theta_max(&self) -> f64 {
        self.theta_max
    }

    /// f = R/g(θ_max), R the rim radius (D3, D9): px per unit of the
    /// lens's g, px per radian for the equidistant lens. 4K/180°
    /// equidistant gives 1303.8.
    pub fn focal_px(&self) -> f64 {
        self.focal_px
    }

    /// Width of the image in px (the side of a square domemaster).
    pub fn size_px(&self) -> f64 {
        2.0 * self.half.x
    }

    /// Height of the image in px.
    pub fn height_px(&self) -> f64 {
        2.0 * self.half.y
    }

    /// Radius of the image circle in px: half the shorter side.
    pub fn rim_radius_px(&self) -> f64 {
        self.rim_px
    }

    /// The image centre (zenith) in pixel coordinates.
    pub fn centre_px(&self) -> DVec2 {
        self.half
    }

    /// Whether geometry is clipped against the view plane z = 0 of the dome
    /// frame before projection (FOV ≤ 180°; the visible set is then inside
    /// the convex half-space in front of that plane).
    pub fn clips_at_view_plane(&self) -> bool {
        self.theta_max <= 0.5 * PI
    }

    /// Polar angle beyond which geometry is removed before or after
    /// refinement: 90° (the view plane) for FOV ≤ 180°, else the guard cone
    /// halfway between the rim and the antipode, (θ_max + π)/2. Between the
    /// rim and this angle geometry is kept and lands outside the image
    /// circle, where a renderer discards its fragments.
    pub fn theta_clip(&self) -> f64 {
        if self.clips_at_view_plane() {
            0.5 * PI
        } else {
            0.5 * (self.theta_max + PI)
        }
    }

    /// The angle, past the view plane, of the *rim skirt* a clipped
    /// triangle gets (see [`refine_triangle`](super::refine_triangle)):
    /// [`RIM_MARGIN_DEG`] when the view plane lies within that of the rim
    /// (FOV > 178°), else `None`. Cut at the view plane, such a triangle
    /// ends in chords between points on the rim itself, which sag inside
    /// the image circle by up to the tolerance and leave an uncovered ring;
    /// the skirt carries the triangle's own plane on past the rim.
    pub fn rim_skirt_rad(&self) -> Option<f64> {
        let margin = RIM_MARGIN_DEG.to_radians();
        (self.clips_at_view_plane() && self.theta_max > 0.5 * PI - margin).then_some(margin)
    }

    /// Largest angle subtended by a piece of an edge that leaves the guard
    /// cone (`None` when clipping at the view plane): half the gap between
    /// the rim and the guard cone. Triangles are culled per sub-triangle
    /// there, so a culled piece starts at least half the gap outside the rim
    /// ((π − θ_max)/4) and its chords cannot sag
    /// into the image circle; kept pieces stay off the antipode.
    pub fn guard_piece_rad(&self) -> Option<f64> {
        (!self.clips_at_view_plane()).then(|| 0.5 * (self.theta_clip() - self.theta_max))
    }

    /// Largest polar angle a kept piece of geometry can reach: the clip angle
    /// when clipping at the view plane (everything is clipped there), else
    /// θ_clip plus half a guard piece. Triangles are then culled per
    /// sub-triangle at the guard cone, so a kept piece ends inside it but its
    /// arc may bulge past it, by at most half its length; the rule caps
    /// pieces that leave the guard cone at [`Self::guard_piece_rad`]. For
    /// FOV > 180° this is (3θ_clip + π)/4, away from the antipode.
    pub fn theta_reach(&self) -> f64 {
        match self.guard_piece_rad() {
            None => self.theta_clip(),
            Some(piece) => self.theta_clip() + 0.5 * piece,
        }
    }

    /// Polar angle beyond which a renderer drops the vertices of geometry
    /// drawn without clipping (pre-subdivided primitives, see
    /// [`pre_subdivide`](super::pre_subdivide)): 7/8 of the way from the
    /// rim to the antipode. It lies past [`Self::theta_reach`], so clipped
    /// or culled geometry never meets it; pieces of at most
    /// [`Self::max_unclipped_piece_rad`] straddling it lie far outside the
    /// image circle and cannot wrap around the antipode. The vertex shader
    /// (`projection.wgsl`) applies it.
    pub fn theta_draw_limit(&self) -> f64 {
        self.theta_max + 0.875 * (PI - self.theta_max)
    }

    /// Largest piece of geometry drawn without clipping: half the gap
    /// between [`Self::theta_draw_limit`] and the antipode, so a piece with
    /// a vertex inside the limit keeps the antipode out of reach.
    pub fn max_unclipped_piece_rad(&self) -> f64 {
        0.5 * (PI - self.theta_draw_limit())
    }

    /// View-space point in dome coordinates: (along image right, along image
    /// up, along the axis). The third component is positive in front.
    pub fn to_dome(&self, p: DVec3) -> DVec3 {
        DVec3::new(p.dot(self.right), p.dot(self.up), p.dot(self.axis))
    }

    /// Dome coordinates back to view space (inverse of [`Self::to_dome`]).
    pub fn from_dome(&self, q: DVec3) -> DVec3 {
        q.x * self.right + q.y * self.up + q.z * self.axis
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dome::Projected;
    use crate::input::Expected;

    fn frame(fov_deg: f64, tilt_deg: f64, size_px: u32) -> Result<DomeProjection, DomeError> {
        DomeProjection::new(&DomeSettings {
            fov_deg,
            tilt_deg,
            size_px,
            ..Default::default()
        })
    }

    #[test]
    fn clip_angles_are_ordered_for_every_fov() {
        // rim ≤ clip ≤ reach < draw limit < π, the guard piece within half
        // the gap between rim and clip, the skirt only next to 180°, for
        // FOVs from 1° to next to 360°.
        for fov in [
            1.0, 90.0, 170.0, 178.0, 178.001, 179.0, 180.0, 181.0, 250.0, 359.9,
        ] {
            let p = frame(fov, 0.0, 4096).unwrap();
            let (rim, clip, reach) = (p.theta_max(), p.theta_clip(), p.theta_reach());
            let limit = p.theta_draw_limit();
            assert!(
                rim <= clip && clip <= reach && reach < limit && limit < PI,
                "{fov}"
            );
            assert!(p.max_unclipped_piece_rad() > 0.0, "{fov}");
            assert_eq!(p.clips_at_view_plane(), fov <= 180.0, "{fov}");
            assert_eq!(
                p.rim_skirt_rad().is_some(),
                fov > 178.0 && fov <= 180.0,
                "{fov}"
            );
            if let Some(piece) = p.guard_piece_rad() {
                assert!(piece <= 0.5 * (clip - rim) && piece > 0.0, "{fov}");
            }
        }
    }

    #[test]
    fn bad_settings_are_refused_with_the_quantity_named() {
        // 1e-320° (subnormal): θ_max underflows, f = ∞, projection NaN.
        for fov in [
            1e-320,
            f64::MIN_POSITIVE,
            1e-300,
            1e-7,
            0.0,
            -1.0,
            360.0,
            f64::NAN,
            f64::INFINITY,
        ] {
            match frame(fov, 0.0, 4096) {
                Err(DomeError::Input(e)) => {
                    assert_eq!(e.what, "dome field of view (deg)");
                    assert_eq!(
                        e.expected,
                        Expected::Range {
                            min: MIN_FOV_DEG,
                            max: 360f64.next_down()
                        }
                    );
                    assert!(
                        e.value == fov || (fov.is_nan() && e.value.is_nan()),
                        "{fov}"
                    );
                }
                other => panic!("{fov}: {other:?}"),
            }
        }
        match frame(180.0, f64::NAN, 4096) {
            Err(DomeError::Input(e)) => {
                assert_eq!((e.what, e.expected), ("dome tilt (deg)", Expected::Finite))
            }
            other => panic!("{other:?}"),
        }
        match frame(180.0, 0.0, 0) {
            Err(DomeError::Input(e)) => {
                assert_eq!(
                    (e.what, e.value, e.expected),
                    ("domemaster size (px)", 0.0, Expected::Positive)
                )
            }
            other => panic!("{other:?}"),
        }
        // Just below 360° is accepted; the default is the 4K/180° dome.
        assert!(frame(360f64.next_down(), 0.0, 4096).is_ok());
        let d = DomeProjection::new(&DomeSettings::default()).unwrap();
        assert_eq!(
            d.settings(),
            DomeSettings {
                fov_deg: 180.0,
                tilt_deg: 0.0,
                size_px: 4096,
                height_px: None,
                lens: crate::dome::FisheyeLens::Equidistant,
            }
        );
    }

    #[test]
    fn smallest_fov_and_largest_size_give_finite_pixels() {
        // At the bound and the largest size, f and every pixel are finite.
        for size in [1, 4096, u32::MAX] {
            let p = frame(MIN_FOV_DEG, 10.0, size).unwrap();
            assert!(p.focal_px().is_finite() && p.focal_px() > 0.0);
            for q in [
                DVec3::new(0.0, 0.0, -1.0),
                DVec3::new(1e-12, 0.0, -1.0),
                DVec3::new(1.0, 2.0, 3.0),
                DVec3::new(0.3, -1.0, 0.0),
            ] {
                match p.project(q) {
                    Projected::Visible(ip) | Projected::OutsideFov(ip) => {
                        assert!(
                            ip.pixel.is_finite() && ip.theta.is_finite(),
                            "{size} {q}: {ip:?}"
                        )
                    }
                    other => panic!("{size} {q}: {other:?}"),
                }
            }
        }
    }
}
