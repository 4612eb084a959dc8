//! Eight rays (AVX2) or sixteen (AVX-512, where the CPU has it) walking a
//! small tree together, one ray to a lane: each box and each triangle is
//! loaded once and tested against all the rays in one run of SIMD
//! arithmetic. A single ray's walk spends most of its
//! instructions on its own bookkeeping (its sheared ray, sorting the
//! children it meets, a leaf at a time); in a tree that fits the
//! first-level cache that bookkeeping, not memory, is its cost. Eight
//! incoherent rays meet more boxes together than one does, so the packet
//! pays only where the tree is small (`Bvh::prefers_packets`). A leaf
//! that only a few of the rays enter is tested ray by ray instead.
//!
//! Each lane does the single-ray test's operations in the same order
//! (`triangle4::test_sheared`, the slab test's), so a ray finds the same
//! surface as it would alone; where two triangles are hit at exactly the
//! same distance (a shared edge) the packet may keep the other one.

use super::{Bvh, Ray};
use crate::geometry::triangle::TriangleHit;

#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
use crate::geometry::lanes::{avx512, F32x16, F32x8};
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
use walk::RayPacket;

/// The largest tree walked by packets of rays (`prefers_packets`).
const MAX_PACKET_NODES: usize = 8;

/// The most rays a packet holds: sixteen where the CPU has AVX-512
/// (`packet_width`), eight otherwise.
pub const MAX_PACKET_WIDTH: usize = 16;

/// Rays a packet holds: sixteen, one AVX-512 register's lanes, where the
/// CPU has AVX-512 (unless `keep_packets_to_avx2` was called); else eight
/// (AVX2's). Fixed at its first call.
pub fn packet_width() -> usize {
    *PACKET_WIDTH.get_or_init(|| {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        if avx512::available() {
            return 16;
        }
        8
    })
}

static PACKET_WIDTH: std::sync::OnceLock<usize> = std::sync::OnceLock::new();

/// Keeps packets to eight rays even where the CPU has AVX-512
/// (`PRISM_AVX512=0`, to compare the two on one machine); before the
/// first render. The images are the same bit for bit.
pub fn keep_packets_to_avx2() {
    let _ = PACKET_WIDTH.set(8);
}

/// Whether packets of rays walk a tree of `nodes` nodes
/// (`Bvh::prefers_packets`).
pub(super) fn walks_packets(nodes: usize) -> bool {
    cfg!(all(target_arch = "x86_64", target_feature = "avx2")) && nodes <= MAX_PACKET_NODES
}

impl Bvh {
    /// Whether a packet's rays are better walked together
    /// (`intersect_packet`) than one at a time: in trees of at most eight
    /// nodes. The path tracer's instructions with eight-ray packets against
    /// single rays (`tools/gen_cave.py`): the Cornell Box (one node) −11%,
    /// caves of 1, 5 and 8 nodes −8%, −5%, −4%, of 9 nodes −1% and +1%.
    pub fn prefers_packets(&self) -> bool {
        walks_packets(self.nodes.len())
    }

    /// `intersect` for up to `packet_width()` rays (`hits[i]` answers
    /// `rays[i]`).
    pub fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<(u32, TriangleHit)>]) {
        assert_eq!(rays.len(), hits.len(), "one answer per ray");
        if self.walk_as_packet::<false>(rays, |lane, hit| hits[lane] = Some(hit)) {
            return;
        }
        for (hit, ray) in hits.iter_mut().zip(rays) {
            *hit = self.intersect(ray);
        }
    }

    /// `occluded` for up to `packet_width()` rays (`blocked[i]` answers
    /// `rays[i]`).
    pub fn occluded_packet(&self, rays: &[Ray], blocked: &mut [bool]) {
        assert_eq!(rays.len(), blocked.len(), "one answer per ray");
        blocked.fill(false);
        if self.walk_as_packet::<true>(rays, |lane, _| blocked[lane] = true) {
            return;
        }
        for (b, ray) in blocked.iter_mut().zip(rays) {
            *b = self.occluded(ray);
        }
    }

    /// Walks `rays` together as one packet, eight to AVX2 lanes or sixteen
    /// to AVX-512 ones where the CPU has it; false (nothing walked) where
    /// the build, the CPU or an empty tree leaves them to single walks.
    #[inline(always)]
    fn walk_as_packet<const ANY_HIT: bool>(
        &self,
        rays: &[Ray],
        found: impl FnMut(usize, (u32, TriangleHit)),
    ) -> bool {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        if !self.nodes.is_empty() {
            if rays.len() <= 8 {
                self.walk_eight::<ANY_HIT>(rays, found);
                return true;
            } else if rays.len() <= 16 && avx512::available() {
                // SAFETY: the CPU has AVX-512F.
                unsafe { self.walk_sixteen::<ANY_HIT>(rays, found) };
                return true;
            }
        }
        let _ = (rays, found);
        false
    }

    /// The packet walk over eight lanes, as AVX2 instructions (out of
    /// line: inlined into both callers, the Cornell Box took 0.5% more
    /// instructions).
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    #[inline(never)]
    fn walk_eight<const ANY_HIT: bool>(
        &self,
        rays: &[Ray],
        found: impl FnMut(usize, (u32, TriangleHit)),
    ) {
        let mut packet = RayPacket::<F32x8>::new(rays);
        self.walk_packet::<ANY_HIT, F32x8>(&mut packet, rays, found);
    }

    /// The packet walk over sixteen lanes, compiled as AVX-512
    /// instructions.
    ///
    /// # Safety
    /// Only where the CPU has AVX-512F (`avx512::available`).
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    #[target_feature(enable = "avx512f")]
    unsafe fn walk_sixteen<const ANY_HIT: bool>(
        &self,
        rays: &[Ray],
        found: impl FnMut(usize, (u32, TriangleHit)),
    ) {
        let mut packet = RayPacket::<F32x16>::new(rays);
        self.walk_packet::<ANY_HIT, F32x16>(&mut packet, rays, found);
    }
}

#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
mod walk {
    use std::mem::MaybeUninit;

    use glam::Vec3;

    use super::super::traverse::RayLanes;
    use super::super::{Bvh, WideNode, WIDTH};
    use super::MAX_PACKET_WIDTH;
    use crate::geometry::lanes::{F32x16, F32x8, Lanes};
    use crate::geometry::triangle::TriangleHit;
    use crate::geometry::triangle4::{test_sheared, LaneHits};
    use crate::geometry::{gamma, Ray};

    /// Lanes a packet walks in: eight (AVX2) or sixteen (AVX-512).
    pub trait PacketLanes: Lanes {
        /// The rays' fields (`row`), a lane per ray; lanes past `rays`
        /// hold `HARMLESS`.
        fn columns(rays: &[Ray]) -> [Self; 8];
    }

    /// A ray's fields as the packet takes them: origin, direction, t_max
    /// and the triangle test's bound on t (0 in free space).
    #[inline(always)]
    fn row(ray: &Ray) -> [f32; 8] {
        let (o, d) = (ray.origin, ray.dir);
        let free = if ray.in_free_space { 0.0 } else { 3.0 };
        [o.x, o.y, o.z, d.x, d.y, d.z, ray.t_max, free]
    }

    /// The fields of a lane without a ray: +z from the origin.
    const HARMLESS: [f32; 8] = [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0];

    impl PacketLanes for F32x8 {
        /// By a transpose in registers (filling the lanes one by one cost
        /// the Cornell Box's render 0.4% more instructions).
        #[inline(always)]
        fn columns(rays: &[Ray]) -> [F32x8; 8] {
            F32x8::transpose(std::array::from_fn(|l| {
                F32x8::from_array(rays.get(l).map_or(HARMLESS, row))
            }))
        }
    }

    impl PacketLanes for F32x16 {
        #[inline(always)]
        fn columns(rays: &[Ray]) -> [F32x16; 8] {
            let rows: [[f32; 8]; 16] = std::array::from_fn(|l| rays.get(l).map_or(HARMLESS, row));
            std::array::from_fn(|field| F32x16::from_array(std::array::from_fn(|l| rows[l][field])))
        }
    }

    /// Nodes waiting: a visit takes one and leaves at most WIDTH, so
    /// WIDTH − 1 more per level, as the single ray's walk bounds it.
    const STACK_SIZE: usize = (WIDTH - 1) * 80 + 1;

    /// The packet's rays as single walks take them, for the lanes in `made`.
    struct Alone {
        rays: [MaybeUninit<RayLanes>; MAX_PACKET_WIDTH],
        made: u32,
    }

    /// Whether a leaf of `count` triangles that the rays of `lanes` enter
    /// is cheaper tested ray by ray: a ray alone tests the triangles four
    /// at a time, but its setup and the single walk's bookkeeping cost
    /// about three of the packet's tests (one triangle against every
    /// lane) per four. So in leaves of up to eight triangles only one ray
    /// ever goes alone, into a leaf of 3, 4, 6, 7 or 8 (which fill their
    /// fours well); leaves of one or two are always tested together.
    #[inline(always)]
    fn alone_is_cheaper(lanes: u32, count: u32) -> bool {
        lanes.count_ones() * count.div_ceil(4) * ALONE_COST <= count
    }

    /// What a ray tested alone costs per four triangles, in the packet's
    /// triangle tests (`alone_is_cheaper`).
    const ALONE_COST: u32 = 3;

    /// A packet's rays, a lane each: what the slab and triangle tests take.
    pub struct RayPacket<L: Lanes> {
        origin: [L; 3],
        inv_dir: [L; 3],
        /// Lanes whose direction's largest axis is x, and y (the others':
        /// z): the triangle test's permutation (`RayShear`).
        major_x: L::Mask,
        major_y: L::Mask,
        sx: L,
        sy: L,
        sz: L,
        t_bound_factor: L,
        /// The closest hit so far, or the ray's own end.
        t_max: L,
        /// Lanes that hold a ray that may meet something.
        live: u32,
    }

    impl<L: PacketLanes> RayPacket<L> {
        #[inline(always)]
        pub fn new(rays: &[Ray]) -> Self {
            debug_assert!(rays.len() <= L::WIDTH);
            // A ray a lane. Lanes without a ray, or with one that is not
            // finite (which, as `Bvh::may_meet` says, meets nothing), hold a
            // harmless ray and stay out of `live`.
            let [ox, oy, oz, dx, dy, dz, t_max, t_bound_factor] = L::columns(rays);
            // 0·x is ±0 for finite x, NaN for infinities and NaN.
            let zero = L::splat(0.0);
            let is_finite = |v: L| (v * zero).cmpeq(zero);
            let finite = [oy, oz, dx, dy, dz]
                .into_iter()
                .fold(is_finite(ox), |all, v| all & is_finite(v));
            let live = L::bits(finite) & ((1u32 << rays.len()) - 1);
            let keep = |v: L, otherwise: f32| L::select(finite, v, L::splat(otherwise));
            let [ox, oy, oz, dx, dy] = [ox, oy, oz, dx, dy].map(|v| keep(v, 0.0));
            let dz = keep(dz, 1.0);
            // `RayShear::new` lane by lane: the largest axis of the
            // direction becomes z (ties as there), the others are sheared.
            let (ax, ay, az) = (dx.abs(), dy.abs(), dz.abs());
            let major_x = ax.cmpgt(ay) & ax.cmpgt(az);
            let major_y = !major_x & ay.cmpgt(az);
            let pick = |on_x: L, on_y: L, on_z: L| {
                L::select(major_x, on_x, L::select(major_y, on_y, on_z))
            };
            let (d_kx, d_ky, d_kz) = (pick(dy, dz, dx), pick(dz, dx, dy), pick(dx, dy, dz));
            // −1·x is the exact negation, zeros included (0 − x is not).
            let (minus_one, one) = (L::splat(-1.0), L::splat(1.0));
            RayPacket {
                origin: [ox, oy, oz],
                inv_dir: [one / dx, one / dy, one / dz],
                major_x,
                major_y,
                sx: minus_one * d_kx / d_kz,
                sy: minus_one * d_ky / d_kz,
                sz: one / d_kz,
                t_bound_factor,
                t_max,
                live,
            }
        }

        /// The lanes of `lanes` that meet child `i`'s box within their
        /// t_max (`traverse::slab_test`'s operations, lane by lane).
        #[inline(always)]
        fn slab(&self, node: &WideNode, i: usize, lanes: u32) -> u32 {
            let (tx0, tx1) = (self.slab_t(node.lo[0][i], 0), self.slab_t(node.hi[0][i], 0));
            let (ty0, ty1) = (self.slab_t(node.lo[1][i], 1), self.slab_t(node.hi[1][i], 1));
            let (tz0, tz1) = (self.slab_t(node.lo[2][i], 2), self.slab_t(node.hi[2][i], 2));
            let entry = tx0
                .min(tx1)
                .max(ty0.min(ty1))
                .max(tz0.min(tz1))
                .max(L::splat(0.0));
            let far_scale = L::splat(1.0 + 2.0 * gamma(3));
            let exit =
                (tx0.max(tx1).min(ty0.max(ty1)).min(tz0.max(tz1)) * far_scale).min(self.t_max);
            let hit = entry.cmple(exit) & entry.cmplt(L::splat(f32::INFINITY));
            L::bits(hit) & lanes
        }

        /// Where each lane's ray crosses the plane `bound` of `axis`. (The
        /// hot helpers are functions, not closures: a closure would not be
        /// compiled for AVX-512 with the walk that inlines it.)
        #[inline(always)]
        fn slab_t(&self, bound: f32, axis: usize) -> L {
            (L::splat(bound) - self.origin[axis]) * self.inv_dir[axis]
        }

        /// Per lane, `on_x`, `on_y` or `on_z` as the ray's largest axis is x,
        /// y or z.
        #[inline(always)]
        fn pick(&self, on_x: L, on_y: L, on_z: L) -> L {
            L::select(self.major_x, on_x, L::select(self.major_y, on_y, on_z))
        }

        /// Vertex `v` translated to each lane's ray origin, permuted so
        /// that the ray runs along z, and sheared.
        #[inline(always)]
        fn shear(&self, v: Vec3) -> (L, L, L) {
            let dx = L::splat(v.x) - self.origin[0];
            let dy = L::splat(v.y) - self.origin[1];
            let dz = L::splat(v.z) - self.origin[2];
            let z = self.pick(dx, dy, dz);
            let x = self.pick(dy, dz, dx) + self.sx * z;
            let y = self.pick(dz, dx, dy) + self.sy * z;
            (x, y, z)
        }

        /// The lanes of `lanes` whose rays hit `tri` within (0, t_max).
        #[inline(always)]
        fn test(&self, tri: &[Vec3; 3], lanes: u32) -> Option<LaneHits<L>> {
            let sheared = [self.shear(tri[0]), self.shear(tri[1]), self.shear(tri[2])];
            test_sheared(sheared, self.sz, self.t_bound_factor, self.t_max, lanes)
        }
    }

    impl Bvh {
        /// Walks the packet's rays (`rays`, lane by lane) through the tree
        /// together; `found(lane, hit)` hears of each closer hit of a lane
        /// (with `ANY_HIT`, of its first hit, after which the lane stops).
        /// Inlined into its callers, so that the sixteen-lane walk is
        /// compiled for AVX-512 with the function that calls it.
        #[inline(always)]
        pub(in crate::geometry::bvh) fn walk_packet<const ANY_HIT: bool, L: PacketLanes>(
            &self,
            packet: &mut RayPacket<L>,
            rays: &[Ray],
            mut found: impl FnMut(usize, (u32, TriangleHit)),
        ) {
            // Each lane's ray as the single walk takes it, made when a leaf
            // is first met by so few lanes that testing them one by one is
            // cheaper (`alone_is_cheaper`); left uninitialised until then (zeroing
            // 8 of them per walk cost more than the tests saved).
            let mut alone = Alone {
                rays: [const { MaybeUninit::uninit() }; MAX_PACKET_WIDTH],
                made: 0,
            };
            // Left uninitialised but for the root: entries below `top` are
            // always written before they are read.
            let mut stack = [const { MaybeUninit::<u32>::uninit() }; STACK_SIZE];
            stack[0].write(0);
            let mut top = 1;
            while top > 0 && packet.live != 0 {
                top -= 1;
                // SAFETY: entries below `top` were all written.
                let node = &self.nodes[unsafe { stack[top].assume_init() } as usize];
                for i in 0..WIDTH {
                    let lanes = packet.slab(node, i, packet.live);
                    if lanes == 0 {
                        continue;
                    }
                    let (first, count) = (node.child[i], node.count[i]);
                    if count == 0 {
                        stack[top].write(first);
                        top += 1;
                    } else if alone_is_cheaper(lanes, count) {
                        self.test_leaf_alone::<ANY_HIT, L>(
                            packet,
                            rays,
                            &mut alone,
                            (first, count),
                            lanes,
                            &mut found,
                        );
                    } else {
                        self.test_leaf_together::<ANY_HIT, L>(
                            packet,
                            (first, count),
                            lanes,
                            &mut found,
                        );
                    }
                }
            }
        }

        /// Tests the leaf's triangles against the rays of `lanes` at once.
        #[inline(always)]
        fn test_leaf_together<const ANY_HIT: bool, L: PacketLanes>(
            &self,
            packet: &mut RayPacket<L>,
            (first, count): (u32, u32),
            lanes: u32,
            found: &mut impl FnMut(usize, (u32, TriangleHit)),
        ) {
            let packets = self.leaf_packets(first, count);
            for k in 0..count as usize {
                let p = &packets[k / 4];
                let Some(hits) = packet.test(&p.triangle(k % 4), lanes & packet.live) else {
                    continue;
                };
                let mut rest = hits.lanes;
                while rest != 0 {
                    let l = rest.trailing_zeros() as usize;
                    rest &= rest - 1;
                    found(l, (p.prim(k % 4), hits.hit(l)));
                }
                if ANY_HIT {
                    packet.live &= !hits.lanes;
                } else {
                    let closer = L::mask(hits.lanes);
                    packet.t_max = L::select(closer, hits.t, packet.t_max);
                }
            }
        }

        /// Tests the leaf against each ray of `lanes` on its own, its
        /// triangles four or eight at a time, as the single walk does.
        #[inline(always)]
        fn test_leaf_alone<const ANY_HIT: bool, L: PacketLanes>(
            &self,
            packet: &mut RayPacket<L>,
            rays: &[Ray],
            alone: &mut Alone,
            leaf: (u32, u32),
            lanes: u32,
            found: &mut impl FnMut(usize, (u32, TriangleHit)),
        ) {
            let mut t_max = packet.t_max.to_array();
            let mut rest = lanes;
            while rest != 0 {
                let l = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                if alone.made & (1 << l) == 0 {
                    alone.rays[l].write(RayLanes::new(&rays[l]));
                    alone.made |= 1 << l;
                }
                // SAFETY: lane l's ray was written, as `made` records.
                let ray = unsafe { alone.rays[l].assume_init_ref() };
                if let Some((prim, hit)) = self.test_leaf(ray, leaf.0, leaf.1, t_max[l]) {
                    found(l, (prim, hit));
                    t_max[l] = hit.t;
                    if ANY_HIT {
                        packet.live &= !(1 << l);
                    }
                }
            }
            packet.t_max = L::from_array(t_max);
        }
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::super::Bvh;
    use crate::geometry::Ray;

    fn next(s: &mut u64) -> f32 {
        *s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*s >> 40) as f32) / (1u64 << 24) as f32
    }

    /// Up to sixteen rays walked together (eight to an AVX2 packet, or
    /// sixteen to an AVX-512 one where the CPU has it) find what each finds
    /// alone (in a tree of
    /// several nodes, though packets are only chosen for one): the same
    /// triangle and hit, bit for bit (or, at a shared edge, another
    /// triangle at the same distance), and the same occlusion. Rays start
    /// inside the triangles' cloud, aim at vertices and edges, end short,
    /// start in free space or are not finite.
    #[test]
    fn packets_find_what_single_rays_find() {
        let mut s = 5u64;
        let mut v = |scale: f32| Vec3::new(next(&mut s), next(&mut s), next(&mut s)) * scale;
        let tris: Vec<[Vec3; 3]> = (0..60)
            .map(|_| {
                let c = v(4.0);
                [c + v(1.0), c + v(1.0), c + v(1.0)]
            })
            .collect();
        let (bvh, _) = Bvh::build(&tris);
        let mut compared = 0;
        for round in 0..800 {
            let n = 1 + round % 16;
            let rays: Vec<Ray> = (0..n)
                .map(|k| {
                    let o = v(6.0) - Vec3::splat(1.0);
                    let target = match (round + k) % 4 {
                        0 => tris[k * 7 % tris.len()][k % 3],
                        1 => (tris[k][0] + tris[k][1]) * 0.5,
                        _ => v(4.0),
                    };
                    let mut ray = Ray::new(o, target - o).starting_in_free_space(k % 3 == 0);
                    if (round + k) % 5 == 0 {
                        ray.t_max = 0.7;
                    }
                    if round % 50 == 7 && k == 0 {
                        ray.dir.x = f32::NAN;
                    }
                    ray
                })
                .collect();
            let mut hits = vec![None; n];
            let mut blocked = vec![false; n];
            bvh.intersect_packet(&rays, &mut hits);
            bvh.occluded_packet(&rays, &mut blocked);
            for (k, ray) in rays.iter().enumerate() {
                let alone = bvh.intersect(ray);
                match (alone, hits[k]) {
                    (None, None) => {}
                    (Some((p, a)), Some((q, b))) if p == q => {
                        assert_eq!(a, b, "ray {k} of round {round}")
                    }
                    (Some((_, a)), Some((_, b))) => {
                        assert_eq!(a.t, b.t, "a tie, ray {k} of round {round}")
                    }
                    (a, b) => panic!("round {round}, ray {k}: alone {a:?}, in a packet {b:?}"),
                }
                assert_eq!(blocked[k], bvh.occluded(ray), "ray {k} of round {round}");
                compared += usize::from(alone.is_some());
            }
        }
        assert!(compared > 1200, "only {compared} rays hit anything");
    }
}
