//! A small bounding volume hierarchy (§3.2.2) over anything with a box.
//!
//! No maintained crate fits here: `bvh` 0.13 is built on nalgebra and
//! `obvhs` 0.4 on glam 0.33–0.34 in f32, while this crate is glam 0.32 in f64.
//! So this is a plain binned-SAH BVH (16 bins), generic over primitives. Nodes
//! of at most 4 primitives always become leaves; up to 16 may stay a leaf
//! when the SAH finds no split cheaper than testing them all, and larger
//! nodes are always split (at the median when the SAH finds nothing), so no
//! leaf holds more than 16 primitives. The caller gives one box per
//! primitive at build time and a hit test per primitive at query time. The
//! scene uses it twice: over each mesh's triangles (the paper builds one BVH
//! per object, because each object's polygon count changes independently) and
//! over the objects.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::ray::Ray;

/// An axis-aligned box.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub(crate) struct Aabb {
    /// Lower corner.
    pub(crate) min: DVec3,
    /// Upper corner.
    pub(crate) max: DVec3,
}

impl Aabb {
    /// The empty box (min = +∞, max = −∞), the identity of [`Aabb::union`].
    pub(crate) const EMPTY: Self = Self {
        min: DVec3::INFINITY,
        max: DVec3::NEG_INFINITY,
    };

    /// The smallest box holding all `points` (empty for none).
    pub(crate) fn from_points(points: impl IntoIterator<Item = DVec3>) -> Self {
        points.into_iter().fold(Self::EMPTY, |b, p| b.grow(p))
    }

    /// This box grown to hold `p`.
    #[inline]
    pub(crate) fn grow(self, p: DVec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The smallest box holding both.
    #[inline]
    pub(crate) fn union(self, o: Self) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// True for the empty box.
    #[inline]
    pub(crate) fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// The centre.
    #[inline]
    pub(crate) fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    /// Surface area (0 for the empty box), the SAH's cost weight.
    #[inline]
    pub(crate) fn surface_area(&self) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.max - self.min;
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// Slab test: the entry distance of the ray into the (closed) box if it
    /// enters it within [0, t_max]. `inv_dir` is 1/dir per component (±∞ for
    /// a zero component).
    ///
    /// An axis the ray is parallel to (`inv_dir` infinite, so also a
    /// direction component too small to invert) is handled explicitly: an
    /// origin outside that slab is a miss, an origin inside it or on one of
    /// its planes leaves the slab unconstrained. The generic form would
    /// compute `0·∞ = NaN` for an origin on a plane, which culls a box the
    /// ray grazes along a face, and `+∞` for an origin outside, which keeps a
    /// box it never reaches. The empty box is never hit, and the result is
    /// always finite.
    #[inline]
    pub(crate) fn hit(&self, origin: DVec3, inv_dir: DVec3, t_max: f64) -> Option<f64> {
        let mut t_near = 0.0f64;
        let mut t_far = t_max;
        for a in 0..3 {
            let (lo_plane, hi_plane, o, inv) = (self.min[a], self.max[a], origin[a], inv_dir[a]);
            if !(lo_plane <= hi_plane) {
                return None; // empty (or NaN) box
            }
            if inv.is_infinite() {
                if o < lo_plane || o > hi_plane {
                    return None;
                }
                continue;
            }
            let t1 = (lo_plane - o) * inv;
            let t2 = (hi_plane - o) * inv;
            t_near = t_near.max(t1.min(t2));
            t_far = t_far.min(t1.max(t2));
        }
        (t_near <= t_far && t_near < f64::INFINITY).then_some(t_near)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub(crate) enum NodeKind {
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
pub(crate) struct Bvh {
    nodes: Vec<Node>,
    indices: Vec<u32>,
}

/// Nodes of at most this many primitives always become leaves: below a few
/// primitives one more box test costs about as much as the primitive tests
/// it would save.
const MAX_LEAF: usize = 4;
/// Nodes of more than this many primitives are always split; between
/// [`MAX_LEAF`] and this the SAH decides. So no leaf holds more.
const MAX_SAH_LEAF: usize = 4 * MAX_LEAF;
/// SAH bins per split, as in Wald's binned builder, where a few dozen bins
/// or fewer give trees of nearly full-sweep quality at a fraction of the
/// build cost (I. Wald, "On fast Construction of SAH-based Bounding Volume
/// Hierarchies", IEEE Symposium on Interactive Ray Tracing, 2007).
const BINS: usize = 16;
/// SAH cost of one box test relative to one primitive test: a slab test and
/// a Möller–Trumbore test are both a few dozen flops, so 1.
const TRAVERSAL_COST: f64 = 1.0;

impl Bvh {
    /// Builds over one box per primitive. Primitives with empty or non-finite
    /// boxes are left out (they cannot be hit).
    pub(crate) fn build(boxes: &[Aabb]) -> Self {
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
    #[cfg(test)]
    pub(crate) fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// The nodes in order (the root first), for flattening onto the GPU.
    pub(crate) fn nodes(&self) -> impl Iterator<Item = (Aabb, NodeKind)> + '_ {
        self.nodes.iter().map(|n| (n.bounds, n.kind))
    }

    /// The primitive indices the leaves' ranges refer to.
    pub(crate) fn indices(&self) -> &[u32] {
        &self.indices
    }

    /// Bounds of everything (empty for an empty BVH).
    pub(crate) fn bounds(&self) -> Aabb {
        self.nodes.first().map_or(Aabb::EMPTY, |n| n.bounds)
    }

    /// The closest hit: `test(prim, t_max)` returns the hit distance of
    /// primitive `prim` if it is below `t_max`. Returns the primitive and its
    /// distance. Children are visited near first, so `t_max` shrinks early.
    pub(crate) fn closest<F>(&self, ray: &Ray, t_max: f64, test: F) -> Option<(usize, f64)>
    where
        F: FnMut(usize, f64) -> Option<f64>,
    {
        self.closest_along(ray.origin(), ray.dir(), t_max, test)
    }

    /// [`Bvh::closest`] along any finite `dir`, unit or not (`t` is then in
    /// units of `|dir|`): the tests use power-of-two directions, whose
    /// reciprocals are exact.
    pub(crate) fn closest_along<F>(
        &self,
        origin: DVec3,
        dir: DVec3,
        t_max: f64,
        mut test: F,
    ) -> Option<(usize, f64)>
    where
        F: FnMut(usize, f64) -> Option<f64>,
    {
        if self.nodes.is_empty() {
            return None;
        }
        let inv = dir.recip();
        let mut best: Option<(usize, f64)> = None;
        let mut t_best = t_max;
        let mut stack: Vec<(u32, f64)> = Vec::with_capacity(64);
        if let Some(t) = self.nodes[0].bounds.hit(origin, inv, t_best) {
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
                    let hl = self.nodes[left as usize].bounds.hit(origin, inv, t_best);
                    let hr = self.nodes[right as usize].bounds.hit(origin, inv, t_best);
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
    pub(crate) fn any<F>(&self, ray: &Ray, t_max: f64, test: F) -> bool
    where
        F: FnMut(usize) -> bool,
    {
        self.any_along(ray.origin(), ray.dir(), t_max, test)
    }

    /// [`Bvh::any`] along any finite `dir` (see [`Bvh::closest_along`]).
    pub(crate) fn any_along<F>(&self, origin: DVec3, dir: DVec3, t_max: f64, mut test: F) -> bool
    where
        F: FnMut(usize) -> bool,
    {
        if self.nodes.is_empty() {
            return false;
        }
        let inv = dir.recip();
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        if self.nodes[0].bounds.hit(origin, inv, t_max).is_some() {
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
                        if self.nodes[c as usize]
                            .bounds
                            .hit(origin, inv, t_max)
                            .is_some()
                        {
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
    let bounds = slice
        .iter()
        .fold(Aabb::EMPTY, |b, &i| b.union(boxes[i as usize]));
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
        None if n > MAX_SAH_LEAF || extent[axis] == 0.0 => {
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
fn sah_split(
    boxes: &[Aabb],
    centers: &[DVec3],
    idx: &mut [u32],
    axis: usize,
    cb: Aabb,
    bounds: Aabb,
) -> Option<usize> {
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
    let split_cost = TRAVERSAL_COST
        + if area > 0.0 {
            best.0 / area
        } else {
            f64::INFINITY
        };
    if !(best.0.is_finite() && (split_cost < leaf_cost || idx.len() > MAX_SAH_LEAF)) {
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
        let oc = ray.origin() - c;
        let b = oc.dot(ray.dir());
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
        let r = Ray::new(DVec3::ZERO, DVec3::X).unwrap();
        assert!(e.closest(&r, f64::INFINITY, |_, _| Some(1.0)).is_none());
        assert!(!e.any(&r, f64::INFINITY, |_| true));
        let one = Bvh::build(&[Aabb {
            min: DVec3::new(1.0, -1.0, -1.0),
            max: DVec3::new(2.0, 1.0, 1.0),
        }]);
        assert_eq!(
            one.closest(&r, f64::INFINITY, |_, _| Some(1.5)),
            Some((0, 1.5))
        );
    }

    #[test]
    fn slab_test_hand_values() {
        let b = Aabb {
            min: DVec3::splat(-1.0),
            max: DVec3::splat(1.0),
        };
        // From (−3, 0, 0) along +x: enters at t = 2.
        let r = Ray::new(DVec3::new(-3.0, 0.0, 0.0), DVec3::X).unwrap();
        assert_eq!(b.hit(r.origin(), r.dir().recip(), f64::INFINITY), Some(2.0));
        assert_eq!(b.hit(r.origin(), r.dir().recip(), 1.5), None);
        // Inside: entry 0.
        assert_eq!(b.hit(DVec3::ZERO, r.dir().recip(), 10.0), Some(0.0));
        // Parallel and outside a slab: miss.
        let r2 = Ray::new(DVec3::new(-3.0, 2.0, 0.0), DVec3::X).unwrap();
        assert_eq!(b.hit(r2.origin(), r2.dir().recip(), f64::INFINITY), None);
    }

    #[test]
    fn slab_test_with_zero_direction_components() {
        let b = Aabb {
            min: DVec3::splat(-1.0),
            max: DVec3::splat(1.0),
        };
        let inf = f64::INFINITY;
        // Along +y with x = 1.5, outside the x slab: a miss, even for t_max = ∞
        // (the generic slab test returned Some(+∞) and kept the box).
        for dir in [DVec3::Y, DVec3::new(-0.0, 1.0, 0.0)] {
            assert_eq!(b.hit(DVec3::new(1.5, -3.0, 0.0), dir.recip(), inf), None);
            assert_eq!(b.hit(DVec3::new(-1.5, -3.0, 0.0), dir.recip(), inf), None);
        }
        // Along ±y in the planes x = ±1 (origin on a slab plane): the ray
        // grazes the face and enters the closed box at t = 2 (the generic test
        // gave +∞ on the min plane and a miss on the max plane).
        for x in [-1.0, 1.0] {
            for dir in [DVec3::Y, DVec3::new(-0.0, 1.0, -0.0)] {
                assert_eq!(
                    b.hit(DVec3::new(x, -3.0, 0.0), dir.recip(), inf),
                    Some(2.0),
                    "x = {x}"
                );
                assert_eq!(b.hit(DVec3::new(x, -3.0, 0.0), dir.recip(), 1.5), None);
            }
            assert_eq!(
                b.hit(DVec3::new(x, 3.0, 0.0), DVec3::NEG_Y.recip(), inf),
                Some(2.0)
            );
            // On an edge (two planes), along the third axis.
            assert_eq!(
                b.hit(DVec3::new(x, 1.0, 4.0), DVec3::NEG_Z.recip(), inf),
                Some(3.0)
            );
        }
        // Inside with two zero components: entry 0.
        assert_eq!(
            b.hit(DVec3::new(0.5, -1.0, 1.0), DVec3::X.recip(), inf),
            Some(0.0)
        );
        // The empty box is never hit; a flat box (min = max on one axis) is.
        assert_eq!(
            Aabb::EMPTY.hit(DVec3::ZERO, DVec3::new(1.0, 2.0, 3.0).recip(), inf),
            None
        );
        assert_eq!(Aabb::EMPTY.hit(DVec3::ZERO, DVec3::X.recip(), inf), None);
        let flat = Aabb {
            min: DVec3::new(0.0, -1.0, -1.0),
            max: DVec3::new(0.0, 1.0, 1.0),
        };
        assert_eq!(
            flat.hit(DVec3::new(0.0, -2.0, 0.0), DVec3::Y.recip(), inf),
            Some(1.0)
        );
        assert_eq!(
            flat.hit(DVec3::new(-2.0, 0.0, 0.0), DVec3::X.recip(), inf),
            Some(2.0)
        );
    }

    #[test]
    fn bvh_keeps_a_hit_grazing_a_node_face() {
        // Boxes as primitives (exact closed-box test): a ray along +y lying
        // in the max-x plane of the whole set must still find box 1's face.
        let boxes = [
            Aabb {
                min: DVec3::new(-1.0, 0.0, -1.0),
                max: DVec3::new(0.0, 1.0, 1.0),
            },
            Aabb {
                min: DVec3::new(0.0, 2.0, -1.0),
                max: DVec3::new(1.0, 3.0, 1.0),
            },
        ];
        let bvh = Bvh::build(&boxes);
        let ray = Ray::new(DVec3::new(1.0, -1.0, 0.0), DVec3::Y).unwrap();
        let got = bvh.closest(&ray, f64::INFINITY, |i, tm| {
            reference_box_t(&boxes[i], &ray).filter(|&t| t < tm)
        });
        assert_eq!(got, Some((1, 3.0)));
        assert!(bvh.any(&ray, 10.0, |i| {
            reference_box_t(&boxes[i], &ray).is_some_and(|t| t < 10.0)
        }));
        // And a ray parallel to x outside every y slab is culled at the root.
        let away = Ray::new(DVec3::new(-5.0, 10.0, 0.0), DVec3::X).unwrap();
        let mut tested = 0;
        bvh.closest(&away, f64::INFINITY, |_, _| {
            tested += 1;
            None
        });
        assert_eq!(tested, 0);
    }

    /// Leaf sizes of a BVH.
    fn leaf_sizes(bvh: &Bvh) -> Vec<usize> {
        bvh.nodes
            .iter()
            .filter_map(|n| match n.kind {
                NodeKind::Leaf { count, .. } => Some(count as usize),
                NodeKind::Inner { .. } => None,
            })
            .collect()
    }

    #[test]
    fn leaves_hold_at_most_sixteen_and_the_sah_may_keep_more_than_four() {
        // 12 almost coincident big boxes: every split costs more than testing
        // them all, so the SAH keeps one leaf of 12 (more than MAX_LEAF).
        let boxes: Vec<Aabb> = (0..12)
            .map(|k| {
                let o = DVec3::new(1e-3 * k as f64, 0.0, 0.0);
                Aabb {
                    min: o - 5.0,
                    max: o + 5.0,
                }
            })
            .collect();
        assert_eq!(leaf_sizes(&Bvh::build(&boxes)), vec![12]);
        // 40 of them: more than MAX_SAH_LEAF, so always split.
        let boxes: Vec<Aabb> = (0..40)
            .map(|k| {
                let o = DVec3::new(1e-3 * k as f64, 0.0, 0.0);
                Aabb {
                    min: o - 5.0,
                    max: o + 5.0,
                }
            })
            .collect();
        let sizes = leaf_sizes(&Bvh::build(&boxes));
        assert!(
            sizes.iter().all(|&n| n <= MAX_SAH_LEAF) && sizes.iter().sum::<usize>() == 40,
            "{sizes:?}"
        );
    }

    /// Reference ray–box test for closed boxes, written out per axis with
    /// the sign of the direction (no reciprocals, no NaN): the entry distance
    /// in [0, ∞), if any.
    fn reference_box_t(b: &Aabb, ray: &Ray) -> Option<f64> {
        reference_box_t_along(b, ray.origin(), ray.dir())
    }

    fn reference_box_t_along(b: &Aabb, origin: DVec3, dir: DVec3) -> Option<f64> {
        let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
        for a in 0..3 {
            let (o, d) = (origin[a], dir[a]);
            if d == 0.0 {
                if o < b.min[a] || o > b.max[a] {
                    return None;
                }
            } else {
                let (near, far) = if d > 0.0 {
                    (b.min[a], b.max[a])
                } else {
                    (b.max[a], b.min[a])
                };
                t0 = t0.max((near - o) / d);
                t1 = t1.min((far - o) / d);
            }
        }
        (t0 <= t1).then_some(t0)
    }

    /// An axis-aligned direction (one or two zero components) from an index.
    fn axis_dir(k: usize, a: f64, b: f64) -> DVec3 {
        let s = if k.is_multiple_of(2) { 1.0 } else { -1.0 };
        match (k / 2) % 6 {
            0 => DVec3::new(s, 0.0, 0.0),
            1 => DVec3::new(0.0, s, 0.0),
            2 => DVec3::new(0.0, 0.0, s),
            3 => DVec3::new(0.0, s * a, b),
            4 => DVec3::new(s * a, 0.0, b),
            _ => DVec3::new(s * a, b, 0.0),
        }
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
                let ray = Ray::new(DVec3::new(ox, oy, oz), d).unwrap();
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
            // Axis-aligned rays (zero direction components) from origins on
            // the spheres' box planes, edges and corners, grazing them.
            for (k, &(ox, oy, oz, dx, dy, _)) in rays.iter().enumerate() {
                if s.is_empty() {
                    break;
                }
                let (c, r) = s[k % s.len()];
                let face = |v: f64, lo: f64, hi: f64| if v < -0.3 { lo } else if v > 0.3 { hi } else { v };
                let o = DVec3::new(face(dx, c.x - r, c.x + r), face(dy, c.y - r, c.y + r), face(ox / 12.0, c.z - r, c.z + r));
                let dir = axis_dir(k, 0.3 + dx.abs(), 0.2 + dy.abs());
                let ray = Ray::new(o - 20.0 * dir.normalize() * (oy / 12.0).abs().min(0.5) , dir).unwrap();
                let brute = s.iter().enumerate()
                    .filter_map(|(i, &(c, r))| sphere_t(&ray, c, r).map(|t| (i, t)))
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                let fast = bvh.closest(&ray, f64::INFINITY, |i, tm| sphere_t(&ray, s[i].0, s[i].1).filter(|&t| t < tm));
                prop_assert_eq!(brute.map(|b| b.1), fast.map(|f| f.1));
                let t_max = 5.0 + oz.abs();
                let brute_any = s.iter().any(|&(c, r)| sphere_t(&ray, c, r).is_some_and(|t| t < t_max));
                let fast_any = bvh.any(&ray, t_max, |i| sphere_t(&ray, s[i].0, s[i].1).is_some_and(|t| t < t_max));
                prop_assert_eq!(brute_any, fast_any);
            }
        }

        /// The same with boxes as primitives (an exact closed-box test), so
        /// that rays lying in a box face really hit it: axis-aligned rays
        /// from origins on the boxes' planes, edges and corners.
        #[test]
        fn bvh_equals_brute_force_for_rays_in_box_planes(
            cubes in proptest::collection::vec((-8i32..8, -8i32..8, -8i32..8, 1i32..4, 1i32..4, 1i32..4), 1..80),
            rays in proptest::collection::vec((0usize..1000, 0usize..12, 0usize..27, -1.0f64..1.0, 0.0f64..1.0, 0.0f64..1.0), 1..30),
        ) {
            // Integer-aligned boxes, so that many share planes with their nodes.
            let boxes: Vec<Aabb> = cubes.iter().map(|&(x, y, z, a, b, c)| {
                let min = DVec3::new(x as f64, y as f64, z as f64);
                Aabb { min, max: min + DVec3::new(a as f64, b as f64, c as f64) }
            }).collect();
            let bvh = Bvh::build(&boxes);
            for &(which, k, corner, back, fa, fb) in &rays {
                let b = boxes[which % boxes.len()];
                // Each coordinate on the min plane, the max plane or inside the slab.
                let pick = |sel: usize, lo: f64, hi: f64, f: f64| match sel % 3 {
                    0 => lo,
                    1 => hi,
                    _ => lo + f * (hi - lo),
                };
                let o = DVec3::new(
                    pick(corner, b.min.x, b.max.x, fa),
                    pick(corner / 3, b.min.y, b.max.y, fb),
                    pick(corner / 9, b.min.z, b.max.z, 0.5),
                );
                // Power-of-two components, not normalised: 1/d is exact, so the
                // slab test and the reference agree to the bit and grazing
                // cases cannot flip by rounding.
                let dir = axis_dir(k, [0.5, 1.0, 2.0][which % 3], [0.25, 1.0, 4.0][(which / 3) % 3]);
                let origin = o - 4.0 * back * dir;
                let ray = (origin, dir);
                let brute = boxes.iter().enumerate()
                    .filter_map(|(i, b)| reference_box_t_along(b, origin, dir).map(|t| (i, t)))
                    .min_by(|a, b| a.1.total_cmp(&b.1));
                let fast = bvh.closest_along(origin, dir, f64::INFINITY, |i, tm| reference_box_t_along(&boxes[i], origin, dir).filter(|&t| t < tm));
                prop_assert_eq!(brute.map(|b| b.1), fast.map(|f| f.1), "ray {:?}", ray);
                let t_max = 3.0;
                let brute_any = boxes.iter().any(|b| reference_box_t_along(b, origin, dir).is_some_and(|t| t < t_max));
                let fast_any = bvh.any_along(origin, dir, t_max, |i| reference_box_t_along(&boxes[i], origin, dir).is_some_and(|t| t < t_max));
                prop_assert_eq!(brute_any, fast_any, "ray {:?}", ray);
                // The box test itself agrees with the reference on every box.
                for bx in &boxes {
                    let want = reference_box_t_along(bx, origin, dir);
                    let got = bx.hit(origin, dir.recip(), f64::INFINITY);
                    prop_assert_eq!(want, got, "{:?} {:?}", bx, ray);
                }
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
        let r = Ray::new(DVec3::new(0.5, 0.5, -1.0), DVec3::Z).unwrap();
        let mut seen = 0;
        bvh.closest(&r, f64::INFINITY, |_, _| {
            seen += 1;
            None
        });
        assert_eq!(seen, 100);
    }
}
