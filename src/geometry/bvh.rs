//! A bounding volume hierarchy over triangles: built top-down as a binary
//! tree with the binned surface area heuristic, then collapsed into an
//! 8-wide tree (each node holds its children's boxes side by side, four to
//! a SIMD slab test, and a ray visits a third as many levels as in the
//! binary tree: on big meshes a ray's time is mostly spent waiting for
//! nodes from memory, one level after another). Leaves keep their
//! triangles four to a packet, tested together (`triangle4`).

use glam::{Vec3, Vec4};

use super::huge_pages::HugeArray;
use super::lanes::Lanes;
use super::triangle::{RayShear, TriangleHit};
use super::triangle4::{self, RayShear4, Triangle4};
use super::{gamma, Aabb, Ray};

/// A binary build node of 32 bytes (the collapse reads them): two SIMD vectors, the box corners in xyz
/// and the links in the w lanes (as bits). Interior: `count == 0`, the first
/// child follows the node, the second is at `offset`. Leaf: `count`
/// primitives from `offset`.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
struct Node {
    /// xyz: box minimum; w: `offset` as bits.
    min: Vec4,
    /// xyz: box maximum; w: `count` as bits.
    max: Vec4,
}

impl Node {
    fn new(bounds: &Aabb, offset: u32, count: u16) -> Self {
        Self {
            min: bounds.min.extend(f32::from_bits(offset)),
            max: bounds.max.extend(f32::from_bits(count as u32)),
        }
    }

    fn offset(&self) -> u32 {
        self.min.w.to_bits()
    }

    fn count(&self) -> u16 {
        self.max.w.to_bits() as u16
    }

    fn set_interior(&mut self, second_child: u32) {
        self.min.w = f32::from_bits(second_child);
        self.max.w = f32::from_bits(0);
    }
}

/// Children per node: a multiple of four (each four share SIMD slab tests).
const WIDTH: usize = 8;

/// The lanes a slab test runs on: all of a node's children at once with
/// AVX2, four at a time otherwise.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
type Slab = super::lanes::F32x8;
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
type Slab = Vec4;

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

/// Bins per axis in the SAH sweep.
const BINS: usize = 16;
/// Leaves never hold more than this many primitives unless they cannot be split.
const MAX_LEAF: usize = 8;
/// Cost of visiting a node relative to testing one packet of triangles.
const TRAVERSAL_COST: f32 = 1.0;
/// Subtrees of at least this many primitives build their halves in parallel.
const PARALLEL_MIN: usize = 16 * 1024;
/// Past this depth the build splits at the median, which bounds the tree's depth.
const SAH_MAX_DEPTH: usize = 40;
/// Traversal stack entries: up to WIDTH − 1 per wide level, and a wide
/// level per binary level at worst (SAH_MAX_DEPTH plus a median-split tree
/// over 2³² primitives).
const STACK_SIZE: usize = (WIDTH - 1) * 80;

#[derive(Clone, Copy)]
struct BuildPrim {
    bounds: Aabb,
    centroid: Vec3,
    index: u32,
}

impl Bvh {
    /// Builds over triangles. Returns the hierarchy and the order in which
    /// the caller must store the triangles: hits name them by that order.
    pub fn build(triangles: &[[Vec3; 3]]) -> (Bvh, Vec<u32>) {
        let bounds: Vec<Aabb> = triangles.iter().map(|t| Aabb::of_points(t)).collect();
        let (mut nodes, bounds, order) = build_boxes(&bounds);
        let packets = pack_leaves(&mut nodes, |prim| triangles[order[prim] as usize]);
        let bvh = Bvh {
            nodes: HugeArray::from_vec(nodes),
            packets: HugeArray::from_vec(packets),
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

/// The wide tree over primitive bounds, its bounds, and the order of the
/// primitives that its leaves' ranges index (not yet packets).
fn build_boxes(bounds: &[Aabb]) -> (Vec<WideNode>, Aabb, Vec<u32>) {
    let mut prims: Vec<BuildPrim> = bounds
        .iter()
        .enumerate()
        .map(|(i, b)| BuildPrim {
            bounds: *b,
            centroid: b.centroid(),
            index: i as u32,
        })
        .collect();
    if prims.is_empty() {
        return (Vec::new(), Aabb::EMPTY, Vec::new());
    }
    let mut binary = Vec::with_capacity(2 * bounds.len());
    build_range(&mut prims, 0, 0, &mut binary);
    let order = prims.iter().map(|p| p.index).collect();
    let mut nodes = Vec::with_capacity(binary.len() / 3 + 1);
    collapse(&binary, 0, &mut nodes);
    let root = &binary[0];
    let bounds = Aabb {
        min: root.min.truncate(),
        max: root.max.truncate(),
    };
    (nodes, bounds, order)
}

/// Copies each leaf's triangles (`triangle(i)`: the i-th in build order)
/// into packets of four and points the leaf at its first packet.
fn pack_leaves(nodes: &mut [WideNode], triangle: impl Fn(usize) -> [Vec3; 3]) -> Vec<Triangle4> {
    let mut packets = Vec::new();
    for node in nodes {
        for slot in 0..WIDTH {
            let count = node.count[slot] as usize;
            if count == 0 {
                continue;
            }
            let first = node.child[slot] as usize;
            node.child[slot] = packets.len() as u32;
            for start in (first..first + count).step_by(4) {
                let n = (first + count - start).min(4);
                let mut tris = [[Vec3::ZERO; 3]; 4];
                for (k, t) in tris[..n].iter_mut().enumerate() {
                    *t = triangle(start + k);
                }
                packets.push(Triangle4::new(&tris[..n], start as u32));
            }
        }
    }
    packets
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

/// Turns the binary subtree at `index` into wide nodes; returns the index
/// of the wide node made for it. Each wide node takes the binary node's
/// descendants down to WIDTH of them, opening the largest surface first.
fn collapse(binary: &[Node], index: usize, wide: &mut Vec<WideNode>) -> u32 {
    let children = |i: usize| -> [usize; 2] { [i + 1, binary[i].offset() as usize] };
    let is_leaf = |i: usize| binary[i].count() > 0;
    let area = |i: usize| {
        Aabb {
            min: binary[i].min.truncate(),
            max: binary[i].max.truncate(),
        }
        .surface_area()
    };
    let mut slots: Vec<usize> = if is_leaf(index) {
        vec![index]
    } else {
        children(index).to_vec()
    };
    while slots.len() < WIDTH {
        let open = slots
            .iter()
            .enumerate()
            .filter(|(_, &c)| !is_leaf(c))
            .max_by(|a, b| area(*a.1).total_cmp(&area(*b.1)))
            .map(|(k, _)| k);
        let Some(k) = open else { break };
        let c = slots.swap_remove(k);
        slots.extend(children(c));
    }
    let me = wide.len();
    wide.push(WideNode {
        lo: [[f32::INFINITY; WIDTH]; 3],
        hi: [[f32::INFINITY; WIDTH]; 3],
        child: [0; WIDTH],
        count: [0; WIDTH],
    });
    for (k, &c) in slots.iter().enumerate() {
        let n = &binary[c];
        let (child, count) = if is_leaf(c) {
            (n.offset(), n.count() as u32)
        } else {
            (collapse(binary, c, wide), 0)
        };
        let node = &mut wide[me];
        for axis in 0..3 {
            node.lo[axis][k] = n.min[axis];
            node.hi[axis][k] = n.max[axis];
        }
        node.child[k] = child;
        node.count[k] = count;
    }
    me as u32
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
    nodes.push(Node::new(&bounds, first as u32, prims.len() as u16));
    let n = prims.len();
    let extent = centroids.diagonal();
    let axis = largest_axis(extent);
    if (n <= 4 || extent[axis] <= 0.0) && n <= u16::MAX as usize {
        // Leaf: one packet (which the SAH never splits) or nothing to split
        // (identical centroids).
        return index;
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

    let (left, right) = prims.split_at_mut(mid);
    if n < PARALLEL_MIN {
        build_range(left, first, depth + 1, nodes);
        let second = build_range(right, first + mid, depth + 1, nodes);
        nodes[index].set_interior(second as u32);
        return index;
    }
    // Big subtrees build on two threads into lists of their own, appended
    // in the order the serial build makes: the same tree either way.
    let subtree = |prims: &mut [BuildPrim], first: usize| {
        let mut own = Vec::with_capacity(2 * prims.len());
        build_range(prims, first, depth + 1, &mut own);
        own
    };
    let (l, r) = rayon::join(|| subtree(left, first), || subtree(right, first + mid));
    append_shifted(nodes, l);
    let second = nodes.len();
    append_shifted(nodes, r);
    nodes[index].set_interior(second as u32);
    index
}

/// Appends a subtree built in a list of its own: its interior nodes' links
/// move by where it lands (leaves' primitive offsets are absolute already).
fn append_shifted(nodes: &mut Vec<Node>, subtree: Vec<Node>) {
    let base = nodes.len() as u32;
    nodes.extend(subtree.into_iter().map(|mut node| {
        if node.count() == 0 {
            node.set_interior(node.offset() + base);
        }
        node
    }));
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

/// Primitive counts and bounds per bin, for each axis.
#[derive(Clone, Copy)]
struct Bins {
    bounds: [[Aabb; BINS]; 3],
    count: [[usize; BINS]; 3],
}

impl Bins {
    const EMPTY: Bins = Bins {
        bounds: [[Aabb::EMPTY; BINS]; 3],
        count: [[0; BINS]; 3],
    };

    /// Bins `prims` on all three axes in one pass over them.
    fn of(prims: &[BuildPrim], binner: &Binner) -> Bins {
        let mut bins = Bins::EMPTY;
        for p in prims {
            for (axis, b) in binner.bins(p).into_iter().enumerate() {
                bins.bounds[axis][b] = bins.bounds[axis][b].union(p.bounds);
                bins.count[axis][b] += 1;
            }
        }
        bins
    }

    fn merge(mut self, other: Bins) -> Bins {
        for axis in 0..3 {
            for b in 0..BINS {
                self.bounds[axis][b] = self.bounds[axis][b].union(other.bounds[axis][b]);
                self.count[axis][b] += other.count[axis][b];
            }
        }
        self
    }
}

/// Maps centroids to bins on each axis (bin 0 on a flat axis).
struct Binner {
    lo: Vec3,
    scale: Vec3,
}

impl Binner {
    fn new(centroids: &Aabb) -> Self {
        let ext = centroids.diagonal();
        let scale = Vec3::select(
            ext.cmpgt(Vec3::ZERO),
            Vec3::splat(BINS as f32) / ext,
            Vec3::ZERO,
        );
        Self {
            lo: centroids.min,
            scale,
        }
    }

    #[inline]
    fn bins(&self, p: &BuildPrim) -> [usize; 3] {
        let b = ((p.centroid - self.lo) * self.scale).to_array();
        b.map(|x| (x as usize).min(BINS - 1))
    }

    /// The bin along one axis (as `bins` gives it).
    #[inline]
    fn bin(&self, p: &BuildPrim, axis: usize) -> usize {
        (((p.centroid[axis] - self.lo[axis]) * self.scale[axis]) as usize).min(BINS - 1)
    }
}

/// Binned SAH over all three axes. Partitions `prims` and returns the split
/// point, or None when keeping a leaf is cheaper (or nothing separates).
fn sah_split(prims: &mut [BuildPrim], bounds: &Aabb, centroids: &Aabb) -> Option<usize> {
    use rayon::prelude::*;
    let n = prims.len();
    let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, bins on the left)
    let binner = Binner::new(centroids);
    let bins = if n >= 4 * PARALLEL_MIN {
        prims
            .par_chunks(PARALLEL_MIN)
            .map(|chunk| Bins::of(chunk, &binner))
            .reduce(|| Bins::EMPTY, Bins::merge)
    } else {
        Bins::of(prims, &binner)
    };
    for axis in 0..3 {
        if centroids.max[axis] <= centroids.min[axis] {
            continue;
        }
        let (bin_bounds, bin_count) = (&bins.bounds[axis], &bins.count[axis]);
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
                packets(cnt) * acc.surface_area() + packets(right_count[i + 1]) * right_area[i + 1];
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, i + 1));
            }
        }
    }
    let (cost, axis, left_bins) = best?;
    let area = bounds.surface_area();
    let split_cost = TRAVERSAL_COST + if area > 0.0 { cost / area } else { packets(n) };
    if n <= MAX_LEAF && split_cost >= packets(n) {
        return None;
    }
    let mut mid = 0;
    for i in 0..n {
        if binner.bin(&prims[i], axis) < left_bins {
            prims.swap(i, mid);
            mid += 1;
        }
    }
    (mid > 0 && mid < n).then_some(mid)
}

/// The packets of four that `n` triangles fill: what testing a leaf costs.
fn packets(n: usize) -> f32 {
    n.div_ceil(4) as f32
}

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
        // Big enough for parallel subtrees and parallel binning at the top.
        let tris = random_triangles(100_000, 3);
        let bounds: Vec<Aabb> = tris.iter().map(|t| Aabb::of_points(t)).collect();
        let build = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| build_boxes(&bounds))
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
