//! Robust spawning of rays from surfaces. A hit point computed in floating
//! point lies within a small box of the true surface; offsetting the origin
//! along the normal by that box's extent, then rounding away, guarantees the
//! new ray cannot re-hit the surface it leaves (pbrt-v4's error-bound method,
//! Pharr, Jakob & Humphreys, §6.8). It scales with the scene: no fixed epsilon.

use glam::Vec3;

/// Moves `p` (with absolute error bound `p_err`) off the surface with normal
/// `n`, to the side that direction `w` points into.
pub fn offset_ray_origin(p: Vec3, p_err: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let (po, offset) = pushed_off(p, p_err, n, w);
    // One float further in each direction the offset moves: rounding in
    // `p + offset` may have lost part of it.
    step_each_towards(po, offset)
}

/// `p` moved along ±`n` by its error bound's extent there, to `w`'s side,
/// and the offset that moved it.
#[inline(always)]
fn pushed_off(p: Vec3, p_err: Vec3, n: Vec3, w: Vec3) -> (Vec3, Vec3) {
    let d = n.abs().dot(p_err);
    let offset = d * n;
    let offset = if w.dot(n) < 0.0 { -offset } else { offset };
    (p + offset, offset)
}

/// `offset_ray_origin` a component at a time, for loops that the compiler
/// vectorises across rays, a ray to a lane (the SSE2 steps of one ray's
/// three components would stop it): the same bits.
#[inline(always)]
pub fn offset_ray_origin_by_components(p: Vec3, p_err: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let (po, offset) = pushed_off(p, p_err, n, w);
    Vec3::new(
        step_towards(po.x, offset.x),
        step_towards(po.y, offset.y),
        step_towards(po.z, offset.z),
    )
}

/// `step_towards` for each component, the three at once in SSE2 (one
/// call of the scalar version each was 3% of a diffuse scene's
/// instructions: three origins a bounce).
#[inline]
fn step_each_towards(x: Vec3, dir: Vec3) -> Vec3 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of x86-64; only registers are touched.
        unsafe {
            let (xs, ds) = (
                _mm_setr_ps(x.x, x.y, x.z, 0.0),
                _mm_setr_ps(dir.x, dir.y, dir.z, 0.0),
            );
            let (xb, db) = (_mm_castps_si128(xs), _mm_castps_si128(ds));
            // +1 where the signs agree (the magnitude grows), −1 elsewhere.
            let differ = _mm_srai_epi32::<31>(_mm_xor_si128(xb, db));
            let step = _mm_or_si128(_mm_slli_epi32::<1>(differ), _mm_set1_epi32(1));
            let stepped = _mm_add_epi32(xb, step);
            // From ±0: the smallest subnormal with dir's sign.
            let sign = _mm_and_si128(db, _mm_set1_epi32(i32::MIN));
            let tiny = _mm_or_si128(sign, _mm_set1_epi32(1));
            let at_zero = _mm_castps_si128(_mm_cmpeq_ps(xs, _mm_setzero_ps()));
            let stepped = _mm_or_si128(
                _mm_and_si128(at_zero, tiny),
                _mm_andnot_si128(at_zero, stepped),
            );
            // No step where dir is zero.
            let still = _mm_castps_si128(_mm_cmpeq_ps(ds, _mm_setzero_ps()));
            let out = _mm_or_si128(_mm_and_si128(still, xb), _mm_andnot_si128(still, stepped));
            let [a, b, c, _] = std::mem::transmute::<__m128i, [f32; 4]>(out);
            Vec3::new(a, b, c)
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    Vec3::new(
        step_towards(x.x, dir.x),
        step_towards(x.y, dir.y),
        step_towards(x.z, dir.z),
    )
}

/// The next float after `x` in the direction of the sign of `dir` (`x`
/// itself when `dir` is zero), without branches: the signs of the
/// offsets vary from ray to ray, and branching on them mispredicted often
/// enough to make this function 5% of a profile. Finite `x` only (a hit
/// point is finite).
#[inline(always)]
fn step_towards(x: f32, dir: f32) -> f32 {
    let bits = x.to_bits();
    // Away from zero (the signs agree) the magnitude, and so the bits, grow.
    let same_sign = (bits ^ dir.to_bits()) >> 31 == 0;
    let stepped = if same_sign {
        bits.wrapping_add(1)
    } else {
        bits.wrapping_sub(1)
    };
    // From ±0 the step is to the smallest subnormal on `dir`'s side.
    let stepped = if x == 0.0 {
        f32::from_bits(1).copysign(dir)
    } else {
        f32::from_bits(stepped)
    };
    if dir == 0.0 {
        x
    } else {
        stepped
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steps_equal_next_up_and_next_down() {
        let mut values = vec![
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
        ];
        values.extend([
            f32::from_bits(1),
            -f32::from_bits(1),
            3.5e-39,
            1e30,
            -1e30,
            278.25,
        ]);
        let mut random = crate::test_random::XorShift32(0x1234_5678);
        for _ in 0..10_000 {
            let v = f32::from_bits(random.next_u32());
            if v.is_finite() && v.abs() < f32::MAX {
                values.push(v);
            }
        }
        for v in values {
            assert_eq!(
                step_towards(v, 0.5).to_bits(),
                v.next_up().to_bits(),
                "{v:e} up"
            );
            assert_eq!(
                step_towards(v, -2.0).to_bits(),
                v.next_down().to_bits(),
                "{v:e} down"
            );
            assert_eq!(step_towards(v, 0.0).to_bits(), v.to_bits());
        }
    }

    /// The three-at-once step is the scalar one's, bit for bit.
    #[test]
    fn components_step_as_one_does() {
        let mut random = crate::test_random::XorShift32(0x9e37_79b9);
        let mut next = || {
            let x = random.next_u32();
            match x % 7 {
                0 => 0.0,
                1 => -0.0,
                2 => f32::from_bits(x % 5),
                _ => f32::from_bits(x & 0xbfff_ffff),
            }
        };
        for _ in 0..20_000 {
            let (p, d) = (
                Vec3::new(next(), next(), next()),
                Vec3::new(next(), next(), next()),
            );
            let want = [0, 1, 2].map(|i| step_towards(p[i], d[i]).to_bits());
            let got = step_each_towards(p, d).to_array().map(f32::to_bits);
            assert_eq!(got, want, "{p:?} towards {d:?}");
        }
    }

    #[test]
    fn offset_moves_to_the_requested_side() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        let err = Vec3::splat(1e-6);
        let up = offset_ray_origin(p, err, Vec3::Y, Vec3::new(0.0, 1.0, 0.0));
        let down = offset_ray_origin(p, err, Vec3::Y, Vec3::new(0.0, -1.0, 0.0));
        assert!(up.y > p.y && down.y < p.y);
        // The offset covers the error box: the box's far corner stays behind.
        assert!(up.y - p.y >= 1e-6 && p.y - down.y >= 1e-6);
    }
}
