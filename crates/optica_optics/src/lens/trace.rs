//! Real-ray (exact, sequential) tracing through a prescription: the primary
//! path and two-reflection ghost paths. The method, the polarisation
//! approximation and the stop crossings are documented on the `lens` module.

use glam::{DVec2, DVec3};
use rayon::prelude::*;
use thiserror::Error;

use super::paraxial::indices;
use super::prescription::LensPrescription;
use crate::fresnel::{Coating, fresnel_unpolarized};
use crate::input::{self, InvalidInput};
use crate::ray::Ray;
use crate::surface::{Hit, Refraction, SphericalSurface, T_EPSILON, reflect, refract};

/// Which sequence of surfaces a ray follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TracePath {
    /// All surfaces in order, refracting at each: the image-forming path.
    Primary,
    /// Reflect at surface `first` (the later one), then at `second`
    /// (`second < first`), then forward to the sensor.
    Ghost {
        /// The surface reflecting first (index into the prescription).
        first: usize,
        /// The surface reflecting second, in front of `first`.
        second: usize,
    },
}

impl TracePath {
    /// The ghost path `(i, j)` (reflect at `i`, then at `j < i`).
    pub fn ghost(i: usize, j: usize) -> Self {
        TracePath::Ghost {
            first: i,
            second: j,
        }
    }
}

/// Where a ray was heading when it failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    /// Travelling +z (towards the sensor).
    Forward,
    /// Travelling −z, between the two reflections of a ghost.
    Backward,
}

/// Why a ray could not be traced.
///
/// [`TraceError::Input`], [`TraceError::InvalidPath`] and
/// [`TraceError::Index`] are about the call (the same for every ray); the
/// others are what happens to one ray in the lens.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum TraceError {
    /// A wavelength that is not a finite number > 0, or a sensor z that is
    /// not finite.
    #[error(transparent)]
    Input(#[from] InvalidInput),
    /// A ghost path that does not exist in this lens.
    #[error("no ghost path ({first}, {second}): {reason}")]
    InvalidPath {
        /// First reflecting surface given.
        first: usize,
        /// Second reflecting surface given.
        second: usize,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// A glass gives no index >= 1 at this wavelength
    /// ([`crate::glass::Glass::try_index`]; every prescription has one over
    /// the visible band, so this happens only outside 380–780 nm).
    #[error("surface {surface}: the glass has no index >= 1 at {wavelength_nm} nm")]
    Index {
        /// Index of the surface.
        surface: usize,
        /// The wavelength, nm.
        wavelength_nm: f64,
    },
    /// The ray's line does not meet the sphere's cap (the ray dies here).
    #[error("the ray misses surface {surface} ({pass:?} pass)")]
    Missed {
        /// Index of the surface.
        surface: usize,
        /// Direction of travel.
        pass: Pass,
    },
    /// Total internal reflection where the path must refract (the ray dies here).
    #[error("total internal reflection at surface {surface} ({pass:?} pass)")]
    TotalInternalReflection {
        /// Index of the surface.
        surface: usize,
        /// Direction of travel.
        pass: Pass,
    },
    /// The ray leaves the last surface parallel to the sensor or away from it.
    #[error("the ray never reaches the sensor plane (direction z = {dir_z})")]
    MissedSensor {
        /// z component of the exit direction.
        dir_z: f64,
    },
}

/// What a ray brings to the sensor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceResult {
    /// Where the ray meets the sensor plane (its z is the sensor z).
    pub position: DVec3,
    /// Unit direction at the sensor.
    pub direction: DVec3,
    /// Largest `r / semi_aperture` met along the path (stop included); the
    /// ray is physically blocked when this exceeds 1.
    pub r_rel: f64,
    /// (x, y) where the ray first crosses the aperture-stop plane.
    pub stop_xy: DVec2,
    /// (x, y) of every crossing of the stop plane, in order; entries past
    /// [`Self::stop_crossings`] repeat the first crossing, so testing an
    /// aperture shape (blades) at all three is testing it at every crossing.
    pub stop_xy_all: [DVec2; MAX_STOP_CROSSINGS],
    /// How many times the path crosses the stop plane (1 or 3 for a ghost).
    pub stop_crossings: u32,
    /// Fraction of the ray's power that arrives: ∏ T over refractions times
    /// the two R of a ghost.
    pub throughput: f64,
}

/// A prescription made ready for tracing at one wavelength: surfaces placed
/// on the axis and indices evaluated once, so a grid of rays costs only the
/// intersections.
#[derive(Clone, Debug)]
pub struct PreparedLens {
    surfaces: Vec<PreparedSurface>,
    stop: usize,
    wavelength_nm: f64,
    table_sensor_z: f64,
}

#[derive(Clone, Copy, Debug)]
struct PreparedSurface {
    geometry: SphericalSurface,
    n_before: f64,
    n_after: f64,
    semi_aperture: f64,
    is_stop: bool,
    coating: Option<Coating>,
}

/// One surface of a [`PreparedLens`] as a tracer on another device (the
/// lens-flare plugin's compute shader) needs it: placed on the axis, with
/// its indices at the lens's wavelength.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceData {
    /// z of the vertex, mm.
    pub vertex_z: f64,
    /// Curvature 1/R, 1/mm (flat is exactly 0).
    pub curvature: f64,
    /// Clear semi-aperture, mm.
    pub semi_aperture_mm: f64,
    /// Index of the medium in front of the surface.
    pub n_before: f64,
    /// Index of the medium behind the surface.
    pub n_after: f64,
    /// Whether this is the aperture stop (an opening: no refraction).
    pub is_stop: bool,
    /// The surface's anti-reflection coating, if any.
    pub coating: Option<Coating>,
}

/// Most crossings of the stop plane a path can have: a ghost reflecting
/// behind the stop and then in front of it crosses it three times (forward,
/// backward between the reflections, forward again).
pub const MAX_STOP_CROSSINGS: usize = 3;

/// How far behind a ray's origin, in mm, the next surface may lie and still
/// be hit. Surfaces that touch (a zero thickness, common in patent tables)
/// meet where the ray leaves the first one, and round-off can put the second
/// a hair behind the origin. 1e-7 mm is far below the 0.01 mm to which
/// tables give thicknesses, yet about 10⁵ times the round-off of a position
/// of 100 mm in f64 (~1e-14 relative, 1e-12 mm).
const COINCIDENT_TOLERANCE_MM: f64 = 1e-7;

/// Smallest `d_z` of a ray leaving the last surface that still reaches the
/// sensor plane. Below it the distance to the sensor exceeds 10¹² times the
/// axial gap (the ray is parallel to the sensor within round-off) and the
/// result is [`TraceError::MissedSensor`].
const MIN_EXIT_DIR_Z: f64 = 1e-12;

/// Ghost paths of a prescription: every pair `(i, j)`, `i > j`, of Fresnel
/// interfaces (the stop excluded), ordered by `i` then `j`.
pub fn ghosts(prescription: &LensPrescription) -> Vec<(usize, usize)> {
    let interfaces = prescription.interfaces();
    let mut out = Vec::with_capacity(interfaces.len() * interfaces.len().saturating_sub(1) / 2);
    for (a, &i) in interfaces.iter().enumerate() {
        for &j in &interfaces[..a] {
            out.push((i, j));
        }
    }
    out
}

/// Traces `ray` through `prescription` along `path` at `wavelength_nm` to the
/// table's sensor plane (last vertex + last thickness: the image plane of a
/// patent table). See [`PreparedLens`] to trace many rays.
pub fn trace(
    prescription: &LensPrescription,
    ray: Ray,
    wavelength_nm: f64,
    path: TracePath,
) -> Result<TraceResult, TraceError> {
    PreparedLens::new(prescription, wavelength_nm)?.trace(ray, path)
}

/// [`trace`] to a sensor plane at `sensor_z` (lens frame: first vertex at 0).
pub fn trace_to(
    prescription: &LensPrescription,
    ray: Ray,
    wavelength_nm: f64,
    path: TracePath,
    sensor_z: f64,
) -> Result<TraceResult, TraceError> {
    PreparedLens::new(prescription, wavelength_nm)?.trace_to(ray, path, sensor_z)
}

/// Running state of one ray along a path.
struct State<'a> {
    ray: Ray,
    r_rel: f64,
    throughput: f64,
    stop_xy: [DVec2; MAX_STOP_CROSSINGS],
    stop_crossings: u32,
    /// Surface hits in order, when the caller wants to draw the path.
    points: Option<&'a mut Vec<DVec3>>,
}

#[derive(Clone, Copy, PartialEq)]
enum Event {
    Refract,
    Reflect,
}

impl PreparedLens {
    /// Places the surfaces of `prescription` on the axis and evaluates its
    /// indices at `wavelength_nm` (a finite number > 0).
    pub fn new(prescription: &LensPrescription, wavelength_nm: f64) -> Result<Self, TraceError> {
        let wavelength_nm = input::positive("wavelength (nm)", wavelength_nm)?;
        let (before, after) =
            indices(prescription, wavelength_nm).map_err(|surface| TraceError::Index {
                surface,
                wavelength_nm,
            })?;
        let z = prescription.vertex_z();
        let surfaces = prescription
            .surfaces()
            .iter()
            .enumerate()
            .map(|(k, s)| PreparedSurface {
                geometry: SphericalSurface::from_checked(z[k], s.curvature),
                n_before: before[k],
                n_after: after[k],
                semi_aperture: s.semi_aperture_mm,
                is_stop: s.is_stop,
                coating: s.coating,
            })
            .collect();
        Ok(Self {
            surfaces,
            stop: prescription.stop_index(),
            wavelength_nm,
            table_sensor_z: prescription.table_image_z(),
        })
    }

    /// The wavelength the indices were evaluated at, in nm.
    pub fn wavelength_nm(&self) -> f64 {
        self.wavelength_nm
    }

    /// z of the table's sensor plane (last vertex + last thickness).
    pub fn table_sensor_z(&self) -> f64 {
        self.table_sensor_z
    }

    /// Index of the stop surface.
    pub fn stop_index(&self) -> usize {
        self.stop
    }

    /// Every surface, front to back, as another tracer needs it.
    pub fn surface_data(&self) -> Vec<SurfaceData> {
        self.surfaces
            .iter()
            .map(|s| SurfaceData {
                vertex_z: s.geometry.vertex_z(),
                curvature: s.geometry.curvature(),
                semi_aperture_mm: s.semi_aperture,
                n_before: s.n_before,
                n_after: s.n_after,
                is_stop: s.is_stop,
                coating: s.coating,
            })
            .collect()
    }

    /// Traces one ray to the table's sensor plane.
    pub fn trace(&self, ray: Ray, path: TracePath) -> Result<TraceResult, TraceError> {
        self.trace_to(ray, path, self.table_sensor_z)
    }

    /// Traces many rays in parallel (rayon) to the table's sensor plane.
    pub fn trace_many(
        &self,
        rays: &[Ray],
        path: TracePath,
    ) -> Vec<Result<TraceResult, TraceError>> {
        rays.par_iter().map(|r| self.trace(*r, path)).collect()
    }

    /// Checks a path against this lens.
    pub fn check_path(&self, path: TracePath) -> Result<(), TraceError> {
        if let TracePath::Ghost { first, second } = path {
            let bad = |reason| {
                Err(TraceError::InvalidPath {
                    first,
                    second,
                    reason,
                })
            };
            if first >= self.surfaces.len() {
                return bad("the first surface is past the last surface");
            }
            if second >= first {
                return bad("the second reflection must be at a surface in front of the first");
            }
            if self.surfaces[first].is_stop || self.surfaces[second].is_stop {
                return bad("the aperture stop reflects nothing");
            }
        }
        Ok(())
    }

    /// Traces one ray along `path` to the plane `z = sensor_z`.
    ///
    /// The sensor plane is met by the ray's line, so a sensor set inside the
    /// last element's sag still gets a continuous grid; only a ray leaving
    /// parallel to the plane or away from it fails ([`TraceError::MissedSensor`]).
    pub fn trace_to(
        &self,
        ray: Ray,
        path: TracePath,
        sensor_z: f64,
    ) -> Result<TraceResult, TraceError> {
        self.trace_impl(ray, path, sensor_z, None)
    }

    /// Like [`PreparedLens::trace_to`], and also returns the polyline the ray
    /// followed: its origin, every surface hit in order, and the sensor point
    /// when it got there. A ray that fails still returns the part it traced,
    /// which is what a lens-layout drawing wants.
    pub fn trace_polyline(
        &self,
        ray: Ray,
        path: TracePath,
        sensor_z: f64,
    ) -> (Vec<DVec3>, Result<TraceResult, TraceError>) {
        let mut points = vec![ray.origin()];
        let result = self.trace_impl(ray, path, sensor_z, Some(&mut points));
        if let Ok(r) = &result {
            points.push(r.position);
        }
        (points, result)
    }

    fn trace_impl(
        &self,
        ray: Ray,
        path: TracePath,
        sensor_z: f64,
        points: Option<&mut Vec<DVec3>>,
    ) -> Result<TraceResult, TraceError> {
        let sensor_z = input::finite("sensor z (mm)", sensor_z)?;
        self.check_path(path)?;
        let mut st = State {
            ray,
            r_rel: 0.0,
            throughput: 1.0,
            stop_xy: [DVec2::ZERO; MAX_STOP_CROSSINGS],
            stop_crossings: 0,
            points,
        };
        let last = self.surfaces.len() - 1;
        match path {
            TracePath::Primary => {
                for k in 0..=last {
                    self.interact(&mut st, k, Pass::Forward, Event::Refract)?;
                }
            }
            TracePath::Ghost {
                first: i,
                second: j,
            } => {
                for k in 0..i {
                    self.interact(&mut st, k, Pass::Forward, Event::Refract)?;
                }
                self.interact(&mut st, i, Pass::Forward, Event::Reflect)?;
                for k in (j + 1..i).rev() {
                    self.interact(&mut st, k, Pass::Backward, Event::Refract)?;
                }
                self.interact(&mut st, j, Pass::Backward, Event::Reflect)?;
                for k in j + 1..=last {
                    self.interact(&mut st, k, Pass::Forward, Event::Refract)?;
                }
            }
        }
        let d = st.ray.dir();
        if !(d.z >= MIN_EXIT_DIR_Z) {
            return Err(TraceError::MissedSensor { dir_z: d.z });
        }
        let t = (sensor_z - st.ray.origin().z) / d.z;
        let mut position = st.ray.at(t);
        position.z = sensor_z;
        if !position.is_finite() {
            return Err(TraceError::MissedSensor { dir_z: d.z });
        }
        // A valid path always crosses the stop (it lies before or after the
        // reflections, and one forward pass spans it); fill the unused
        // entries with the first crossing.
        let mut stop_xy_all = st.stop_xy;
        for k in (st.stop_crossings as usize).max(1)..MAX_STOP_CROSSINGS {
            stop_xy_all[k] = stop_xy_all[0];
        }
        Ok(TraceResult {
            position,
            direction: d,
            r_rel: st.r_rel,
            stop_xy: stop_xy_all[0],
            stop_xy_all,
            stop_crossings: st.stop_crossings,
            throughput: st.throughput,
        })
    }

    /// Finds the hit on surface `k`, allowing a coincident surface just
    /// behind the ray's origin (zero thickness).
    fn hit(&self, k: usize, ray: &Ray, pass: Pass) -> Result<Hit, TraceError> {
        let geometry = &self.surfaces[k].geometry;
        if let Some(h) = geometry.intersect(ray) {
            return Ok(h);
        }
        // Back the origin off by the tolerance and accept a hit at most that
        // far behind the real origin: the surface may pass through it
        // (touching surfaces). Seen from the backed-off origin such a hit is
        // at t in [T_EPSILON, 2·tol + T_EPSILON] — `intersect` drops hits
        // closer than T_EPSILON — i.e. between tol behind the real origin and
        // just ahead of it, where the first `intersect` could not see it.
        let back = Ray::from_unit(
            ray.origin() - ray.dir() * COINCIDENT_TOLERANCE_MM,
            ray.dir(),
        );
        match geometry.intersect(&back) {
            Some(h) if h.t <= 2.0 * COINCIDENT_TOLERANCE_MM + T_EPSILON => Ok(Hit {
                t: h.t - COINCIDENT_TOLERANCE_MM,
                ..h
            }),
            _ => Err(TraceError::Missed { surface: k, pass }),
        }
    }

    fn interact(
        &self,
        st: &mut State,
        k: usize,
        pass: Pass,
        event: Event,
    ) -> Result<(), TraceError> {
        let s = &self.surfaces[k];
        let hit = self.hit(k, &st.ray, pass)?;
        let p = hit.point;
        if let Some(points) = st.points.as_deref_mut() {
            points.push(p);
        }
        let r = (p.x * p.x + p.y * p.y).sqrt();
        st.r_rel = st.r_rel.max(r / s.semi_aperture);
        if s.is_stop {
            // The stop is an opening in one medium: no refraction, no Fresnel.
            if let Some(slot) = st.stop_xy.get_mut(st.stop_crossings as usize) {
                *slot = DVec2::new(p.x, p.y);
            }
            st.stop_crossings += 1;
            st.ray = Ray::from_unit(p, st.ray.dir());
            return Ok(());
        }
        let (n1, n2) = match pass {
            Pass::Forward => (s.n_before, s.n_after),
            Pass::Backward => (s.n_after, s.n_before),
        };
        let cos_i = st.ray.dir().dot(hit.normal).abs().min(1.0);
        let reflectance = match &s.coating {
            Some(c) => c.reflectance(cos_i, n1, n2, self.wavelength_nm),
            None => fresnel_unpolarized(cos_i, n1, n2),
        };
        let dir = match event {
            Event::Reflect => {
                st.throughput *= reflectance;
                reflect(st.ray.dir(), hit.normal)
            }
            Event::Refract => match refract(st.ray.dir(), hit.normal, n1, n2) {
                Refraction::Transmitted(d) => {
                    st.throughput *= 1.0 - reflectance;
                    d
                }
                Refraction::TotalInternalReflection => {
                    return Err(TraceError::TotalInternalReflection { surface: k, pass });
                }
            },
        };
        st.ray = Ray::from_unit(p, dir);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::builtin;
    use super::*;
    use crate::glass::{Glass, LAMBDA_D_NM};
    use crate::input::Expected;
    use crate::lens::LensSurface;
    use proptest::prelude::*;

    #[test]
    fn polyline_follows_the_trace() {
        let lens = builtin::tessar();
        let prepared = PreparedLens::new(&lens, LAMBDA_D_NM).unwrap();
        let ray = Ray::new(DVec3::new(0.0, 5.0, -20.0), DVec3::Z).unwrap();
        let sensor = prepared.table_sensor_z();
        let (points, result) = prepared.trace_polyline(ray, TracePath::Primary, sensor);
        let result = result.unwrap();
        // origin, one hit per surface (8 with the stop), the sensor point
        assert_eq!(points.len(), lens.surfaces().len() + 2);
        assert_eq!(*points.last().unwrap(), result.position);
        assert_eq!(
            prepared.trace_to(ray, TracePath::Primary, sensor).unwrap(),
            result
        );
        // z increases along a primary path
        assert!(points.windows(2).all(|w| w[1].z >= w[0].z));
        // a ghost path goes back: some step decreases z
        let (ghost, _) = prepared.trace_polyline(ray, TracePath::ghost(6, 5), sensor);
        assert!(ghost.windows(2).any(|w| w[1].z < w[0].z));
    }

    #[test]
    fn ghost_counts_match_reference() {
        // n(n−1)/2 ghosts for n interfaces (the blog's "Ghost enumeration"):
        // Tessar 7 interfaces → 21, double Gauss 14 → 91, Heliar 8 → 28.
        assert_eq!(ghosts(&builtin::tessar()).len(), 21);
        assert_eq!(ghosts(&builtin::double_gauss()).len(), 91);
        assert_eq!(ghosts(&builtin::heliar()).len(), 28);
        let g = ghosts(&builtin::tessar());
        assert!(
            g.iter().all(|&(i, j)| i > j && i != 3 && j != 3),
            "stop (surface 3) excluded"
        );
        assert_eq!(g[0], (1, 0));
    }

    #[test]
    fn near_axis_real_ray_agrees_with_paraxial() {
        // Small-angle limit: a ray at h = 1e-3 mm crosses the axis at the
        // paraxial focus and its sine-condition focal length h / sin(u') equals
        // the paraxial EFL (spherical aberration is O(h²) ~ 1e-10 here).
        for p in [
            builtin::tessar(),
            builtin::double_gauss(),
            builtin::heliar(),
        ] {
            let q = p.paraxial(LAMBDA_D_NM).unwrap();
            let h = 1e-3;
            let ray = Ray::new(DVec3::new(0.0, h, -20.0), DVec3::Z).unwrap();
            let r = trace_to(&p, ray, LAMBDA_D_NM, TracePath::Primary, q.image_z_mm).unwrap();
            let last_z = *p.vertex_z().last().unwrap();
            // Where the exit ray meets the axis.
            let z_cross = r.position.z - r.position.y * r.direction.z / r.direction.y;
            let bfl_real = z_cross - last_z;
            assert!(
                (bfl_real / q.bfl_mm - 1.0).abs() < 1e-6,
                "{}: {bfl_real} vs {}",
                p.name(),
                q.bfl_mm
            );
            let efl_real = -h / r.direction.y;
            assert!(
                (efl_real / q.efl_mm - 1.0).abs() < 1e-6,
                "{}: {efl_real} vs {}",
                p.name(),
                q.efl_mm
            );
            assert!(r.position.y.abs() < 1e-6 * h * 1e3);
            assert_eq!(r.stop_crossings, 1);
        }
    }

    /// Stop, then a flat slab of index n in air: the hand-computable 2-surface case.
    fn slab(n: f64) -> LensPrescription {
        LensPrescription::new(
            "slab",
            "hand computation",
            vec![
                LensSurface::stop(5.0, Glass::Air, 20.0),
                LensSurface::new(f64::INFINITY, 10.0, Glass::Constant(n), 20.0),
                LensSurface::new(f64::INFINITY, 30.0, Glass::Air, 20.0),
            ],
        )
        .unwrap()
    }

    #[test]
    fn ghost_throughput_of_a_slab_by_hand() {
        // Normal incidence: R = ((n−1)/(n+1))² = 0.04 for n = 1.5 on either
        // side; ghost (2, 1) = T·R·R·T = 0.96² · 0.04² = 0.00147456.
        let p = slab(1.5);
        let ray = Ray::new(DVec3::new(1.0, 2.0, -1.0), DVec3::Z).unwrap();
        let r = trace(&p, ray, 550.0, TracePath::ghost(2, 1)).unwrap();
        assert!(
            (r.throughput - 0.96 * 0.96 * 0.04 * 0.04).abs() < 1e-15,
            "{}",
            r.throughput
        );
        assert!((r.position - DVec3::new(1.0, 2.0, 45.0)).length() < 1e-12);
        assert_eq!(r.stop_xy, DVec2::new(1.0, 2.0));
        // Primary: T² = 0.9216.
        let r = trace(&p, ray, 550.0, TracePath::Primary).unwrap();
        assert!((r.throughput - 0.9216).abs() < 1e-15);

        // Oblique, 30° in air: Snell and the Fresnel s/p formulas written out here.
        let n: f64 = 1.5;
        let (ci, si) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let st = si / n;
        let ct = (1.0 - st * st).sqrt();
        let rs = ((ci - n * ct) / (ci + n * ct)).powi(2);
        let rp = ((n * ci - ct) / (n * ci + ct)).powi(2);
        let big_r = 0.5 * (rs + rp); // same value from inside at the refracted angle
        let want = (1.0 - big_r) * big_r * big_r * (1.0 - big_r);
        let dir = DVec3::new(si, 0.0, ci);
        let r = trace(
            &p,
            Ray::new(DVec3::new(0.0, 0.0, -1.0), dir).unwrap(),
            550.0,
            TracePath::ghost(2, 1),
        )
        .unwrap();
        assert!(
            (r.throughput - want).abs() < 1e-15,
            "{} vs {want}",
            r.throughput
        );
        // Lateral walk: 1 mm in air to the stop, 5 mm air, then three 10 mm glass
        // crossings at tan θt, then 30 mm air; all tangents by hand.
        let x = (1.0 + 5.0 + 30.0) * si / ci + 3.0 * 10.0 * st / ct;
        assert!((r.position.x - x).abs() < 1e-12, "{} vs {x}", r.position.x);
        assert!(
            (r.direction - dir).length() < 1e-12,
            "a slab ghost leaves parallel to the input"
        );
    }

    #[test]
    fn on_axis_tessar_ghost_throughput_by_hand() {
        // On the axis every incidence is normal, so each interface gives
        // R = ((n1 − n2)/(n1 + n2))² with the table's n_d (the n_d/V_d model
        // reproduces n_d at the d line). Ghost (6, 5): T0 T1 T2 T4 T5 · R6 ·
        // R5 · T6 T7 (the stop, surface 3, does nothing).
        let n: [f64; 9] = [1.0, 1.6910, 1.5486, 1.0, 1.0, 1.6398, 1.0, 1.6910, 1.0];
        let r = |k: usize| ((n[k] - n[k + 1]) / (n[k] + n[k + 1])).powi(2);
        let t = |k: usize| 1.0 - r(k);
        let want = t(0) * t(1) * t(2) * t(4) * t(5) * r(6) * r(5) * t(6) * t(7);
        let p = builtin::tessar();
        let got = trace(
            &p,
            Ray::new(DVec3::new(0.0, 0.0, -10.0), DVec3::Z).unwrap(),
            LAMBDA_D_NM,
            TracePath::ghost(6, 5),
        )
        .unwrap();
        assert!(
            (got.throughput / want - 1.0).abs() < 1e-12,
            "{} vs {want}",
            got.throughput
        );
        assert!(got.position.truncate().length() < 1e-12 && got.stop_crossings == 1);
        // Ghost (5, 2) straddles the stop: it crosses the stop plane three times.
        let got = trace(
            &p,
            Ray::new(DVec3::new(0.0, 0.0, -10.0), DVec3::Z).unwrap(),
            LAMBDA_D_NM,
            TracePath::ghost(5, 2),
        )
        .unwrap();
        let want = t(0) * t(1) * t(2) * t(4) * r(5) * t(4) * r(2) * t(4) * t(5) * t(6) * t(7);
        assert!(
            (got.throughput / want - 1.0).abs() < 1e-12,
            "{} vs {want}",
            got.throughput
        );
        assert_eq!(got.stop_crossings, 3);
    }

    #[test]
    fn unpolarised_product_is_the_blogs_approximation() {
        // The figures in the module docs: 30° on n = 1.5. The tracer
        // multiplies s/p-averaged factors; the exact unpolarised value of a
        // meridional ray averages the s and p products.
        use crate::fresnel::try_fresnel_sp;
        let (ci, si) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let (rs, rp) = try_fresnel_sp(ci, 1.0, 1.5).unwrap().unwrap();
        assert!(
            (rs - 0.0578).abs() < 5e-5 && (rp - 0.0252).abs() < 5e-5,
            "{rs} {rp}"
        );
        let mean = 0.5 * (rs + rp);
        assert!((mean * mean - 1.72e-3).abs() < 5e-6);
        assert!((0.5 * (rs * rs + rp * rp) - 1.99e-3).abs() < 5e-6);
        // Slab ghost (2, 1): T R R T, every interface at the same angle pair.
        let r = trace(
            &slab(1.5),
            Ray::new(DVec3::new(0.0, 0.0, -1.0), DVec3::new(si, 0.0, ci)).unwrap(),
            550.0,
            TracePath::ghost(2, 1),
        )
        .unwrap();
        let exact = 0.5 * ((1.0 - rs).powi(2) * rs * rs + (1.0 - rp).powi(2) * rp * rp);
        assert!((r.throughput - 1.58e-3).abs() < 5e-6, "{}", r.throughput);
        assert!((exact - 1.79e-3).abs() < 5e-6, "{exact}");
        assert!((r.throughput - (1.0 - mean).powi(2) * mean * mean).abs() < 1e-15);
    }

    #[test]
    fn glass_without_an_index_fails_the_trace_typed() {
        // 1.5/1.2 is valid over 380–780 nm, but its Cauchy curve falls to
        // 0.965 at 1500 nm: `Glass::index` would have traced a lens of index
        // 0.965; try_index makes it an index error naming the surface.
        let p = slab(1.5)
            .edited(|s| s[1].glass_after = Glass::Abbe { nd: 1.5, vd: 1.2 })
            .unwrap();
        let ray = Ray::new(DVec3::new(0.0, 1.0, -1.0), DVec3::Z).unwrap();
        assert!(trace(&p, ray, 780.0, TracePath::Primary).is_ok());
        assert_eq!(
            trace(&p, ray, 1500.0, TracePath::Primary),
            Err(TraceError::Index {
                surface: 1,
                wavelength_nm: 1500.0
            })
        );
        assert_eq!(
            PreparedLens::new(&p, 1500.0).unwrap_err(),
            TraceError::Index {
                surface: 1,
                wavelength_nm: 1500.0
            }
        );
    }

    #[test]
    fn every_stop_crossing_is_recorded() {
        // Tessar ghost (5, 2) straddles the stop (surface 3): three crossings,
        // at three different places for an oblique ray; the first is stop_xy.
        let p = builtin::tessar();
        let ray = Ray::new(DVec3::new(0.0, 2.0, -10.0), DVec3::new(0.0, 0.05, 1.0)).unwrap();
        let r = trace(&p, ray, LAMBDA_D_NM, TracePath::ghost(5, 2)).unwrap();
        assert_eq!(r.stop_crossings, 3);
        assert_eq!(r.stop_xy_all[0], r.stop_xy);
        let [a, b, c] = r.stop_xy_all;
        assert!(
            (a - b).length() > 0.1 && (b - c).length() > 0.1 && (a - c).length() > 0.1,
            "{a} {b} {c}"
        );
        // The polyline shows the same three points on the stop plane (z = 4.16 + 2.10 + 9.80).
        let prepared = PreparedLens::new(&p, LAMBDA_D_NM).unwrap();
        let (points, _) =
            prepared.trace_polyline(ray, TracePath::ghost(5, 2), prepared.table_sensor_z());
        let stop_z = p.vertex_z()[3];
        let on_stop: Vec<DVec2> = points
            .iter()
            .filter(|q| (q.z - stop_z).abs() < 1e-9)
            .map(|q| q.truncate())
            .collect();
        assert_eq!(on_stop, vec![a, b, c]);
        // One crossing: every entry is that crossing.
        let r = trace(&p, ray, LAMBDA_D_NM, TracePath::ghost(6, 5)).unwrap();
        assert_eq!(r.stop_crossings, 1);
        assert_eq!(r.stop_xy_all, [r.stop_xy; 3]);
    }

    #[test]
    fn surface_data_is_the_prepared_lens() {
        // Tessar at the d line: vertices at the running sum of thicknesses,
        // the stop flagged, each surface's index behind it the next one's
        // in front, air in front of the first.
        let p = builtin::tessar();
        let lens = PreparedLens::new(&p, LAMBDA_D_NM).unwrap();
        let data = lens.surface_data();
        assert_eq!(data.len(), p.surfaces().len());
        let z = p.vertex_z();
        for (k, s) in data.iter().enumerate() {
            assert_eq!(s.vertex_z, z[k]);
            assert_eq!(s.curvature, p.surfaces()[k].curvature);
            assert_eq!(s.is_stop, k == p.stop_index());
            assert_eq!(s.semi_aperture_mm, p.surfaces()[k].semi_aperture_mm);
        }
        assert_eq!(data[0].n_before, 1.0);
        assert!((data[0].n_after - 1.6910).abs() < 1e-4);
        for w in data.windows(2) {
            assert_eq!(w[0].n_after, w[1].n_before);
        }
    }

    #[test]
    fn coated_ghost_throughput_by_hand() {
        // Quarter-wave layer of index n_c at its design wavelength, normal
        // incidence: R = ((n0 n2 − n_c²)/(n0 n2 + n_c²))² (Hecht, Optics §9.7).
        let (n, nc, wl) = (1.5, 1.38, 550.0);
        let coat = Coating::quarter_wave(nc, wl).unwrap();
        let p = slab(n).with_coating_everywhere(coat).unwrap();
        let rr = ((n - nc * nc) / (n + nc * nc)).powi(2);
        let r = trace(
            &p,
            Ray::new(DVec3::new(0.0, 0.0, -1.0), DVec3::Z).unwrap(),
            wl,
            TracePath::ghost(2, 1),
        )
        .unwrap();
        let want = (1.0 - rr) * rr * rr * (1.0 - rr);
        assert!(
            (r.throughput - want).abs() < 1e-14,
            "{} vs {want}",
            r.throughput
        );
    }

    #[test]
    fn ray_far_outside_misses_with_typed_error() {
        // Surface 0 of the Tessar has R = 42.97 mm: a ray 60 mm off axis,
        // parallel to it, has no intersection with that sphere.
        let p = builtin::tessar();
        let r = trace(
            &p,
            Ray::new(DVec3::new(0.0, 60.0, -10.0), DVec3::Z).unwrap(),
            LAMBDA_D_NM,
            TracePath::Primary,
        );
        assert_eq!(
            r,
            Err(TraceError::Missed {
                surface: 0,
                pass: Pass::Forward
            })
        );
        // A ray inside the sphere but outside the semi-aperture (19.2 mm)
        // keeps going to the sensor, flagged by r_rel > 1.
        let r = trace(
            &p,
            Ray::new(DVec3::new(0.0, 19.5, -10.0), DVec3::Z).unwrap(),
            LAMBDA_D_NM,
            TracePath::Primary,
        )
        .expect("a ray 0.3 mm outside the front semi-aperture is traced, not lost");
        assert!(r.r_rel > 1.0 && r.position.is_finite(), "{r:?}");
    }

    #[test]
    fn total_internal_reflection_is_typed() {
        // Flat entry, then a convex exit of R = −12 in n = 1.8: a ray at 9 mm
        // meets it at asin(9/12) = 48.6° > critical asin(1/1.8) = 33.7°.
        let p = LensPrescription::new(
            "tir",
            "hand",
            vec![
                LensSurface::stop(1.0, Glass::Air, 11.0),
                LensSurface::new(f64::INFINITY, 12.0, Glass::Constant(1.8), 11.0),
                LensSurface::new(-12.0, 20.0, Glass::Air, 11.0),
            ],
        )
        .unwrap();
        let r = trace(
            &p,
            Ray::new(DVec3::new(0.0, 9.0, -1.0), DVec3::Z).unwrap(),
            550.0,
            TracePath::Primary,
        );
        assert_eq!(
            r,
            Err(TraceError::TotalInternalReflection {
                surface: 2,
                pass: Pass::Forward
            })
        );
    }

    #[test]
    fn bad_inputs_are_typed() {
        let p = builtin::tessar();
        let ok = Ray::new(DVec3::new(0.0, 1.0, -1.0), DVec3::Z).unwrap();
        for bad in [f64::NAN, 0.0, -550.0, f64::INFINITY] {
            let e = trace(&p, ok, bad, TracePath::Primary).unwrap_err();
            assert!(
                matches!(&e, TraceError::Input(i) if i.what == "wavelength (nm)" && i.expected == Expected::Positive),
                "{e}"
            );
        }
        // (4, 3): the Tessar's stop is surface 3; (2, 2): not in front; (8, 2): past the last surface.
        for (i, j) in [(4, 3), (2, 2), (8, 2)] {
            let e = trace(&p, ok, 550.0, TracePath::ghost(i, j)).unwrap_err();
            assert!(
                matches!(e, TraceError::InvalidPath { first, second, .. } if (first, second) == (i, j)),
                "{e}"
            );
        }
        let e = trace_to(&p, ok, 550.0, TracePath::Primary, f64::INFINITY).unwrap_err();
        assert!(
            matches!(&e, TraceError::Input(i) if i.what == "sensor z (mm)" && i.value == f64::INFINITY),
            "{e}"
        );
        // A ray with no direction cannot be built, so no tracer sees one.
        assert_eq!(
            Ray::new(DVec3::ZERO, DVec3::ZERO).unwrap_err().expected,
            Expected::Direction
        );
    }

    #[test]
    fn zero_thickness_touching_surfaces_trace() {
        // A meniscus cemented at the vertex with a zero air gap: the on-axis ray
        // meets both surfaces at the same point and must not be lost.
        let p = LensPrescription::new(
            "touching",
            "zero gap",
            vec![
                LensSurface::new(50.0, 3.0, Glass::Constant(1.5), 10.0),
                LensSurface::new(40.0, 0.0, Glass::Air, 10.0),
                LensSurface::new(40.0, 3.0, Glass::Constant(1.6), 10.0),
                LensSurface::new(-60.0, 2.0, Glass::Air, 10.0),
                LensSurface::stop(50.0, Glass::Air, 8.0),
            ],
        )
        .unwrap();
        let r = trace(
            &p,
            Ray::new(DVec3::new(0.0, 0.0, -5.0), DVec3::Z).unwrap(),
            550.0,
            TracePath::Primary,
        )
        .unwrap();
        assert!(r.position.is_finite() && r.position.x.abs() < 1e-12);
    }

    #[test]
    fn flat_surface_heliar_traces() {
        // The Heliar's plano surface (c = 0, not the stop) in the middle of a path.
        let p = builtin::heliar();
        assert!(p.surfaces()[6].is_flat() && !p.surfaces()[6].is_stop);
        let r = trace(
            &p,
            Ray::new(DVec3::new(0.0, 5.0, -10.0), DVec3::Z).unwrap(),
            LAMBDA_D_NM,
            TracePath::Primary,
        )
        .unwrap();
        assert!(
            r.position.y.abs() < 0.5,
            "f/3.5 Heliar focuses a 5 mm ray near the axis: {}",
            r.position.y
        );
        assert_eq!(r.position.z, p.table_image_z());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn finite_rays_give_finite_results_or_typed_errors(
            x in -80.0f64..80.0, y in -80.0f64..80.0, z in -60.0f64..-0.5,
            dx in -1.0f64..1.0, dy in -1.0f64..1.0, dz in -0.2f64..1.0,
            wl in 300.0f64..1000.0, which in 0usize..4, g in 0usize..200,
        ) {
            let p = match which { 0 => builtin::tessar(), 1 => builtin::double_gauss(), 2 => builtin::heliar(), _ => slab(1.7) };
            let gh = ghosts(&p);
            let path = if g % 5 == 0 { TracePath::Primary } else { let (i, j) = gh[g % gh.len()]; TracePath::ghost(i, j) };
            prop_assume!(DVec3::new(dx, dy, dz).length() > 1e-6);
            let ray = Ray::new(DVec3::new(x, y, z), DVec3::new(dx, dy, dz)).unwrap();
            let count = p.surfaces().len();
            match trace(&p, ray, wl, path) {
                Ok(r) => {
                    prop_assert!(r.position.is_finite() && r.direction.is_finite());
                    prop_assert!(r.r_rel.is_finite() && r.r_rel >= 0.0);
                    prop_assert!(r.stop_xy.is_finite());
                    prop_assert!(r.throughput.is_finite() && (0.0..=1.0).contains(&r.throughput));
                    prop_assert!((r.direction.length() - 1.0).abs() < 1e-9);
                    prop_assert!(r.stop_crossings == 1 || r.stop_crossings == 3, "{}", r.stop_crossings);
                }
                // The call is valid (finite ray, wavelength in 300–1000 nm
                // where every shipped glass has an index, a path of this
                // lens), so only what happens to the ray in the lens may fail:
                // it misses a surface or meets TIR on a surface the path
                // visits in that direction, or leaves away from the sensor.
                Err(TraceError::Missed { surface, pass } | TraceError::TotalInternalReflection { surface, pass }) => {
                    prop_assert!(surface < count);
                    if pass == Pass::Backward {
                        // Only a ghost (i, j) runs backward, over j..i.
                        let TracePath::Ghost { first, second } = path else {
                            return Err(TestCaseError::fail("a backward pass on the primary path"));
                        };
                        prop_assert!(second <= surface && surface < first, "{surface} outside ({first}, {second})");
                    }
                }
                Err(TraceError::MissedSensor { dir_z }) => prop_assert!(!(dir_z >= MIN_EXIT_DIR_Z), "{dir_z}"),
                Err(e) => prop_assert!(false, "a valid call failed with {e:?}"),
            }
        }
    }
}
