//! A small Whitted ray tracer with a level per ray (§3.3.3, Steps 2–6).
//!
//! For each pixel: its level (eq. 1–8, optionally quantised and held by the
//! hysteresis) decides everything. Level 0 → background colour, no ray
//! (Step 2). Otherwise the primary ray is traced with the reflection limit of
//! eq. 9 and every object is intersected at the mesh of eq. 10 (Steps 3–4);
//! shadow and reflection rays inherit the level (§3.3.1: rays spawned by
//! reflection get the same level as their primary ray).
//!
//! Shading: ambient + per light (shadow ray, 1/d² falloff) Lambert + Phong;
//! a reflective object mixes (1 − k_r)·local + k_r·reflected. When eq. 9's
//! limit stops the recursion the reflected term is dropped (black), as in
//! Whitted's cut-off, so that every extra bounce only adds light and a deeper
//! limit is never further from the full-quality image in that term.
//! Refraction is not modelled: the demo scenes have no transparent objects.

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::budget::{reflect_limit, sanitize_level};
use super::cave::CaveWall;
use super::error::FoveatedError;
use super::hysteresis::LevelQuantization;
use super::level::VisualField;
use super::tracker::GazeEstimate;
use crate::ray::Ray;
use crate::surface::reflect;

/// Image size and the global reflection limit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct TraceSettings {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Reflect_max of eq. 9 (the paper uses 3).
    pub reflect_max: u32,
}

impl TraceSettings {
    /// `width × height`, or [`FoveatedError::InvalidParameter`] when the
    /// product overflows `usize` or the image (one colour and one set of work
    /// counters per pixel) could not be allocated at all. A zero side gives 0.
    pub fn pixel_count(&self) -> Result<usize, FoveatedError> {
        let too_big = || {
            FoveatedError::InvalidParameter(format!("image of {}×{} pixels is too large", self.width, self.height))
        };
        let n = self.width.checked_mul(self.height).ok_or_else(too_big)?;
        let per_pixel = std::mem::size_of::<(DVec3, TraceStats)>();
        if n > isize::MAX as usize / per_pixel {
            return Err(too_big());
        }
        Ok(n)
    }
}

/// Work counters of a render.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct TraceStats {
    /// Primary rays (pixels with level > 0).
    pub primary_rays: u64,
    /// Reflection rays.
    pub reflection_rays: u64,
    /// Shadow rays.
    pub shadow_rays: u64,
    /// Ray–triangle tests.
    pub triangle_tests: u64,
    /// Pixels set to the background without a ray (level 0).
    pub background_pixels: u64,
}

impl TraceStats {
    /// All rays traced: primary + reflection + shadow.
    pub fn rays(&self) -> u64 {
        self.primary_rays + self.reflection_rays + self.shadow_rays
    }

    fn add(mut self, o: Self) -> Self {
        self.primary_rays += o.primary_rays;
        self.reflection_rays += o.reflection_rays;
        self.shadow_rays += o.shadow_rays;
        self.triangle_tests += o.triangle_tests;
        self.background_pixels += o.background_pixels;
        self
    }
}

/// A rendered image: linear RGB, row 0 at the top.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RenderedImage {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width × height` colours, row-major.
    pub pixels: Vec<DVec3>,
    /// Work done.
    pub stats: TraceStats,
}

/// Where primary rays come from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Camera {
    /// A symmetric pinhole camera.
    Pinhole {
        /// Eye.
        eye: DVec3,
        /// Unit view direction.
        forward: DVec3,
        /// Unit up, perpendicular to `forward`.
        up: DVec3,
        /// Vertical field of view in radians (0, π).
        fov_y: f64,
    },
    /// A CAVE wall seen from a tracked eye: pixel (x, y) is the ray from the
    /// eye through the wall point at that pixel's centre (the ray-traced twin
    /// of [`CaveWall::off_axis`]).
    Wall {
        /// The wall (the image covers it exactly).
        wall: CaveWall,
        /// Eye, in front of the wall.
        eye: DVec3,
    },
}

impl Camera {
    /// A pinhole camera. Errors: non-finite input, `forward` ∥ `up`, fov_y ∉ (0, π).
    pub fn pinhole(eye: DVec3, forward: DVec3, up: DVec3, fov_y: f64) -> Result<Self, FoveatedError> {
        if !(eye.is_finite() && forward.is_finite() && up.is_finite()) {
            return Err(FoveatedError::NonFinite("camera"));
        }
        let f = forward
            .try_normalize()
            .ok_or(FoveatedError::DegenerateDirection("camera forward"))?;
        let r = f
            .cross(up)
            .try_normalize()
            .ok_or(FoveatedError::DegenerateDirection("camera up ∥ forward"))?;
        if !(fov_y > 0.0 && fov_y < std::f64::consts::PI) {
            return Err(FoveatedError::InvalidParameter(format!("fov_y {fov_y} outside (0, π)")));
        }
        Ok(Self::Pinhole {
            eye,
            forward: f,
            up: r.cross(f),
            fov_y,
        })
    }

    /// A wall camera; the eye must be in front of the wall (typed error otherwise).
    pub fn cave(wall: CaveWall, eye: DVec3) -> Result<Self, FoveatedError> {
        wall.check_eye(eye)?;
        Ok(Self::Wall { wall, eye })
    }

    /// The eye.
    pub fn eye(&self) -> DVec3 {
        match *self {
            Self::Pinhole { eye, .. } | Self::Wall { eye, .. } => eye,
        }
    }

    /// The primary ray through the centre of pixel (x, y) of a w × h image
    /// (row 0 at the top); `None` where the camera cannot form a ray (a
    /// non-finite eye or frame), which the renderer draws as background.
    pub fn primary_ray(&self, x: usize, y: usize, w: usize, h: usize) -> Option<Ray> {
        let s = (x as f64 + 0.5) / w as f64;
        let t = 1.0 - (y as f64 + 0.5) / h as f64;
        match *self {
            Self::Pinhole {
                eye,
                forward,
                up,
                fov_y,
            } => {
                let right = forward.cross(up);
                let half_h = (fov_y / 2.0).tan();
                let half_w = half_h * w as f64 / h as f64;
                Ray::new(eye, forward + right * ((2.0 * s - 1.0) * half_w) + up * ((2.0 * t - 1.0) * half_h)).ok()
            }
            Self::Wall { wall, eye } => wall.ray_through(eye, s, t),
        }
    }
}

/// Offset for secondary ray origins, relative to the hit's distance from the
/// origin: big enough to leave the surface, small against the scene.
fn offset(p: DVec3) -> f64 {
    1e-7 * (1.0 + p.abs().max_element())
}

/// Traces one ray of `level` with at most `limit` further reflections (eq. 9
/// already applied); `depth` reflections have been made so far.
fn trace(scene: &super::scene::Scene, ray: &Ray, level: f64, depth: u32, limit: u32, st: &mut TraceStats) -> DVec3 {
    let Some(h) = scene.intersect(ray, level, f64::INFINITY, &mut st.triangle_tests) else {
        return scene.background;
    };
    let obj = &scene.objects()[h.object];
    let mesh = obj.mesh(h.lod);
    let m = obj.material();
    let p = ray.at(h.hit.t);
    // Two-sided: turn both normals towards the incoming ray.
    let mut geo = mesh.face_normal(h.hit.triangle);
    if geo.dot(ray.dir()) > 0.0 {
        geo = -geo;
    }
    let mut n = mesh.shading_normal(&h.hit);
    if n.dot(geo) < 0.0 {
        n = -n;
    }
    let origin = p + geo * offset(p);
    let view = -ray.dir();
    let mut local = scene.ambient * m.color;
    for light in scene.lights() {
        let to_l = light.position - origin;
        let dist = to_l.length();
        if dist.is_nan() || dist <= 0.0 {
            continue;
        }
        let l = to_l / dist;
        let ndl = n.dot(l);
        if ndl <= 0.0 {
            continue;
        }
        st.shadow_rays += 1;
        if scene.occluded(&Ray::from_unit(origin, l), level, dist, &mut st.triangle_tests) {
            continue;
        }
        let irr = light.intensity / (dist * dist);
        let spec = reflect(-l, n).dot(view).max(0.0).powf(m.shininess);
        local += irr * (m.color * (m.diffuse * ndl) + DVec3::splat(m.specular * spec));
    }
    if !m.reflective || m.reflectance <= 0.0 {
        return local;
    }
    let mut color = local * (1.0 - m.reflectance);
    if depth < limit {
        st.reflection_rays += 1;
        let r = Ray::from_unit(origin, reflect(ray.dir(), n));
        // A shading normal can send the reflection into the surface; it then
        // simply hits the surface again, which is finite and rare.
        color += trace(scene, &r, level, depth + 1, limit, st) * m.reflectance;
    }
    color
}

/// Traces one primary ray at `level` (Steps 2–6): background for level 0,
/// else the Whitted colour with eq. 9's reflection limit and eq. 10's meshes.
pub fn trace_ray(
    scene: &super::scene::Scene,
    ray: &Ray,
    level: f64,
    reflect_max: u32,
    stats: &mut TraceStats,
) -> DVec3 {
    let level = sanitize_level(level);
    if level <= 0.0 {
        stats.background_pixels += 1;
        return scene.background;
    }
    stats.primary_rays += 1;
    trace(scene, ray, level, 0, reflect_limit(level, reflect_max), stats)
}

/// Per-pixel levels of the primary rays: eq. 1–8 for the estimated gaze (1
/// everywhere under [`GazeEstimate::FullQuality`]), quantised by `quant`.
///
/// The level of a pixel is taken along its primary ray from the camera's
/// eye, which is where the gaze frame sits in a tracked CAVE. An invalid
/// `field` gives 1 everywhere ([`VisualField::level_of_angles`]).
///
/// Errors: [`FoveatedError::InvalidParameter`] when `width × height`
/// overflows ([`TraceSettings::pixel_count`]). A zero side gives no levels.
pub fn pixel_levels(
    camera: &Camera,
    settings: &TraceSettings,
    field: &VisualField,
    gaze: &GazeEstimate,
    quant: LevelQuantization,
) -> Result<Vec<f64>, FoveatedError> {
    let (w, h) = (settings.width, settings.height);
    let n = settings.pixel_count()?;
    Ok((0..n)
        .into_par_iter()
        .map(|i| {
            match camera.primary_ray(i % w, i / w, w, h) {
                Some(ray) => quant.apply(gaze.level(field, ray.dir())),
                None => 0.0,
            }
        })
        .collect())
}

/// Renders with one level per pixel (`levels.len()` must be width × height).
///
/// Errors: [`FoveatedError::InvalidParameter`] for an empty image, a
/// `width × height` that overflows, or a level count that differs from it.
pub fn render(
    scene: &super::scene::Scene,
    camera: &Camera,
    settings: &TraceSettings,
    levels: &[f64],
) -> Result<RenderedImage, FoveatedError> {
    let (w, h) = (settings.width, settings.height);
    if w == 0 || h == 0 {
        return Err(FoveatedError::InvalidParameter("empty image".into()));
    }
    let n = settings.pixel_count()?;
    if levels.len() != n {
        return Err(FoveatedError::InvalidParameter(format!(
            "{} levels for {}×{} pixels",
            levels.len(),
            w,
            h
        )));
    }
    let out: Vec<(DVec3, TraceStats)> = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut st = TraceStats::default();
            let c = match camera.primary_ray(i % w, i / w, w, h) {
                Some(ray) => trace_ray(scene, &ray, levels[i], settings.reflect_max, &mut st),
                None => {
                    st.background_pixels += 1;
                    scene.background
                }
            };
            (c, st)
        })
        .collect();
    let stats = out.iter().fold(TraceStats::default(), |a, (_, s)| a.add(*s));
    Ok(RenderedImage {
        width: w,
        height: h,
        pixels: out.into_iter().map(|(c, _)| c).collect(),
        stats,
    })
}

/// The full-quality render (level 1 for every ray): the reference of the
/// report. Errors as [`render`].
pub fn render_full_quality(
    scene: &super::scene::Scene,
    camera: &Camera,
    settings: &TraceSettings,
) -> Result<RenderedImage, FoveatedError> {
    if settings.width == 0 || settings.height == 0 {
        return Err(FoveatedError::InvalidParameter("empty image".into()));
    }
    render(scene, camera, settings, &vec![1.0; settings.pixel_count()?])
}

#[cfg(test)]
mod tests {
    use super::super::cave::front_right_floor;
    use super::super::level::GazeFrame;
    use super::super::scene::{DemoDetail, demo_scene};
    use super::*;

    fn setup(n: usize) -> (super::super::scene::Scene, Camera, TraceSettings) {
        let scene = demo_scene(&DemoDetail::small()).unwrap();
        let wall = front_right_floor(3.0).unwrap()[0];
        let cam = Camera::cave(wall, DVec3::new(0.0, 1.5, 0.0)).unwrap();
        (
            scene,
            cam,
            TraceSettings {
                width: n,
                height: n,
                reflect_max: 3,
            },
        )
    }

    #[test]
    fn level_zero_ray_gives_background_and_no_work() {
        let (scene, cam, _) = setup(8);
        let mut st = TraceStats::default();
        let ray = cam.primary_ray(8, 9, 16, 16).unwrap();
        assert_eq!(trace_ray(&scene, &ray, 0.0, 3, &mut st), scene.background);
        assert_eq!(
            st,
            TraceStats {
                background_pixels: 1,
                ..Default::default()
            }
        );
        // The same ray at level 1 hits the mirror sphere in front of the eye.
        let c = trace_ray(&scene, &ray, 1.0, 3, &mut st);
        assert_ne!(c, scene.background);
        assert!(st.triangle_tests > 0 && st.primary_rays == 1);
    }

    #[test]
    fn gaze_behind_the_head_renders_background_only() {
        let (scene, cam, s) = setup(16);
        let behind = GazeEstimate::Tracked(GazeFrame::new(cam.eye(), DVec3::Z, DVec3::Y).unwrap());
        let lv = pixel_levels(&cam, &s, &VisualField::paper(), &behind, LevelQuantization::Continuous).unwrap();
        assert!(lv.iter().all(|&l| l == 0.0));
        let img = render(&scene, &cam, &s, &lv).unwrap();
        assert!(img.pixels.iter().all(|&p| p == scene.background));
        assert_eq!(img.stats.rays(), 0);
    }

    #[test]
    fn full_quality_fallback_equals_the_reference() {
        let (scene, cam, s) = setup(12);
        let lost = GazeEstimate::FullQuality { last: None };
        let lv = pixel_levels(&cam, &s, &VisualField::paper(), &lost, LevelQuantization::Steps(4)).unwrap();
        let a = render(&scene, &cam, &s, &lv).unwrap();
        let b = render_full_quality(&scene, &cam, &s).unwrap();
        assert_eq!(a, b);
        assert!(a.pixels.iter().all(|p| p.is_finite()));
    }

    #[test]
    fn reflection_depth_follows_eq9() {
        // One pixel on the mirror sphere: level 1/3 → 1 reflection at most,
        // level 1 → up to 3 (Reflect_max = 3).
        // Pixel (8, 9) of 16 looks at the mirror sphere 0.26 m from its centre.
        let (scene, cam, _) = setup(8);
        let ray = cam.primary_ray(8, 9, 16, 16).unwrap();
        let mut a = TraceStats::default();
        trace_ray(&scene, &ray, 1.0 / 3.0, 3, &mut a);
        assert_eq!(a.reflection_rays, 1);
        let mut b = TraceStats::default();
        trace_ray(&scene, &ray, 1.0, 3, &mut b);
        assert!(b.reflection_rays >= 1 && b.reflection_rays <= 3);
    }

    #[test]
    fn foveation_saves_work_and_stays_finite() {
        let (scene, cam, s) = setup(16);
        let gaze = GazeEstimate::Tracked(GazeFrame::new(cam.eye(), DVec3::new(1.0, -0.2, -1.0), DVec3::Y).unwrap());
        let lv = pixel_levels(&cam, &s, &VisualField::paper(), &gaze, LevelQuantization::Continuous).unwrap();
        let fov = render(&scene, &cam, &s, &lv).unwrap();
        let full = render_full_quality(&scene, &cam, &s).unwrap();
        assert!(fov.pixels.iter().all(|p| p.is_finite()));
        assert!(fov.stats.triangle_tests < full.stats.triangle_tests);
        assert!(fov.stats.rays() <= full.stats.rays());
        assert!(fov.stats.background_pixels > 0);
        assert!(render(&scene, &cam, &s, &lv[1..]).is_err());
    }

    #[test]
    fn oversized_image_is_a_typed_error_not_an_overflow() {
        // width × height overflows usize: debug builds used to panic, release
        // builds to wrap (here to 0, i.e. an image of no pixels).
        let (scene, cam, _) = setup(4);
        let field = VisualField::paper();
        let gaze = GazeEstimate::FullQuality { last: None };
        let invalid = |r: Result<(), FoveatedError>| matches!(r, Err(FoveatedError::InvalidParameter(_)));
        for (w, h) in [(usize::MAX, 2), (1 << (usize::BITS / 2), 1 << (usize::BITS / 2)), (usize::MAX / 3, 5)] {
            let s = TraceSettings { width: w, height: h, reflect_max: 3 };
            assert!(s.width.checked_mul(s.height).is_none());
            assert!(invalid(s.pixel_count().map(|_| ())));
            assert!(invalid(render(&scene, &cam, &s, &[]).map(|_| ())));
            assert!(invalid(render_full_quality(&scene, &cam, &s).map(|_| ())));
            assert!(invalid(pixel_levels(&cam, &s, &field, &gaze, LevelQuantization::Continuous).map(|_| ())));
        }
        // No overflow, but no allocation could hold it: typed too, before any allocation.
        let huge = TraceSettings { width: usize::MAX / 8, height: 1, reflect_max: 3 };
        assert!(invalid(huge.pixel_count().map(|_| ())));
        assert!(invalid(render_full_quality(&scene, &cam, &huge).map(|_| ())));
        // Ordinary sizes are unaffected.
        let ok = TraceSettings { width: 3, height: 2, reflect_max: 3 };
        assert_eq!(ok.pixel_count(), Ok(6));
        assert_eq!(pixel_levels(&cam, &ok, &field, &gaze, LevelQuantization::Continuous).unwrap(), vec![1.0; 6]);
    }

    #[test]
    fn invalid_field_renders_full_quality() {
        // A visual field with a NaN central radius (public fields, deserialisable)
        // used to give level 0, i.e. background, for every pixel.
        let (scene, cam, s) = setup(8);
        let mut field = VisualField::paper();
        field.central = f64::NAN;
        let gaze = GazeEstimate::Tracked(GazeFrame::new(cam.eye(), DVec3::new(1.0, -0.2, -1.0), DVec3::Y).unwrap());
        let lv = pixel_levels(&cam, &s, &field, &gaze, LevelQuantization::Steps(4)).unwrap();
        assert!(lv.iter().all(|&l| l == 1.0));
        assert_eq!(render(&scene, &cam, &s, &lv).unwrap(), render_full_quality(&scene, &cam, &s).unwrap());
    }

    #[test]
    fn wall_camera_needs_the_eye_in_front() {
        let wall = front_right_floor(3.0).unwrap()[0];
        assert!(matches!(
            Camera::cave(wall, DVec3::new(0.0, 1.5, -1.5)),
            Err(FoveatedError::EyeNotInFront { .. })
        ));
        assert!(Camera::pinhole(DVec3::ZERO, DVec3::Y, DVec3::Y, 1.0).is_err());
    }

    #[test]
    fn pinhole_centre_ray_is_forward() {
        let c = Camera::pinhole(DVec3::ZERO, DVec3::NEG_Z, DVec3::Y, 1.0).unwrap();
        let r = c.primary_ray(1, 1, 3, 3).unwrap();
        assert!((r.dir() - DVec3::NEG_Z).length() < 1e-15);
    }
}
