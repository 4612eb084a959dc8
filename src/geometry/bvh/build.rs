//! Building the BVH: binned SAH splits of a binary tree (in parallel for
//! large subtrees), collapsed into 8-wide nodes, leaves packed into
//! packets of four triangles.

use glam::{Vec3, Vec4};

use super::{WideNode, WIDTH};
use crate::geometry::triangle4::Triangle4;
use crate::geometry::Aabb;

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
#[derive(Clone, Copy)]
struct BuildPrim {
    bounds: Aabb,
    centroid: Vec3,
    index: u32,
}

/// The wide tree over primitive bounds, its bounds, and the order of the
/// primitives that its leaves' ranges index (not yet packets).
pub(super) fn build_boxes(bounds: &[Aabb]) -> (Vec<WideNode>, Aabb, Vec<u32>) {
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
    // Grown as built, not reserved for the worst case (2N − 1 nodes; a
    // tree of SAH leaves has a fraction of that): reserved address space
    // counts against `ulimit -v` though it is never touched.
    let mut binary = Vec::new();
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
pub(super) fn pack_leaves(
    nodes: &mut [WideNode],
    triangle: impl Fn(usize) -> [Vec3; 3],
) -> Vec<Triangle4> {
    // Exactly the packets there will be: a vector that grows by doubling
    // reserves address space it never uses (which `ulimit -v` counts).
    let packets_needed: usize = nodes
        .iter()
        .flat_map(|n| n.count)
        .map(|c| (c as usize).div_ceil(4))
        .sum();
    let mut packets = Vec::with_capacity(packets_needed);
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
        let mut own = Vec::new();
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
