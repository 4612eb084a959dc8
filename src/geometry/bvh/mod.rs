//! A bounding volume hierarchy over triangles: built top-down as a binary
//! tree with the binned surface area heuristic, then collapsed into an
//! 8-wide tree (each node holds its children's boxes side by side, four to
//! a SIMD slab test, and a ray visits a third as many levels as in the
//! binary tree: on big meshes a ray's time is mostly spent waiting for
//! nodes from memory, one level after another). Leaves keep their
//! triangles four to a packet, tested together (`triangle4`).

use glam::Vec3;

use super::huge_pages::HugeArray;
use super::triangle::TriangleHit;
use super::triangle4::Triangle4;
use super::{Aabb, Ray};

/// Children per node: a multiple of four (each four share SIMD slab tests).
const WIDTH: usize = 8;

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
    /// The tree outgrows the second-level cache: a single ray's walk asks
    /// for nodes and triangles ahead of their tests (`PREFETCH_ABOVE_BYTES`).
    prefetches: bool,
}

/// Trees bigger than this (nodes and packets) are prefetched by single
/// rays: a second-level cache's size. Below it the prefetches are
/// instructions that find the lines already there (5.2% more instructions
/// on the Cornell Box, whose tree is 1.5 KiB).
const PREFETCH_ABOVE_BYTES: usize = 1 << 20;

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
        let bounds_of = |i| Aabb::of_points(&triangle(i));
        let (mut nodes, mut bounds, mut order) = build_boxes(count, bounds_of, LeafCost::Packets);
        if packet::walks_packets(nodes.len()) {
            // Packets of rays will walk a tree this small, and they test a
            // leaf's triangles one by one, not four at a time: built again
            // for that, with smaller leaves (the Cornell Box's walls one to a
            // leaf, not two), while it stays small enough.
            let small = build_boxes(count, bounds_of, LeafCost::Triangles);
            if packet::walks_packets(small.0.len()) {
                (nodes, bounds, order) = small;
            }
        }
        let packets = pack_leaves(&mut nodes, |prim| triangle(order[prim] as usize));
        let mut bvh = Bvh {
            nodes: HugeArray::filled_in_parallel(nodes.len(), |i| nodes[i]),
            packets,
            bounds,
            prefetches: false,
        };
        bvh.prefetches = bvh.size_bytes() > PREFETCH_ABOVE_BYTES;
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

    /// `intersect` for every ray of `rays` (`hits[i]` answers `rays[i]`),
    /// their walks interleaved so that their waits for memory overlap:
    /// faster than one by one where the tree outgrows the caches, and the
    /// same hits, bit for bit.
    pub fn intersect_stream(&self, rays: &[Ray], hits: &mut [Option<(u32, TriangleHit)>]) {
        assert_eq!(rays.len(), hits.len(), "one answer per ray");
        self.traverse_stream::<false>(rays, |i, hit| hits[i] = hit);
    }

    /// `occluded` for every ray of `rays`, interleaved as `intersect_stream`.
    pub fn occluded_stream(&self, rays: &[Ray], occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len(), "one answer per ray");
        self.traverse_stream::<true>(rays, |i, hit| occluded[i] = hit.is_some());
    }
}

mod build;
mod leaf_cost;
mod packet;
pub use packet::{keep_packets_to_avx2, packet_width, MAX_PACKET_WIDTH};
mod traverse;

use build::{build_boxes, pack_leaves};
use leaf_cost::LeafCost;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::triangle::{self, RayShear};

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
                .install(|| build_boxes(bounds.len(), |i| bounds[i], LeafCost::Packets))
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

    /// The most triangles one leaf among `nodes` holds.
    fn largest_leaf(nodes: &[WideNode]) -> u32 {
        nodes.iter().flat_map(|n| n.count).max().unwrap_or(0)
    }

    /// A room of six walls and a lamp below its ceiling (14 triangles) is
    /// small enough for packets of rays, and is built for them: leaves of
    /// one wall, not two, and hits as brute force finds them, alone and in
    /// packets. A big mesh keeps the tree built for single rays.
    #[test]
    fn a_small_tree_is_built_for_packets() {
        let quad = |o: Vec3, a: Vec3, b: Vec3| [[o, o + a, o + a + b], [o, o + a + b, o + b]];
        let (x, y, z) = (Vec3::X * 10.0, Vec3::Y * 10.0, Vec3::Z * 10.0);
        let tris: Vec<[Vec3; 3]> = [
            quad(Vec3::ZERO, x, z),
            quad(y, z, x),
            quad(Vec3::ZERO, y, x),
            quad(z, x, y),
            quad(Vec3::ZERO, z, y),
            quad(x, y, z),
            quad(Vec3::new(4.0, 9.9, 4.0), Vec3::Z * 2.0, Vec3::X * 2.0),
        ]
        .concat();
        let (bvh, order) = Bvh::build(&tris);
        let single_ray_tree =
            build_boxes(tris.len(), |i| Aabb::of_points(&tris[i]), LeafCost::Packets).0;
        if packet::walks_packets(single_ray_tree.len()) {
            assert!(bvh.prefers_packets(), "{} nodes", bvh.node_count());
            assert!(
                largest_leaf(&bvh.nodes) <= 2,
                "a leaf of {}",
                largest_leaf(&bvh.nodes)
            );
            assert!(
                largest_leaf(&single_ray_tree) > 2,
                "the rebuild changes nothing here"
            );
        }
        let mut random = crate::test_random::XorShift64(17);
        let mut next = || random.next_f64() as f32;
        let mut hits_found = 0;
        for _ in 0..200 {
            let rays: Vec<Ray> = (0..16)
                .map(|_| {
                    let o = Vec3::new(next(), next(), next()) * 9.0 + Vec3::splat(0.5);
                    let d = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
                    Ray::new(o, d.normalize_or(Vec3::Y))
                })
                .collect();
            let mut packet = vec![None; rays.len()];
            bvh.intersect_packet(&rays, &mut packet);
            for (ray, in_packet) in rays.iter().zip(&packet) {
                let shear = RayShear::new(ray);
                let brute = tris
                    .iter()
                    .filter_map(|t| triangle::intersect(&shear, t, ray.t_max))
                    .map(|h| h.t)
                    .min_by(f32::total_cmp);
                let alone = bvh.intersect(ray);
                assert_eq!(alone.map(|(_, h)| h.t), brute);
                assert_eq!(in_packet.map(|(_, h)| h.t), brute);
                if let Some((p, h)) = alone {
                    let t =
                        triangle::intersect(&shear, &tris[order[p as usize] as usize], ray.t_max);
                    assert_eq!(t.map(|t| t.t), Some(h.t), "the hit names its triangle");
                    hits_found += 1;
                }
            }
        }
        // Every ray starts inside the closed room.
        assert_eq!(hits_found, 200 * 16);

        let big = random_triangles(3000, 7);
        let (bvh, _) = Bvh::build(&big);
        let single_ray_tree =
            build_boxes(big.len(), |i| Aabb::of_points(&big[i]), LeafCost::Packets).0;
        assert_eq!(bvh.node_count(), single_ray_tree.len());
    }

    #[test]
    fn a_stream_finds_each_rays_hit_bit_for_bit() {
        let tris = random_triangles(20_000, 11);
        let (bvh, _) = Bvh::build(&tris);
        let ends = random_triangles(3_000, 5);
        let mut rays: Vec<Ray> = ends
            .iter()
            .map(|r| {
                let mut ray = Ray::new(r[0] * 1.2 - 1.0, (r[1] - r[0] * 1.2 + 1.0).normalize());
                ray.t_max = 4.0 * r[2].x.fract() + 0.1;
                ray
            })
            .collect();
        // Rays that can meet nothing, among the others.
        rays[17].dir = Vec3::NAN;
        rays[2999].origin.x = f32::INFINITY;
        let mut hits = vec![None; rays.len()];
        bvh.intersect_stream(&rays, &mut hits);
        let mut occluded = vec![false; rays.len()];
        bvh.occluded_stream(&rays, &mut occluded);
        let bits = |h: Option<(u32, TriangleHit)>| {
            h.map(|(p, h)| (p, h.t.to_bits(), h.b.map(f32::to_bits)))
        };
        let mut met = 0;
        for (i, ray) in rays.iter().enumerate() {
            let one = bvh.intersect(ray);
            met += one.is_some() as usize;
            assert_eq!(bits(hits[i]), bits(one), "ray {i}");
            assert_eq!(occluded[i], bvh.occluded(ray), "ray {i}");
        }
        // Neither all nor none: the rays test both answers.
        assert!(met > 300 && met < 2700, "{met} of 3000 rays hit");
        // An empty tree answers every ray.
        let (empty, _) = Bvh::build(&[]);
        let mut hits = vec![Some((0, hits.iter().flatten().next().unwrap().1)); 5];
        empty.intersect_stream(&rays[..5], &mut hits);
        assert!(hits.iter().all(Option::is_none));
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
