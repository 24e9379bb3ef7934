//! A small Whitted tracer with a level per ray (documented on [`trace_ray`]).

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::budget::{reflect_limit, sanitize_level};
use super::cave::CaveWall;
use super::error::FoveatedError;
use super::hysteresis::LevelQuantization;
use super::level::VisualField;
use super::scene::TracerScene;
use super::tracker::GazeEstimate;
use crate::input::{self, Expected, InvalidInput};
use crate::ray::Ray;
use crate::surface::{Refraction, reflect, refract};

/// Offset of secondary ray origins (shadow and reflection rays) along the
/// surface normal, relative to the hit point's largest coordinate (plus 1 m,
/// so that it does not vanish near the origin). The hit point's rounding
/// error grows with its coordinates: a few ulps, 2.2e-16 each, relative.
/// 1e-7 is some 10⁸ ulps, so a secondary ray never re-hits its own surface
/// through rounding, and 0.1 µm at 1 m, far below the thinnest feature of
/// the test scenes (a 0.2 m torus tube).
const SECONDARY_RAY_OFFSET_REL: f64 = 1e-7;

/// Image size and the global reflection limit, checked by
/// [`TraceSettings::new`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct TraceSettings {
    width: usize,
    height: usize,
    reflect_max: u32,
}

impl TraceSettings {
    /// `width × height` pixels (each at least 1) and Reflect_max of eq. 9
    /// (the paper uses 3).
    ///
    /// Errors: [`FoveatedError::Input`] for a zero side, or for a pixel count
    /// that overflows `usize` or that no allocation could hold (one colour
    /// and one set of work counters per pixel).
    pub fn new(width: usize, height: usize, reflect_max: u32) -> Result<Self, FoveatedError> {
        for (what, n) in [
            ("image width (pixels)", width),
            ("image height (pixels)", height),
        ] {
            if n == 0 {
                return Err(InvalidInput::new(what, 0.0, Expected::Positive).into());
            }
        }
        let per_pixel = std::mem::size_of::<(DVec3, TraceStats)>();
        let max = isize::MAX as usize / per_pixel;
        match width.checked_mul(height) {
            Some(n) if n <= max => Ok(Self {
                width,
                height,
                reflect_max,
            }),
            _ => Err(InvalidInput::new(
                "image pixel count",
                width as f64 * height as f64,
                Expected::Range {
                    min: 1.0,
                    max: max as f64,
                },
            )
            .into()),
        }
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// Reflect_max of eq. 9.
    pub fn reflect_max(&self) -> u32 {
        self.reflect_max
    }

    /// `width × height`.
    pub fn pixel_count(&self) -> usize {
        self.width * self.height
    }
}

/// Work counters of a render.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct TraceStats {
    /// Primary rays (pixels with level > 0).
    pub primary_rays: u64,
    /// Reflection rays.
    pub reflection_rays: u64,
    /// Refraction rays.
    pub refraction_rays: u64,
    /// Shadow rays.
    pub shadow_rays: u64,
    /// Ray–triangle tests.
    pub triangle_tests: u64,
    /// Pixels set to the background without a ray (level 0).
    pub background_pixels: u64,
}

impl TraceStats {
    /// All rays traced: primary + reflection + refraction + shadow.
    pub fn rays(&self) -> u64 {
        self.primary_rays + self.reflection_rays + self.refraction_rays + self.shadow_rays
    }

    fn add(mut self, o: Self) -> Self {
        self.primary_rays += o.primary_rays;
        self.reflection_rays += o.reflection_rays;
        self.refraction_rays += o.refraction_rays;
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

/// Where the reference tracer's primary rays come from. Built by
/// [`TracerCamera::pinhole`] or [`TracerCamera::cave`], so every pixel has a
/// ray.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TracerCamera(CameraKind);

#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
enum CameraKind {
    /// A symmetric pinhole camera: unit forward, unit up ⟂ forward, fov_y ∈ (0, π).
    Pinhole {
        eye: DVec3,
        forward: DVec3,
        up: DVec3,
        fov_y: f64,
    },
    /// A CAVE wall seen from an eye in front of it.
    Wall { wall: CaveWall, eye: DVec3 },
}

impl TracerCamera {
    /// A symmetric pinhole camera at `eye` (m) looking along `forward`, with
    /// `up` (neither need be unit) and a vertical field of view `fov_y` in
    /// radians, strictly between 0 and π.
    ///
    /// Errors: [`FoveatedError::Input`] for a non-finite eye, a zero or
    /// non-finite direction, or a field of view outside (0, π);
    /// [`FoveatedError::DegenerateDirection`] for `up` parallel to `forward`.
    pub fn pinhole(
        eye: DVec3,
        forward: DVec3,
        up: DVec3,
        fov_y: f64,
    ) -> Result<Self, FoveatedError> {
        let eye = input::finite_vec3("camera position (m)", eye)?;
        let f = input::direction("camera forward", forward)?;
        let up = input::direction("camera up", up)?;
        let r = f
            .cross(up)
            .try_normalize()
            .ok_or(FoveatedError::DegenerateDirection(
                "camera up parallel to forward",
            ))?;
        if !(fov_y > 0.0 && fov_y < std::f64::consts::PI) {
            // `Expected::Range` is inclusive; both ends are refused here.
            let range = Expected::Range {
                min: 0.0,
                max: std::f64::consts::PI,
            };
            return Err(
                InvalidInput::new("camera vertical field of view (rad)", fov_y, range).into(),
            );
        }
        Ok(Self(CameraKind::Pinhole {
            eye,
            forward: f,
            up: r.cross(f),
            fov_y,
        }))
    }

    /// A CAVE wall seen from a tracked eye: pixel (x, y) is the ray from the
    /// eye through the wall point at that pixel's centre (the ray-traced twin
    /// of [`CaveWall::off_axis`]). Errors: those of [`CaveWall::check_eye`].
    pub fn cave(wall: CaveWall, eye: DVec3) -> Result<Self, FoveatedError> {
        wall.check_eye(eye)?;
        Ok(Self(CameraKind::Wall { wall, eye }))
    }

    /// The eye (m).
    pub fn eye(&self) -> DVec3 {
        match self.0 {
            CameraKind::Pinhole { eye, .. } | CameraKind::Wall { eye, .. } => eye,
        }
    }

    /// The primary ray through the centre of pixel (x, y) of an image of
    /// `settings`' size (row 0 at the top). A pixel outside the image gives
    /// the ray through the same place extended beyond the image's edge.
    pub fn primary_ray(&self, x: usize, y: usize, settings: &TraceSettings) -> Ray {
        self.primary_ray_at(x as f64 + 0.5, y as f64 + 0.5, settings)
    }

    /// The primary ray through the image point (`px`, `py`), in pixels from
    /// the top left corner (a pixel's centre is at + 0.5).
    pub fn primary_ray_at(&self, px: f64, py: f64, settings: &TraceSettings) -> Ray {
        let (w, h) = (settings.width as f64, settings.height as f64);
        let s = px / w;
        let t = 1.0 - py / h;
        match self.0 {
            CameraKind::Pinhole {
                eye,
                forward,
                up,
                fov_y,
            } => {
                let right = forward.cross(up);
                let half_h = (fov_y / 2.0).tan();
                let half_w = half_h * w / h;
                // The forward component is 1, so the sum is never zero.
                let d =
                    forward + right * ((2.0 * s - 1.0) * half_w) + up * ((2.0 * t - 1.0) * half_h);
                Ray::from_unit(eye, d.normalize())
            }
            CameraKind::Wall { wall, eye } => wall.ray_from_checked_eye(eye, s, t),
        }
    }
}

/// Offset for secondary ray origins: [`SECONDARY_RAY_OFFSET_REL`] scaled by
/// the hit's largest coordinate.
fn offset(p: DVec3) -> f64 {
    SECONDARY_RAY_OFFSET_REL * (1.0 + p.abs().max_element())
}

/// Traces one ray of `level` with at most `limit` further reflections (eq. 9
/// already applied); `depth` reflections have been made so far.
fn trace(
    scene: &TracerScene,
    ray: &Ray,
    level: f64,
    depth: u32,
    limit: u32,
    st: &mut TraceStats,
) -> DVec3 {
    let Some(h) = scene.intersect(ray, level, f64::INFINITY, &mut st.triangle_tests) else {
        return scene.background();
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
    let mut local = scene.ambient() * m.color;
    for light in scene.lights() {
        let to_l = light.position - origin;
        let dist = to_l.length();
        if !(dist > 0.0) {
            continue;
        }
        let l = to_l / dist;
        let ndl = n.dot(l);
        if ndl <= 0.0 {
            continue;
        }
        st.shadow_rays += 1;
        if scene.occluded(
            &Ray::from_unit(origin, l),
            level,
            dist,
            &mut st.triangle_tests,
        ) {
            continue;
        }
        let irr = light.intensity / (dist * dist);
        let spec = reflect(-l, n).dot(view).max(0.0).powf(m.shininess);
        local += irr * (m.color * (m.diffuse * ndl) + DVec3::splat(m.specular * spec));
    }
    let mut kr = if m.reflective { m.reflectance } else { 0.0 };
    let kt = m.transmittance;
    if kr <= 0.0 && kt <= 0.0 {
        return local;
    }
    let color = local * (1.0 - kr - kt);
    if depth >= limit {
        return color;
    }
    let mut secondary = DVec3::ZERO;
    if kt > 0.0 {
        // Entering when the ray meets the winding's front face: meshes are
        // closed and wound outwards, so the inside has the object's index.
        let entering = mesh.face_normal(h.hit.triangle).dot(ray.dir()) < 0.0;
        let (n1, n2) = if entering { (1.0, m.ior) } else { (m.ior, 1.0) };
        match refract(ray.dir(), n, n1, n2) {
            Refraction::Transmitted(d) => {
                st.refraction_rays += 1;
                // Behind the surface: the geometric normal faces the ray.
                let r = Ray::from_unit(p - geo * offset(p), d);
                secondary += trace(scene, &r, level, depth + 1, limit, st) * kt;
            }
            // Total internal reflection: the transmitted share is reflected.
            Refraction::TotalInternalReflection => kr += kt,
        }
    }
    if kr > 0.0 {
        st.reflection_rays += 1;
        let r = Ray::from_unit(origin, reflect(ray.dir(), n));
        // A shading normal can send the reflection into the surface; it then
        // simply hits the surface again, which is finite and rare.
        secondary += trace(scene, &r, level, depth + 1, limit, st) * kr;
    }
    color + secondary
}

/// Traces one primary ray at `level`, Steps 2–6 of the paper's §3.3.3, in
/// linear RGB.
///
/// The level (eq. 1–8, optionally quantised and held by the hysteresis)
/// decides everything. Level 0 → background colour, no ray (Step 2).
/// Otherwise the ray is traced with the reflection limit of eq. 9 and every
/// object is intersected at the mesh of eq. 10 (Steps 3–4); shadow and
/// reflection rays inherit the level (§3.3.1: rays spawned by reflection get
/// the same level as their primary ray). A level outside [0, 1] is clamped;
/// NaN counts as 1 (full quality).
///
/// Shading (after T. Whitted, "An Improved Illumination Model for Shaded
/// Display", *Communications of the ACM* 23(6), 1980, the paper's tracer):
/// ambient + per light (shadow ray, 1/d² falloff) Lambert + Phong; an
/// object mixes (1 − k_r − k_t)·local + k_r·reflected + k_t·refracted
/// (Snell's law into the object's index and out of it; on total internal
/// reflection the transmitted share is reflected). Reflection and
/// refraction both count towards eq. 9's limit (the paper's scenes have
/// only mirrors; a refraction is one more bounce of the same tree). When the
/// limit stops the recursion both terms are dropped (black), as in
/// Whitted's cut-off, so that every extra bounce only adds light and a deeper
/// limit is never further from the full-quality image in that term. Shadow
/// rays treat transparent objects as opaque, as Whitted's did.
pub fn trace_ray(
    scene: &TracerScene,
    ray: &Ray,
    level: f64,
    reflect_max: u32,
    stats: &mut TraceStats,
) -> DVec3 {
    let level = sanitize_level(level);
    if level <= 0.0 {
        stats.background_pixels += 1;
        return scene.background();
    }
    stats.primary_rays += 1;
    trace(
        scene,
        ray,
        level,
        0,
        reflect_limit(level, reflect_max),
        stats,
    )
}

/// Per-pixel levels of the primary rays, row-major: eq. 1–8 for the
/// estimated gaze (1 everywhere under [`GazeEstimate::FullQuality`]),
/// quantised by `quant`.
///
/// The level of a pixel is taken along its primary ray from the camera's
/// eye, which is where the gaze frame sits in a tracked CAVE.
pub fn pixel_levels(
    camera: &TracerCamera,
    settings: &TraceSettings,
    field: &VisualField,
    gaze: &GazeEstimate,
    quant: LevelQuantization,
) -> Vec<f64> {
    let w = settings.width;
    (0..settings.pixel_count())
        .into_par_iter()
        .map(|i| quant.apply(gaze.level(field, camera.primary_ray(i % w, i / w, settings).dir())))
        .collect()
}

/// Renders with one level per pixel, row-major: [`trace_ray`] for each
/// pixel's primary ray, in parallel.
///
/// Errors: [`FoveatedError::LengthMismatch`] when `levels` does not hold
/// one level per pixel.
pub fn render(
    scene: &TracerScene,
    camera: &TracerCamera,
    settings: &TraceSettings,
    levels: &[f64],
) -> Result<RenderedImage, FoveatedError> {
    let n = settings.pixel_count();
    if levels.len() != n {
        return Err(FoveatedError::LengthMismatch {
            what: "levels for the image's pixels",
            expected: n,
            got: levels.len(),
        });
    }
    Ok(render_with(scene, camera, settings, |i| levels[i]))
}

/// The full-quality render (level 1 for every ray): the reference the report
/// compares foveated renders with.
pub fn render_full_quality(
    scene: &TracerScene,
    camera: &TracerCamera,
    settings: &TraceSettings,
) -> RenderedImage {
    render_with(scene, camera, settings, |_| 1.0)
}

/// How the periphery's rays are spread (the plugin's `GazeRayTracer`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Layers {
    /// Rays of level in [`outer_level`](Layers::outer_level), 1) are traced
    /// on a grid this many times coarser per axis; 1 (or 0) traces every
    /// pixel at its level.
    pub scale: u32,
    /// Rays of a level below it are traced on a grid 2·scale times coarser
    /// (the outer layer); 0 for none.
    pub outer_level: f64,
}

impl Layers {
    /// Every pixel traced at its level: [`render`] with [`pixel_levels`].
    pub const PER_PIXEL: Self = Self {
        scale: 1,
        outer_level: 0.0,
    };
}

/// A grid `k` times coarser than the image, whose texel (i, j) holds the ray
/// through ((i + ½)·k, (j + ½)·k), traced where its level lies in [lo, 1).
struct Layer {
    k: usize,
    width: usize,
    height: usize,
    texels: Vec<(Option<DVec3>, TraceStats)>,
}

impl Layer {
    fn trace(
        k: usize,
        lo: f64,
        settings: &TraceSettings,
        ray_level: &(impl Fn(f64, f64) -> (Ray, f64) + Sync),
        scene: &TracerScene,
    ) -> Self {
        let (width, height) = (settings.width.div_ceil(k), settings.height.div_ceil(k));
        let texels = (0..width * height)
            .into_par_iter()
            .map(|i| {
                let mut st = TraceStats::default();
                let (ray, l) = ray_level(
                    ((i % width) as f64 + 0.5) * k as f64,
                    ((i / width) as f64 + 0.5) * k as f64,
                );
                let c = (l < 1.0 && l >= lo)
                    .then(|| trace_ray(scene, &ray, l, settings.reflect_max, &mut st));
                (c, st)
            })
            .collect();
        Self {
            k,
            width,
            height,
            texels,
        }
    }

    /// The bilinear blend at image point (px, py), if all four taps were traced.
    fn sample(&self, px: f64, py: f64) -> Option<DVec3> {
        let k = self.k as f64;
        let (gx, gy) = (px / k - 0.5, py / k - 0.5);
        let x0 = gx.floor().clamp(0.0, (self.width - 1) as f64);
        let y0 = gy.floor().clamp(0.0, (self.height - 1) as f64);
        let (fx, fy) = ((gx - x0).clamp(0.0, 1.0), (gy - y0).clamp(0.0, 1.0));
        let (x0, y0) = (x0 as usize, y0 as usize);
        let (x1, y1) = ((x0 + 1).min(self.width - 1), (y0 + 1).min(self.height - 1));
        let tap = |x: usize, y: usize| self.texels[y * self.width + x].0;
        let (c00, c10, c01, c11) = (tap(x0, y0)?, tap(x1, y0)?, tap(x0, y1)?, tap(x1, y1)?);
        Some(c00.lerp(c10, fx).lerp(c01.lerp(c11, fx), fy))
    }
}

/// Renders as the plugin's GPU tracer schedules its rays (the twin of
/// `trace_mid`, `trace_outer` and `trace_full` in its `raytrace.wgsl`):
/// each ray's level is eq. 1–8 of its direction for `gaze`, quantised by
/// `quant`. Rays of level 1 (the central field) are traced at every pixel;
/// rays of level in [outer_level, 1) on the middle layer, a grid
/// `layers.scale` times coarser per axis (texel (i, j) is the ray through
/// image point ((i + ½)·scale, (j + ½)·scale)), and with an outer layer,
/// every ray of level below 1 on a grid 2·scale times coarser. A
/// peripheral pixel takes the bilinear blend of its layer (the middle one
/// at level ≥ outer_level, else the outer one), else of the other layer
/// where one of its own taps was not traced, else it is traced itself;
/// pixels of level 0 are background.
pub fn render_layered(
    scene: &TracerScene,
    camera: &TracerCamera,
    settings: &TraceSettings,
    field: &VisualField,
    gaze: &GazeEstimate,
    quant: LevelQuantization,
    layers: Layers,
) -> RenderedImage {
    let ray_level = |px: f64, py: f64| {
        let ray = camera.primary_ray_at(px, py, settings);
        let l = quant.apply(gaze.level(field, ray.dir()));
        (ray, l)
    };
    let (w, h) = (settings.width, settings.height);
    if layers.scale <= 1 {
        return render_with(scene, camera, settings, |i| {
            ray_level((i % w) as f64 + 0.5, (i / w) as f64 + 0.5).1
        });
    }
    let k = layers.scale as usize;
    let outer_level = layers.outer_level.clamp(0.0, 1.0);
    let mid = Layer::trace(k, outer_level, settings, &ray_level, scene);
    let outer = (outer_level > 0.0).then(|| Layer::trace(2 * k, 0.0, settings, &ray_level, scene));
    let full: Vec<(DVec3, TraceStats)> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let mut st = TraceStats::default();
            let (px, py) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            let (ray, l) = ray_level(px, py);
            if l <= 0.0 {
                st.background_pixels += 1;
                return (scene.background(), st);
            }
            if l < 1.0 {
                let from_mid = || mid.sample(px, py);
                let from_outer = || outer.as_ref().and_then(|o| o.sample(px, py));
                let blended = if l < outer_level {
                    from_outer().or_else(from_mid)
                } else {
                    from_mid().or_else(from_outer)
                };
                if let Some(c) = blended {
                    return (c, st);
                }
            }
            let c = trace_ray(scene, &ray, l, settings.reflect_max, &mut st);
            (c, st)
        })
        .collect();
    let stats = mid
        .texels
        .iter()
        .chain(outer.iter().flat_map(|o| o.texels.iter()))
        .map(|(_, s)| *s)
        .chain(full.iter().map(|(_, s)| *s))
        .fold(TraceStats::default(), |a, s| a.add(s));
    RenderedImage {
        width: w,
        height: h,
        pixels: full.into_iter().map(|(c, _)| c).collect(),
        stats,
    }
}

/// Renders pixel `i` at `level(i)`.
fn render_with(
    scene: &TracerScene,
    camera: &TracerCamera,
    settings: &TraceSettings,
    level: impl Fn(usize) -> f64 + Sync,
) -> RenderedImage {
    let w = settings.width;
    let out: Vec<(DVec3, TraceStats)> = (0..settings.pixel_count())
        .into_par_iter()
        .map(|i| {
            let mut st = TraceStats::default();
            let ray = camera.primary_ray(i % w, i / w, settings);
            let c = trace_ray(scene, &ray, level(i), settings.reflect_max, &mut st);
            (c, st)
        })
        .collect();
    let stats = out
        .iter()
        .fold(TraceStats::default(), |a, (_, s)| a.add(*s));
    RenderedImage {
        width: w,
        height: settings.height,
        pixels: out.into_iter().map(|(c, _)| c).collect(),
        stats,
    }
}

#[cfg(test)]
mod tests {
    use super::super::cave::front_right_floor;
    use super::super::level::GazeFrame;
    use super::super::mesh::TriangleMesh;
    use super::super::scene::{DemoDetail, LodObject, TracerMaterial, demo_scene};
    use super::*;

    fn setup(n: usize) -> (TracerScene, TracerCamera, TraceSettings) {
        let scene = demo_scene(&DemoDetail::small()).unwrap();
        let wall = front_right_floor(3.0).unwrap()[0];
        let cam = TracerCamera::cave(wall, DVec3::new(0.0, 1.5, 0.0)).unwrap();
        (scene, cam, TraceSettings::new(n, n, 3).unwrap())
    }

    /// Pixel (8, 9) of a 16 × 16 wall image: it looks at the mirror sphere
    /// 0.26 m from its centre.
    fn mirror_ray(cam: &TracerCamera) -> Ray {
        cam.primary_ray(8, 9, &TraceSettings::new(16, 16, 3).unwrap())
    }

    #[test]
    fn level_zero_ray_gives_background_and_no_work() {
        let (scene, cam, _) = setup(8);
        let mut st = TraceStats::default();
        let ray = mirror_ray(&cam);
        assert_eq!(trace_ray(&scene, &ray, 0.0, 3, &mut st), scene.background());
        assert_eq!(
            st,
            TraceStats {
                background_pixels: 1,
                ..Default::default()
            }
        );
        // The same ray at level 1 hits the mirror sphere in front of the eye.
        let c = trace_ray(&scene, &ray, 1.0, 3, &mut st);
        assert_ne!(c, scene.background());
        assert!(st.triangle_tests > 0 && st.primary_rays == 1);
    }

    #[test]
    fn gaze_behind_the_head_renders_background_only() {
        let (scene, cam, s) = setup(16);
        let behind = GazeEstimate::Tracked(GazeFrame::new(cam.eye(), DVec3::Z, DVec3::Y).unwrap());
        let lv = pixel_levels(
            &cam,
            &s,
            &VisualField::paper(),
            &behind,
            LevelQuantization::Continuous,
        );
        assert!(lv.iter().all(|&l| l == 0.0));
        let img = render(&scene, &cam, &s, &lv).unwrap();
        assert!(img.pixels.iter().all(|&p| p == scene.background()));
        assert_eq!(img.stats.rays(), 0);
    }

    #[test]
    fn full_quality_fallback_equals_the_reference() {
        let (scene, cam, s) = setup(12);
        let lost = GazeEstimate::FullQuality { last: None };
        let lv = pixel_levels(
            &cam,
            &s,
            &VisualField::paper(),
            &lost,
            LevelQuantization::Steps(4),
        );
        let a = render(&scene, &cam, &s, &lv).unwrap();
        let b = render_full_quality(&scene, &cam, &s);
        assert_eq!(a, b);
        assert!(a.pixels.iter().all(|p| p.is_finite()));
    }

    /// A sphere in front of a red wall, hit through its centre: a clear
    /// sphere of index 1 is invisible (the ray goes through unbent); at
    /// index 1.5 the central ray still goes straight (normal incidence) and
    /// sees the wall through two refractions; with one bounce allowed it
    /// stops inside and sees black; an off-centre ray is bent.
    #[test]
    fn refraction_enters_and_leaves_by_snell() {
        let ball = |ior: f64, kt: f64| {
            let glass = TracerMaterial {
                color: DVec3::ONE,
                diffuse: 0.0,
                specular: 0.0,
                shininess: 1.0,
                reflective: false,
                reflectance: 0.0,
                transmittance: kt,
                ior,
            };
            let sphere = TriangleMesh::uv_sphere(DVec3::new(0.0, 0.0, -3.0), 1.0, 48, 96).unwrap();
            let wall = TriangleMesh::quad(
                DVec3::new(-50.0, -50.0, -10.0),
                DVec3::new(100.0, 0.0, 0.0),
                DVec3::new(0.0, 100.0, 0.0),
            )
            .unwrap();
            let red = TracerMaterial::diffuse(DVec3::new(1.0, 0.0, 0.0));
            TracerScene::new(
                vec![
                    LodObject::new(vec![sphere], glass).unwrap(),
                    LodObject::new(vec![wall], red).unwrap(),
                ],
                vec![],
                DVec3::splat(0.5),
                DVec3::new(0.0, 0.0, 1.0),
            )
            .unwrap()
        };
        let central = Ray::from_unit(DVec3::ZERO, DVec3::NEG_Z);
        let wall_colour = DVec3::new(0.5, 0.0, 0.0);
        let mut st = TraceStats::default();
        let c = trace_ray(&ball(1.0, 1.0), &central, 1.0, 3, &mut st);
        assert!((c - wall_colour).length() < 1e-12, "{c}");
        assert_eq!(st.refraction_rays, 2);
        let c = trace_ray(&ball(1.5, 1.0), &central, 1.0, 3, &mut st);
        assert!((c - wall_colour).length() < 1e-9, "{c}");
        // One bounce: the ray enters and is cut off inside (black).
        let c = trace_ray(&ball(1.5, 1.0), &central, 1.0, 1, &mut st);
        assert_eq!(c, DVec3::ZERO);
        // Half transmitted at each of the two surfaces: a quarter of the
        // wall, and the sphere's own (white ambient, 0.5) colour at half
        // weight on entry and a quarter on exit.
        let c = trace_ray(&ball(1.5, 0.5), &central, 1.0, 3, &mut st);
        assert!(
            (c - (DVec3::splat(0.375) + wall_colour * 0.25)).length() < 1e-9,
            "{c}"
        );
        // Off centre at index 1.5 the ray is bent towards the axis and on
        // through the far side: it still sees the wall, not the background.
        let off = Ray::from_unit(DVec3::ZERO, DVec3::new(0.25, 0.0, -3.0).normalize());
        let c = trace_ray(&ball(1.5, 1.0), &off, 1.0, 3, &mut st);
        assert!((c - wall_colour).length() < 1e-9, "{c}");
    }

    /// The layered schedule: per pixel it is `render` with `pixel_levels`;
    /// at half resolution the central field is unchanged, the periphery
    /// traces about a quarter of the primary rays, and no gaze is full
    /// quality.
    #[test]
    fn layered_render_keeps_the_central_field() {
        let (scene, cam, s) = setup(24);
        let gaze = GazeEstimate::Tracked(
            GazeFrame::new(cam.eye(), DVec3::new(-0.6, -0.2, -1.0), DVec3::Y).unwrap(),
        );
        let field = VisualField::paper();
        let q = LevelQuantization::Steps(8);
        let lv = pixel_levels(&cam, &s, &field, &gaze, q);
        let per_pixel = render(&scene, &cam, &s, &lv).unwrap();
        assert_eq!(
            render_layered(&scene, &cam, &s, &field, &gaze, q, Layers::PER_PIXEL),
            per_pixel
        );
        let two = Layers {
            scale: 2,
            outer_level: 0.0,
        };
        let half = render_layered(&scene, &cam, &s, &field, &gaze, q, two);
        let central = lv.iter().filter(|&&l| l >= 1.0).count() as u64;
        let peripheral = lv.iter().filter(|&&l| l > 0.0 && l < 1.0).count() as u64;
        assert!(central > 0 && peripheral > 0);
        for (i, &l) in lv.iter().enumerate() {
            if l >= 1.0 {
                assert_eq!(half.pixels[i], per_pixel.pixels[i]);
            }
        }
        assert!(half.stats.primary_rays < central + peripheral / 2);
        // With the outer layer (levels below ½ on a quarter-resolution
        // grid) fewer rays still, the central field again unchanged.
        let nested = Layers {
            scale: 2,
            outer_level: 0.5,
        };
        let quarter = render_layered(&scene, &cam, &s, &field, &gaze, q, nested);
        assert!(quarter.stats.primary_rays < half.stats.primary_rays);
        for (i, &l) in lv.iter().enumerate() {
            if l >= 1.0 {
                assert_eq!(quarter.pixels[i], per_pixel.pixels[i]);
            }
            assert!(quarter.pixels[i].is_finite());
        }
        let lost = GazeEstimate::FullQuality { last: None };
        assert_eq!(
            render_layered(&scene, &cam, &s, &field, &lost, q, nested),
            render_full_quality(&scene, &cam, &s)
        );
    }

    #[test]
    fn reflection_depth_follows_eq9() {
        // One pixel on the mirror sphere: level 1/3 → 1 reflection at most,
        // level 1 → up to 3 (Reflect_max = 3).
        let (scene, cam, _) = setup(8);
        let ray = mirror_ray(&cam);
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
        let gaze = GazeEstimate::Tracked(
            GazeFrame::new(cam.eye(), DVec3::new(1.0, -0.2, -1.0), DVec3::Y).unwrap(),
        );
        let lv = pixel_levels(
            &cam,
            &s,
            &VisualField::paper(),
            &gaze,
            LevelQuantization::Continuous,
        );
        let fov = render(&scene, &cam, &s, &lv).unwrap();
        let full = render_full_quality(&scene, &cam, &s);
        assert!(fov.pixels.iter().all(|p| p.is_finite()));
        assert!(fov.stats.triangle_tests < full.stats.triangle_tests);
        assert!(fov.stats.rays() <= full.stats.rays());
        assert!(fov.stats.background_pixels > 0);
        assert_eq!(
            render(&scene, &cam, &s, &lv[1..]),
            Err(FoveatedError::LengthMismatch {
                what: "levels for the image's pixels",
                expected: 256,
                got: 255
            })
        );
    }

    #[test]
    fn image_sizes_are_checked_once() {
        // width × height overflows usize, or no allocation could hold it:
        // a typed error from the constructor, before any allocation.
        let count = |w: usize, h: usize| match TraceSettings::new(w, h, 3) {
            Err(FoveatedError::Input(e)) => (e.what, e.expected),
            other => panic!("expected an input error, got {other:?}"),
        };
        let per_pixel = std::mem::size_of::<(DVec3, TraceStats)>();
        let too_many = (
            "image pixel count",
            Expected::Range {
                min: 1.0,
                max: (isize::MAX as usize / per_pixel) as f64,
            },
        );
        for (w, h) in [
            (usize::MAX, 2),
            (1 << (usize::BITS / 2), 1 << (usize::BITS / 2)),
            (usize::MAX / 8, 1),
        ] {
            assert_eq!(count(w, h), too_many, "{w} × {h}");
        }
        assert_eq!(count(0, 5), ("image width (pixels)", Expected::Positive));
        assert_eq!(count(5, 0), ("image height (pixels)", Expected::Positive));
        // Ordinary sizes are unaffected.
        let ok = TraceSettings::new(3, 2, 4).unwrap();
        assert_eq!(
            (ok.width(), ok.height(), ok.reflect_max(), ok.pixel_count()),
            (3, 2, 4, 6)
        );
        let (_, cam, _) = setup(4);
        let gaze = GazeEstimate::FullQuality { last: None };
        assert_eq!(
            pixel_levels(
                &cam,
                &ok,
                &VisualField::paper(),
                &gaze,
                LevelQuantization::Continuous
            ),
            vec![1.0; 6]
        );
    }

    #[test]
    fn cameras_are_checked_once() {
        let wall = front_right_floor(3.0).unwrap()[0];
        assert!(matches!(
            TracerCamera::cave(wall, DVec3::new(0.0, 1.5, -1.5)),
            Err(FoveatedError::EyeNotInFront { .. })
        ));
        assert_eq!(
            TracerCamera::pinhole(DVec3::ZERO, DVec3::Y, DVec3::Y * 2.0, 1.0),
            Err(FoveatedError::DegenerateDirection(
                "camera up parallel to forward"
            ))
        );
        let fov = |f: f64| match TracerCamera::pinhole(DVec3::ZERO, DVec3::NEG_Z, DVec3::Y, f) {
            Err(FoveatedError::Input(e)) => e.what,
            other => panic!("{other:?}"),
        };
        for bad in [0.0, std::f64::consts::PI, f64::NAN, -1.0] {
            assert_eq!(fov(bad), "camera vertical field of view (rad)");
        }
        let zero = TracerCamera::pinhole(DVec3::ZERO, DVec3::ZERO, DVec3::Y, 1.0).unwrap_err();
        assert_eq!(
            zero,
            FoveatedError::Input(InvalidInput::new(
                "camera forward",
                0.0,
                Expected::Direction
            ))
        );
    }

    #[test]
    fn pinhole_rays_are_unit_and_centred() {
        // A forward of any length is normalised; the centre pixel looks along it.
        let c = TracerCamera::pinhole(DVec3::ZERO, DVec3::NEG_Z * 4.0, DVec3::Y, 1.0).unwrap();
        let s = TraceSettings::new(3, 3, 3).unwrap();
        assert!((c.primary_ray(1, 1, &s).dir() - DVec3::NEG_Z).length() < 1e-15);
        // The top-left pixel centre: tan of the half-angles is (2/3)·tan(0.5).
        let r = c.primary_ray(0, 0, &s);
        let k = 2.0 / 3.0 * 0.5f64.tan();
        assert!((r.dir() - DVec3::new(-k, k, -1.0).normalize()).length() < 1e-15);
        assert!((r.dir().length() - 1.0).abs() < 1e-15);
    }

    #[test]
    fn wall_camera_rays_hit_the_pixel_centres() {
        let wall = front_right_floor(3.0).unwrap()[0];
        let eye = DVec3::new(0.3, 1.2, 0.4);
        let cam = TracerCamera::cave(wall, eye).unwrap();
        let s = TraceSettings::new(4, 2, 3).unwrap();
        // Pixel (3, 1): s = 3.5/4, t = 1 − 1.5/2 (row 0 at the top).
        let r = cam.primary_ray(3, 1, &s);
        let p = wall.point_at(3.5 / 4.0, 0.25);
        assert!((r.dir() - (p - eye).normalize()).length() < 1e-15);
        assert_eq!(r, wall.ray_through(eye, 3.5 / 4.0, 0.25).unwrap());
    }
}
