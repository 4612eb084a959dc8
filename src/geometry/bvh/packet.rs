//! Eight rays walking a small tree together, one ray to a lane: each box
//! and each triangle is loaded once and tested against all eight rays in
//! one run of AVX2 arithmetic. A single ray's walk spends most of its
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

/// The largest tree walked by packets of rays (`prefers_packets`).
const MAX_PACKET_NODES: usize = 8;

impl Bvh {
    /// Whether up to eight rays are better walked together
    /// (`intersect_packet`) than one at a time: in trees of at most eight
    /// nodes. The path tracer's instructions, packets against single rays
    /// (`tools/gen_cave.py`): the Cornell Box (one node) −11%, caves of 1,
    /// 5 and 8 nodes −8%, −5%, −4%, of 9 nodes −1% and +1%.
    pub fn prefers_packets(&self) -> bool {
        cfg!(all(target_arch = "x86_64", target_feature = "avx2"))
            && self.nodes.len() <= MAX_PACKET_NODES
    }

    /// `intersect` for up to eight rays (`hits[i]` answers `rays[i]`).
    pub fn intersect_packet(&self, rays: &[Ray], hits: &mut [Option<(u32, TriangleHit)>]) {
        assert_eq!(rays.len(), hits.len(), "one answer per ray");
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        if rays.len() <= 8 && !self.nodes.is_empty() {
            let mut packet = avx2::RayPacket::new(rays);
            self.walk_packet::<false>(&mut packet, rays, |lane, hit| hits[lane] = Some(hit));
            return;
        }
        for (hit, ray) in hits.iter_mut().zip(rays) {
            *hit = self.intersect(ray);
        }
    }

    /// `occluded` for up to eight rays (`blocked[i]` answers `rays[i]`).
    pub fn occluded_packet(&self, rays: &[Ray], blocked: &mut [bool]) {
        assert_eq!(rays.len(), blocked.len(), "one answer per ray");
        blocked.fill(false);
        #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
        if rays.len() <= 8 && !self.nodes.is_empty() {
            let mut packet = avx2::RayPacket::new(rays);
            self.walk_packet::<true>(&mut packet, rays, |lane, _| blocked[lane] = true);
            return;
        }
        for (b, ray) in blocked.iter_mut().zip(rays) {
            *b = self.occluded(ray);
        }
    }
}

#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
mod avx2 {
    use std::mem::MaybeUninit;

    use glam::Vec3;

    use super::super::traverse::RayLanes;
    use super::super::{Bvh, WideNode, WIDTH};
    use crate::geometry::lanes::{F32x8, Lanes, Mask8};
    use crate::geometry::triangle::TriangleHit;
    use crate::geometry::triangle4::{test_sheared, LaneHits};
    use crate::geometry::{gamma, Ray};

    /// Nodes waiting: a visit takes one and leaves at most WIDTH, so
    /// WIDTH − 1 more per level, as the single ray's walk bounds it.
    const STACK_SIZE: usize = (WIDTH - 1) * 80 + 1;

    /// The packet's rays as single walks take them, for the lanes in `made`.
    struct Alone {
        rays: [MaybeUninit<RayLanes>; 8],
        made: u32,
    }

    /// Leaves met by this many lanes or fewer are tested ray by ray: in
    /// the Cornell Box 28% of the triangle tests were for one lane and 15%
    /// for two, each a full eight-lane test.
    const FEW_LANES: u32 = 3;

    /// Eight rays, a lane each: what the slab and triangle tests take.
    pub struct RayPacket {
        origin: [F32x8; 3],
        inv_dir: [F32x8; 3],
        /// Lanes whose direction's largest axis is x, and y (the others':
        /// z): the triangle test's permutation (`RayShear`).
        major_x: Mask8,
        major_y: Mask8,
        sx: F32x8,
        sy: F32x8,
        sz: F32x8,
        t_bound_factor: F32x8,
        /// The closest hit so far, or the ray's own end.
        t_max: F32x8,
        /// Lanes that hold a ray that may meet something.
        live: u32,
    }

    impl RayPacket {
        pub fn new(rays: &[Ray]) -> Self {
            debug_assert!(rays.len() <= 8);
            // A row a ray, transposed into a lane a ray. Lanes without a
            // ray, or with one that is not finite (which, as
            // `Bvh::may_meet` says, meets nothing), hold a harmless ray (+z
            // from the origin) and stay out of `live`.
            let harmless = F32x8::from_array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
            let rows = std::array::from_fn(|l| match rays.get(l) {
                Some(ray) => {
                    let (o, d) = (ray.origin, ray.dir);
                    let free = if ray.in_free_space { 0.0 } else { 3.0 };
                    F32x8::from_array([o.x, o.y, o.z, d.x, d.y, d.z, ray.t_max, free])
                }
                None => harmless,
            });
            let [ox, oy, oz, dx, dy, dz, t_max, t_bound_factor] = F32x8::transpose(rows);
            // 0·x is ±0 for finite x, NaN for infinities and NaN.
            let zero = F32x8::splat(0.0);
            let is_finite = |v: F32x8| (v * zero).cmpeq(zero);
            let finite = [oy, oz, dx, dy, dz]
                .into_iter()
                .fold(is_finite(ox), |all, v| all & is_finite(v));
            let live = F32x8::bits(finite) & ((1u32 << rays.len()) - 1);
            let keep = |v: F32x8, otherwise: f32| F32x8::select(finite, v, F32x8::splat(otherwise));
            let [ox, oy, oz, dx, dy] = [ox, oy, oz, dx, dy].map(|v| keep(v, 0.0));
            let dz = keep(dz, 1.0);
            // `RayShear::new` lane by lane: the largest axis of the
            // direction becomes z (ties as there), the others are sheared.
            let (ax, ay, az) = (dx.abs(), dy.abs(), dz.abs());
            let major_x = ax.cmpgt(ay) & ax.cmpgt(az);
            let major_y = !major_x & ay.cmpgt(az);
            let pick = |on_x: F32x8, on_y: F32x8, on_z: F32x8| {
                F32x8::select(major_x, on_x, F32x8::select(major_y, on_y, on_z))
            };
            let (d_kx, d_ky, d_kz) = (pick(dy, dz, dx), pick(dz, dx, dy), pick(dx, dy, dz));
            // −1·x is the exact negation, zeros included (0 − x is not).
            let (minus_one, one) = (F32x8::splat(-1.0), F32x8::splat(1.0));
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
            let (o, id) = (&self.origin, &self.inv_dir);
            let slab = |bound: f32, axis: usize| (F32x8::splat(bound) - o[axis]) * id[axis];
            let (tx0, tx1) = (slab(node.lo[0][i], 0), slab(node.hi[0][i], 0));
            let (ty0, ty1) = (slab(node.lo[1][i], 1), slab(node.hi[1][i], 1));
            let (tz0, tz1) = (slab(node.lo[2][i], 2), slab(node.hi[2][i], 2));
            let entry = tx0
                .min(tx1)
                .max(ty0.min(ty1))
                .max(tz0.min(tz1))
                .max(F32x8::splat(0.0));
            let far_scale = F32x8::splat(1.0 + 2.0 * gamma(3));
            let exit =
                (tx0.max(tx1).min(ty0.max(ty1)).min(tz0.max(tz1)) * far_scale).min(self.t_max);
            let hit = entry.cmple(exit) & entry.cmplt(F32x8::splat(f32::INFINITY));
            F32x8::bits(hit) & lanes
        }

        /// The lanes of `lanes` whose rays hit `tri` within (0, t_max).
        #[inline(always)]
        fn test(&self, tri: &[Vec3; 3], lanes: u32) -> Option<LaneHits<F32x8>> {
            let vertex = |v: Vec3| {
                let d = [
                    F32x8::splat(v.x) - self.origin[0],
                    F32x8::splat(v.y) - self.origin[1],
                    F32x8::splat(v.z) - self.origin[2],
                ];
                // Permute each lane so that its ray's largest axis is z.
                let pick = |on_x: F32x8, on_y: F32x8, on_z: F32x8| {
                    F32x8::select(self.major_x, on_x, F32x8::select(self.major_y, on_y, on_z))
                };
                let z = pick(d[0], d[1], d[2]);
                let x = pick(d[1], d[2], d[0]) + self.sx * z;
                let y = pick(d[2], d[0], d[1]) + self.sy * z;
                (x, y, z)
            };
            let sheared = [vertex(tri[0]), vertex(tri[1]), vertex(tri[2])];
            test_sheared(sheared, self.sz, self.t_bound_factor, self.t_max, lanes)
        }
    }

    impl Bvh {
        /// Walks the packet's rays (`rays`, lane by lane) through the tree
        /// together; `found(lane, hit)` hears of each closer hit of a lane
        /// (with `ANY_HIT`, of its first hit, after which the lane stops).
        pub(in crate::geometry::bvh) fn walk_packet<const ANY_HIT: bool>(
            &self,
            packet: &mut RayPacket,
            rays: &[Ray],
            mut found: impl FnMut(usize, (u32, TriangleHit)),
        ) {
            // Each lane's ray as the single walk takes it, made when a leaf
            // is first met by so few lanes that testing them one by one is
            // cheaper (`FEW_LANES`); left uninitialised until then (zeroing
            // 8 of them per walk cost more than the tests saved).
            let mut alone = Alone {
                rays: [const { MaybeUninit::uninit() }; 8],
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
                    } else if lanes.count_ones() <= FEW_LANES {
                        self.test_leaf_alone::<ANY_HIT>(
                            packet,
                            rays,
                            &mut alone,
                            (first, count),
                            lanes,
                            &mut found,
                        );
                    } else {
                        self.test_leaf_together::<ANY_HIT>(
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
        fn test_leaf_together<const ANY_HIT: bool>(
            &self,
            packet: &mut RayPacket,
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
                    let closer = F32x8::mask(hits.lanes);
                    packet.t_max = F32x8::select(closer, hits.t, packet.t_max);
                }
            }
        }

        /// Tests the leaf against each ray of `lanes` on its own, its
        /// triangles four or eight at a time, as the single walk does.
        #[inline(always)]
        fn test_leaf_alone<const ANY_HIT: bool>(
            &self,
            packet: &mut RayPacket,
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
            packet.t_max = F32x8::from_array(t_max);
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

    /// Eight rays walked together find what each finds alone (in a tree of
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
        for round in 0..400 {
            let n = 1 + round % 8;
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
        assert!(compared > 300, "only {compared} rays hit anything");
    }
}
