//! The collimated beam from a light at infinity and the square of the pupil
//! plane the ray grid covers.

use glam::{DVec2, DVec3};

use super::FlareError;
use crate::input::{self, InvalidInput};
use crate::lens::{LensPrescription, TracePath};
use crate::ray::Ray;

/// Smallest accepted `d_z` of the unit light direction: below it the beam is
/// parallel to the lens (cos θ < 1e-9, θ > 89.99999994°) and carries no
/// power (its cross-section is `area · d_z`).
pub const MIN_LIGHT_Z: f64 = 1e-9;

/// Entrance-pupil bounds are the paraxial pupil radius times this: real
/// pupils are larger than paraxial ones off axis (pupil aberration) and the
/// grid must not cut light off. 1.25 is checked, not derived: for the shipped
/// lenses up to 30° no passing ray falls outside (see
/// [`PupilBounds::entrance_pupil`]).
pub const ENTRANCE_PUPIL_MARGIN: f64 = 1.25;

/// Beam rays start this far (mm) in front of both the pupil plane and the
/// first surface's cap. Any positive distance works (the rays are traced
/// from there); 1 mm keeps the origin clear of the cap by far more than
/// round-off on lenses of any size.
const BEAM_START_CLEARANCE_MM: f64 = 1.0;

/// The square `center ± half_width` (in x and y) of the plane `z = plane_z`
/// that the ray grid covers, in the lens frame (first vertex at z = 0), mm.
///
/// Restricting the grid to this square is the blog's *Bundle bounding*
/// ("many rays are blocked and never reach the sensor, so the bundle is
/// restricted to a limited part of the aperture"): [`PupilBounds::for_path`]
/// picks the entrance pupil for paths whose light must pass the stop before
/// it reflects, and the front element otherwise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PupilBounds {
    plane_z: f64,
    center: DVec2,
    half_width: f64,
}

impl PupilBounds {
    /// The square `center ± half_width` of the plane `z = plane_z`: all
    /// finite, `half_width > 0`.
    pub fn new(plane_z: f64, center: DVec2, half_width: f64) -> Result<Self, InvalidInput> {
        Ok(Self {
            plane_z: input::finite("pupil plane z (mm)", plane_z)?,
            center: input::finite_vec2("pupil centre (mm)", center)?,
            half_width: input::positive("pupil half-width (mm)", half_width)?,
        })
    }

    /// z of the plane, mm.
    pub fn plane_z(&self) -> f64 {
        self.plane_z
    }

    /// Centre of the square, mm.
    pub fn center(&self) -> DVec2 {
        self.center
    }

    /// Half the side of the square, mm.
    pub fn half_width(&self) -> f64 {
        self.half_width
    }

    /// Everything that can enter the front element: the square around its
    /// clear disc, on the plane halfway down its sag at the rim, widened by
    /// the lateral walk `|sag|/2 · tan θ` of oblique rays over that depth.
    /// Use it for ghosts that reflect before reaching the stop, whose light is
    /// not limited by the entrance pupil.
    pub fn front_aperture(
        prescription: &LensPrescription,
        light: DVec3,
    ) -> Result<Self, FlareError> {
        let d = light_direction(light)?;
        let s = &prescription.surfaces()[0];
        let h = s.semi_aperture_mm;
        let c = s.curvature;
        // Stable sag c h² / (1 + √(1 − c² h²)); a prescription has |c h| <= 1.
        let sag = c * h * h / (1.0 + (1.0 - (c * h).powi(2)).max(0.0).sqrt());
        let tan = d.truncate().length() / d.z;
        Ok(Self::new(
            0.5 * sag,
            DVec2::ZERO,
            h + 0.5 * sag.abs() * tan,
        )?)
    }

    /// The paraxial entrance pupil at `wavelength_nm` (its plane and radius)
    /// times [`ENTRANCE_PUPIL_MARGIN`]: the square of Hullin et al.'s "grid
    /// over the entrance pupil", for paths that cross the stop before their
    /// first reflection.
    ///
    /// That it cuts no light is checked, not proved, and only for the
    /// shipped Tessar and double Gauss at 550 nm, azimuth 30°: at 0°, 15°
    /// and 30° field no ray of a 33² front-aperture grid that reaches the
    /// sensor unclipped misses the square (in a one-off 201² run up to 35°
    /// the farthest such ray was at 0.83 of the half-width), and the power
    /// of every such ghost matches the front-aperture bounds to Monte-Carlo
    /// noise, summed to 1 %, at 30° (Tessar) and 20° (double Gauss). For
    /// other lenses, stronger pupil aberration or wider fields, compare with
    /// [`PupilBounds::front_aperture`] (always safe, coarser).
    pub fn entrance_pupil(
        prescription: &LensPrescription,
        wavelength_nm: f64,
    ) -> Result<Self, FlareError> {
        let q = prescription.paraxial(wavelength_nm)?;
        Ok(Self::new(
            q.entrance_pupil_z_mm,
            DVec2::ZERO,
            q.entrance_pupil_radius_mm * ENTRANCE_PUPIL_MARGIN,
        )?)
    }

    /// Bounds for `path`: the entrance pupil when the path crosses the stop
    /// before its first reflection (the primary path; ghosts reflecting first
    /// behind the stop), else the front aperture; falls back to the front
    /// aperture when the paraxial pupil does not exist (afocal lens).
    pub fn for_path(
        prescription: &LensPrescription,
        path: TracePath,
        light: DVec3,
        wavelength_nm: f64,
    ) -> Result<Self, FlareError> {
        let stop_first = match path {
            TracePath::Primary => true,
            TracePath::Ghost { first, .. } => first > prescription.stop_index(),
        };
        if stop_first {
            match Self::entrance_pupil(prescription, wavelength_nm) {
                Ok(b) => return Ok(b),
                // A bad wavelength is the caller's; no pupil is the lens's.
                Err(FlareError::Paraxial(crate::lens::ParaxialError::Input(e))) => {
                    return Err(e.into());
                }
                Err(_) => {}
            }
        }
        Self::front_aperture(prescription, light)
    }

    /// Area of the square on its plane, mm².
    pub fn area_mm2(&self) -> f64 {
        4.0 * self.half_width * self.half_width
    }
}

/// The unit light direction (direction of travel) from a user vector of any
/// length: finite and non-zero ([`FlareError::Input`]), and travelling into
/// the lens, `d_z > MIN_LIGHT_Z` after normalising
/// ([`FlareError::LightBehindLens`] otherwise).
pub fn light_direction(light: DVec3) -> Result<DVec3, FlareError> {
    let d = input::direction("light direction", light)?;
    if d.z > MIN_LIGHT_Z {
        Ok(d)
    } else {
        Err(FlareError::LightBehindLens { dir_z: d.z })
    }
}

/// Direction of travel of light arriving `field_deg` off axis, tilted
/// towards the azimuth `azimuth_deg` (from +x towards +y):
/// `(sin θ cos φ, sin θ sin φ, cos θ)`. The source itself lies in the
/// opposite direction. Non-finite angles give a non-finite vector, which
/// [`light_direction`] (and so every function taking a light) refuses.
pub fn light_from_field(field_deg: f64, azimuth_deg: f64) -> DVec3 {
    let (t, a) = (field_deg.to_radians(), azimuth_deg.to_radians());
    DVec3::new(t.sin() * a.cos(), t.sin() * a.sin(), t.cos())
}

/// A rectangle of a beam's pupil plane, mm: where a ghost's light passes
/// ([`super::passing_rect`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PupilRect {
    /// The corner of least x and y.
    pub min: DVec2,
    /// The corner of greatest x and y.
    pub max: DVec2,
}

impl PupilRect {
    /// The smallest rectangle holding both.
    pub fn union(self, other: Self) -> Self {
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }
}

/// A collimated beam: a light direction and the pupil square it fills.
///
/// The grid of rays over the square is regular, not random (the blog's
/// *Rasterisation and shading*: "use regularly spaced bundles, not randomly
/// generated ones"), so that grid cells on the sensor correspond to cells
/// on the entrance plane. All rays are parallel to the light direction `d`;
/// their power is measured as unit irradiance on a plane perpendicular to
/// `d`, so a cell of area `A` on the pupil plane carries `A · d_z` (its beam
/// cross-section).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Beam {
    direction: DVec3,
    bounds: PupilBounds,
    start_z: f64,
}

impl Beam {
    /// A beam along `light` (normalised; must travel towards +z) over `bounds`.
    /// Rays start in front of the first surface's whole cap so every ray meets
    /// surface 0 from the front.
    pub fn new(
        prescription: &LensPrescription,
        light: DVec3,
        bounds: PupilBounds,
    ) -> Result<Self, FlareError> {
        let direction = light_direction(light)?;
        let c0 = prescription.surfaces()[0].curvature.abs();
        let widest = prescription
            .surfaces()
            .iter()
            .map(|s| s.semi_aperture_mm)
            .fold(0.0, f64::max);
        // |sag(r)| <= r on a cap, so backing off by the largest radius a grid
        // ray can have (capped by |R|) clears the cap.
        let reach = bounds.center.length() + std::f64::consts::SQRT_2 * bounds.half_width + widest;
        let depth = if c0 > 0.0 { reach.min(1.0 / c0) } else { 0.0 };
        let start_z = bounds.plane_z.min(0.0) - depth - BEAM_START_CLEARANCE_MM;
        Ok(Self {
            direction,
            bounds,
            start_z,
        })
    }

    /// [`Beam::new`] with [`PupilBounds::for_path`].
    pub fn for_path(
        prescription: &LensPrescription,
        path: TracePath,
        light: DVec3,
        wavelength_nm: f64,
    ) -> Result<Self, FlareError> {
        let d = light_direction(light)?;
        let b = PupilBounds::for_path(prescription, path, d, wavelength_nm)?;
        Self::new(prescription, d, b)
    }

    /// The blog's *Symmetry*: the beam of `path` for `light` turned about
    /// the axis into the x–z plane (azimuth 0), its pupil square widened
    /// to be symmetric about y = 0, and the azimuth it was turned by,
    /// radians. A lens of surfaces centred on its axis images this beam as
    /// it does the light's own, turned back by the azimuth, and mirror
    /// symmetric about y = 0: the rays of the grid's rows `j` and
    /// `n − 1 − j` land at `(x, ±y)`, so half the rows need tracing.
    pub fn meridional(
        prescription: &LensPrescription,
        path: TracePath,
        light: DVec3,
        wavelength_nm: f64,
    ) -> Result<(Self, f64), FlareError> {
        let d = light_direction(light)?;
        let azimuth = d.y.atan2(d.x);
        let canonical = DVec3::new(d.x.hypot(d.y), 0.0, d.z);
        let b = PupilBounds::for_path(prescription, path, canonical, wavelength_nm)?;
        let symmetric = PupilBounds::new(
            b.plane_z(),
            DVec2::new(b.center().x, 0.0),
            b.half_width() + b.center().y.abs(),
        )?;
        Ok((Self::new(prescription, canonical, symmetric)?, azimuth))
    }

    /// Unit direction of travel.
    pub fn direction(&self) -> DVec3 {
        self.direction
    }

    /// The pupil square.
    pub fn bounds(&self) -> PupilBounds {
        self.bounds
    }

    /// Point of the pupil square at `(u, v) ∈ [0, 1]²`.
    pub fn pupil_point(&self, u: f64, v: f64) -> DVec2 {
        self.bounds.center + self.bounds.half_width * DVec2::new(2.0 * u - 1.0, 2.0 * v - 1.0)
    }

    /// The ray through the pupil point at `(u, v)`, started in front of the
    /// lens. `u`, `v` outside [0, 1] extrapolate the square; a start point
    /// that is not finite (non-finite or enormous `u`, `v`) is refused.
    pub fn ray_at(&self, u: f64, v: f64) -> Result<Ray, InvalidInput> {
        Ray::new(self.start_of(u, v), self.direction)
    }

    /// [`Beam::ray_at`] for the crate's own grid coordinates in [0, 1]².
    pub(crate) fn grid_ray(&self, u: f64, v: f64) -> Ray {
        Ray::from_unit(self.start_of(u, v), self.direction)
    }

    fn start_of(&self, u: f64, v: f64) -> DVec3 {
        let p = self.pupil_point(u, v);
        let back = (self.bounds.plane_z - self.start_z) / self.direction.z;
        DVec3::new(p.x, p.y, self.bounds.plane_z) - self.direction * back
    }

    /// The beam over the smallest square of its plane that holds `rect`
    /// (clipped to its own square), centred on `rect`; with `symmetric`
    /// the square stays centred on the old square's y (a meridional
    /// beam's mirror symmetry, [`Beam::meridional`], is kept). The rays
    /// keep their direction and start plane, so a ray of the new grid is
    /// the ray of the old one through the same pupil point.
    pub fn within(&self, rect: PupilRect, symmetric: bool) -> Self {
        let (c, h) = (self.bounds.center, self.bounds.half_width);
        let lo = rect.min.clamp(c - h, c + h);
        let hi = rect.max.clamp(c - h, c + h).max(lo);
        let mut center = 0.5 * (lo + hi);
        let mut half = 0.5 * (hi - lo);
        if symmetric {
            center.y = c.y;
            half.y = (hi.y - c.y).abs().max((lo.y - c.y).abs());
        }
        // A square of at least a thousandth of the old side, never empty.
        let half_width = half.x.max(half.y).max(1e-3 * h);
        Self {
            direction: self.direction,
            bounds: PupilBounds {
                plane_z: self.bounds.plane_z,
                center,
                half_width,
            },
            start_z: self.start_z,
        }
    }

    /// Power of the whole square at unit irradiance normal to the beam:
    /// `area · d_z` (the beam's cross-section), mm².
    pub fn cross_section_mm2(&self) -> f64 {
        self.bounds.area_mm2() * self.direction.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lens::builtin;

    /// The meridional beam's grid is mirror symmetric row for row, and,
    /// turned back by the azimuth, carries the light's own ghost: the same
    /// power, centred in the same place.
    #[test]
    fn a_meridional_beam_images_the_turned_light() {
        use crate::lens::PreparedLens;
        use crate::lens_flare::{GridOptions, trace_grid};
        let lens = builtin::double_gauss();
        let prepared = PreparedLens::new(&lens, 550.0).unwrap();
        let light = DVec3::new(-0.12, 0.09, 1.0).normalize();
        let aperture = crate::lens_flare::Aperture::circle(lens.stop_semi_aperture_mm()).unwrap();
        let opts = crate::lens_flare::EstimateOptions::default();
        let ranked =
            crate::lens_flare::estimate_ghosts(&lens, light, 550.0, &aperture, &opts).unwrap();
        let path = ranked[0].path;
        let (beam, azimuth) = Beam::meridional(&lens, path, light, 550.0).unwrap();
        assert!((azimuth - 0.09f64.atan2(-0.12)).abs() < 1e-12);
        let n = 33;
        let grid = trace_grid(&prepared, path, &beam, n, &GridOptions::default()).unwrap();
        let mut checked = 0;
        for j in 0..n {
            for i in 0..n {
                let (a, b) = (grid.ray(i, j).unwrap(), grid.ray(i, n - 1 - j).unwrap());
                assert_eq!(a.alive, b.alive);
                if a.alive {
                    assert!((a.sensor - DVec2::new(b.sensor.x, -b.sensor.y)).length() < 1e-9);
                    assert!((a.throughput - b.throughput).abs() < 1e-12);
                    checked += 1;
                }
            }
        }
        assert!(checked > n * n / 4, "{checked}");
        let direct_beam = Beam::for_path(&lens, path, light, 550.0).unwrap();
        let direct = trace_grid(&prepared, path, &direct_beam, n, &GridOptions::default()).unwrap();
        let (p0, p1) = (grid.stats().power, direct.stats().power);
        assert!((p0 - p1).abs() < 0.02 * p1, "{p0} vs {p1}");
        let centre = |g: &crate::lens_flare::RayGrid| {
            let live: Vec<DVec2> = g
                .rays()
                .iter()
                .filter(|r| r.alive && r.r_rel <= 1.0)
                .map(|r| r.sensor)
                .collect();
            live.iter().sum::<DVec2>() / live.len() as f64
        };
        let turned = DVec2::from_angle(azimuth).rotate(centre(&grid));
        let want = centre(&direct);
        assert!(
            (turned - want).length() < 0.02 * want.length().max(1.0),
            "{turned} vs {want}"
        );
    }

    #[test]
    fn light_validation() {
        for bad in [
            DVec3::new(f64::NAN, 0.0, 1.0),
            DVec3::ZERO,
            light_from_field(f64::INFINITY, 0.0),
        ] {
            let e = light_direction(bad).unwrap_err();
            assert!(
                matches!(e, FlareError::Input(i) if i.what == "light direction"),
                "{bad}: {e}"
            );
        }
        assert_eq!(
            light_direction(DVec3::new(1.0, 0.0, 0.0)),
            Err(FlareError::LightBehindLens { dir_z: 0.0 })
        );
        assert_eq!(
            light_direction(DVec3::new(0.0, 0.0, -2.0)),
            Err(FlareError::LightBehindLens { dir_z: -1.0 })
        );
        let d = light_direction(DVec3::new(0.0, 3.0, 4.0)).unwrap();
        assert!((d - DVec3::new(0.0, 0.6, 0.8)).length() < 1e-15);
        let f = light_from_field(30.0, 90.0);
        assert!((f - DVec3::new(0.0, 0.5, 0.75f64.sqrt())).length() < 1e-12);
    }

    #[test]
    fn beam_rays_pass_their_pupil_points_and_start_in_front() {
        let p = builtin::tessar();
        let d = light_from_field(20.0, 30.0);
        let beam = Beam::for_path(&p, TracePath::Primary, d, 550.0).unwrap();
        let b = beam.bounds();
        for (u, v) in [(0.0, 0.0), (1.0, 0.3), (0.5, 0.5)] {
            let r = beam.ray_at(u, v).unwrap();
            let t = (b.plane_z - r.origin().z) / r.dir().z;
            let q = r.at(t);
            assert!((q.truncate() - beam.pupil_point(u, v)).length() < 1e-12);
            // Surface 0 (R = 42.97) has its cap in z in [0, 42.97].
            assert!(r.origin().z < -1.0);
        }
        // Cross-section: area · cos 20°.
        assert!((beam.cross_section_mm2() - b.area_mm2() * 20f64.to_radians().cos()).abs() < 1e-9);
    }

    #[test]
    fn entrance_pupil_bounds_hold_all_light() {
        // For every ghost that crosses the stop before reflecting, trace a
        // 33² grid over the (larger) front-aperture square and check that
        // every ray that gets through unclipped passes the entrance-pupil
        // square too: the pupil bounds cut no light.
        use crate::lens::{PreparedLens, ghosts};
        use crate::lens_flare::{GridOptions, trace_grid};
        for p in [builtin::tessar(), builtin::double_gauss()] {
            let lens = PreparedLens::new(&p, 550.0).unwrap();
            let stop = p.stop_index();
            for field in [0.0, 15.0, 30.0] {
                let d = light_from_field(field, 30.0);
                let front = Beam::new(&p, d, PupilBounds::front_aperture(&p, d).unwrap()).unwrap();
                let ep = PupilBounds::entrance_pupil(&p, 550.0).unwrap();
                for (i, j) in ghosts(&p).into_iter().filter(|&(i, _)| i > stop) {
                    let g = trace_grid(
                        &lens,
                        TracePath::ghost(i, j),
                        &front,
                        33,
                        &GridOptions::default(),
                    )
                    .unwrap();
                    for (k, r) in g.rays().iter().enumerate() {
                        if !(r.alive && r.r_rel <= 1.0) {
                            continue;
                        }
                        let ray = front
                            .ray_at((k % 33) as f64 / 32.0, (k / 33) as f64 / 32.0)
                            .unwrap();
                        let q = ray
                            .at((ep.plane_z - ray.origin().z) / ray.dir().z)
                            .truncate()
                            - ep.center;
                        assert!(
                            q.abs().max_element() <= ep.half_width,
                            "{}: ({i},{j}) at {field}°",
                            p.name()
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn entrance_pupil_bounds_keep_the_energy_at_a_wide_field() {
        // Every ghost that crosses the stop before reflecting gets the same
        // power through the entrance-pupil square as through the
        // front-aperture square (which holds everything entering the lens):
        // brute-force references over each square, 200² stratified rays, at
        // 30° for the Tessar (2.5× its ±12° field) and at 20° for the double
        // Gauss (at 30° only 2 of its ghosts behind the stop still get
        // light). Per ghost within the Monte-Carlo noise of its passing rays;
        // summed over the ghosts within 1 %.
        use crate::lens::{PreparedLens, ghosts};
        use crate::lens_flare::{Aperture, GridOptions, SensorWindow, reference_image};
        let w = SensorWindow::new(DVec2::ZERO, 1.0, 1, 1).unwrap();
        let o = GridOptions::default();
        for (p, field) in [(builtin::tessar(), 30.0), (builtin::double_gauss(), 20.0)] {
            let lens = PreparedLens::new(&p, 550.0).unwrap();
            let stop = p.stop_index();
            let ap = Aperture::of_stop(&p);
            let d = light_from_field(field, 30.0);
            let front = Beam::new(&p, d, PupilBounds::front_aperture(&p, d).unwrap()).unwrap();
            let ep = Beam::new(&p, d, PupilBounds::entrance_pupil(&p, 550.0).unwrap()).unwrap();
            let (mut sum_front, mut sum_ep, mut lit) = (0.0, 0.0, 0);
            for (i, j) in ghosts(&p).into_iter().filter(|&(i, _)| i > stop) {
                let path = TracePath::ghost(i, j);
                let a = reference_image(&lens, path, &front, &ap, w, 200, 1, &o).unwrap();
                let b = reference_image(&lens, path, &ep, &ap, w, 200, 1, &o).unwrap();
                let noise = 4.0 / (a.passed.min(b.passed).max(1) as f64).sqrt();
                assert!(
                    (b.power - a.power).abs() <= noise * a.power.max(b.power),
                    "{} at {field}°: ({i},{j}) front {} vs pupil {}",
                    p.name(),
                    a.power,
                    b.power
                );
                sum_front += a.power;
                sum_ep += b.power;
                lit += (a.passed > 0) as usize;
            }
            assert!(
                lit >= 8 && (sum_ep / sum_front - 1.0).abs() < 0.01,
                "{}: {sum_ep} vs {sum_front}, {lit} lit",
                p.name()
            );
        }
    }

    #[test]
    fn bounds_choice_follows_the_stop() {
        // Tessar stop is surface 3: ghost (5, 4) reflects behind it, (2, 0) in front.
        let p = builtin::tessar();
        let q = p.paraxial(550.0).unwrap();
        let behind = PupilBounds::for_path(&p, TracePath::ghost(5, 4), DVec3::Z, 550.0).unwrap();
        assert_eq!(behind.plane_z, q.entrance_pupil_z_mm);
        assert!(
            (behind.half_width - ENTRANCE_PUPIL_MARGIN * q.entrance_pupil_radius_mm).abs() < 1e-12
        );
        let front = PupilBounds::for_path(&p, TracePath::ghost(2, 0), DVec3::Z, 550.0).unwrap();
        assert_eq!(
            front.half_width, 19.2,
            "on axis: the front semi-aperture of US 2,854,889"
        );
        // A bad wavelength is refused, not hidden behind the front-aperture fallback.
        let e = PupilBounds::for_path(&p, TracePath::ghost(5, 4), DVec3::Z, f64::NAN).unwrap_err();
        assert!(
            matches!(e, FlareError::Input(i) if i.what == "wavelength (nm)"),
            "{e}"
        );
    }

    #[test]
    fn bounds_and_rays_are_checked() {
        let what = |e: InvalidInput| e.what;
        assert_eq!(
            PupilBounds::new(f64::NAN, DVec2::ZERO, 1.0).map_err(what),
            Err("pupil plane z (mm)")
        );
        assert_eq!(
            PupilBounds::new(0.0, DVec2::new(0.0, f64::INFINITY), 1.0).map_err(what),
            Err("pupil centre (mm)")
        );
        assert_eq!(
            PupilBounds::new(0.0, DVec2::ZERO, 0.0).map_err(what),
            Err("pupil half-width (mm)")
        );
        let p = builtin::tessar();
        let b = PupilBounds::new(-1.0, DVec2::new(1.0, 2.0), 3.0).unwrap();
        assert_eq!(
            (b.plane_z(), b.center(), b.half_width(), b.area_mm2()),
            (-1.0, DVec2::new(1.0, 2.0), 3.0, 36.0)
        );
        let beam = Beam::new(&p, DVec3::Z, b).unwrap();
        assert_eq!(beam.ray_at(f64::NAN, 0.5).unwrap_err().what, "ray origin");
        assert_eq!(beam.ray_at(1e308, 0.5).unwrap_err().what, "ray origin");
        assert_eq!(beam.ray_at(1.0, 0.0).unwrap(), beam.grid_ray(1.0, 0.0));
    }
}
