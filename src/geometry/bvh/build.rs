//! Building the BVH: binned SAH splits of a binary tree (in parallel for
//! large subtrees), collapsed into 8-wide nodes, leaves packed into
//! packets of four triangles.

use glam::{Vec3, Vec4};

use super::leaf_cost::LeafCost;
use super::{WideNode, WIDTH};
use crate::geometry::huge_pages::HugeArray;
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
    fn new(bounds: &Box4, offset: u32, count: u16) -> Self {
        Self {
            min: bounds.min.truncate().extend(f32::from_bits(offset)),
            max: bounds.max.truncate().extend(f32::from_bits(count as u32)),
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

/// Bins per axis in the SAH sweep, at most.
const BINS: usize = 16;
/// Bins per axis at least (nodes of few primitives have fewer bins: most
/// nodes are small, and there the sweeps over the bins cost more than
/// binning the primitives).
const MIN_BINS: usize = 4;
/// Leaves never hold more than this many primitives unless they cannot be split.
const MAX_LEAF: usize = 8;
/// Cost of visiting a node relative to testing one packet of triangles.
const TRAVERSAL_COST: f32 = 1.0;
/// Subtrees of at least this many primitives build their halves in parallel.
const PARALLEL_MIN: usize = 16 * 1024;
/// Past this depth the build splits at the median, which bounds the tree's depth.
const SAH_MAX_DEPTH: usize = 40;
/// Above this many primitives, a node's bins see a sample this big.
const BINNING_SAMPLE: usize = 1 << 16;

/// A box as two SIMD vectors (xyz; the w lanes are not part of it), so
/// that a union is two instructions.
#[derive(Clone, Copy)]
struct Box4 {
    min: Vec4,
    max: Vec4,
}

impl Box4 {
    const EMPTY: Box4 = Box4 {
        min: Vec4::splat(f32::INFINITY),
        max: Vec4::splat(f32::NEG_INFINITY),
    };

    #[inline]
    fn union(self, other: Box4) -> Box4 {
        Box4 {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    #[inline]
    fn grow(self, p: Vec4) -> Box4 {
        Box4 {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    fn aabb(&self) -> Aabb {
        Aabb {
            min: self.min.truncate(),
            max: self.max.truncate(),
        }
    }

    fn diagonal(&self) -> Vec3 {
        self.aabb().diagonal()
    }

    fn surface_area(&self) -> f32 {
        self.aabb().surface_area()
    }
}

/// A primitive as the build sees it: its box, and its index in the w lane
/// of `bounds.min` (as bits). 32 bytes.
#[derive(Clone, Copy)]
struct BuildPrim {
    bounds: Box4,
}

impl BuildPrim {
    fn new(bounds: Aabb, index: u32) -> Self {
        Self {
            bounds: Box4 {
                min: bounds.min.extend(f32::from_bits(index)),
                max: bounds.max.extend(0.0),
            },
        }
    }

    fn index(&self) -> u32 {
        self.bounds.min.w.to_bits()
    }

    /// Twice the box's centre (in xyz): binning compares centres, which
    /// the doubling leaves in the same bins, exactly.
    #[inline]
    fn centroid2(&self) -> Vec4 {
        self.bounds.min + self.bounds.max
    }
}

/// The wide tree over the bounds of `count` primitives (`bounds(i)`), its
/// bounds, and the order of the primitives that its leaves' ranges index
/// (not yet packets).
pub(super) fn build_boxes(
    count: usize,
    bounds: impl Fn(usize) -> Aabb + Sync,
    leaf_cost: LeafCost,
) -> (Vec<WideNode>, Aabb, Vec<u32>) {
    use rayon::prelude::*;
    // In parallel: on big meshes the first touch of these pages (the
    // kernel zeroing them) costs as much as the arithmetic.
    let mut prims: Vec<BuildPrim> = (0..count)
        .into_par_iter()
        .map(|i| BuildPrim::new(bounds(i), i as u32))
        .collect();
    if prims.is_empty() {
        return (Vec::new(), Aabb::EMPTY, Vec::new());
    }
    // Grown as built, not reserved for the worst case (2N − 1 nodes; a
    // tree of SAH leaves has a fraction of that): reserved address space
    // counts against `ulimit -v` though it is never touched.
    let mut binary = Vec::new();
    let boxes = bounds_of(&prims);
    build_range(&mut prims, boxes, 0, 0, leaf_cost, &mut binary);
    let order = prims.par_iter().map(BuildPrim::index).collect();
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
    triangle: impl Fn(usize) -> [Vec3; 3] + Sync,
) -> HugeArray<Triangle4> {
    // Where each packet's triangles start, and how many it holds; the
    // leaves point at their first packets.
    let mut packet_starts: Vec<(u32, u8)> = Vec::new();
    for node in nodes {
        for slot in 0..WIDTH {
            let count = node.count[slot] as usize;
            if count == 0 {
                continue;
            }
            let first = node.child[slot] as usize;
            node.child[slot] = packet_starts.len() as u32;
            for start in (first..first + count).step_by(4) {
                packet_starts.push((start as u32, (first + count - start).min(4) as u8));
            }
        }
    }
    // Filled on every thread, where they will stay: on big meshes the
    // first touch of the pages costs as much as the copying.
    HugeArray::filled_in_parallel(packet_starts.len(), |i| {
        let (start, n) = (packet_starts[i].0 as usize, packet_starts[i].1 as usize);
        let mut tris = [[Vec3::ZERO; 3]; 4];
        for (k, t) in tris[..n].iter_mut().enumerate() {
            *t = triangle(start + k);
        }
        Triangle4::new(&tris[..n], start as u32)
    })
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

/// Builds the binary subtree over `prims` (whose box and centres' box are
/// `boxes`) into `nodes`; returns its root's index.
fn build_range(
    prims: &mut [BuildPrim],
    boxes: (Box4, Box4),
    first: usize,
    depth: usize,
    leaf_cost: LeafCost,
    nodes: &mut Vec<Node>,
) -> usize {
    let (bounds, centroids) = boxes;
    let index = nodes.len();
    nodes.push(Node::new(&bounds, first as u32, prims.len() as u16));
    let n = prims.len();
    let extent = centroids.diagonal();
    let axis = largest_axis(extent);
    if (n <= leaf_cost.never_split() || extent[axis] <= 0.0) && n <= u16::MAX as usize {
        // Leaf: one that the SAH would never split, or nothing to split
        // (identical centroids).
        return index;
    }

    let split = if depth < SAH_MAX_DEPTH && extent[axis] > 0.0 {
        match sah_split(prims, &bounds, &centroids, leaf_cost) {
            Some(split) => split,
            None if n <= MAX_LEAF => return index,
            None => median_split(prims, axis),
        }
    } else {
        median_split(prims, axis)
    };
    let Split {
        mid,
        left: left_boxes,
        right: right_boxes,
    } = split;

    let (left, right) = prims.split_at_mut(mid);
    // Big subtrees near the root build on two threads: the left one into
    // `nodes`, the right one into a list of its own appended after it, in
    // the order the serial build makes (the same tree either way). Forks
    // stop a few levels below one per thread: each one copies its right
    // subtree's nodes once more, into pages touched for the first time.
    if n < PARALLEL_MIN || depth >= rayon::current_num_threads().ilog2() as usize + 3 {
        build_range(left, left_boxes, first, depth + 1, leaf_cost, nodes);
        let second = build_range(right, right_boxes, first + mid, depth + 1, leaf_cost, nodes);
        nodes[index].set_interior(second as u32);
        return index;
    }
    let right_subtree = || {
        let mut own = Vec::new();
        build_range(
            right,
            right_boxes,
            first + mid,
            depth + 1,
            leaf_cost,
            &mut own,
        );
        own
    };
    let (_, r) = rayon::join(
        || build_range(left, left_boxes, first, depth + 1, leaf_cost, nodes),
        right_subtree,
    );
    let second = nodes.len();
    append_shifted(nodes, r);
    nodes[index].set_interior(second as u32);
    index
}

/// Where a node's primitives were divided, and each side's box and box
/// of (doubled) centres.
struct Split {
    mid: usize,
    left: (Box4, Box4),
    right: (Box4, Box4),
}

/// The box around `prims` and the box around their (doubled) centres, in
/// one pass over them (the build is bound by reading memory), on every
/// thread where there are many.
fn bounds_of(prims: &[BuildPrim]) -> (Box4, Box4) {
    use rayon::prelude::*;
    let fold = |prims: &[BuildPrim]| prims.iter().fold(NO_BOXES, with_prim);
    if prims.len() < 4 * PARALLEL_MIN {
        return fold(prims);
    }
    prims
        .par_chunks(PARALLEL_MIN)
        .map(fold)
        .reduce(|| NO_BOXES, |a, b| (a.0.union(b.0), a.1.union(b.1)))
}

/// The box and centre box of no primitives.
const NO_BOXES: (Box4, Box4) = (Box4::EMPTY, Box4::EMPTY);

/// `boxes` (a box and a box of doubled centres) grown by `p`.
#[inline]
fn with_prim((bounds, centroids): (Box4, Box4), p: &BuildPrim) -> (Box4, Box4) {
    (bounds.union(p.bounds), centroids.grow(p.centroid2()))
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

fn median_split(prims: &mut [BuildPrim], axis: usize) -> Split {
    let mid = prims.len() / 2;
    prims.select_nth_unstable_by(mid, |a, b| {
        a.centroid2()[axis].total_cmp(&b.centroid2()[axis])
    });
    Split {
        mid,
        left: bounds_of(&prims[..mid]),
        right: bounds_of(&prims[mid..]),
    }
}

/// Primitive counts and bounds per bin, for each axis.
#[derive(Clone, Copy)]
struct Bins {
    bounds: [[Box4; BINS]; 3],
    count: [[usize; BINS]; 3],
}

impl Bins {
    const EMPTY: Bins = Bins {
        bounds: [[Box4::EMPTY; BINS]; 3],
        count: [[0; BINS]; 3],
    };

    /// Bins `prims` on all three axes in one pass over them.
    fn of<'p>(prims: impl Iterator<Item = &'p BuildPrim>, binner: &Binner) -> Bins {
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

/// Maps centroids (doubled, as `BuildPrim::centroid2`) to bins on each
/// axis (bin 0 on a flat axis).
struct Binner {
    lo: Vec4,
    scale: Vec4,
    /// Bins per axis (up to BINS).
    count: usize,
}

impl Binner {
    /// For `n` primitives whose doubled centres lie in `centroids`: a bin
    /// for every four of them, MIN_BINS to BINS.
    fn new(centroids: &Box4, n: usize) -> Self {
        let count = (n / 4).clamp(MIN_BINS, BINS);
        let ext = centroids.diagonal();
        let scale = Vec3::select(
            ext.cmpgt(Vec3::ZERO),
            Vec3::splat(count as f32) / ext,
            Vec3::ZERO,
        );
        Self {
            lo: centroids.min,
            scale: scale.extend(0.0),
            count,
        }
    }

    #[inline]
    fn bins(&self, p: &BuildPrim) -> [usize; 3] {
        let b = ((p.centroid2() - self.lo) * self.scale).to_array();
        [b[0], b[1], b[2]].map(|x| (x as usize).min(self.count - 1))
    }

    /// The bin along one axis (as `bins` gives it).
    #[inline]
    fn bin(&self, p: &BuildPrim, axis: usize) -> usize {
        (((p.centroid2()[axis] - self.lo[axis]) * self.scale[axis]) as usize).min(self.count - 1)
    }
}

/// Binned SAH over all three axes. Partitions `prims` and returns the split
/// point, or None when keeping a leaf is cheaper (or nothing separates).
fn sah_split(
    prims: &mut [BuildPrim],
    bounds: &Box4,
    centroids: &Box4,
    leaf_cost: LeafCost,
) -> Option<Split> {
    use rayon::prelude::*;
    let n = prims.len();
    let mut best: Option<(f32, usize, usize)> = None; // (cost, axis, bins on the left)
    let binner = Binner::new(centroids, n);
    let bins_used = binner.count;
    let bins = if n >= 4 * PARALLEL_MIN {
        // The bins see every k-th primitive, BINNING_SAMPLE of them or
        // more: the build spends most of its time reading memory, and a
        // sample that big puts the cheapest plane within a bin of where
        // all of them would.
        let stride = (n / BINNING_SAMPLE).max(1);
        prims
            .par_chunks(PARALLEL_MIN * stride)
            .map(|chunk| Bins::of(chunk.iter().step_by(stride), &binner))
            .reduce(|| Bins::EMPTY, Bins::merge)
    } else {
        Bins::of(prims.iter(), &binner)
    };
    for axis in 0..3 {
        if centroids.max[axis] <= centroids.min[axis] {
            continue;
        }
        let (bin_bounds, bin_count) = (&bins.bounds[axis], &bins.count[axis]);
        // Sweep from the right to get suffix areas, then from the left.
        let mut right_area = [0.0f32; BINS];
        let mut right_count = [0usize; BINS];
        let (mut acc, mut cnt) = (Box4::EMPTY, 0);
        for i in (1..bins_used).rev() {
            acc = acc.union(bin_bounds[i]);
            cnt += bin_count[i];
            right_area[i] = acc.surface_area();
            right_count[i] = cnt;
        }
        let (mut acc, mut cnt) = (Box4::EMPTY, 0);
        for i in 0..bins_used - 1 {
            acc = acc.union(bin_bounds[i]);
            cnt += bin_count[i];
            if cnt == 0 || right_count[i + 1] == 0 {
                continue;
            }
            let cost = leaf_cost.of(cnt) * acc.surface_area()
                + leaf_cost.of(right_count[i + 1]) * right_area[i + 1];
            if best.is_none_or(|b| cost < b.0) {
                best = Some((cost, axis, i + 1));
            }
        }
    }
    let (cost, axis, left_bins) = best?;
    let area = bounds.surface_area();
    let split_cost = TRAVERSAL_COST
        + if area > 0.0 {
            cost / area
        } else {
            leaf_cost.of(n)
        };
    if n <= MAX_LEAF && split_cost >= leaf_cost.of(n) {
        return None;
    }
    let split = partition(prims, |p| binner.bin(p, axis) < left_bins);
    (split.mid > 0 && split.mid < n).then_some(split)
}

/// Moves the primitives `on_left` accepts before the others, growing each
/// side's boxes as it goes: the children need no pass of their own to
/// find them (the build spends most of its time reading primitives).
fn partition(prims: &mut [BuildPrim], on_left: impl Fn(&BuildPrim) -> bool) -> Split {
    let (mut left, mut right) = (NO_BOXES, NO_BOXES);
    // Hoare's scheme: from both ends, each misplaced pair swapped once.
    let (mut l, mut r) = (0, prims.len());
    loop {
        while l < r && on_left(&prims[l]) {
            left = with_prim(left, &prims[l]);
            l += 1;
        }
        while l < r && !on_left(&prims[r - 1]) {
            right = with_prim(right, &prims[r - 1]);
            r -= 1;
        }
        if l >= r {
            break;
        }
        prims.swap(l, r - 1);
        left = with_prim(left, &prims[l]);
        right = with_prim(right, &prims[r - 1]);
        l += 1;
        r -= 1;
    }
    Split {
        mid: l,
        left,
        right,
    }
}
