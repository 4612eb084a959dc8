//! A bounding volume hierarchy over triangles: built top-down as a binary
//! tree with the binned surface area heuristic, then collapsed into an
//! 8-wide tree (each node holds its children's boxes side by side, four to
//! a SIMD slab test, and a ray visits a third as many levels as in the
//! binary tree: on big meshes a ray's time is mostly spent waiting for
//! nodes from memory, one level after another). Leaves keep their
//! triangles four to a packet, tested together (`triangle4`).

use glam::Vec3;

use super::huge_pages::HugeArray;
use super::lanes::Lanes;
use super::triangle::{RayShear, TriangleHit};
use super::triangle4::{self, RayShear4, Triangle4};
use super::{gamma, Aabb, Ray};

/// Children per node: a multiple of four (each four share SIMD slab tests).
const WIDTH: usize = 8;

/// The lanes a slab test runs on: all of a node's children at once with
/// AVX2, four at a time otherwise.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
type Slab = super::lanes::F32x8;
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
type Slab = glam::Vec4;

/// A wide node: the children's boxes as structure of arrays (`lo[axis][k]`
/// is child k's lower bound on that axis), and per child either a node
/// index (`count == 0`) or a leaf: its first packet and its number of
/// triangles. Unused slots have empty boxes (+∞ on both sides), which no
/// ray hits.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct WideNode {
    lo: [[f32; WIDTH]; 3],
    hi: [[f32; WIDTH]; 3],
    child: [u32; WIDTH],
    count: [u32; WIDTH],
}

pub struct Bvh {
    nodes: HugeArray<WideNode>,
    /// The leaves' triangles, four to a packet, leaf after leaf.
    packets: HugeArray<Triangle4>,
    bounds: Aabb,
}

/// Traversal stack entries: up to WIDTH − 1 per wide level, and a wide
/// level per binary level at worst (SAH_MAX_DEPTH plus a median-split tree
/// over 2³² primitives).
const STACK_SIZE: usize = (WIDTH - 1) * 80;

impl Bvh {
    /// Builds over triangles. Returns the hierarchy and the order in which
    /// the caller must store the triangles: hits name them by that order.
    pub fn build(triangles: &[[Vec3; 3]]) -> (Bvh, Vec<u32>) {
        Self::build_from(triangles.len(), |i| triangles[i])
    }

    /// `build` over `count` triangles that `triangle(i)` gives (wherever
    /// they are kept).
    pub fn build_from(
        count: usize,
        triangle: impl Fn(usize) -> [Vec3; 3] + Sync,
    ) -> (Bvh, Vec<u32>) {
        let (mut nodes, bounds, order) = build_boxes(count, |i| Aabb::of_points(&triangle(i)));
        let packets = pack_leaves(&mut nodes, |prim| triangle(order[prim] as usize));
        let bvh = Bvh {
            nodes: HugeArray::filled_in_parallel(nodes.len(), |i| nodes[i]),
            packets,
            bounds,
        };
        (bvh, order)
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Nodes and packets.
    pub fn size_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<WideNode>()
            + self.packets.len() * std::mem::size_of::<Triangle4>()
    }

    /// The closest hit within (0, ray.t_max): the triangle (in build order)
    /// and where it is hit.
    pub fn intersect(&self, ray: &Ray) -> Option<(u32, TriangleHit)> {
        self.traverse::<false>(ray)
    }

    /// Whether anything lies on the ray within (0, ray.t_max).
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.traverse::<true>(ray).is_some()
    }

    /// Visits nodes front to back (children sorted by entry distance).
    /// With `ANY_HIT` it stops at the first hit.
    #[inline]
    fn traverse<const ANY_HIT: bool>(&self, ray: &Ray) -> Option<(u32, TriangleHit)> {
        // A NaN in the ray would pass every slab test (SIMD min/max drop
        // NaN operands), empty slots included, and never end.
        if self.nodes.is_empty() || !(ray.origin.is_finite() && ray.dir.is_finite()) {
            return None;
        }
        let ray_shear = RayShear::new(ray);
        let shear = RayShear4::new(&ray_shear);
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        let shear8 = triangle4::RayShear8::new(&ray_shear);
        let inv = ray.dir.recip();
        let o = [ray.origin.x, ray.origin.y, ray.origin.z].map(Slab::splat);
        let id = [inv.x, inv.y, inv.z].map(Slab::splat);
        // The far distance is enlarged by 2γ(3): conservative against rounding.
        let far_scale = Slab::splat(1.0 + 2.0 * gamma(3));
        let mut t_max = ray.t_max;
        let mut closest = None;
        // Interior nodes still to visit, with their entry distances. Left
        // uninitialised: zeroing 2 KB per ray cost 5% of a Cornell render.
        let mut stack = [const { std::mem::MaybeUninit::<(u32, f32)>::uninit() }; STACK_SIZE];
        let mut top = 0usize;
        let mut current = 0u32;
        loop {
            let node = &self.nodes[current as usize];
            let mut mask = 0u32;
            let mut near = [0f32; WIDTH];
            for g in (0..WIDTH).step_by(Slab::WIDTH) {
                let slab = |bounds: &[[f32; WIDTH]; 3], axis: usize| {
                    (Slab::load(&bounds[axis][g..]) - o[axis]) * id[axis]
                };
                let (tx0, tx1) = (slab(&node.lo, 0), slab(&node.hi, 0));
                let (ty0, ty1) = (slab(&node.lo, 1), slab(&node.hi, 1));
                let (tz0, tz1) = (slab(&node.lo, 2), slab(&node.hi, 2));
                let entry = tx0
                    .min(tx1)
                    .max(ty0.min(ty1))
                    .max(tz0.min(tz1))
                    .max(Slab::splat(0.0));
                let exit = (tx0.max(tx1).min(ty0.max(ty1)).min(tz0.max(tz1)) * far_scale)
                    .min(Slab::splat(t_max));
                // An empty slot's entry is +∞, which also "meets" an exit at
                // +∞ on an unbounded ray: finite entries only.
                let hit = entry.cmple(exit) & entry.cmplt(Slab::splat(f32::INFINITY));
                mask |= Slab::bits(hit) << g;
                near[g..g + Slab::WIDTH].copy_from_slice(&entry.to_array()[..Slab::WIDTH]);
            }
            // Leaves are tested at once, nearest first; hit nodes are sorted
            // nearest first.
            let mut nodes = [(0u32, 0f32); WIDTH];
            let mut n = 0;
            let mut leaves = [(0u32, 0u32, 0f32); WIDTH];
            let mut nl = 0;
            while mask != 0 {
                let i = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if node.count[i] > 0 {
                    let entry = (node.child[i], node.count[i], near[i]);
                    insert_by_distance(&mut leaves, &mut nl, entry, |e| e.2);
                } else {
                    let entry = (node.child[i], near[i]);
                    insert_by_distance(&mut nodes, &mut n, entry, |e| e.1);
                }
            }
            // Fetch the child nodes from memory while the leaves are tested
            // (on big meshes, waiting for nodes is most of a ray's time).
            for &(child, _) in &nodes[..n] {
                prefetch(&self.nodes[child as usize]);
            }
            for &(first, count, t_enter) in &leaves[..nl] {
                if t_enter > t_max {
                    continue;
                }
                let packets = &self.packets[first as usize..][..count.div_ceil(4) as usize];
                // Leaves of five to eight triangles (MAX_LEAF) as one test
                // of eight lanes where there is AVX2, two of four elsewhere.
                #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
                if let [p, q] = packets {
                    let lanes = (1u32 << count) - 1;
                    if let Some((lane, hit)) =
                        triangle4::intersect_pair(&shear8, p, q, lanes, t_max)
                    {
                        let prim = packets[lane / 4].prim(lane % 4);
                        if ANY_HIT {
                            return Some((prim, hit));
                        }
                        t_max = hit.t;
                        closest = Some((prim, hit));
                    }
                    continue;
                }
                let mut left = count;
                for packet in packets {
                    let lanes = (1u32 << left.min(4)) - 1;
                    left = left.saturating_sub(4);
                    if let Some((lane, hit)) = triangle4::intersect(&shear, packet, lanes, t_max) {
                        let prim = packet.prim(lane);
                        if ANY_HIT {
                            return Some((prim, hit));
                        }
                        t_max = hit.t;
                        closest = Some((prim, hit));
                    }
                }
            }
            // Go on with the nearest node; keep the others, farthest deepest.
            for k in (1..n).rev() {
                stack[top].write(nodes[k]);
                top += 1;
            }
            if n > 0 && nodes[0].1 <= t_max {
                current = nodes[0].0;
                continue;
            }
            loop {
                if top == 0 {
                    return closest;
                }
                top -= 1;
                // SAFETY: entries below `top` were all written above.
                let (node, t_enter) = unsafe { stack[top].assume_init() };
                if t_enter <= t_max {
                    current = node;
                    break;
                }
            }
        }
    }
}

/// Asks for every cache line of a node ahead of its use.
#[inline(always)]
fn prefetch(node: &WideNode) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let p = node as *const WideNode as *const i8;
        // Nodes are aligned to their 64-byte lines.
        for offset in (0..std::mem::size_of::<WideNode>()).step_by(64) {
            // SAFETY: a prefetch only hints the cache; the line is the node's.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.add(offset)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = node;
}

/// Inserts `entry` into the first `*len` entries of `list`, kept sorted
/// nearest first by `distance` (insertion sort: at most WIDTH).
#[inline]
fn insert_by_distance<T: Copy>(
    list: &mut [T; WIDTH],
    len: &mut usize,
    entry: T,
    distance: impl Fn(&T) -> f32,
) {
    let t = distance(&entry);
    let mut j = *len;
    while j > 0 && distance(&list[j - 1]) > t {
        list[j] = list[j - 1];
        j -= 1;
    }
    list[j] = entry;
    *len += 1;
}

mod build;

use build::{build_boxes, pack_leaves};

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::triangle;

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
    fn the_parallel_build_makes_the_serial_tree() {
        // Big enough for parallel subtrees, parallel binning and a binning
        // sample at the top (more than 4 · 65,536 primitives), and forks
        // that stop at different depths on one thread and on four.
        let tris = random_triangles(300_000, 3);
        let bounds: Vec<Aabb> = tris.iter().map(|t| Aabb::of_points(t)).collect();
        let build = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| build_boxes(bounds.len(), |i| bounds[i]))
        };
        let (a, _, order_a) = build(1);
        let (b, _, order_b) = build(4);
        assert_eq!(order_a, order_b);
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(&b) {
            assert_eq!((x.child, x.count), (y.child, y.count));
            assert_eq!(
                x.lo.map(|a| a.map(f32::to_bits)),
                y.lo.map(|a| a.map(f32::to_bits))
            );
            assert_eq!(
                x.hi.map(|a| a.map(f32::to_bits)),
                y.hi.map(|a| a.map(f32::to_bits))
            );
        }
    }

    #[test]
    fn closest_hit_and_occlusion_match_brute_force() {
        let tris = random_triangles(3000, 7);
        let (bvh, order) = Bvh::build(&tris);
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
            let got = bvh.intersect(&ray);
            match (brute, got) {
                (None, None) => {}
                (Some((i, h)), Some((p, g))) => {
                    assert_eq!(order[p as usize] as usize, i);
                    assert_eq!(h.t, g.t);
                }
                (b, g) => panic!("brute force {b:?} but BVH {g:?}"),
            }
            assert_eq!(bvh.occluded(&ray), brute.is_some());
        }
    }

    #[test]
    fn unbounded_rays_never_enter_empty_slots() {
        // Three triangles: the root has fewer than WIDTH children, and a ray
        // with a positive direction and no t_max must still terminate.
        let tris = [
            [Vec3::ZERO, Vec3::X, Vec3::Y],
            [
                Vec3::splat(5.0),
                Vec3::new(6.0, 5.0, 5.0),
                Vec3::new(5.0, 6.0, 5.0),
            ],
            [
                Vec3::splat(9.0),
                Vec3::new(10.0, 9.0, 9.0),
                Vec3::new(9.0, 10.0, 9.0),
            ],
        ];
        let (bvh, _) = Bvh::build(&tris);
        let ray = Ray::new(
            Vec3::new(-1.0, -1.0, -1.0),
            Vec3::new(1.0, 2.0, 3.0).normalize(),
        );
        assert!(ray.t_max.is_infinite());
        // It passes beside all three (at z = 0 it is at x = -2/3; at z = 5,
        // x = 1; at z = 9, x = 7/3): the traversal must end with no hit.
        let shear = RayShear::new(&ray);
        assert!(tris
            .iter()
            .all(|t| triangle::intersect(&shear, t, ray.t_max).is_none()));
        assert!(bvh.intersect(&ray).is_none());
        assert!(!bvh.occluded(&ray));
        let hit = bvh.intersect(&Ray::new(Vec3::new(5.2, 5.2, 4.0), Vec3::Z));
        assert!(hit.is_some());
        // Rays with a NaN (a camera far from the origin once normalised a
        // zero direction) hit nothing instead of looping over empty slots.
        for (o, d) in [
            (Vec3::new(5.2, 5.2, 4.0), Vec3::NAN),
            (Vec3::new(f32::NAN, 5.2, 4.0), Vec3::Z),
            (Vec3::new(5.2, 5.2, f32::INFINITY), Vec3::Z),
        ] {
            let ray = Ray {
                origin: o,
                dir: d,
                t_max: f32::INFINITY,
                in_free_space: false,
            };
            assert!(bvh.intersect(&ray).is_none());
            assert!(!bvh.occluded(&ray));
        }
    }

    #[test]
    fn empty_and_identical_primitives() {
        let (bvh, order) = Bvh::build(&[]);
        assert!(order.is_empty());
        assert!(bvh.intersect(&Ray::new(Vec3::ZERO, Vec3::X)).is_none());
        // Many triangles with the same centroid become one leaf, not a stack overflow.
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let tris = vec![t; 100];
        let (bvh, _) = Bvh::build(&tris);
        let ray = Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z);
        assert!(bvh.intersect(&ray).is_some());
    }
}
