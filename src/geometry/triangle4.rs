//! The watertight ray/triangle test (`triangle::intersect`) on four
//! triangles at once: a BVH leaf stores its triangles four to a packet, as
//! structure of arrays, so one run of SIMD arithmetic tests them all. With
//! AVX2 two packets (a leaf of five to eight) are tested as one, eight
//! lanes wide. Each lane does exactly the scalar test's operations in the
//! same order, so the hits (distances and barycentrics, bit for bit) are
//! the scalar test's.

use glam::{Vec3, Vec4};

use super::gamma;
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
use super::lanes::F32x8;
use super::lanes::Lanes;
use super::triangle::{RayShear, TriangleHit};

/// Up to four triangles: `v[k][axis]` holds vertex k's coordinate on that
/// axis for each lane, `prim[lane]` the triangle's index in build order.
/// Lanes past a leaf's end repeat its last triangle and are masked off.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub struct Triangle4 {
    v: [[Vec4; 3]; 3],
    prim: [u32; 4],
}

impl Triangle4 {
    /// Packs up to four triangles (the last repeats into unused lanes).
    pub fn new(tris: &[[Vec3; 3]], first_prim: u32) -> Self {
        debug_assert!((1..=4).contains(&tris.len()));
        let mut v = [[Vec4::ZERO; 3]; 3];
        let mut prim = [0; 4];
        for lane in 0..4 {
            let l = lane.min(tris.len() - 1);
            for (k, vertex) in tris[l].iter().enumerate() {
                for axis in 0..3 {
                    v[k][axis][lane] = vertex[axis];
                }
            }
            prim[lane] = first_prim + l as u32;
        }
        Self { v, prim }
    }

    pub fn prim(&self, lane: usize) -> u32 {
        self.prim[lane]
    }

    /// The triangle in `lane`.
    #[inline(always)]
    pub fn triangle(&self, lane: usize) -> [Vec3; 3] {
        self.v
            .map(|axes| Vec3::new(axes[0][lane], axes[1][lane], axes[2][lane]))
    }
}

/// The per-ray values of the test, splatted across lanes.
pub struct PacketShear<L> {
    k: [usize; 3],
    origin: [L; 3],
    sx: L,
    sy: L,
    sz: L,
    t_bound_factor: L,
}

impl<L: Lanes> PacketShear<L> {
    pub fn new(s: &RayShear) -> Self {
        let k = [s.kx, s.ky, s.kz];
        Self {
            k,
            origin: k.map(|a| L::splat(s.origin[a])),
            sx: L::splat(s.sx),
            sy: L::splat(s.sy),
            sz: L::splat(s.sz),
            t_bound_factor: L::splat(s.t_bound_factor),
        }
    }
}

pub type RayShear4 = PacketShear<Vec4>;
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
pub type RayShear8 = PacketShear<F32x8>;

/// The nearest hit among the lanes in `lanes` (a bit mask) with t in
/// (0, t_max): the lane and its hit. Ties go to the lowest lane, as the
/// scalar test run lane by lane would have it.
#[inline]
pub fn intersect(
    s: &RayShear4,
    p: &Triangle4,
    lanes: u32,
    t_max: f32,
) -> Option<(usize, TriangleHit)> {
    intersect_lanes(s, &p.v, lanes, t_max)
}

/// `intersect` on two packets as one of eight lanes: lanes 0–3 are `p`'s,
/// 4–7 `q`'s.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[inline]
pub fn intersect_pair(
    s: &RayShear8,
    p: &Triangle4,
    q: &Triangle4,
    lanes: u32,
    t_max: f32,
) -> Option<(usize, TriangleHit)> {
    let v = std::array::from_fn(|k| {
        std::array::from_fn(|axis| F32x8::from_halves(p.v[k][axis], q.v[k][axis]))
    });
    intersect_lanes(s, &v, lanes, t_max)
}

/// The test on `v[k][axis]`, vertex k's coordinates in each lane.
#[inline(always)]
fn intersect_lanes<L: Lanes>(
    s: &PacketShear<L>,
    v: &[[L; 3]; 3],
    lanes: u32,
    t_max: f32,
) -> Option<(usize, TriangleHit)> {
    // Translate to the ray origin, permute so the ray runs along z, shear.
    let vertex = |k: usize| {
        let v = &v[k];
        let z = v[s.k[2]] - s.origin[2];
        let x = (v[s.k[0]] - s.origin[0]) + s.sx * z;
        let y = (v[s.k[1]] - s.origin[1]) + s.sy * z;
        (x, y, z)
    };
    let sheared = [vertex(0), vertex(1), vertex(2)];
    let hits = test_sheared(sheared, s.sz, s.t_bound_factor, L::splat(t_max), lanes)?;
    // The nearest lane; the lowest of equals.
    let t = hits.t.to_array();
    let mut lane = hits.lanes.trailing_zeros() as usize;
    let mut rest = hits.lanes & (hits.lanes - 1);
    while rest != 0 {
        let l = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        if t[l] < t[lane] {
            lane = l;
        }
    }
    Some((lane, hits.hit(lane)))
}

/// What the test found in its lanes: which hit (bits), at what t, and the
/// edge functions with 1/det that make the barycentrics.
pub(super) struct LaneHits<L> {
    pub lanes: u32,
    pub t: L,
    pub e: [L; 3],
    pub inv_det: L,
}

impl<L: Lanes> LaneHits<L> {
    /// Lane `lane`'s hit.
    #[inline(always)]
    pub fn hit(&self, lane: usize) -> TriangleHit {
        let inv = self.inv_det.to_array()[lane];
        let [e0, e1, e2] = self.e.map(|e| e.to_array()[lane]);
        TriangleHit {
            t: self.t.to_array()[lane],
            b: [e0 * inv, e1 * inv, e2 * inv],
        }
    }
}

/// The largest magnitude of three, lane by lane. (A function, not a
/// closure: closures are not compiled for AVX-512 with the sixteen-lane
/// walk that inlines this test.)
#[inline(always)]
fn max3<L: Lanes>(a: L, b: L, c: L) -> L {
    a.abs().max(b.abs()).max(c.abs())
}

/// The rest of the watertight test once the vertices are translated to
/// the ray origin, permuted and sheared (`sheared[k]`: vertex k's x, y and
/// its z before scaling by `sz`): the lanes of `lanes` whose hit lies
/// within (0, t_max), or None. A lane may hold another triangle (one ray,
/// four or eight triangles) or another ray (one triangle, eight rays:
/// `ray_packet`); either way it does the scalar test's operations in the
/// same order.
#[inline(always)]
pub(super) fn test_sheared<L: Lanes>(
    sheared: [(L, L, L); 3],
    sz: L,
    t_bound_factor: L,
    t_max: L,
    lanes: u32,
) -> Option<LaneHits<L>> {
    let [(x0, y0, z0), (x1, y1, z1), (x2, y2, z2)] = sheared;
    // Edge functions: signed areas seen from the ray.
    let mut e0 = x1 * y2 - y1 * x2;
    let mut e1 = x2 * y0 - y2 * x0;
    let mut e2 = x0 * y1 - y0 * x1;
    let on_edge =
        L::bits(e0.cmpeq(L::splat(0.0)) | e1.cmpeq(L::splat(0.0)) | e2.cmpeq(L::splat(0.0)));
    if on_edge & lanes != 0 {
        // Exactly on an edge in f32: decide in f64 so neighbours agree.
        let [x0, y0, x1, y1, x2, y2] = [x0, y0, x1, y1, x2, y2].map(L::to_array);
        let (mut f0, mut f1, mut f2) = (e0.to_array(), e1.to_array(), e2.to_array());
        for l in 0..L::WIDTH {
            if on_edge & lanes & (1 << l) != 0 {
                let edge = |ax: f32, ay: f32, bx: f32, by: f32| {
                    (ax as f64 * by as f64 - ay as f64 * bx as f64) as f32
                };
                f0[l] = edge(x1[l], y1[l], x2[l], y2[l]);
                f1[l] = edge(x2[l], y2[l], x0[l], y0[l]);
                f2[l] = edge(x0[l], y0[l], x1[l], y1[l]);
            }
        }
        (e0, e1, e2) = (L::from_array(f0), L::from_array(f1), L::from_array(f2));
    }
    let zero = L::splat(0.0);
    let negative = e0.cmplt(zero) | e1.cmplt(zero) | e2.cmplt(zero);
    let positive = e0.cmpgt(zero) | e1.cmpgt(zero) | e2.cmpgt(zero);
    let det = e0 + e1 + e2;
    let mut ok = !(negative & positive) & det.cmpne(zero) & L::mask(lanes);
    if L::bits(ok) == 0 {
        return None;
    }

    // Scaled distance, compared against the range without dividing.
    let (z0, z1, z2) = (z0 * sz, z1 * sz, z2 * sz);
    let t_scaled = e0 * z0 + e1 * z1 + e2 * z2;
    let range = t_max * det;
    let below = det.cmplt(zero) & (t_scaled.cmpge(zero) | t_scaled.cmplt(range));
    let above = det.cmpgt(zero) & (t_scaled.cmple(zero) | t_scaled.cmpgt(range));
    ok = ok & !(below | above);
    if L::bits(ok) == 0 {
        return None;
    }
    let inv_det = L::splat(1.0) / det;
    let t = t_scaled * inv_det;
    ok = ok & t.cmplt(t_max);

    // Reject t that is not surely positive given the rounding above.
    let max_z = max3(z0, z1, z2);
    let max_x = max3(x0, x1, x2);
    let max_y = max3(y0, y1, y2);
    let delta_z = L::splat(gamma(3)) * max_z;
    let delta_x = L::splat(gamma(5)) * (max_x + max_z);
    let delta_y = L::splat(gamma(5)) * (max_y + max_z);
    let delta_e =
        L::splat(2.0) * (L::splat(gamma(2)) * max_x * max_y + delta_y * max_x + delta_x * max_y);
    let max_e = max3(e0, e1, e2);
    let delta_t = t_bound_factor
        * (L::splat(gamma(3)) * max_e * max_z + delta_e * max_z + delta_z * max_e)
        * inv_det.abs();
    ok = ok & t.cmpgt(delta_t);

    let lanes = L::bits(ok);
    (lanes != 0).then_some(LaneHits {
        lanes,
        t,
        e: [e0, e1, e2],
        inv_det,
    })
}

#[cfg(test)]
mod tests {
    use super::super::{triangle, Ray};
    use super::*;

    fn next(s: &mut u64) -> f32 {
        *s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*s >> 40) as f32) / (1u64 << 24) as f32
    }

    /// Every lane answers as the scalar test does, bit for bit: random
    /// triangles and rays, and rays through shared edges and vertices.
    #[test]
    fn lanes_match_the_scalar_test_bit_for_bit() {
        let mut s = 11u64;
        let mut agreed = 0;
        // Eight triangles go to the pair test where there is one.
        let most = if cfg!(all(target_arch = "x86_64", target_feature = "avx2")) {
            8
        } else {
            4
        };
        for case in 0..40_000 {
            let n = 1 + case % most;
            let tris: Vec<[Vec3; 3]> = (0..n)
                .map(|_| {
                    let c = Vec3::new(next(&mut s), next(&mut s), next(&mut s)) * 2.0;
                    let mut v = || c + Vec3::new(next(&mut s), next(&mut s), next(&mut s)) - 0.5;
                    [v(), v(), v()]
                })
                .collect();
            let o = Vec3::new(next(&mut s), next(&mut s), next(&mut s)) * 4.0 - 1.0;
            // Aim at a vertex, an edge's midpoint or a random point.
            let target = match case % 3 {
                0 => tris[0][case % 3],
                1 => (tris[0][0] + tris[0][1]) * 0.5,
                _ => Vec3::new(next(&mut s), next(&mut s), next(&mut s)) * 2.0,
            };
            let mut ray = Ray::new(o, target - o);
            ray.t_max = if case % 5 == 0 { 0.9 } else { f32::INFINITY };
            let shear = RayShear::new(&ray);
            let scalar = tris
                .iter()
                .enumerate()
                .filter_map(|(i, t)| triangle::intersect(&shear, t, ray.t_max).map(|h| (i, h)))
                .fold(
                    None,
                    |best: Option<(usize, TriangleHit)>, (i, h)| match best {
                        Some(b) if b.1.t <= h.t => Some(b),
                        _ => Some((i, h)),
                    },
                );
            let lanes = (1u32 << n) - 1;
            let (got, prim) = match n {
                ..=4 => {
                    let packet = Triangle4::new(&tris, 100);
                    let got = intersect(&RayShear4::new(&shear), &packet, lanes, ray.t_max);
                    (got, got.map(|(lane, _)| packet.prim(lane)))
                }
                #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
                _ => pair(&shear, &tris, lanes, ray.t_max),
                #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
                _ => unreachable!("at most four triangles a case without AVX2"),
            };
            match (scalar, got) {
                (None, None) => {}
                (Some((i, h)), Some((lane, g))) => {
                    assert_eq!(i, lane, "case {case}");
                    assert_eq!(prim, Some(100 + i as u32));
                    assert_eq!(h.t.to_bits(), g.t.to_bits(), "case {case}");
                    assert_eq!(h.b.map(f32::to_bits), g.b.map(f32::to_bits), "case {case}");
                    agreed += 1;
                }
                (a, b) => panic!("case {case}: scalar {a:?}, packet {b:?}"),
            }
        }
        assert!(agreed > 2000, "too few hits to compare: {agreed}");
    }

    /// Five to eight triangles as two packets through `intersect_pair`.
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    fn pair(
        shear: &RayShear,
        tris: &[[Vec3; 3]],
        lanes: u32,
        t_max: f32,
    ) -> (Option<(usize, TriangleHit)>, Option<u32>) {
        let (p, q) = (
            Triangle4::new(&tris[..4], 100),
            Triangle4::new(&tris[4..], 104),
        );
        let got = intersect_pair(&RayShear8::new(shear), &p, &q, lanes, t_max);
        (got, got.map(|(lane, _)| [p, q][lane / 4].prim(lane % 4)))
    }

    #[test]
    fn masked_lanes_never_hit() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let far = [
            Vec3::Z * 5.0,
            Vec3::Z * 5.0 + Vec3::X,
            Vec3::Z * 5.0 + Vec3::Y,
        ];
        let packet = Triangle4::new(&[far, tri], 0);
        let ray = Ray::new(Vec3::new(0.2, 0.2, 10.0), -Vec3::Z);
        let s = RayShear4::new(&RayShear::new(&ray));
        // Both lanes hit; the nearer (lane 0, at z = 5) wins unless masked.
        assert_eq!(intersect(&s, &packet, 0b11, ray.t_max).unwrap().0, 0);
        assert_eq!(intersect(&s, &packet, 0b10, ray.t_max).unwrap().0, 1);
        // Lanes 2 and 3 repeat lane 1 but are not part of the leaf.
        assert!(intersect(&s, &packet, 0b00, ray.t_max).is_none());
    }
}
