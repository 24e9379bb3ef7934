//! Fisheye projection of view-space points to domemaster pixels and back.
//!
//! Forward (D1, D2, D9): in dome coordinates (x, y, z) = (right, up, axis)
//! of the point, ρ = √(x² + y²), θ = atan2(ρ, z), and the pixel is
//! `centre + f·g(θ)·(x, −y)/ρ` (image rows grow downwards; g(θ) = θ for
//! the equidistant lens). The atan2 form is
//! accurate for every θ in [0, π]; `acos(z/|p|)` loses half the digits near the
//! zenith and near the antipode. Near the zenith θ/ρ → 1/z, so no special case
//! is needed there; at the antipode (ρ = 0, z > 0) the azimuth is undefined and
//! the result is [`Projected::Antipode`].
//!
//! Inverse: r = |pixel − centre|, θ = g⁻¹(r/f), direction
//! `sin θ·(Δu, −Δv)/r` across and `cos θ` along the axis.

use std::f64::consts::PI;

use glam::{DVec2, DVec3};

use super::camera::DomeProjection;

/// Points whose polar angle is within this of π (the antipode of the dome axis)
/// are reported as [`Projected::Antipode`]: their azimuth, hence their pixel,
/// is not determined by the data (a 1e-9 rad perturbation moves them by up to
/// 2·f·π px around the circle r = f·π).
///
/// Why 1e-9: the polar angle of a direction given in f64 is known to about
/// 1e-16 rad, but the azimuth of a point at angular distance ε from the
/// antipode is known only to ~1e-16/ε rad; at ε = 1e-9 that is 1e-7 rad, a
/// 1e-3 px wobble on the r = f·π circle of an 8K frame. Closer to the
/// antipode the pixel is noise.
pub const ANTIPODE_EPS_RAD: f64 = 1e-9;

/// Relative slack on the rim radius in [`DomeProjection::unproject`]: a pixel
/// computed on the rim by [`DomeProjection::project`] may land a few ulps
/// (~1e-16 relative) outside it; 1e-12 accepts those and nothing a user could
/// tell from the rim (1e-12 of 4096 px is 4e-9 px).
const RIM_SLACK_REL: f64 = 1e-12;

/// A projected point that has a pixel position.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImagePoint {
    /// Continuous pixel coordinates (origin top-left, +v down).
    pub pixel: DVec2,
    /// Polar angle from the dome axis, radians.
    pub theta: f64,
    /// Distance from the camera (radial depth), in view-space units.
    pub distance: f64,
}

/// Result of projecting one view-space point. Never NaN: every input has
/// exactly one of these outcomes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projected {
    /// Inside the image circle (θ ≤ FOV/2).
    Visible(ImagePoint),
    /// Outside the field of view (FOV/2 < θ < π − ε): for FOV ≤ 180° this
    /// includes everything behind the viewer. The pixel is still given
    /// (r > size/2, up to f·π) for clippers and for the error measure.
    OutsideFov(ImagePoint),
    /// Within [`ANTIPODE_EPS_RAD`] of the antipode: no defined pixel.
    Antipode,
    /// On a pole of an equirectangular panorama (within
    /// [`POLE_EPS_RAD`](super::POLE_EPS_RAD)): a whole row of the image,
    /// no one pixel.
    Pole,
    /// The camera origin itself (all coordinates exactly zero): no direction.
    Origin,
    /// A coordinate is NaN or infinite.
    Invalid,
}

impl Projected {
    /// The pixel when the point is in the image circle.
    pub fn visible_pixel(&self) -> Option<DVec2> {
        match self {
            Projected::Visible(p) => Some(p.pixel),
            _ => None,
        }
    }

    /// The image point, inside or outside the field of view.
    pub fn image_point(&self) -> Option<ImagePoint> {
        match self {
            Projected::Visible(p) | Projected::OutsideFov(p) => Some(*p),
            _ => None,
        }
    }
}

impl DomeProjection {
    /// Polar angle θ ∈ [0, π] of a view-space point from the dome axis
    /// (atan2 form, D2). The origin gives 0; a non-finite point gives NaN
    /// (classify untrusted points with [`Self::project`]).
    pub fn theta(&self, p: DVec3) -> f64 {
        let q = self.to_dome(p);
        q.x.hypot(q.y).atan2(q.z)
    }

    /// Projects a view-space point (D1–D3).
    pub fn project(&self, p: DVec3) -> Projected {
        if !p.is_finite() {
            return Projected::Invalid;
        }
        if p == DVec3::ZERO {
            return Projected::Origin;
        }
        let q = self.to_dome(p);
        let Some((pixel, theta)) = self.pixel_theta_of_dome(q) else {
            return Projected::Antipode;
        };
        let ip = ImagePoint {
            pixel,
            theta,
            distance: p.length(),
        };
        if theta <= self.theta_max() {
            Projected::Visible(ip)
        } else {
            Projected::OutsideFov(ip)
        }
    }

    /// Pixel of a view-space direction (or point; only its direction counts),
    /// inside or outside the image circle. `None` at the origin, at the
    /// antipode or for non-finite input.
    pub fn pixel_of_direction(&self, d: DVec3) -> Option<DVec2> {
        if !d.is_finite() || d == DVec3::ZERO {
            return None;
        }
        self.pixel_theta_of_dome(self.to_dome(d)).map(|(px, _)| px)
    }

    /// The core of the forward map on dome coordinates; `None` at the antipode.
    fn pixel_theta_of_dome(&self, q: DVec3) -> Option<(DVec2, f64)> {
        let rho = q.x.hypot(q.y);
        let theta = rho.atan2(q.z);
        if PI - theta < ANTIPODE_EPS_RAD {
            return None;
        }
        let centre = self.centre_px();
        if rho == 0.0 {
            // On the axis in front (the antipode was handled above).
            return Some((centre, 0.0));
        }
        let k = self.focal_px() * self.map().radius(theta) / rho;
        Some((centre + DVec2::new(k * q.x, -k * q.y), theta))
    }

    /// Unit view-space direction seen at a pixel, or `None` outside the image
    /// circle (r > size/2, beyond the rim) or for non-finite input.
    pub fn unproject(&self, pixel: DVec2) -> Option<DVec3> {
        if !pixel.is_finite() {
            return None;
        }
        let d = pixel - self.centre_px();
        let (du, dv) = (d.x, -d.y);
        let r = du.hypot(dv);
        // A relative slack so that pixels computed on the rim round-trip.
        if r > self.rim_radius_px() * (1.0 + RIM_SLACK_REL) {
            return None;
        }
        let theta = self.map().theta_of_radius(r / self.focal_px());
        let (s, c) = theta.sin_cos();
        let q = if r == 0.0 {
            DVec3::Z
        } else {
            DVec3::new(s * du / r, s * dv / r, c)
        };
        Some(self.from_dome(q))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn dome(fov: f64, tilt: f64, size: u32) -> DomeProjection {
        crate::dome::test_dome(fov, tilt, size)
    }

    #[test]
    fn focal_length_4k_180() {
        // D3: 4K/180° gives f = 2048/(π/2) ≈ 1303.8 px/rad.
        let p = dome(180.0, 0.0, 4096);
        assert!((p.focal_px() - 4096.0 / PI).abs() < 1e-9);
        assert!((p.focal_px() - 1303.8).abs() < 0.1);
    }

    #[test]
    fn zenith_projects_to_centre() {
        let p = dome(180.0, 0.0, 4096);
        let px = p
            .project(DVec3::new(0.0, 0.0, -7.0))
            .visible_pixel()
            .unwrap();
        assert_eq!(px, DVec2::new(2048.0, 2048.0));
    }

    #[test]
    fn horizon_at_180_is_on_the_rim() {
        // θ = 90° at 180° FOV: r = f·π/2 = size/2.
        let p = dome(180.0, 0.0, 4096);
        for k in 0..12 {
            let phi = k as f64 * PI / 6.0;
            let v = DVec3::new(phi.cos(), phi.sin(), 0.0) * 3.0;
            let px = p.project(v).visible_pixel().unwrap();
            let r = (px - p.centre_px()).length();
            assert!((r - 2048.0).abs() < 1e-9, "r = {r}");
        }
    }

    #[test]
    fn forty_five_degrees_is_half_radius() {
        // θ = 45° at 180° FOV: r = f·π/4 = size/4.
        let p = dome(180.0, 0.0, 4096);
        let v = DVec3::new(1.0, 0.0, -1.0);
        let px = p.project(v).visible_pixel().unwrap();
        assert!((px - DVec2::new(2048.0 + 1024.0, 2048.0)).length() < 1e-9);
    }

    #[test]
    fn audience_front_is_bottom_centre_and_up_is_top() {
        // Domemaster convention: view −Y (front, on the horizon) at the bottom
        // centre of the frame, +Y at the top centre, +X on the right.
        let p = dome(180.0, 0.0, 2048);
        let front = p.project(DVec3::NEG_Y).visible_pixel().unwrap();
        assert!((front - DVec2::new(1024.0, 2048.0)).length() < 1e-9);
        let back = p.project(DVec3::Y).visible_pixel().unwrap();
        assert!((back - DVec2::new(1024.0, 0.0)).length() < 1e-9);
        let right = p.project(DVec3::X).visible_pixel().unwrap();
        assert!((right - DVec2::new(2048.0, 1024.0)).length() < 1e-9);
    }

    #[test]
    fn tilt_moves_the_zenith_towards_the_front() {
        // A 30° forward tilt: the direction 30° from view −Z towards −Y is the
        // image centre, and view −Z itself is 30° above it (towards the top).
        let p = dome(180.0, 30.0, 4096);
        let t = 30f64.to_radians();
        let axis = DVec3::new(0.0, -t.sin(), -t.cos());
        let c = p.project(axis * 5.0).visible_pixel().unwrap();
        assert!((c - p.centre_px()).length() < 1e-9);
        let z = p.project(DVec3::NEG_Z).visible_pixel().unwrap();
        let expect = p.centre_px() + DVec2::new(0.0, -p.focal_px() * t);
        assert!((z - expect).length() < 1e-9, "{z} vs {expect}");
    }

    #[test]
    fn wide_fov_scale_and_outside() {
        // 250° FOV: the rim is at θ = 125°; θ = 90° is at 90/125 of the radius;
        // a point behind the rim (θ = 150°) is OutsideFov with r > size/2.
        let p = dome(250.0, 0.0, 1000);
        let px = p.project(DVec3::X).visible_pixel().unwrap();
        assert!(((px.x - 500.0) - 500.0 * 90.0 / 125.0).abs() < 1e-9);
        let t = 150f64.to_radians();
        match p.project(DVec3::new(t.sin(), 0.0, -t.cos())) {
            Projected::OutsideFov(ip) => {
                assert!((ip.theta - t).abs() < 1e-12);
                assert!((ip.pixel.x - 500.0 - 500.0 * 150.0 / 125.0).abs() < 1e-9);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn singular_inputs_are_typed() {
        let p = dome(220.0, 10.0, 4096);
        assert_eq!(p.project(DVec3::ZERO), Projected::Origin);
        assert_eq!(
            p.project(DVec3::new(f64::NAN, 0.0, 0.0)),
            Projected::Invalid
        );
        assert_eq!(
            p.project(DVec3::new(0.0, f64::INFINITY, 0.0)),
            Projected::Invalid
        );
        // The exact antipode of the tilted axis, and a point 1e-12 rad off it.
        let anti = -p.axis() * 4.0;
        assert_eq!(p.project(anti), Projected::Antipode);
        let near = anti + p.right() * 4e-12;
        assert_eq!(p.project(near), Projected::Antipode);
        // Just outside the antipode band: finite pixel near r = f·π.
        let off = anti + p.right() * 4e-6;
        let ip = p.project(off).image_point().unwrap();
        assert!(ip.pixel.is_finite());
        let want = p.focal_px() * (PI - 1e-6f64.atan());
        assert!(((ip.pixel - p.centre_px()).length() - want).abs() < 1e-6);
        assert_eq!(p.pixel_of_direction(anti), None);
        assert_eq!(p.pixel_of_direction(DVec3::ZERO), None);
        assert_eq!(p.unproject(DVec2::new(f64::NAN, 1.0)), None);
        // Beyond the rim in the frame corner.
        assert_eq!(p.unproject(DVec2::new(0.0, 0.0)), None);
    }

    #[test]
    fn tiny_and_huge_points_are_finite() {
        let p = dome(180.0, 0.0, 4096);
        for v in [
            DVec3::new(1e-300, 0.0, -1e-300),
            DVec3::new(1e150, -1e150, -1e150),
            DVec3::new(1e-320, 0.0, -1.0),
        ] {
            let ip = p.project(v).image_point().unwrap();
            assert!(ip.pixel.is_finite() && ip.theta.is_finite(), "{v}");
        }
    }

    #[test]
    fn every_lens_puts_its_rim_on_the_circle_and_known_angles_where_they_belong() {
        // 180° at 4096 px, R = 2048: θ = 45° lands at R·g(45°)/g(90°).
        use crate::dome::FisheyeLens::*;
        let h = |t: f64| (0.5 * t).tan();
        let s = |t: f64| (0.5 * t).sin();
        let q = PI / 4.0;
        let k = [1.0, -0.04, 0.003, -0.0001];
        let poly = |t: f64| t * (k[0] + t * t * (k[1] + t * t * (k[2] + t * t * k[3])));
        for (lens, want) in [
            (Equidistant, 0.5),
            (Equisolid, s(q) / s(2.0 * q)),
            (Stereographic, h(q) / h(2.0 * q)),
            (Orthographic, q.sin()),
            (Polynomial { k }, poly(q) / poly(2.0 * q)),
        ] {
            let p = crate::dome::test_lens_dome(lens, 180.0, 0.0, 4096);
            let rim = p.project(DVec3::X).visible_pixel().unwrap();
            assert!(
                (rim - DVec2::new(4096.0, 2048.0)).length() < 1e-9,
                "{lens:?}"
            );
            let px = p
                .project(DVec3::new(1.0, 0.0, -1.0))
                .visible_pixel()
                .unwrap();
            assert!(
                (px.x - 2048.0 - 2048.0 * want).abs() < 1e-9,
                "{lens:?}: {px}"
            );
            // Every singular input stays typed, every finite one finite.
            assert_eq!(p.project(DVec3::ZERO), Projected::Origin);
            assert_eq!(p.project(DVec3::Z), Projected::Antipode);
            assert_eq!(p.project(DVec3::splat(f64::NAN)), Projected::Invalid);
            for v in [
                DVec3::new(1e-300, 0.0, -1e-300),
                DVec3::new(1e150, -1e150, 1e150),
            ] {
                let ip = p.project(v).image_point().unwrap();
                assert!(ip.pixel.is_finite(), "{lens:?} {v}");
            }
        }
    }

    #[test]
    fn a_wide_target_fits_the_circle_to_its_height() {
        // 1920 × 1080: the circle has radius 540 around (960, 540).
        let p = DomeProjection::new(&crate::dome::DomeSettings {
            fov_deg: 180.0,
            size_px: 1920,
            height_px: Some(1080),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(
            (p.size_px(), p.height_px(), p.rim_radius_px()),
            (1920.0, 1080.0, 540.0)
        );
        assert_eq!(p.centre_px(), DVec2::new(960.0, 540.0));
        let right = p.project(DVec3::X).visible_pixel().unwrap();
        assert!((right - DVec2::new(1500.0, 540.0)).length() < 1e-9);
        let front = p.project(DVec3::NEG_Y).visible_pixel().unwrap();
        assert!((front - DVec2::new(960.0, 1080.0)).length() < 1e-9);
        // The corners beyond the circle see nothing; a pixel inside round-trips.
        assert_eq!(p.unproject(DVec2::new(100.0, 540.0)), None);
        let d = p.unproject(DVec2::new(1200.0, 300.0)).unwrap();
        let back = p.project(d).visible_pixel().unwrap();
        assert!((back - DVec2::new(1200.0, 300.0)).length() < 1e-9);
    }

    proptest! {
        #[test]
        fn pixel_round_trip(fov in 10.0f64..359.0, tilt in -40.0f64..40.0,
                            u in 0.0f64..1.0, v in 0.0f64..1.0, lens in 0usize..5) {
            let lens = crate::dome::rule::tests::TEST_LENSES[lens];
            let p = crate::dome::test_lens_dome(lens, fov.min(lens.max_fov_deg()), tilt, 4096);
            let px = DVec2::new(u, v) * 4096.0;
            match p.unproject(px) {
                None => prop_assert!((px - p.centre_px()).length() > 2048.0 * (1.0 - 1e-9)),
                Some(d) => {
                    prop_assert!((d.length() - 1.0).abs() < 1e-12);
                    let back = p.project(d * 3.0).visible_pixel().unwrap();
                    prop_assert!((back - px).length() < 1e-7, "{} vs {}", back, px);
                }
            }
        }

        #[test]
        fn direction_round_trip(fov in 10.0f64..359.0, tilt in -90.0f64..90.0,
                                x in -1.0f64..1.0, y in -1.0f64..1.0, z in -1.0f64..1.0,
                                s in 1e-3f64..1e3) {
            let p = dome(fov, tilt, 4096);
            let d = DVec3::new(x, y, z);
            prop_assume!(d.length() > 1e-3);
            let d = d.normalize();
            match p.project(d * s) {
                Projected::Visible(ip) => {
                    let back = p.unproject(ip.pixel).unwrap();
                    // (angle_between uses acos: no better than ~1e-8 near 0.)
                    prop_assert!((back - d).length() < 1e-9, "{} vs {}", back, d);
                    prop_assert!((ip.distance - s).abs() < 1e-9 * s);
                }
                Projected::OutsideFov(ip) => {
                    prop_assert!(ip.theta > p.theta_max());
                    prop_assert!((ip.pixel - p.centre_px()).length() > 2048.0);
                }
                Projected::Antipode => prop_assert!(p.theta(d) > PI - 1e-6),
                other => prop_assert!(false, "{other:?}"),
            }
        }

        #[test]
        fn finite_input_never_gives_nan(x in -1e6f64..1e6, y in -1e6f64..1e6, z in -1e6f64..1e6,
                                        fov in 1.0f64..359.99) {
            let p = dome(fov, 0.0, 2048);
            if let Some(ip) = p.project(DVec3::new(x, y, z)).image_point() {
                prop_assert!(ip.pixel.is_finite() && ip.theta.is_finite());
            }
        }
    }
}
