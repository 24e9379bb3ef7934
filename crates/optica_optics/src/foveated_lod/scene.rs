//! Scenes of objects with a chain of meshes each (the per-object LOD of eq.
//! 10), point lights and materials, with a BVH over the objects.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::budget::lod_for_level;
use super::bvh::{Aabb, Bvh};
use super::error::FoveatedError;
use super::mesh::{MeshHit, TriangleMesh};
use crate::input;
use crate::ray::Ray;

/// Surface appearance for the reference tracer's Whitted shading: plain
/// data, checked by [`LodObject::new`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TracerMaterial {
    /// Albedo (linear RGB).
    pub color: DVec3,
    /// Diffuse (Lambert) weight.
    pub diffuse: f64,
    /// Phong specular weight.
    pub specular: f64,
    /// Phong exponent.
    pub shininess: f64,
    /// The paper's "specular object" flag: reflective objects spawn
    /// reflection rays, up to eq. 9's limit.
    pub reflective: bool,
    /// Fraction of light reflected when `reflective` (0..=1).
    pub reflectance: f64,
    /// Fraction of light transmitted by refraction (0..=1, with
    /// `reflectance` at most 1 together). 0 (opaque) when absent.
    #[serde(default)]
    pub transmittance: f64,
    /// Refractive index of the object's inside (the outside is air, 1);
    /// used when `transmittance` > 0. 1.5 when absent.
    #[serde(default = "default_ior")]
    pub ior: f64,
}

fn default_ior() -> f64 {
    1.5
}

impl TracerMaterial {
    /// A diffuse object of this colour (the paper's scene B): Lambert 0.9,
    /// a faint Phong highlight (0.2, exponent 20), not reflective.
    pub fn diffuse(color: DVec3) -> Self {
        Self {
            color,
            diffuse: 0.9,
            specular: 0.2,
            shininess: 20.0,
            reflective: false,
            reflectance: 0.0,
            transmittance: 0.0,
            ior: default_ior(),
        }
    }

    /// A reflective object (the paper's scene A): this colour locally with
    /// Lambert 0.6 and a sharper Phong highlight (0.6, exponent 60), and
    /// `reflectance` mirrored.
    pub fn mirror(color: DVec3, reflectance: f64) -> Self {
        Self {
            color,
            diffuse: 0.6,
            specular: 0.6,
            shininess: 60.0,
            reflective: true,
            reflectance,
            transmittance: 0.0,
            ior: default_ior(),
        }
    }

    /// A transparent object (glass, water): a faint tint of this colour
    /// locally (Lambert 0.1, Phong 0.6, exponent 80), 0.1 mirrored and
    /// `transmittance` refracted with index `ior` (glass 1.5, water 1.33).
    pub fn glass(color: DVec3, transmittance: f64, ior: f64) -> Self {
        Self {
            color,
            diffuse: 0.1,
            specular: 0.6,
            shininess: 80.0,
            reflective: true,
            reflectance: 0.1,
            transmittance,
            ior,
        }
    }
}

/// A point light of the reference tracer (the paper's scenes have one,
/// §4.2): plain data, checked by [`TracerScene::new`].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TracerLight {
    /// Position (m).
    pub position: DVec3,
    /// Radiant intensity (linear RGB); irradiance falls as 1/d².
    pub intensity: DVec3,
}

/// One object O_j: meshes of the same shape sorted by ascending triangle
/// count (N_j,min = the first, N_j,max = the last) and a material.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct LodObject {
    lods: Vec<TriangleMesh>,
    counts: Vec<usize>,
    material: TracerMaterial,
    bounds: Aabb,
}

impl LodObject {
    /// An object from its LOD meshes (any order; sorted here). Errors:
    /// [`FoveatedError::InvalidScene`] for no mesh; [`FoveatedError::Input`]
    /// for a non-finite material number or a reflectance outside [0, 1].
    pub fn new(
        mut lods: Vec<TriangleMesh>,
        material: TracerMaterial,
    ) -> Result<Self, FoveatedError> {
        if lods.is_empty() {
            return Err(FoveatedError::InvalidScene("object without meshes".into()));
        }
        let m = material;
        input::finite_vec3("material colour", m.color)?;
        input::finite("material diffuse weight", m.diffuse)?;
        input::finite("material specular weight", m.specular)?;
        // Phong's 0⁰ is 1 on the CPU and 0 on the GPU: a positive exponent
        // keeps the two the same.
        input::positive("material shininess", m.shininess)?;
        input::in_range("material reflectance", m.reflectance, 0.0, 1.0)?;
        input::in_range("material transmittance", m.transmittance, 0.0, 1.0)?;
        let kr = if m.reflective { m.reflectance } else { 0.0 };
        input::in_range(
            "material reflectance + transmittance",
            kr + m.transmittance,
            0.0,
            1.0,
        )?;
        input::in_range("material refractive index", m.ior, 1.0, 4.0)?;
        lods.sort_by_key(|l| l.triangle_count());
        let counts = lods.iter().map(|l| l.triangle_count()).collect();
        let bounds = lods.iter().fold(Aabb::EMPTY, |b, l| b.union(l.bounds()));
        Ok(Self {
            lods,
            counts,
            material,
            bounds,
        })
    }

    /// Triangle counts of the chain, ascending.
    pub fn triangle_counts(&self) -> &[usize] {
        &self.counts
    }

    /// The material.
    pub fn material(&self) -> &TracerMaterial {
        &self.material
    }

    /// The meshes of the chain, coarsest first.
    pub fn meshes(&self) -> &[TriangleMesh] {
        &self.lods
    }

    /// The mesh of chain index `lod`.
    pub(crate) fn mesh(&self, lod: usize) -> &TriangleMesh {
        &self.lods[lod.min(self.lods.len() - 1)]
    }

    /// [`lod_for_level`](super::lod_for_level) (eq. 10 over the chain): the
    /// chain index a ray of this level uses.
    pub fn lod_for_level(&self, level: f64) -> usize {
        lod_for_level(&self.counts, level)
    }

    /// Bounds over all LODs.
    pub(crate) fn bounds(&self) -> Aabb {
        self.bounds
    }
}

/// A hit in the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SceneHit {
    /// Object index.
    pub(crate) object: usize,
    /// Chain index of the mesh that was hit.
    pub(crate) lod: usize,
    /// The mesh hit.
    pub(crate) hit: MeshHit,
}

/// The reference tracer's scene: objects, lights, ambient light and the
/// background colour.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TracerScene {
    objects: Vec<LodObject>,
    lights: Vec<TracerLight>,
    ambient: DVec3,
    background: DVec3,
    top: Bvh,
}

impl TracerScene {
    /// A scene; builds the BVH over the objects. `ambient` (linear RGB) is
    /// added as ambient × albedo; `background` (linear RGB) is the colour of
    /// rays that hit nothing and of level-0 pixels (the paper's §3.3.2).
    ///
    /// Errors: [`FoveatedError::Input`] for a non-finite light, ambient or
    /// background.
    pub fn new(
        objects: Vec<LodObject>,
        lights: Vec<TracerLight>,
        ambient: DVec3,
        background: DVec3,
    ) -> Result<Self, FoveatedError> {
        for l in &lights {
            input::finite_vec3("light position (m)", l.position)?;
            input::finite_vec3("light intensity", l.intensity)?;
        }
        input::finite_vec3("ambient light", ambient)?;
        input::finite_vec3("background colour", background)?;
        let boxes: Vec<Aabb> = objects.iter().map(|o| o.bounds()).collect();
        let top = Bvh::build(&boxes);
        Ok(Self {
            objects,
            lights,
            ambient,
            background,
            top,
        })
    }

    /// The objects.
    pub fn objects(&self) -> &[LodObject] {
        &self.objects
    }

    /// The lights.
    pub fn lights(&self) -> &[TracerLight] {
        &self.lights
    }

    /// Ambient light (linear RGB).
    pub fn ambient(&self) -> DVec3 {
        self.ambient
    }

    /// The background colour (linear RGB).
    pub fn background(&self) -> DVec3 {
        self.background
    }

    /// The closest hit below `t_max` for a ray of this `level`: every object
    /// is tested at the mesh eq. 10 gives for the level. Adds triangle tests
    /// to `tests`.
    pub(crate) fn intersect(
        &self,
        ray: &Ray,
        level: f64,
        t_max: f64,
        tests: &mut u64,
    ) -> Option<SceneHit> {
        let mut found: Option<SceneHit> = None;
        self.top.closest(ray, t_max, |oi, tm| {
            let o = &self.objects[oi];
            let lod = o.lod_for_level(level);
            o.mesh(lod).intersect(ray, tm, tests).map(|hit| {
                found = Some(SceneHit {
                    object: oi,
                    lod,
                    hit,
                });
                hit.t
            })
        });
        // As in `TriangleMesh::intersect`, the last accepted hit is the closest.
        found
    }

    /// True when something blocks the ray before `t_max`, at this level's LODs.
    pub(crate) fn occluded(&self, ray: &Ray, level: f64, t_max: f64, tests: &mut u64) -> bool {
        self.top.any(ray, t_max, |oi| {
            let o = &self.objects[oi];
            o.mesh(o.lod_for_level(level)).occluded(ray, t_max, tests)
        })
    }
}

/// Tessellations of the demo scene's LOD chains.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DemoDetail {
    /// One entry per LOD: sphere rings r (segments 2r, 4r(r − 1) triangles)
    /// and torus minor segments r (major 2r, 4r² triangles).
    pub rings: Vec<u32>,
}

impl DemoDetail {
    /// Chains near the paper's counts (§4.2: N_min = 500, N_max = 5804):
    /// spheres 528 … 5624 triangles, tori 576 … 5776.
    pub fn paper() -> Self {
        Self {
            rings: vec![12, 18, 26, 38],
        }
    }

    /// Small chains for fast tests (spheres 48 … 528 triangles).
    pub fn small() -> Self {
        Self {
            rings: vec![4, 6, 8, 12],
        }
    }
}

/// The demo scene used by the tests and the report: like the paper's (§4.2)
/// eight objects, half of them reflective, one point light, around a CAVE of
/// side 3 m centred at the origin with its floor at y = 0 (see
/// [`front_right_floor`](super::front_right_floor)); a ground plane at y = 0.
///
/// Errors: [`FoveatedError::InvalidScene`] for no LOD;
/// [`FoveatedError::Input`] for a ring count below 3.
pub fn demo_scene(detail: &DemoDetail) -> Result<TracerScene, FoveatedError> {
    if detail.rings.is_empty() {
        return Err(FoveatedError::InvalidScene(
            "demo scene without LODs".into(),
        ));
    }
    // A torus of r tube segments needs r ≥ 3; the sphere's 2 would do.
    for &r in &detail.rings {
        input::in_range("demo tessellation rings", r as f64, 3.0, u32::MAX as f64)?;
    }
    let sphere = |c: DVec3, r: f64, m: TracerMaterial| -> Result<LodObject, FoveatedError> {
        let lods = detail
            .rings
            .iter()
            .map(|&k| TriangleMesh::uv_sphere(c, r, k, 2 * k))
            .collect::<Result<Vec<_>, _>>()?;
        LodObject::new(lods, m)
    };
    let torus = |c: DVec3, axis: DVec3, m: TracerMaterial| -> Result<LodObject, FoveatedError> {
        let lods = detail
            .rings
            .iter()
            .map(|&k| TriangleMesh::torus(c, axis, 0.55, 0.2, 2 * k, k))
            .collect::<Result<Vec<_>, _>>()?;
        LodObject::new(lods, m)
    };
    let v = DVec3::new;
    let objects = vec![
        sphere(
            v(0.0, 0.7, -3.5),
            0.7,
            TracerMaterial::mirror(v(0.9, 0.9, 0.95), 0.7),
        )?,
        torus(
            v(-1.4, 0.75, -3.0),
            v(0.0, 0.3, 1.0),
            TracerMaterial::diffuse(v(0.9, 0.3, 0.2)),
        )?,
        torus(
            v(1.4, 0.75, -3.2),
            v(0.3, 1.0, 0.2),
            TracerMaterial::mirror(v(0.95, 0.8, 0.3), 0.6),
        )?,
        sphere(
            v(2.6, 0.5, -1.6),
            0.5,
            TracerMaterial::diffuse(v(0.2, 0.7, 0.3)),
        )?,
        sphere(
            v(3.2, 0.8, 0.6),
            0.8,
            TracerMaterial::mirror(v(0.8, 0.85, 0.9), 0.7),
        )?,
        sphere(
            v(-2.6, 0.5, -2.2),
            0.5,
            TracerMaterial::diffuse(v(0.3, 0.4, 0.9)),
        )?,
        torus(
            v(0.9, 0.6, -5.2),
            v(-0.5, 1.0, 0.3),
            TracerMaterial::diffuse(v(0.8, 0.8, 0.2)),
        )?,
        sphere(
            v(-0.9, 0.9, -5.6),
            0.9,
            TracerMaterial::mirror(v(0.9, 0.6, 0.7), 0.5),
        )?,
        // Ground: one LOD (a quad is exact at any budget).
        LodObject::new(
            vec![TriangleMesh::quad(
                v(-20.0, 0.0, 20.0),
                v(40.0, 0.0, 0.0),
                v(0.0, 0.0, -40.0),
            )?],
            TracerMaterial::diffuse(v(0.55, 0.55, 0.5)),
        )?,
    ];
    let lights = vec![TracerLight {
        position: v(1.0, 4.0, 1.0),
        intensity: DVec3::splat(22.0),
    }];
    TracerScene::new(objects, lights, DVec3::splat(0.08), v(0.05, 0.06, 0.1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::input::{Expected, InvalidInput};

    #[test]
    fn lod_follows_eq10() {
        let s = demo_scene(&DemoDetail::paper()).unwrap();
        let o = &s.objects()[0];
        assert_eq!(o.triangle_counts(), &[528, 1224, 2600, 5624]);
        // Level 1 → N_max → finest; level 0 → N_min → coarsest.
        assert_eq!(o.lod_for_level(1.0), 3);
        assert_eq!(o.lod_for_level(0.0), 0);
        // Level 0.5 → 528 + 0.5·5096 = 3076 → the first chain entry ≥ 3076 is 5624.
        assert_eq!(o.lod_for_level(0.5), 3);
        // Level 0.2 → 528 + 1019.2 = 1547.2 → 2600.
        assert_eq!(o.lod_for_level(0.2), 2);
        // Level 0.1 → 1037.6 → 1224.
        assert_eq!(o.lod_for_level(0.1), 1);
    }

    #[test]
    fn scene_hit_agrees_with_each_object_brute_force() {
        let s = demo_scene(&DemoDetail::small()).unwrap();
        let eye = DVec3::new(0.0, 1.5, 0.0);
        for k in 0..200 {
            let a = k as f64 * 0.61;
            let ray = Ray::new(
                eye,
                DVec3::new(a.cos(), -0.3 + 0.5 * (1.7 * a).sin(), a.sin() - 0.5),
            )
            .unwrap();
            for level in [1.0, 0.3, 0.0] {
                let mut n = 0;
                let got = s
                    .intersect(&ray, level, f64::INFINITY, &mut n)
                    .map(|h| h.hit.t);
                let brute = s
                    .objects()
                    .iter()
                    .filter_map(|o| {
                        o.mesh(o.lod_for_level(level))
                            .intersect_brute_force(&ray, f64::INFINITY)
                    })
                    .map(|h| h.t)
                    .min_by(f64::total_cmp);
                assert_eq!(got, brute);
            }
        }
    }

    #[test]
    fn bad_objects_are_rejected() {
        assert!(matches!(
            LodObject::new(vec![], TracerMaterial::diffuse(DVec3::ONE)),
            Err(FoveatedError::InvalidScene(_))
        ));
        let q = TriangleMesh::quad(DVec3::ZERO, DVec3::X, DVec3::Y).unwrap();
        assert_eq!(
            LodObject::new(vec![q.clone()], TracerMaterial::mirror(DVec3::ONE, 1.5)),
            Err(FoveatedError::Input(InvalidInput::new(
                "material reflectance",
                1.5,
                Expected::Range { min: 0.0, max: 1.0 }
            )))
        );
        let light = TracerLight {
            position: DVec3::NAN,
            intensity: DVec3::ONE,
        };
        let o = LodObject::new(vec![q], TracerMaterial::diffuse(DVec3::ONE)).unwrap();
        let e = TracerScene::new(vec![o], vec![light], DVec3::ZERO, DVec3::ZERO).unwrap_err();
        assert!(matches!(e, FoveatedError::Input(i) if i.what == "light position (m)"));
        assert!(matches!(
            demo_scene(&DemoDetail { rings: vec![] }),
            Err(FoveatedError::InvalidScene(_))
        ));
        assert_eq!(
            demo_scene(&DemoDetail { rings: vec![4, 2] }).unwrap_err(),
            FoveatedError::Input(InvalidInput::new(
                "demo tessellation rings",
                2.0,
                Expected::Range {
                    min: 3.0,
                    max: u32::MAX as f64
                }
            ))
        );
    }
}
