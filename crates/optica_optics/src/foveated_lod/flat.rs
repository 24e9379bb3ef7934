//! A [`TracerScene`] flattened into the arrays the plugin's GPU tracer
//! reads (`raytrace.wgsl` in `optica_foveated_lod`): every LOD mesh of every
//! object with its BVH, in f32, indices absolute, so the shader needs no
//! pointer and the scene is uploaded once.

use serde::Serialize;

use super::bvh::NodeKind;
use super::scene::{TracerLight, TracerScene};

/// Set in [`FlatNode::a`] of a leaf.
pub const LEAF_BIT: u32 = 1 << 31;

/// A BVH node: an inner node has its children at nodes `a` and `b`; a leaf
/// (`a & LEAF_BIT`) holds triangles `a & !LEAF_BIT .. + b`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FlatNode {
    /// Lower corner of the node's box (m).
    pub min: [f32; 3],
    /// Left child, or `LEAF_BIT |` the first triangle.
    pub a: u32,
    /// Upper corner (m).
    pub max: [f32; 3],
    /// Right child, or the leaf's triangle count.
    pub b: u32,
}

/// A vertex: position (m) and unit normal.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FlatVertex {
    /// Position (m).
    pub position: [f32; 3],
    /// Unit normal (zero where the mesh gave none).
    pub normal: [f32; 3],
}

/// One LOD mesh: the root of its BVH and its triangle count (eq. 10's N).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FlatMesh {
    /// Index of the BVH's root node.
    pub root: u32,
    /// Triangles in the mesh.
    pub triangles: u32,
}

/// An object: its bounds, its meshes (coarsest first) and its material, in
/// the f32 the shader reads.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FlatObject {
    /// Lower corner of the bounds over all its meshes (m).
    pub min: [f32; 3],
    /// First of its meshes in [`FlatScene::meshes`].
    pub first_mesh: u32,
    /// Upper corner (m).
    pub max: [f32; 3],
    /// Number of its meshes.
    pub mesh_count: u32,
    /// Albedo (linear RGB).
    pub color: [f32; 3],
    /// Lambert weight.
    pub diffuse: f32,
    /// Phong weight.
    pub specular: f32,
    /// Phong exponent.
    pub shininess: f32,
    /// Mirrored fraction (0 for an object that is not reflective).
    pub reflectance: f32,
    /// Refracted fraction.
    pub transmittance: f32,
    /// Refractive index of the inside.
    pub ior: f32,
}

/// The scene as flat arrays; see the module docs.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct FlatScene {
    /// BVH nodes of every mesh.
    pub nodes: Vec<FlatNode>,
    /// Triangles (absolute vertex indices), each leaf's contiguous.
    pub triangles: Vec<[u32; 3]>,
    /// Vertices of every mesh.
    pub vertices: Vec<FlatVertex>,
    /// Meshes, each object's coarsest first.
    pub meshes: Vec<FlatMesh>,
    /// Objects.
    pub objects: Vec<FlatObject>,
    /// Lights.
    pub lights: Vec<TracerLight>,
    /// The deepest BVH's depth (a root alone is 1): a near-first walk keeps
    /// at most this many nodes on its stack.
    pub max_depth: u32,
}

/// The depth of the tree under node `root`.
fn depth(nodes: &[FlatNode], root: u32) -> u32 {
    let mut deepest = 0;
    let mut stack = vec![(root, 1)];
    while let Some((i, d)) = stack.pop() {
        deepest = deepest.max(d);
        let n = nodes[i as usize];
        if n.a & LEAF_BIT == 0 {
            stack.extend([(n.a, d + 1), (n.b, d + 1)]);
        }
    }
    deepest
}

fn f3(v: glam::DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

impl FlatScene {
    /// Flattens `scene`. Each mesh's triangles are stored in its BVH's leaf
    /// order, so a leaf is a range.
    pub fn from_scene(scene: &TracerScene) -> Self {
        let mut flat = Self {
            lights: scene.lights().to_vec(),
            ..Self::default()
        };
        for object in scene.objects() {
            let first_mesh = flat.meshes.len() as u32;
            for mesh in object.meshes() {
                let vertex_base = flat.vertices.len() as u32;
                flat.vertices
                    .extend(mesh.positions().iter().zip(mesh.normals()).map(|(&p, &n)| {
                        FlatVertex {
                            position: f3(p),
                            normal: f3(n),
                        }
                    }));
                let triangle_base = flat.triangles.len() as u32;
                let bvh = mesh.bvh();
                flat.triangles.extend(
                    bvh.indices()
                        .iter()
                        .map(|&t| mesh.triangles()[t as usize].map(|i| i + vertex_base)),
                );
                let node_base = flat.nodes.len() as u32;
                flat.nodes.extend(bvh.nodes().map(|(b, kind)| {
                    let (a, b2) = match kind {
                        NodeKind::Leaf { first, count } => {
                            (LEAF_BIT | (triangle_base + first), count)
                        }
                        NodeKind::Inner { left, right } => (node_base + left, node_base + right),
                    };
                    FlatNode {
                        min: f3(b.min),
                        a,
                        max: f3(b.max),
                        b: b2,
                    }
                }));
                flat.max_depth = flat.max_depth.max(depth(&flat.nodes, node_base));
                flat.meshes.push(FlatMesh {
                    root: node_base,
                    triangles: mesh.triangle_count() as u32,
                });
            }
            let m = object.material();
            let b = object.bounds();
            flat.objects.push(FlatObject {
                min: f3(b.min),
                first_mesh,
                max: f3(b.max),
                mesh_count: object.meshes().len() as u32,
                color: f3(m.color),
                diffuse: m.diffuse as f32,
                specular: m.specular as f32,
                shininess: m.shininess as f32,
                reflectance: if m.reflective {
                    m.reflectance as f32
                } else {
                    0.0
                },
                transmittance: m.transmittance as f32,
                ior: m.ior as f32,
            });
        }
        flat
    }

    /// Bytes the arrays take on the GPU (16-byte aligned elements as the
    /// shader declares them).
    pub fn gpu_bytes(&self) -> usize {
        32 * self.nodes.len()
            + 16 * self.triangles.len()
            + 32 * self.vertices.len()
            + 8 * self.meshes.len()
            + 80 * self.objects.len()
            + 32 * self.lights.len()
    }
}

#[cfg(test)]
mod tests {
    use glam::DVec3;

    use super::super::budget::lod_for_level;
    use super::super::scene::{DemoDetail, demo_scene};
    use super::*;
    use crate::ray::Ray;

    /// The closest hit over the flat arrays, in f64, walking them as the
    /// shader does: (object, mesh of the chain, t).
    fn closest(flat: &FlatScene, ray: &Ray, level: f64) -> Option<(usize, usize, f64)> {
        let v = |i: u32| DVec3::from(flat.vertices[i as usize].position.map(f64::from));
        let mut best: Option<(usize, usize, f64)> = None;
        for (oi, o) in flat.objects.iter().enumerate() {
            let counts: Vec<usize> = (0..o.mesh_count)
                .map(|k| flat.meshes[(o.first_mesh + k) as usize].triangles as usize)
                .collect();
            let lod = lod_for_level(&counts, level);
            let mut stack = vec![flat.meshes[o.first_mesh as usize + lod].root];
            while let Some(ni) = stack.pop() {
                let n = flat.nodes[ni as usize];
                let lo = DVec3::from(n.min.map(f64::from));
                let hi = DVec3::from(n.max.map(f64::from));
                let box_ = super::super::bvh::Aabb { min: lo, max: hi };
                if box_
                    .hit(ray.origin(), ray.dir().recip(), f64::INFINITY)
                    .is_none()
                {
                    continue;
                }
                if n.a & LEAF_BIT == 0 {
                    stack.extend([n.a, n.b]);
                    continue;
                }
                let first = n.a & !LEAF_BIT;
                for t in first..first + n.b {
                    let [a, b, c] = flat.triangles[t as usize].map(v);
                    let (e1, e2) = (b - a, c - a);
                    let p = ray.dir().cross(e2);
                    let det = e1.dot(p);
                    if det.abs() < 1e-14 {
                        continue;
                    }
                    let s = ray.origin() - a;
                    let u = s.dot(p) / det;
                    let q = s.cross(e1);
                    let w = ray.dir().dot(q) / det;
                    let t = e2.dot(q) / det;
                    if u >= 0.0
                        && w >= 0.0
                        && u + w <= 1.0
                        && t > 1e-9
                        && best.is_none_or(|b| t < b.2)
                    {
                        best = Some((oi, lod, t));
                    }
                }
            }
        }
        best
    }

    /// Every mesh keeps each of its triangles exactly once, and a walk of
    /// the flat arrays finds the tracer's closest hit at each level.
    #[test]
    fn flat_arrays_hold_the_scene() {
        let scene = demo_scene(&DemoDetail::small()).unwrap();
        let flat = FlatScene::from_scene(&scene);
        assert_eq!(flat.objects.len(), scene.objects().len());
        assert!(
            flat.max_depth > 1 && flat.max_depth < 40,
            "{}",
            flat.max_depth
        );
        let total: usize = scene
            .objects()
            .iter()
            .flat_map(|o| o.meshes())
            .map(|m| m.triangle_count())
            .sum();
        assert_eq!(flat.triangles.len(), total);
        for (i, mesh) in flat.meshes.iter().enumerate() {
            let mut seen = Vec::new();
            let mut stack = vec![mesh.root];
            while let Some(ni) = stack.pop() {
                let n = flat.nodes[ni as usize];
                if n.a & LEAF_BIT == 0 {
                    stack.extend([n.a, n.b]);
                } else {
                    seen.extend((n.a & !LEAF_BIT)..(n.a & !LEAF_BIT) + n.b);
                }
            }
            seen.sort_unstable();
            seen.dedup();
            assert_eq!(seen.len(), mesh.triangles as usize, "mesh {i}");
        }
        let eye = DVec3::new(0.0, 1.5, 0.0);
        let mut hits = 0;
        for k in 0..200 {
            let a = k as f64 * 0.0314;
            let dir = DVec3::new(a.sin() * 0.9, -0.25 + 0.1 * (k % 5) as f64, -a.cos()).normalize();
            let ray = Ray::from_unit(eye, dir);
            for level in [0.1, 0.5, 1.0] {
                let mut tests = 0;
                let want = scene.intersect(&ray, level, f64::INFINITY, &mut tests);
                let got = closest(&flat, &ray, level);
                match (want, got) {
                    (None, None) => {}
                    (Some(w), Some(g)) => {
                        hits += 1;
                        assert_eq!((w.object, w.lod), (g.0, g.1), "ray {k} level {level}");
                        assert!((w.hit.t - g.2).abs() < 1e-5 * (1.0 + w.hit.t));
                    }
                    (w, g) => panic!("ray {k} level {level}: {w:?} vs {g:?}"),
                }
            }
        }
        assert!(hits > 200, "{hits} hits");
    }
}
