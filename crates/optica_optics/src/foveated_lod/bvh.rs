//! A small bounding volume hierarchy (§3.2.2) over anything with a box.
//!
//! No maintained crate fits here: `bvh` 0.13 is built on nalgebra and
//! `obvhs` 0.4 on glam 0.33–0.34 in f32, while this crate is glam 0.32 in f64.
//! So this is a plain binned-SAH BVH (16 bins, leaves of at most 4
//! primitives), generic over primitives: the caller gives one box per
//! primitive at build time and a hit test per primitive at query time. The
//! scene uses it twice: over each mesh's triangles (the paper builds one BVH
//! per object, because each object's polygon count changes independently) and
//! over the objects.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::ray::Ray;

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Aabb {
    /// Lower corner.
    pub min: DVec3,
    /// Upper corner.
    pub max: DVec3,
}

impl Aabb {
    /// The empty box (min = +∞, max = −∞), the identity of [`Aabb::union`].
    pub const EMPTY: Self = Self {
        min: DVec3::INFINITY,
        max: DVec3::NEG_INFINITY,
    };

    /// The smallest box holding all `points` (empty for none).
    pub fn from_points(points: impl IntoIterator<Item = DVec3>) -> Self {
        points.into_iter().fold(Self::EMPTY, |b, p| b.grow(p))
    }

    /// This box grown to hold `p`.
    #[inline]
    pub fn grow(self, p: DVec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The smallest box holding both.
    #[inline]
    pub fn union(self, o: Self) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// True for the empty box.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// The centre.
    #[inline]
    pub fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    /// Surface area (0 for the empty box), the SAH's cost weight.
    #[inline]
    pub fn surface_area(&self) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.max - self.min;
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// Slab test: the entry distance of the ray into the box if it enters it
    /// within [0, t_max]. `inv_dir` is 1/dir per component (±∞ for 0).
    ///
    /// A 0·∞ = NaN (origin on a slab plane of an axis the ray is parallel to)
    /// is ignored by `f64::min`/`max`, which only ever keeps a box the ray
    /// grazes: the test is conservative, never misses a hit.
    #[inline]
    pub fn hit(&self, origin: DVec3, inv_dir: DVec3, t_max: f64) -> Option<f64> {
        let t1 = (self.min - origin) * inv_dir;
        let t2 = (self.max - origin) * inv_dir;
        let mut t_near = 0.0f64;
        let mut t_far = t_max;
        for a in 0..3 {
            let (lo, hi) = (t1[a].min(t2[a]), t1[a].max(t2[a]));
            t_near = t_near.max(lo);
            t_far = t_far.min(hi);
        }
        (t_near <= t_far).then_some(t_near)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
enum NodeKind {
    /// Primitives `indices[first..first + count]`.
    Leaf { first: u32, count: u32 },
    /// Children at these node indices.
    Inner { left: u32, right: u32 },
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
struct Node {
    bounds: Aabb,
    kind: NodeKind,
}

/// A BVH over primitive indices `0..n`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Bvh {
    nodes: Vec<Node>,
    indices: Vec<u32>,
}

const MAX_LEAF: usize = 4;
const BINS: usize = 16;
/// SAH cost of one box test relative to one primitive test.
const TRAVERSAL_COST: f64 = 1.0;

impl Bvh {
    /// Builds over one box per primitive. Primitives with empty or non-finite
    /// boxes are left out (they cannot be hit).
    pub fn build(boxes: &[Aabb]) -> Self {
        let mut indices: Vec<u32> = (0..boxes.len() as u32)
            .filter(|&i| {
                let b = boxes[i as usize];
                !b.is_empty() && b.min.is_finite() && b.max.is_finite()
            })
            .collect();
        let centers: Vec<DVec3> = boxes.iter().map(|b| b.center()).collect();
        let mut nodes = Vec::with_capacity(2 * indices.len() / MAX_LEAF + 1);
        if !indices.is_empty() {
            let n = indices.len();
            build_node(boxes, &centers, &mut indices, 0, n, &mut nodes);
        }
        Self { nodes, indices }
    }

    /// Number of nodes (0 for an empty BVH).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Bounds of everything (empty for an empty BVH).
    pub fn bounds(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::EMPTY, |n| n.bounds)
    }

    /// The closest hit: `test(prim, t_max)` returns the hit distance of
    /// primitive `prim` if it is below `t_max`. Returns the primitive and its
    /// distance. Children are visited near first, so `t_max` shrinks early.
    pub fn closest<F>(&self, ray: &Ray, t_max: f64, mut test: F) -> Option<(usize, f64)>
    where
        F: FnMut(usize, f64) -> Option<f64>,
    {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = ray.dir.recip();
        let mut best: Option<(usize, f64)> = None;
        let mut t_best = t_max;
        let mut stack: Vec<(u32, f64)> = Vec::with_capacity(64);
        if let Some(t) = self.nodes[0].bounds.hit(ray.origin, inv, t_best) {
            stack.push((0, t));
        }
        while let Some((ni, t_enter)) = stack.pop() {
            if t_enter > t_best {
                continue;
            }
            match self.nodes[ni as usize].kind {
                NodeKind::Leaf { first, count } => {
                    for &p in &self.indices[first as usize..(first + count) as usize] {
                        if let Some(t) = test(p as usize, t_best)
                            && t < t_best
                        {
                            t_best = t;
                            best = Some((p as usize, t));
                        }
                    }
                }
                NodeKind::Inner { left, right } => {
                    let hl = self.nodes[left as usize].bounds.hit(ray.origin, inv, t_best);
                    let hr = self.nodes[right as usize].bounds.hit(ray.origin, inv, t_best);
                    match (hl, hr) {
                        (Some(a), Some(b)) => {
                            // Push the far child first so the near one pops first.
                            if a <= b {
                                stack.push((right, b));
                                stack.push((left, a));
                            } else {
                                stack.push((left, a));
                                stack.push((right, b));
                            }
                        }
                        (Some(a), None) => stack.push((left, a)),
                        (None, Some(b)) => stack.push((right, b)),
                        (None, None) => {}
                    }
                }
            }
        }
        best
    }

    /// Any hit (for shadow rays): `test(prim)` is true when the primitive
    /// blocks the ray before `t_max`; stops at the first.
    pub fn any<F>(&self, ray: &Ray, t_max: f64, mut test: F) -> bool
    where
        F: FnMut(usize) -> bool,
    {
        if self.nodes.is_empty() {
            return false;
        }
        let inv = ray.dir.recip();
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        if self.nodes[0].bounds.hit(ray.origin, inv, t_max).is_some() {
            stack.push(0);
        }
        while let Some(ni) = stack.pop() {
            match self.nodes[ni as usize].kind {
                NodeKind::Leaf { first, count } => {
                    for &p in &self.indices[first as usize..(first + count) as usize] {
                        if test(p as usize) {
                            return true;
                        }
                    }
                }
                NodeKind::Inner { left, right } => {
                    for c in [left, right] {
                        if self.nodes[c as usize].bounds.hit(ray.origin, inv, t_max).is_some() {
                            stack.push(c);
                        }
                    }
                }
            }
        }
        false
    }
}

/// Builds the node for `indices[lo..hi]` and returns its index.
fn build_node(
    boxes: &[Aabb],
    centers: &[DVec3],
    indices: &mut [u32],
    lo: usize,
    hi: usize,
    nodes: &mut Vec<Node>,
) -> u32 {
    let slice = &indices[lo..hi];
    let bounds = slice.iter().fold(Aabb::EMPTY, |b, &i| b.union(boxes[i as usize]));
    let me = nodes.len() as u32;
    nodes.push(Node {
        bounds,
        kind: NodeKind::Leaf {
            first: lo as u32,
            count: (hi - lo) as u32,
        },
    });
    let n = hi - lo;
    if n <= MAX_LEAF {
        return me;
    }
    let cb = Aabb::from_points(slice.iter().map(|&i| centers[i as usize]));
    let extent = cb.max - cb.min;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let mid = if extent[axis] > 0.0 {
        sah_split(boxes, centers, &mut indices[lo..hi], axis, cb, bounds).map(|m| lo + m)
    } else {
        None
    };
    let mid = match mid {
        Some(m) => m,
        None if n > 4 * MAX_LEAF || extent[axis] == 0.0 => {
            // SAH found nothing better than a leaf, or all centres coincide:
            // split at the median (by index when the centres are equal) so
            // that big leaves never form.
            let m = n / 2;
            indices[lo..hi].select_nth_unstable_by(m, |&a, &b| {
                centers[a as usize][axis].total_cmp(&centers[b as usize][axis])
            });
            lo + m
        }
        None => return me,
    };
    let left = build_node(boxes, centers, indices, lo, mid, nodes);
    let right = build_node(boxes, centers, indices, mid, hi, nodes);
    nodes[me as usize].kind = NodeKind::Inner { left, right };
    me
}

/// Binned SAH along `axis`: partitions `idx` in place and returns the split
/// position, or `None` when a leaf is cheaper.
fn sah_split(boxes: &[Aabb], centers: &[DVec3], idx: &mut [u32], axis: usize, cb: Aabb, bounds: Aabb) -> Option<usize> {
    let lo = cb.min[axis];
    let scale = BINS as f64 / (cb.max[axis] - lo);
    let bin_of = |c: f64| (((c - lo) * scale) as usize).min(BINS - 1);
    let mut bin_box = [Aabb::EMPTY; BINS];
    let mut bin_n = [0usize; BINS];
    for &i in idx.iter() {
        let b = bin_of(centers[i as usize][axis]);
        bin_box[b] = bin_box[b].union(boxes[i as usize]);
        bin_n[b] += 1;
    }
    // Sweep from the right to get suffix areas, then from the left.
    let mut right_area = [0.0; BINS];
    let mut right_n = [0usize; BINS];
    let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
    for k in (1..BINS).rev() {
        acc = acc.union(bin_box[k]);
        cnt += bin_n[k];
        right_area[k] = acc.surface_area();
        right_n[k] = cnt;
    }
    let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
    let mut best = (f64::INFINITY, 0usize);
    for k in 1..BINS {
        acc = acc.union(bin_box[k - 1]);
        cnt += bin_n[k - 1];
        if cnt == 0 || right_n[k] == 0 {
            continue;
        }
        let cost = acc.surface_area() * cnt as f64 + right_area[k] * right_n[k] as f64;
        if cost < best.0 {
            best = (cost, k);
        }
    }
    let area = bounds.surface_area();
    let leaf_cost = idx.len() as f64;
    let split_cost = TRAVERSAL_COST + if area > 0.0 { best.0 / area } else { f64::INFINITY };
    if !(best.0.is_finite() && (split_cost < leaf_cost || idx.len() > 4 * MAX_LEAF)) {
        return None;
    }
    // Partition by bin.
    let mut i = 0;
    let mut j = idx.len();
    while i < j {
        if bin_of(centers[idx[i] as usize][axis]) < best.1 {
            i += 1;
        } else {
            j -= 1;
            idx.swap(i, j);
        }
    }
    (i > 0 && i < idx.len()).then_some(i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Ray–sphere test used as a primitive (distance of the near forward root).
    fn sphere_t(ray: &Ray, c: DVec3, r: f64) -> Option<f64> {
        let oc = ray.origin - c;
        let b = oc.dot(ray.dir);
        let q = oc.length_squared() - r * r;
        let disc = b * b - q;
        if disc < 0.0 {
            return None;
        }
        let s = disc.sqrt();
        [-b - s, -b + s].into_iter().find(|&t| t > 0.0)
    }

    #[test]
    fn empty_and_single() {
        let e = Bvh::build(&[]);
        let r = Ray::new(DVec3::ZERO, DVec3::X);
        assert!(e.closest(&r, f64::INFINITY, |_, _| Some(1.0)).is_none());
        assert!(!e.any(&r, f64::INFINITY, |_| true));
        let one = Bvh::build(&[Aabb {
            min: DVec3::new(1.0, -1.0, -1.0),
            max: DVec3::new(2.0, 1.0, 1.0),
        }]);
        assert_eq!(one.closest(&r, f64::INFINITY, |_, _| Some(1.5)), Some((0, 1.5)));
    }

    #[test]
    fn slab_test_hand_values() {
        let b = Aabb {
            min: DVec3::splat(-1.0),
            max: DVec3::splat(1.0),
        };
        // From (−3, 0, 0) along +x: enters at t = 2.
        let r = Ray::new(DVec3::new(-3.0, 0.0, 0.0), DVec3::X);
        assert_eq!(b.hit(r.origin, r.dir.recip(), f64::INFINITY), Some(2.0));
        assert_eq!(b.hit(r.origin, r.dir.recip(), 1.5), None);
        // Inside: entry 0.
        assert_eq!(b.hit(DVec3::ZERO, r.dir.recip(), 10.0), Some(0.0));
        // Parallel and outside a slab: miss.
        let r2 = Ray::new(DVec3::new(-3.0, 2.0, 0.0), DVec3::X);
        assert_eq!(b.hit(r2.origin, r2.dir.recip(), f64::INFINITY), None);
    }

    proptest! {
        /// BVH closest/any hit = brute force over random spheres and rays.
        #[test]
        fn bvh_equals_brute_force(
            spheres in proptest::collection::vec((-10.0f64..10.0, -10.0f64..10.0, -10.0f64..10.0, 0.05f64..1.5), 0..120),
            rays in proptest::collection::vec((-12.0f64..12.0, -12.0f64..12.0, -12.0f64..12.0, -1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0), 1..20),
        ) {
            let s: Vec<(DVec3, f64)> = spheres.iter().map(|&(x, y, z, r)| (DVec3::new(x, y, z), r)).collect();
            let boxes: Vec<Aabb> = s.iter().map(|&(c, r)| Aabb { min: c - r, max: c + r }).collect();
            let bvh = Bvh::build(&boxes);
            for &(ox, oy, oz, dx, dy, dz) in &rays {
                let d = DVec3::new(dx, dy, dz);
                if d.length() < 1e-3 {
                    continue;
                }
                let ray = Ray::new(DVec3::new(ox, oy, oz), d);
                let brute = s.iter().enumerate()
                    .filter_map(|(i, &(c, r))| sphere_t(&ray, c, r).map(|t| (i, t)))
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                let fast = bvh.closest(&ray, f64::INFINITY, |i, tm| sphere_t(&ray, s[i].0, s[i].1).filter(|&t| t < tm));
                prop_assert_eq!(brute.map(|b| b.1), fast.map(|f| f.1));
                let t_max = 5.0;
                let brute_any = s.iter().any(|&(c, r)| sphere_t(&ray, c, r).is_some_and(|t| t < t_max));
                let fast_any = bvh.any(&ray, t_max, |i| sphere_t(&ray, s[i].0, s[i].1).is_some_and(|t| t < t_max));
                prop_assert_eq!(brute_any, fast_any);
            }
        }
    }

    #[test]
    fn coincident_centres_still_split() {
        // 100 identical boxes: the median-by-index split keeps leaves small.
        let boxes = vec![
            Aabb {
                min: DVec3::ZERO,
                max: DVec3::ONE
            };
            100
        ];
        let bvh = Bvh::build(&boxes);
        assert!(bvh.node_count() > 25);
        let r = Ray::new(DVec3::new(0.5, 0.5, -1.0), DVec3::Z);
        let mut seen = 0;
        bvh.closest(&r, f64::INFINITY, |_, _| {
            seen += 1;
            None
        });
        assert_eq!(seen, 100);
    }
}
