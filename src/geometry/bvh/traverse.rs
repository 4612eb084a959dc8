//! Walking the wide tree: one ray at a time, or a stream of rays whose
//! walks take turns, node by node. On a big mesh a ray spends most of its
//! time waiting for nodes and triangles to arrive from memory; a stream
//! asks for each ray's next node and leaves and visits the other rays'
//! meanwhile, so several waits overlap. Both make the same tests in the
//! same order and find the same hits, bit for bit. The single ray keeps
//! its state in locals rather than in a paused `Walk`: as a loop over
//! `Walk` turns it took 3% more instructions on the Cornell Box, whose
//! tree fits in the first-level cache.

use std::mem::MaybeUninit;

use super::{Bvh, WideNode, WIDTH};
use crate::geometry::lanes::Lanes;
use crate::geometry::triangle::{RayShear, TriangleHit};
use crate::geometry::triangle4::{self, RayShear4, Triangle4};
use crate::geometry::{gamma, Ray};

/// The lanes a slab test runs on: all of a node's children at once with
/// AVX2, four at a time otherwise.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
type Slab = crate::geometry::lanes::F32x8;
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
type Slab = glam::Vec4;

/// Traversal stack entries: up to WIDTH − 1 per wide level, and a wide
/// level per binary level at worst (SAH_MAX_DEPTH plus a median-split tree
/// over 2³² primitives).
const STACK_SIZE: usize = (WIDTH - 1) * 80;

/// Rays whose walks a stream interleaves: enough for their node loads to
/// cover one another's waits, few enough that their stacks' tops stay in
/// the first-level cache.
const IN_FLIGHT: usize = 8;

/// One ray's walk, paused between node visits.
struct Walk {
    ray: RayLanes,
    t_max: f32,
    closest: Option<(u32, TriangleHit)>,
    /// The node to visit next.
    current: u32,
    /// Interior nodes still to visit, with their entry distances. Left
    /// uninitialised: zeroing 2 KB per ray cost 5% of a Cornell render.
    stack: [MaybeUninit<(u32, f32)>; STACK_SIZE],
    top: usize,
    /// Leaves of the last node visited, to test on the walk's next turn.
    leaves: [Leaf; WIDTH],
    leaf_count: usize,
}

/// A leaf to test: its first packet, its triangle count, and where the ray
/// enters its box.
type Leaf = (u32, u32, f32);

impl Walk {
    /// A walk that has not started (every field set, the stack left
    /// uninitialised).
    #[inline(always)]
    fn idle() -> Walk {
        Walk {
            ray: RayLanes::new(&Ray::new(glam::Vec3::ZERO, glam::Vec3::Z)),
            t_max: 0.0,
            closest: None,
            current: 0,
            stack: [const { MaybeUninit::uninit() }; STACK_SIZE],
            top: 0,
            leaves: [(0, 0, 0.0); WIDTH],
            leaf_count: 0,
        }
    }

    /// Starts the walk of `ray` (which `Bvh::may_meet`) from the root, in
    /// place: a walk is kilobytes, and moving one would copy its stack.
    #[inline(always)]
    fn start(&mut self, ray: &Ray) {
        self.ray = RayLanes::new(ray);
        self.t_max = ray.t_max;
        self.closest = None;
        self.current = 0;
        self.top = 0;
        self.leaf_count = 0;
    }

    /// Keeps `nodes` (nearest first) to visit later, the farthest deepest.
    #[inline(always)]
    fn push(&mut self, nodes: &[(u32, f32)]) {
        for &node in nodes.iter().rev() {
            self.stack[self.top].write(node);
            self.top += 1;
        }
    }

    /// Takes the nearest node left that the closest hit so far does not
    /// lie before; false when none is left.
    #[inline(always)]
    fn pop(&mut self) -> bool {
        while self.top > 0 {
            self.top -= 1;
            // SAFETY: entries below `top` were all written by `push`.
            let (node, t_enter) = unsafe { self.stack[self.top].assume_init() };
            if t_enter <= self.t_max {
                self.current = node;
                return true;
            }
        }
        false
    }
}

impl Bvh {
    /// Visits nodes front to back (children sorted by entry distance).
    /// With `ANY_HIT` it stops at the first hit.
    #[inline]
    pub(super) fn traverse<const ANY_HIT: bool>(&self, ray: &Ray) -> Option<(u32, TriangleHit)> {
        if !self.may_meet(ray) {
            return None;
        }
        let lanes = RayLanes::new(ray);
        let mut t_max = ray.t_max;
        let mut closest = None;
        // Interior nodes still to visit, with their entry distances. Left
        // uninitialised: zeroing 2 KB per ray cost 5% of a Cornell render.
        let mut stack = [const { std::mem::MaybeUninit::<(u32, f32)>::uninit() }; STACK_SIZE];
        let mut top = 0usize;
        let mut current = 0u32;
        loop {
            let node = &self.nodes[current as usize];
            let (mask, near) = slab_test(node, &lanes, t_max);
            // Leaves are tested at once, nearest first; hit nodes are sorted
            // nearest first.
            let (mut nodes, mut n) = ([(0u32, 0f32); WIDTH], 0);
            let (mut leaves, mut nl) = ([(0u32, 0u32, 0f32); WIDTH], 0);
            sort_children(
                node,
                mask,
                &near,
                (&mut nodes, &mut n),
                (&mut leaves, &mut nl),
            );
            // On a big tree, ask for every hit leaf's triangles at once, so
            // that their waits overlap rather than come one leaf after
            // another, then for the child nodes, which arrive while the
            // leaves are tested (waiting for memory is most of such a ray's
            // time: coherent rays +4%, incoherent +3% on a 1M-triangle mesh).
            if self.prefetches {
                self.prefetch(&leaves[..nl], &nodes[..n]);
            }
            for &(first, count, t_enter) in &leaves[..nl] {
                if t_enter > t_max {
                    continue;
                }
                if let Some((prim, hit)) = self.test_leaf(&lanes, first, count, t_max) {
                    if ANY_HIT {
                        return Some((prim, hit));
                    }
                    t_max = hit.t;
                    closest = Some((prim, hit));
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

    /// `traverse` for every ray of `rays`, `IN_FLIGHT` walks taking turns
    /// node by node; `done(i, hit)` receives ray i's answer, in the order
    /// the walks end.
    pub(super) fn traverse_stream<const ANY_HIT: bool>(
        &self,
        rays: &[Ray],
        mut done: impl FnMut(usize, Option<(u32, TriangleHit)>),
    ) {
        // Each walk made in place: `array::from_fn` built the array (its
        // stacks are kilobytes) and then copied it, 41% more instructions
        // on a streamed render of a 1.8 MiB tree.
        let mut slots = [const { MaybeUninit::<Walk>::uninit() }; IN_FLIGHT];
        for slot in &mut slots {
            slot.write(Walk::idle());
        }
        // SAFETY: every slot was written just above.
        let walks = unsafe { &mut *slots.as_mut_ptr().cast::<[Walk; IN_FLIGHT]>() };
        let mut next = 0;
        // The ray each walk follows; None once no ray is left for it.
        let mut following: [Option<usize>; IN_FLIGHT] =
            std::array::from_fn(|k| self.start_next(&mut walks[k], rays, &mut next, &mut done));
        while following.iter().any(Option::is_some) {
            for (walk, ray) in walks.iter_mut().zip(&mut following) {
                let Some(i) = *ray else { continue };
                if !self.step::<ANY_HIT>(walk) {
                    done(i, walk.closest);
                    *ray = self.start_next(walk, rays, &mut next, &mut done);
                }
            }
        }
    }

    /// Starts `walk` on the first ray from `rays[*next]` on that may meet
    /// something, answering those before it that cannot; that ray's
    /// index, or None when no ray is left.
    fn start_next(
        &self,
        walk: &mut Walk,
        rays: &[Ray],
        next: &mut usize,
        done: &mut impl FnMut(usize, Option<(u32, TriangleHit)>),
    ) -> Option<usize> {
        while let Some(ray) = rays.get(*next) {
            *next += 1;
            if self.may_meet(ray) {
                walk.start(ray);
                return Some(*next - 1);
            }
            done(*next - 1, None);
        }
        None
    }

    /// False for a ray that can meet nothing: the tree is empty, or the
    /// ray has a NaN, which would pass every slab test (SIMD min/max drop
    /// NaN operands), empty slots included, and never end.
    #[inline(always)]
    fn may_meet(&self, ray: &Ray) -> bool {
        !self.nodes.is_empty() && ray.origin.is_finite() && ray.dir.is_finite()
    }

    /// One turn of a walk in a stream: visits its current node and moves
    /// on to the nearest node left, as `traverse` does, except that a node
    /// whose leaves the ray meets asks for their triangles, keeps all its
    /// children on the stack and ends the turn; the walk's next turn tests
    /// those leaves (their triangles have arrived meanwhile) before it
    /// takes the next node. The same tests in the same order as
    /// `traverse`. False when the walk is over.
    #[inline(always)]
    fn step<const ANY_HIT: bool>(&self, walk: &mut Walk) -> bool {
        if walk.leaf_count > 0 {
            let (leaves, count) = (walk.leaves, std::mem::take(&mut walk.leaf_count));
            for &(first, count, t_enter) in &leaves[..count] {
                if t_enter > walk.t_max {
                    continue;
                }
                if let Some((prim, hit)) = self.test_leaf(&walk.ray, first, count, walk.t_max) {
                    walk.t_max = hit.t;
                    walk.closest = Some((prim, hit));
                    if ANY_HIT {
                        return false;
                    }
                }
            }
            return self.resume(walk);
        }
        let node = &self.nodes[walk.current as usize];
        let (mask, near) = slab_test(node, &walk.ray, walk.t_max);
        let (mut nodes, mut n) = ([(0u32, 0f32); WIDTH], 0);
        sort_children(
            node,
            mask,
            &near,
            (&mut nodes, &mut n),
            (&mut walk.leaves, &mut walk.leaf_count),
        );
        self.prefetch(&walk.leaves[..walk.leaf_count], &nodes[..n]);
        if walk.leaf_count > 0 {
            walk.push(&nodes[..n]);
            return true;
        }
        walk.push(&nodes[1.min(n)..n]);
        if n > 0 && nodes[0].1 <= walk.t_max {
            walk.current = nodes[0].0;
            return true;
        }
        self.resume(walk)
    }

    /// Takes the walk's next node from its stack and asks for it: it may
    /// have sat there long enough to leave the cache. False when none is
    /// left.
    #[inline(always)]
    fn resume(&self, walk: &mut Walk) -> bool {
        let more = walk.pop();
        if more {
            prefetch_bytes(std::slice::from_ref(&self.nodes[walk.current as usize]));
        }
        more
    }

    /// The packets of the leaf whose first packet is `first` and which
    /// holds `count` triangles.
    #[inline(always)]
    pub(super) fn leaf_packets(&self, first: u32, count: u32) -> &[Triangle4] {
        &self.packets[first as usize..][..count.div_ceil(4) as usize]
    }

    /// Asks for the triangles of `leaves`, all at once so that their waits
    /// overlap, then for the nodes of `children`, ahead of their tests.
    #[inline(always)]
    fn prefetch(&self, leaves: &[Leaf], children: &[(u32, f32)]) {
        for &(first, count, _) in leaves {
            prefetch_bytes(self.leaf_packets(first, count));
        }
        for &(child, _) in children {
            prefetch_bytes(std::slice::from_ref(&self.nodes[child as usize]));
        }
    }

    /// The nearest hit within (0, t_max) among a leaf's `count`
    /// triangles, which start at packet `first`.
    #[inline(always)]
    pub(super) fn test_leaf(
        &self,
        ray: &RayLanes,
        first: u32,
        count: u32,
        mut t_max: f32,
    ) -> Option<(u32, TriangleHit)> {
        let packets = self.leaf_packets(first, count);
        // Leaves of five to eight triangles (MAX_LEAF) as one test of eight
        // lanes where there is AVX2, two of four elsewhere.
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        if let [p, q] = packets {
            let lanes = (1u32 << count) - 1;
            return triangle4::intersect_pair(&ray.shear8, p, q, lanes, t_max)
                .map(|(lane, hit)| (packets[lane / 4].prim(lane % 4), hit));
        }
        let mut left = count;
        let mut closest = None;
        for packet in packets {
            let lanes = (1u32 << left.min(4)) - 1;
            left = left.saturating_sub(4);
            if let Some((lane, hit)) = triangle4::intersect(&ray.shear4, packet, lanes, t_max) {
                t_max = hit.t;
                closest = Some((packet.prim(lane), hit));
            }
        }
        closest
    }
}

/// A ray's values as the tests take them, splatted across lanes: origin
/// and inverse direction for the slab tests; the sheared ray for the
/// triangle tests, four lanes wide and, where there is AVX2, eight.
pub(super) struct RayLanes {
    origin: [Slab; 3],
    inv_dir: [Slab; 3],
    shear4: RayShear4,
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    shear8: triangle4::RayShear8,
}

impl RayLanes {
    #[inline(always)]
    pub(super) fn new(ray: &Ray) -> Self {
        let shear = RayShear::new(ray);
        let inv = ray.dir.recip();
        RayLanes {
            origin: [ray.origin.x, ray.origin.y, ray.origin.z].map(Slab::splat),
            inv_dir: [inv.x, inv.y, inv.z].map(Slab::splat),
            shear4: RayShear4::new(&shear),
            #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
            shear8: triangle4::RayShear8::new(&shear),
        }
    }
}

/// Sorts the children in `mask` into interior nodes (child, entry) and
/// leaves (first packet, count, entry), each nearest first.
#[inline(always)]
fn sort_children(
    node: &WideNode,
    mut mask: u32,
    near: &[f32; WIDTH],
    (nodes, n): (&mut [(u32, f32); WIDTH], &mut usize),
    (leaves, nl): (&mut [Leaf; WIDTH], &mut usize),
) {
    while mask != 0 {
        let i = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        if node.count[i] > 0 {
            let entry = (node.child[i], node.count[i], near[i]);
            insert_by_distance(leaves, nl, entry, |e| e.2);
        } else {
            insert_by_distance(nodes, n, (node.child[i], near[i]), |e| e.1);
        }
    }
}

/// Which of a node's children the ray meets within [0, t_max], as a bit
/// mask, and where it enters each.
#[inline(always)]
fn slab_test(node: &WideNode, ray: &RayLanes, t_max: f32) -> (u32, [f32; WIDTH]) {
    let (o, id) = (&ray.origin, &ray.inv_dir);
    let mut mask = 0u32;
    let mut near = [0f32; WIDTH];
    // The far distance is enlarged by 2γ(3): conservative against rounding.
    let far_scale = Slab::splat(1.0 + 2.0 * gamma(3));
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
        let exit =
            (tx0.max(tx1).min(ty0.max(ty1)).min(tz0.max(tz1)) * far_scale).min(Slab::splat(t_max));
        // An empty slot's entry is +∞, which also "meets" an exit at +∞ on
        // an unbounded ray: finite entries only.
        let hit = entry.cmple(exit) & entry.cmplt(Slab::splat(f32::INFINITY));
        mask |= Slab::bits(hit) << g;
        near[g..g + Slab::WIDTH].copy_from_slice(&entry.to_array()[..Slab::WIDTH]);
    }
    (mask, near)
}

/// Asks for every cache line of `items` ahead of their use.
#[inline(always)]
fn prefetch_bytes<T>(items: &[T]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let p = items.as_ptr() as *const i8;
        for offset in (0..std::mem::size_of_val(items)).step_by(64) {
            // SAFETY: a prefetch only hints the cache; the line is the items'.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(p.add(offset)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = items;
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
