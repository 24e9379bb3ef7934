//! Scenes of objects with a chain of meshes each (the per-object LOD of eq.
//! 10), point lights and materials, with a BVH over the objects.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::budget::{choose_lod, polygon_budget};
use super::bvh::{Aabb, Bvh};
use super::error::FoveatedError;
use super::mesh::{MeshHit, TriangleMesh};
use crate::ray::Ray;

/// Surface appearance for the Whitted shading model.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// Albedo (linear RGB).
    pub color: DVec3,
    /// Diffuse (Lambert) weight.
    pub diffuse: f64,
    /// Phong specular weight.
    pub specular: f64,
    /// Phong exponent.
    pub shininess: f64,
    /// The paper's 鏡面物体 (specular object) flag: reflective objects spawn
    /// reflection rays, up to eq. 9's limit.
    pub reflective: bool,
    /// Fraction of light reflected when `reflective` (0..=1).
    pub reflectance: f64,
}

impl Material {
    /// A diffuse (拡散) object of this colour.
    pub fn diffuse(color: DVec3) -> Self {
        Self {
            color,
            diffuse: 0.9,
            specular: 0.2,
            shininess: 20.0,
            reflective: false,
            reflectance: 0.0,
        }
    }

    /// A reflective object: this colour locally, `reflectance` mirrored.
    pub fn mirror(color: DVec3, reflectance: f64) -> Self {
        Self {
            color,
            diffuse: 0.6,
            specular: 0.6,
            shininess: 60.0,
            reflective: true,
            reflectance,
        }
    }
}

/// A point light (the paper's scenes have one, §4.2).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PointLight {
    /// Position.
    pub position: DVec3,
    /// Radiant intensity (linear RGB); irradiance falls as 1/d².
    pub intensity: DVec3,
}

/// One object O_j: meshes of the same shape sorted by ascending triangle
/// count (N_j,min = the first, N_j,max = the last) and a material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LodObject {
    lods: Vec<TriangleMesh>,
    counts: Vec<usize>,
    material: Material,
    bounds: Aabb,
}

impl LodObject {
    /// An object from its LOD meshes (any order; sorted here). Errors: no
    /// mesh, a non-finite material number, or a reflectance outside [0, 1].
    pub fn new(mut lods: Vec<TriangleMesh>, material: Material) -> Result<Self, FoveatedError> {
        if lods.is_empty() {
            return Err(FoveatedError::InvalidScene("object without meshes".into()));
        }
        let m = material;
        if !(m.color.is_finite() && m.diffuse.is_finite() && m.specular.is_finite() && m.shininess.is_finite()) {
            return Err(FoveatedError::NonFinite("material"));
        }
        if !(0.0..=1.0).contains(&m.reflectance) {
            return Err(FoveatedError::InvalidScene(format!(
                "reflectance {} outside [0, 1]",
                m.reflectance
            )));
        }
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
    pub fn material(&self) -> &Material {
        &self.material
    }

    /// The mesh of chain index `lod`.
    pub fn mesh(&self, lod: usize) -> &TriangleMesh {
        &self.lods[lod.min(self.lods.len() - 1)]
    }

    /// Eq. 10 then [`choose_lod`]: the chain index a ray of this level uses.
    pub fn lod_for_level(&self, level: f64) -> usize {
        let (lo, hi) = (self.counts[0], self.counts[self.counts.len() - 1]);
        choose_lod(&self.counts, polygon_budget(level, lo, hi))
    }

    /// Bounds over all LODs.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }
}

/// A hit in the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SceneHit {
    /// Object index.
    pub object: usize,
    /// Chain index of the mesh that was hit.
    pub lod: usize,
    /// The mesh hit.
    pub hit: MeshHit,
}

/// Objects, lights, ambient light and the background colour.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    objects: Vec<LodObject>,
    lights: Vec<PointLight>,
    /// Ambient light (linear RGB), added as ambient × albedo.
    pub ambient: DVec3,
    /// Colour of rays that hit nothing and of level-0 pixels (§3.3.2).
    pub background: DVec3,
    top: Bvh,
}

impl Scene {
    /// A scene; builds the BVH over the objects. Errors: non-finite lights,
    /// ambient or background.
    pub fn new(
        objects: Vec<LodObject>,
        lights: Vec<PointLight>,
        ambient: DVec3,
        background: DVec3,
    ) -> Result<Self, FoveatedError> {
        if lights
            .iter()
            .any(|l| !(l.position.is_finite() && l.intensity.is_finite()))
        {
            return Err(FoveatedError::NonFinite("light"));
        }
        if !(ambient.is_finite() && background.is_finite()) {
            return Err(FoveatedError::NonFinite("ambient or background"));
        }
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
    pub fn lights(&self) -> &[PointLight] {
        &self.lights
    }

    /// The closest hit below `t_max` for a ray of this `level`: every object
    /// is tested at the mesh eq. 10 gives for the level. Adds triangle tests
    /// to `tests`.
    pub fn intersect(&self, ray: &Ray, level: f64, t_max: f64, tests: &mut u64) -> Option<SceneHit> {
        let mut found: Option<SceneHit> = None;
        self.top.closest(ray, t_max, |oi, tm| {
            let o = &self.objects[oi];
            let lod = o.lod_for_level(level);
            o.mesh(lod).intersect(ray, tm, tests).map(|hit| {
                found = Some(SceneHit { object: oi, lod, hit });
                hit.t
            })
        });
        // As in `TriangleMesh::intersect`, the last accepted hit is the closest.
        found
    }

    /// True when something blocks the ray before `t_max`, at this level's LODs.
    pub fn occluded(&self, ray: &Ray, level: f64, t_max: f64, tests: &mut u64) -> bool {
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
/// [`super::cave::front_right_floor`]); a ground plane at y = 0.
pub fn demo_scene(detail: &DemoDetail) -> Result<Scene, FoveatedError> {
    if detail.rings.is_empty() || detail.rings.iter().any(|&r| r < 3) {
        return Err(FoveatedError::InvalidParameter(
            "demo rings must be ≥ 3 and non-empty".into(),
        ));
    }
    let sphere = |c: DVec3, r: f64, m: Material| -> Result<LodObject, FoveatedError> {
        let lods = detail
            .rings
            .iter()
            .map(|&k| TriangleMesh::uv_sphere(c, r, k, 2 * k))
            .collect::<Result<Vec<_>, _>>()?;
        LodObject::new(lods, m)
    };
    let torus = |c: DVec3, axis: DVec3, m: Material| -> Result<LodObject, FoveatedError> {
        let lods = detail
            .rings
            .iter()
            .map(|&k| TriangleMesh::torus(c, axis, 0.55, 0.2, 2 * k, k))
            .collect::<Result<Vec<_>, _>>()?;
        LodObject::new(lods, m)
    };
    let v = DVec3::new;
    let objects = vec![
        sphere(v(0.0, 0.7, -3.5), 0.7, Material::mirror(v(0.9, 0.9, 0.95), 0.7))?,
        torus(
            v(-1.4, 0.75, -3.0),
            v(0.0, 0.3, 1.0),
            Material::diffuse(v(0.9, 0.3, 0.2)),
        )?,
        torus(
            v(1.4, 0.75, -3.2),
            v(0.3, 1.0, 0.2),
            Material::mirror(v(0.95, 0.8, 0.3), 0.6),
        )?,
        sphere(v(2.6, 0.5, -1.6), 0.5, Material::diffuse(v(0.2, 0.7, 0.3)))?,
        sphere(v(3.2, 0.8, 0.6), 0.8, Material::mirror(v(0.8, 0.85, 0.9), 0.7))?,
        sphere(v(-2.6, 0.5, -2.2), 0.5, Material::diffuse(v(0.3, 0.4, 0.9)))?,
        torus(
            v(0.9, 0.6, -5.2),
            v(-0.5, 1.0, 0.3),
            Material::diffuse(v(0.8, 0.8, 0.2)),
        )?,
        sphere(v(-0.9, 0.9, -5.6), 0.9, Material::mirror(v(0.9, 0.6, 0.7), 0.5))?,
        // Ground: one LOD (a quad is exact at any budget).
        LodObject::new(
            vec![TriangleMesh::quad(
                v(-20.0, 0.0, 20.0),
                v(40.0, 0.0, 0.0),
                v(0.0, 0.0, -40.0),
            )?],
            Material::diffuse(v(0.55, 0.55, 0.5)),
        )?,
    ];
    let lights = vec![PointLight {
        position: v(1.0, 4.0, 1.0),
        intensity: DVec3::splat(22.0),
    }];
    Scene::new(objects, lights, DVec3::splat(0.08), v(0.05, 0.06, 0.1))
}

#[cfg(test)]
mod tests {
    use super::*;

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
            let ray = Ray::new(eye, DVec3::new(a.cos(), -0.3 + 0.5 * (1.7 * a).sin(), a.sin() - 0.5)).unwrap();
            for level in [1.0, 0.3, 0.0] {
                let mut n = 0;
                let got = s.intersect(&ray, level, f64::INFINITY, &mut n).map(|h| h.hit.t);
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
        assert!(LodObject::new(vec![], Material::diffuse(DVec3::ONE)).is_err());
        let q = TriangleMesh::quad(DVec3::ZERO, DVec3::X, DVec3::Y).unwrap();
        assert!(LodObject::new(vec![q.clone()], Material::mirror(DVec3::ONE, 1.5)).is_err());
        let light = PointLight {
            position: DVec3::NAN,
            intensity: DVec3::ONE,
        };
        let o = LodObject::new(vec![q], Material::diffuse(DVec3::ONE)).unwrap();
        assert!(Scene::new(vec![o], vec![light], DVec3::ZERO, DVec3::ZERO).is_err());
        assert!(demo_scene(&DemoDetail { rings: vec![] }).is_err());
    }
}
