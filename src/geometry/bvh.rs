//! A bounding volume hierarchy over triangles, built top-down with the
//! binned surface area heuristic and flattened depth-first into 32-byte nodes.

use glam::{Vec3, Vec3A, Vec4};

use super::triangle::{self, RayShear, TriangleHit};
use super::{gamma, Aabb, Ray};

/// A flattened node of 32 bytes: two SIMD vectors, the box corners in xyz
/// and the links in the w lanes (as bits). Interior: `count == 0`, the first
/// child follows the node, the second is at `offset`. Leaf: `count`
/// primitives from `offset`.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct Node {
    /// xyz: box minimum; w: `offset` as bits.
    min: Vec4,
    /// xyz: box maximum; w: `count | axis << 16` as bits.
    max: Vec4,
}

impl Node {
    fn new(bounds: &Aabb, offset: u32, count: u16, axis: u16) -> Self {
        Self {
            min: bounds.min.extend(f32::from_bits(offset)),
            max: bounds
                .max
                .extend(f32::from_bits(count as u32 | (axis as u32) << 16)),
        }
    }

    fn offset(&self) -> u32 {
        self.min.w.to_bits()
    }

    fn count(&self) -> u16 {
        self.max.w.to_bits() as u16
    }

    fn axis(&self) -> u16 {
        (self.max.w.to_bits() >> 16) as u16
    }

    fn set_interior(&mut self, second_child: u32, axis: u16) {
        self.min.w = f32::from_bits(second_child);
        self.max.w = f32::from_bits((axis as u32) << 16);
    }
}

pub struct Bvh {
    nodes: Vec<Node>,
}

/// Bins per axis in the SAH sweep.
const BINS: usize = 16;
/// Leaves never hold more than this many primitives unless they cannot be split.
const MAX_LEAF: usize = 8;
/// Cost of visiting a node relative to one triangle test.
const TRAVERSAL_COST: f32 = 1.0;
/// Past this depth the build splits at the median, which bounds the tree's depth.
const SAH_MAX_DEPTH: usize = 40;
/// Enough for SAH_MAX_DEPTH plus a median-split tree over 2³² primitives.
const STACK_SIZE: usize = 80;

#[derive(Clone, Copy)]
struct BuildPrim {
    bounds: Aabb,
    centroid: Vec3,
    index: u32,
}

impl Bvh {
    /// Builds over primitive bounds. Returns the hierarchy and the order in
    /// which the primitives must be stored: leaf ranges index that order.
    pub fn build(bounds: &[Aabb]) -> (Bvh, Vec<u32>) {
        let mut prims: Vec<BuildPrim> = bounds
            .iter()
            .enumerate()
            .map(|(i, b)| BuildPrim {
                bounds: *b,
                centroid: b.centroid(),
                index: i as u32,
            })
            .collect();
        let mut nodes = Vec::with_capacity(2 * bounds.len().max(1));
        if prims.is_empty() {
            nodes.push(Node::new(&Aabb::EMPTY, 0, 0, u16::MAX));
        } else {
            build_range(&mut prims, 0, 0, &mut nodes);
        }
        let order = prims.iter().map(|p| p.index).collect();
        (Bvh { nodes }, order)
    }

    pub fn bounds(&self) -> Aabb {
        let n = &self.nodes[0];
        Aabb {
            min: n.min.truncate(),
            max: n.max.truncate(),
        }
    }

    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    pub fn size_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>()
    }

    /// The closest hit among `tris` (stored in build order) within (0, ray.t_max).
    pub fn intersect(&self, ray: &Ray, tris: &[[Vec3; 3]]) -> Option<(u32, TriangleHit)> {
        self.traverse::<false>(ray, tris)
    }

    /// Whether anything lies on the ray within (0, ray.t_max).
    pub fn occluded(&self, ray: &Ray, tris: &[[Vec3; 3]]) -> bool {
        self.traverse::<true>(ray, tris).is_some()
    }

    /// Visits nodes front to back. With `ANY_HIT` it stops at the first hit.
    #[inline]
    fn traverse<const ANY_HIT: bool>(
        &self,
        ray: &Ray,
        tris: &[[Vec3; 3]],
    ) -> Option<(u32, TriangleHit)> {
        if self.nodes[0].axis() == u16::MAX {
            return None;
        }
        let shear = RayShear::new(ray);
        let inv_dir = Vec3A::from(ray.dir.recip());
        let origin = Vec3A::from(ray.origin);
        let negative = [inv_dir.x < 0.0, inv_dir.y < 0.0, inv_dir.z < 0.0];
        let mut t_max = ray.t_max;
        let mut closest = None;
        let mut stack = [0u32; STACK_SIZE];
        let mut top = 0usize;
        let mut current = 0usize;
        loop {
            let node = &self.nodes[current];
            if hit_box(node, origin, inv_dir, t_max) {
                let count = node.count();
                if count > 0 {
                    let start = node.offset() as usize;
                    let leaf = &tris[start..start + count as usize];
                    for (prim, tri) in (start..).zip(leaf) {
                        if let Some(hit) = triangle::intersect(&shear, tri, t_max) {
                            if ANY_HIT {
                                return Some((prim as u32, hit));
                            }
                            t_max = hit.t;
                            closest = Some((prim as u32, hit));
                        }
                    }
                } else {
                    // Visit the child on the ray's near side first.
                    let (near, far) = if negative[node.axis() as usize] {
                        (node.offset() as usize, current + 1)
                    } else {
                        (current + 1, node.offset() as usize)
                    };
                    stack[top] = far as u32;
                    top += 1;
                    current = near;
                    continue;
                }
            }
            if top == 0 {
                return closest;
            }
            top -= 1;
            current = stack[top] as usize;
        }
    }
}

/// Slab test, conservative against rounding (the far distance is enlarged by 2γ(3)).
#[inline]
fn hit_box(node: &Node, origin: Vec3A, inv_dir: Vec3A, t_max: f32) -> bool {
    let t0 = (Vec3A::from_vec4(node.min) - origin) * inv_dir;
    let t1 = (Vec3A::from_vec4(node.max) - origin) * inv_dir;
    let near = t0.min(t1).max_element().max(0.0);
    let far = t0.max(t1).min_element() * (1.0 + 2.0 * gamma(3));
    near <= far.min(t_max)
}

fn build_range(
    prims: &mut [BuildPrim],
    first: usize,
    depth: usize,
    nodes: &mut Vec<Node>,
) -> usize {
    let bounds = prims.iter().fold(Aabb::EMPTY, |b, p| b.union(p.bounds));
    let centroids = prims.iter().fold(Aabb::EMPTY, |b, p| b.grow(p.centroid));
    let index = nodes.len();
    nodes.push(Node::new(&bounds, first as u32, prims.len() as u16, 0));
    let n = prims.len();
    let extent = centroids.diagonal();
    let axis = largest_axis(extent);
    if (n <= 2 || extent[axis] <= 0.0) && n <= u16::MAX as usize {
        return index; // Leaf: nothing to split (or identical centroids).
    }

    let mid = if depth < SAH_MAX_DEPTH && extent[axis] > 0.0 {
        match sah_split(prims, &bounds, &centroids) {
            Some(mid) => mid,
            None if n <= MAX_LEAF => return index,
            None => median_split(prims, axis),
        }
    } else {
        median_split(prims, axis)
    };

    let split_axis = if depth < SAH_MAX_DEPTH {
        axis_of_split(prims, mid)
    } else {
        axis
    };
    let (left, right) = prims.split_at_mut(mid);
    build_range(left, first, depth + 1, nodes);
    let second = build_range(right, first + mid, depth + 1, nodes);
    nodes[index].set_interior(second as u32, split_axis as u16);
    index
}

/// The axis along which the two halves' centroids are best separated, for
/// ordering the traversal.
fn axis_of_split(prims: &[BuildPrim], mid: usize) -> usize {
    let c = |s: &[BuildPrim]| {
        s.iter()
            .fold(Aabb::EMPTY, |b, p| b.grow(p.centroid))
            .centroid()
    };
    largest_axis((c(&prims[mid..]) - c(&prims[..mid])).abs())
}

fn largest_axis(v: Vec3) -> usize {
    if v.x >= v.y && v.x >= v.z {
        0
    } else if v.y >= v.z {
        1
    } else {
        2
    }
}

fn median_split(prims: &mut [BuildPrim], axis: usize) -> usize {
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
    mid
}

/// Binned SAH over all three axes. Partitions `prims` and returns the split
/// point, or None when keeping a leaf is cheaper (or nothing separates).
fn sah_split(prims: &mut [BuildPrim], bounds: &Aabb, centroids: &Aabb) -> Option<usize> {
    let n = prims.len();
    let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, bins on the left)
    let bin_of = |p: &BuildPrim, axis: usize| {
        let lo = centroids.min[axis];
        let ext = centroids.max[axis] - lo;
        (((p.centroid[axis] - lo) / ext * BINS as f32) as usize).min(BINS - 1)
    };
    for axis in 0..3 {
        if centroids.max[axis] <= centroids.min[axis] {
            continue;
        }
        let mut bin_bounds = [Aabb::EMPTY; BINS];
        let mut bin_count = [0usize; BINS];
        for p in prims.iter() {
            let b = bin_of(p, axis);
            bin_bounds[b] = bin_bounds[b].union(p.bounds);
            bin_count[b] += 1;
        }
        // Sweep from the right to get suffix areas, then from the left.
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0usize; BINS];
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for i in (1..BINS).rev() {
            acc = acc.union(bin_bounds[i]);
            cnt += bin_count[i];
            right_area[i] = acc.surface_area();
            right_count[i] = cnt;
        }
        let (mut acc, mut cnt) = (Aabb::EMPTY, 0);
        for i in 0..BINS - 1 {
            acc = acc.union(bin_bounds[i]);
            cnt += bin_count[i];
            if cnt == 0 || right_count[i + 1] == 0 {
                continue;
            }
            let cost =
                cnt as f32 * acc.surface_area() + right_count[i + 1] as f32 * right_area[i + 1];
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, i + 1));
            }
        }
    }
    let (cost, axis, left_bins) = best?;
    let area = bounds.surface_area();
    let split_cost = TRAVERSAL_COST + if area > 0.0 { cost / area } else { n as f32 };
    if n <= MAX_LEAF && split_cost >= n as f32 {
        return None;
    }
    let mut mid = 0;
    for i in 0..n {
        if bin_of(&prims[i], axis) < left_bins {
            prims.swap(i, mid);
            mid += 1;
        }
    }
    (mid > 0 && mid < n).then_some(mid)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random_triangles(n: usize, seed: u64) -> Vec<[Vec3; 3]> {
        let mut s = seed;
        let mut next = || {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((s >> 40) as f32) / (1u64 << 24) as f32
        };
        (0..n)
            .map(|_| {
                let c = Vec3::new(next(), next(), next()) * 10.0;
                let mut v = || c + Vec3::new(next(), next(), next()) - 0.5;
                [v(), v(), v()]
            })
            .collect()
    }

    #[test]
    fn closest_hit_and_occlusion_match_brute_force() {
        let tris = random_triangles(3000, 7);
        let bounds: Vec<Aabb> = tris.iter().map(|t| Aabb::of_points(t)).collect();
        let (bvh, order) = Bvh::build(&bounds);
        let ordered: Vec<[Vec3; 3]> = order.iter().map(|&i| tris[i as usize]).collect();
        let rays = random_triangles(500, 99);
        for r in rays {
            let mut ray = Ray::new(r[0] * 1.3 - 2.0, (r[1] - r[0] * 1.3 + 2.0).normalize());
            ray.t_max = 12.0;
            let shear = RayShear::new(&ray);
            let brute = tris
                .iter()
                .enumerate()
                .filter_map(|(i, t)| triangle::intersect(&shear, t, ray.t_max).map(|h| (i, h)))
                .min_by(|a, b| a.1.t.total_cmp(&b.1.t));
            let got = bvh.intersect(&ray, &ordered);
            match (brute, got) {
                (None, None) => {}
                (Some((i, h)), Some((p, g))) => {
                    assert_eq!(order[p as usize] as usize, i);
                    assert_eq!(h.t, g.t);
                }
                (b, g) => panic!("brute force {b:?} but BVH {g:?}"),
            }
            assert_eq!(bvh.occluded(&ray, &ordered), brute.is_some());
        }
    }

    #[test]
    fn empty_and_identical_primitives() {
        let (bvh, order) = Bvh::build(&[]);
        assert!(order.is_empty());
        assert!(bvh.intersect(&Ray::new(Vec3::ZERO, Vec3::X), &[]).is_none());
        // Many triangles with the same centroid become one leaf, not a stack overflow.
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let tris = vec![t; 100];
        let bounds: Vec<Aabb> = tris.iter().map(|t| Aabb::of_points(t)).collect();
        let (bvh, _) = Bvh::build(&bounds);
        let ray = Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z);
        assert!(bvh.intersect(&ray, &tris).is_some());
    }
}
