//! SIMD lanes for the packet ray/triangle test: four (`glam::Vec4`, SSE),
//! in builds with AVX2 eight (`F32x8`) and, where the CPU has AVX-512,
//! sixteen (`F32x16`, only inside functions compiled for AVX-512). The test
//! is written once over `Lanes`; each operation is the IEEE one in every
//! lane, so every width gives the scalar test's results bit for bit.

use std::ops::{Add, BitAnd, BitOr, Div, IndexMut, Mul, Not, Sub};

use glam::{BVec4A, Vec4};

/// The operations the packet test needs, lane by lane. Comparisons are
/// ordered (false where a lane is NaN) except `ne`, as in SSE.
pub trait Lanes:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self>
{
    type Mask: Copy
        + BitAnd<Output = Self::Mask>
        + BitOr<Output = Self::Mask>
        + Not<Output = Self::Mask>;
    /// The lanes as an array of `WIDTH` values.
    type Array: Copy + IndexMut<usize, Output = f32> + AsRef<[f32]>;
    const WIDTH: usize;
    fn splat(x: f32) -> Self;
    fn cmpeq(self, other: Self) -> Self::Mask;
    fn cmpne(self, other: Self) -> Self::Mask;
    fn cmplt(self, other: Self) -> Self::Mask;
    fn cmple(self, other: Self) -> Self::Mask;
    fn cmpgt(self, other: Self) -> Self::Mask;
    fn cmpge(self, other: Self) -> Self::Mask;
    fn abs(self) -> Self;
    /// `a` in the lanes of `mask`, `b` in the others.
    fn select(mask: Self::Mask, a: Self, b: Self) -> Self;
    /// `min` and `max` as SSE/AVX compute them: the second operand where
    /// either is NaN.
    fn min(self, other: Self) -> Self;
    fn max(self, other: Self) -> Self;
    /// Bit i set where lane i of the mask is.
    fn bits(mask: Self::Mask) -> u32;
    /// The mask of the lanes whose bits are set in `bits`.
    fn mask(bits: u32) -> Self::Mask;
    fn to_array(self) -> Self::Array;
    fn from_array(lanes: Self::Array) -> Self;
    /// The first `WIDTH` values of `values`.
    fn load(values: &[f32]) -> Self;
}

impl Lanes for Vec4 {
    type Mask = BVec4A;
    type Array = [f32; 4];
    const WIDTH: usize = 4;
    #[inline(always)]
    fn splat(x: f32) -> Self {
        Vec4::splat(x)
    }
    #[inline(always)]
    fn cmpeq(self, other: Self) -> BVec4A {
        self.cmpeq(other)
    }
    #[inline(always)]
    fn cmpne(self, other: Self) -> BVec4A {
        self.cmpne(other)
    }
    #[inline(always)]
    fn cmplt(self, other: Self) -> BVec4A {
        self.cmplt(other)
    }
    #[inline(always)]
    fn cmple(self, other: Self) -> BVec4A {
        self.cmple(other)
    }
    #[inline(always)]
    fn cmpgt(self, other: Self) -> BVec4A {
        self.cmpgt(other)
    }
    #[inline(always)]
    fn cmpge(self, other: Self) -> BVec4A {
        self.cmpge(other)
    }
    #[inline(always)]
    fn abs(self) -> Self {
        Vec4::abs(self)
    }
    #[inline(always)]
    fn select(mask: BVec4A, a: Self, b: Self) -> Self {
        Vec4::select(mask, a, b)
    }
    #[inline(always)]
    fn min(self, other: Self) -> Self {
        Vec4::min(self, other)
    }
    #[inline(always)]
    fn max(self, other: Self) -> Self {
        Vec4::max(self, other)
    }
    #[inline(always)]
    fn bits(mask: BVec4A) -> u32 {
        mask.bitmask()
    }
    /// One load from a table of the sixteen, instead of building the mask
    /// lane by lane on every test.
    #[inline(always)]
    fn mask(bits: u32) -> BVec4A {
        const MASKS: [BVec4A; 16] = {
            let mut m = [BVec4A::FALSE; 16];
            let mut i = 0;
            while i < 16 {
                m[i] = BVec4A::new(i & 1 != 0, i & 2 != 0, i & 4 != 0, i & 8 != 0);
                i += 1;
            }
            m
        };
        MASKS[(bits & 15) as usize]
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 4] {
        Vec4::to_array(&self)
    }
    #[inline(always)]
    fn from_array(l: [f32; 4]) -> Self {
        Vec4::from_array(l)
    }
    #[inline(always)]
    fn load(values: &[f32]) -> Self {
        Vec4::from_slice(values)
    }
}

#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
pub use avx::{F32x8, Mask8};

#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
mod avx {
    // SAFETY (every `unsafe` below): the intrinsics need AVX/AVX2, which
    // this module is only compiled with; none touches memory but its own
    // locals.
    use std::arch::x86_64::*;
    use std::ops::{Add, BitAnd, BitOr, Div, Mul, Not, Sub};

    use glam::Vec4;

    use super::Lanes;

    /// Eight f32 lanes in one AVX register.
    #[derive(Clone, Copy, Debug)]
    pub struct F32x8(__m256);

    /// Eight lanes of all-ones or all-zeros.
    #[derive(Clone, Copy, Debug)]
    pub struct Mask8(__m256);

    impl F32x8 {
        /// Lanes 0–3 from `low`, 4–7 from `high`.
        #[inline(always)]
        pub fn from_halves(low: Vec4, high: Vec4) -> Self {
            unsafe { F32x8(_mm256_set_m128(high.into(), low.into())) }
        }

        /// Rows become columns: lane j of result i is lane i of `rows[j]`
        /// (eight values of eight records into a lane per record).
        #[inline(always)]
        pub fn transpose(rows: [F32x8; 8]) -> [F32x8; 8] {
            let r = rows.map(|r| r.0);
            unsafe {
                // Pairs of rows interleaved, then quads, then the halves.
                let t0 = _mm256_unpacklo_ps(r[0], r[1]);
                let t1 = _mm256_unpackhi_ps(r[0], r[1]);
                let t2 = _mm256_unpacklo_ps(r[2], r[3]);
                let t3 = _mm256_unpackhi_ps(r[2], r[3]);
                let t4 = _mm256_unpacklo_ps(r[4], r[5]);
                let t5 = _mm256_unpackhi_ps(r[4], r[5]);
                let t6 = _mm256_unpacklo_ps(r[6], r[7]);
                let t7 = _mm256_unpackhi_ps(r[6], r[7]);
                let u0 = _mm256_shuffle_ps::<0x44>(t0, t2);
                let u1 = _mm256_shuffle_ps::<0xee>(t0, t2);
                let u2 = _mm256_shuffle_ps::<0x44>(t1, t3);
                let u3 = _mm256_shuffle_ps::<0xee>(t1, t3);
                let u4 = _mm256_shuffle_ps::<0x44>(t4, t6);
                let u5 = _mm256_shuffle_ps::<0xee>(t4, t6);
                let u6 = _mm256_shuffle_ps::<0x44>(t5, t7);
                let u7 = _mm256_shuffle_ps::<0xee>(t5, t7);
                [
                    _mm256_permute2f128_ps::<0x20>(u0, u4),
                    _mm256_permute2f128_ps::<0x20>(u1, u5),
                    _mm256_permute2f128_ps::<0x20>(u2, u6),
                    _mm256_permute2f128_ps::<0x20>(u3, u7),
                    _mm256_permute2f128_ps::<0x31>(u0, u4),
                    _mm256_permute2f128_ps::<0x31>(u1, u5),
                    _mm256_permute2f128_ps::<0x31>(u2, u6),
                    _mm256_permute2f128_ps::<0x31>(u3, u7),
                ]
                .map(F32x8)
            }
        }
    }

    macro_rules! binary {
        ($trait:ident, $method:ident, $type:ident, $intrinsic:ident) => {
            impl $trait for $type {
                type Output = $type;
                #[inline(always)]
                fn $method(self, other: $type) -> $type {
                    unsafe { $type($intrinsic(self.0, other.0)) }
                }
            }
        };
    }
    binary!(Add, add, F32x8, _mm256_add_ps);
    binary!(Sub, sub, F32x8, _mm256_sub_ps);
    binary!(Mul, mul, F32x8, _mm256_mul_ps);
    binary!(Div, div, F32x8, _mm256_div_ps);
    binary!(BitAnd, bitand, Mask8, _mm256_and_ps);
    binary!(BitOr, bitor, Mask8, _mm256_or_ps);

    impl Not for Mask8 {
        type Output = Mask8;
        #[inline(always)]
        fn not(self) -> Mask8 {
            unsafe {
                let ones = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
                Mask8(_mm256_xor_ps(self.0, ones))
            }
        }
    }

    impl Lanes for F32x8 {
        type Mask = Mask8;
        type Array = [f32; 8];
        const WIDTH: usize = 8;
        #[inline(always)]
        fn splat(x: f32) -> Self {
            unsafe { F32x8(_mm256_set1_ps(x)) }
        }
        #[inline(always)]
        fn cmpeq(self, other: Self) -> Mask8 {
            unsafe { Mask8(_mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, other.0)) }
        }
        #[inline(always)]
        fn cmpne(self, other: Self) -> Mask8 {
            unsafe { Mask8(_mm256_cmp_ps::<_CMP_NEQ_UQ>(self.0, other.0)) }
        }
        #[inline(always)]
        fn cmplt(self, other: Self) -> Mask8 {
            unsafe { Mask8(_mm256_cmp_ps::<_CMP_LT_OQ>(self.0, other.0)) }
        }
        #[inline(always)]
        fn cmple(self, other: Self) -> Mask8 {
            unsafe { Mask8(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, other.0)) }
        }
        #[inline(always)]
        fn cmpgt(self, other: Self) -> Mask8 {
            unsafe { Mask8(_mm256_cmp_ps::<_CMP_GT_OQ>(self.0, other.0)) }
        }
        #[inline(always)]
        fn cmpge(self, other: Self) -> Mask8 {
            unsafe { Mask8(_mm256_cmp_ps::<_CMP_GE_OQ>(self.0, other.0)) }
        }
        #[inline(always)]
        fn abs(self) -> Self {
            unsafe {
                let magnitude = _mm256_castsi256_ps(_mm256_set1_epi32(i32::MAX));
                F32x8(_mm256_and_ps(self.0, magnitude))
            }
        }
        #[inline(always)]
        fn select(mask: Mask8, a: F32x8, b: F32x8) -> F32x8 {
            unsafe { F32x8(_mm256_blendv_ps(b.0, a.0, mask.0)) }
        }
        #[inline(always)]
        fn min(self, other: Self) -> Self {
            unsafe { F32x8(_mm256_min_ps(self.0, other.0)) }
        }
        #[inline(always)]
        fn max(self, other: Self) -> Self {
            unsafe { F32x8(_mm256_max_ps(self.0, other.0)) }
        }
        #[inline(always)]
        fn bits(mask: Mask8) -> u32 {
            unsafe { _mm256_movemask_ps(mask.0) as u32 }
        }
        #[inline(always)]
        fn mask(bits: u32) -> Mask8 {
            unsafe {
                let lane_bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
                let set = _mm256_and_si256(_mm256_set1_epi32(bits as i32), lane_bits);
                Mask8(_mm256_castsi256_ps(_mm256_cmpeq_epi32(set, lane_bits)))
            }
        }
        #[inline(always)]
        fn to_array(self) -> [f32; 8] {
            unsafe { std::mem::transmute::<__m256, [f32; 8]>(self.0) }
        }
        #[inline(always)]
        fn from_array(lanes: [f32; 8]) -> Self {
            Self::load(&lanes)
        }
        #[inline(always)]
        fn load(values: &[f32]) -> Self {
            let lanes = &values[..8];
            unsafe { F32x8(_mm256_loadu_ps(lanes.as_ptr())) }
        }
    }
}

#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
pub(crate) use avx512::F32x16;

/// Sixteen lanes in one AVX-512 register. The build targets x86-64-v3, so
/// these operations are inlined as AVX-512 instructions only into
/// functions compiled with `#[target_feature(enable = "avx512f")]`, which
/// run only where the CPU has it (`avx512::available`).
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
pub(crate) mod avx512 {
    // SAFETY (every `unsafe` below): the intrinsics need AVX-512F. These
    // types are private to the crate, and only code behind `available`
    // makes them (`Bvh::walk_sixteen` and a test); none touches memory but
    // its own locals and the slices it is given.
    use std::arch::x86_64::*;
    use std::ops::{Add, BitAnd, BitOr, Div, Mul, Not, Sub};

    use super::Lanes;

    /// Whether this CPU (and its OS) runs AVX-512F.
    #[inline]
    pub fn available() -> bool {
        std::arch::is_x86_feature_detected!("avx512f")
    }

    /// Sixteen f32 lanes.
    #[derive(Clone, Copy, Debug)]
    pub struct F32x16(__m512);

    /// A bit per lane.
    #[derive(Clone, Copy, Debug)]
    pub struct Mask16(u16);

    macro_rules! binary {
        ($trait:ident, $method:ident, $intrinsic:ident) => {
            impl $trait for F32x16 {
                type Output = F32x16;
                #[inline(always)]
                fn $method(self, other: F32x16) -> F32x16 {
                    unsafe { F32x16($intrinsic(self.0, other.0)) }
                }
            }
        };
    }
    binary!(Add, add, _mm512_add_ps);
    binary!(Sub, sub, _mm512_sub_ps);
    binary!(Mul, mul, _mm512_mul_ps);
    binary!(Div, div, _mm512_div_ps);

    impl BitAnd for Mask16 {
        type Output = Mask16;
        #[inline(always)]
        fn bitand(self, other: Mask16) -> Mask16 {
            Mask16(self.0 & other.0)
        }
    }

    impl BitOr for Mask16 {
        type Output = Mask16;
        #[inline(always)]
        fn bitor(self, other: Mask16) -> Mask16 {
            Mask16(self.0 | other.0)
        }
    }

    impl Not for Mask16 {
        type Output = Mask16;
        #[inline(always)]
        fn not(self) -> Mask16 {
            Mask16(!self.0)
        }
    }

    impl Lanes for F32x16 {
        type Mask = Mask16;
        type Array = [f32; 16];
        const WIDTH: usize = 16;
        #[inline(always)]
        fn splat(x: f32) -> Self {
            unsafe { F32x16(_mm512_set1_ps(x)) }
        }
        #[inline(always)]
        fn cmpeq(self, other: Self) -> Mask16 {
            unsafe { Mask16(_mm512_cmp_ps_mask::<_CMP_EQ_OQ>(self.0, other.0)) }
        }
        #[inline(always)]
        fn cmpne(self, other: Self) -> Mask16 {
            unsafe { Mask16(_mm512_cmp_ps_mask::<_CMP_NEQ_UQ>(self.0, other.0)) }
        }
        #[inline(always)]
        fn cmplt(self, other: Self) -> Mask16 {
            unsafe { Mask16(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(self.0, other.0)) }
        }
        #[inline(always)]
        fn cmple(self, other: Self) -> Mask16 {
            unsafe { Mask16(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(self.0, other.0)) }
        }
        #[inline(always)]
        fn cmpgt(self, other: Self) -> Mask16 {
            unsafe { Mask16(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(self.0, other.0)) }
        }
        #[inline(always)]
        fn cmpge(self, other: Self) -> Mask16 {
            unsafe { Mask16(_mm512_cmp_ps_mask::<_CMP_GE_OQ>(self.0, other.0)) }
        }
        #[inline(always)]
        fn abs(self) -> Self {
            unsafe { F32x16(_mm512_abs_ps(self.0)) }
        }
        #[inline(always)]
        fn select(mask: Mask16, a: F32x16, b: F32x16) -> F32x16 {
            unsafe { F32x16(_mm512_mask_blend_ps(mask.0, b.0, a.0)) }
        }
        #[inline(always)]
        fn min(self, other: Self) -> Self {
            unsafe { F32x16(_mm512_min_ps(self.0, other.0)) }
        }
        #[inline(always)]
        fn max(self, other: Self) -> Self {
            unsafe { F32x16(_mm512_max_ps(self.0, other.0)) }
        }
        #[inline(always)]
        fn bits(mask: Mask16) -> u32 {
            mask.0 as u32
        }
        #[inline(always)]
        fn mask(bits: u32) -> Mask16 {
            Mask16(bits as u16)
        }
        #[inline(always)]
        fn to_array(self) -> [f32; 16] {
            unsafe { std::mem::transmute::<__m512, [f32; 16]>(self.0) }
        }
        #[inline(always)]
        fn from_array(lanes: [f32; 16]) -> Self {
            Self::load(&lanes)
        }
        #[inline(always)]
        fn load(values: &[f32]) -> Self {
            let lanes = &values[..16];
            unsafe { F32x16(_mm512_loadu_ps(lanes.as_ptr())) }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every width agrees with scalar IEEE arithmetic and comparisons, NaN,
    /// infinities and signed zeros included.
    fn check<L: Lanes>() {
        let values = [
            0.0,
            -0.0,
            1.5,
            -2.25,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            3.0e-39,
        ];
        let n = L::WIDTH;
        for shift in 0..8 {
            let a: [f32; 16] = std::array::from_fn(|i| values[i % 8]);
            let b: [f32; 16] = std::array::from_fn(|i| values[(i + shift + i / 8) % 8]);
            let (x, y) = (L::load(&a), L::load(&b));
            let bits = |f: &dyn Fn(f32, f32) -> bool| {
                (0..n)
                    .filter(|&i| f(a[i], b[i]))
                    .map(|i| 1u32 << i)
                    .sum::<u32>()
            };
            assert_eq!(L::bits(x.cmpeq(y)), bits(&|p, q| p == q));
            assert_eq!(L::bits(x.cmpne(y)), bits(&|p, q| p != q));
            assert_eq!(L::bits(x.cmplt(y)), bits(&|p, q| p < q));
            assert_eq!(L::bits(x.cmple(y)), bits(&|p, q| p <= q));
            assert_eq!(L::bits(x.cmpgt(y)), bits(&|p, q| p > q));
            assert_eq!(L::bits(x.cmpge(y)), bits(&|p, q| p >= q));
            let lanes = |v: L| {
                v.to_array().as_ref()[..n]
                    .iter()
                    .map(|f| f.to_bits())
                    .collect::<Vec<_>>()
            };
            let expect = |f: &dyn Fn(f32, f32) -> f32| {
                (0..n).map(|i| f(a[i], b[i]).to_bits()).collect::<Vec<_>>()
            };
            let nan_safe = |v: Vec<u32>| {
                v.into_iter()
                    .map(|b| {
                        if f32::from_bits(b).is_nan() {
                            u32::MAX
                        } else {
                            b
                        }
                    })
                    .collect::<Vec<_>>()
            };
            assert_eq!(nan_safe(lanes(x + y)), nan_safe(expect(&|p, q| p + q)));
            assert_eq!(nan_safe(lanes(x - y)), nan_safe(expect(&|p, q| p - q)));
            assert_eq!(nan_safe(lanes(x * y)), nan_safe(expect(&|p, q| p * q)));
            assert_eq!(nan_safe(lanes(x / y)), nan_safe(expect(&|p, q| p / q)));
            assert_eq!(nan_safe(lanes(x.abs())), nan_safe(expect(&|p, _| p.abs())));
            // SSE's min and max: the second operand unless the first wins.
            assert_eq!(lanes(x.min(y)), expect(&|p, q| if p < q { p } else { q }));
            assert_eq!(lanes(x.max(y)), expect(&|p, q| if p > q { p } else { q }));
            assert_eq!(lanes(L::load(&b)), expect(&|_, q| q));
            let all = (1u32 << n) - 1;
            let mask = (shift as u32 * 0x9e37) & all;
            assert_eq!(L::bits(L::mask(mask)), mask);
            assert_eq!(L::bits(!L::mask(mask) & L::mask(all)), !mask & all);
            assert_eq!(L::bits(L::mask(mask) | L::mask(1)), mask | 1);
        }
    }

    #[test]
    fn four_lanes_are_ieee_lane_by_lane() {
        check::<Vec4>();
    }

    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    #[test]
    fn eight_lanes_are_ieee_lane_by_lane() {
        check::<F32x8>();
        let halves =
            F32x8::from_halves(Vec4::new(1.0, 2.0, 3.0, 4.0), Vec4::new(5.0, 6.0, 7.0, 8.0));
        assert_eq!(halves.to_array(), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
    }

    /// Sixteen lanes, where the CPU has AVX-512 (the check is compiled
    /// for it, so that the operations are the AVX-512 instructions).
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    #[test]
    fn sixteen_lanes_are_ieee_lane_by_lane() {
        #[target_feature(enable = "avx512f")]
        fn check_sixteen() {
            check::<F32x16>();
            let a: [f32; 16] = std::array::from_fn(|i| i as f32);
            let b: [f32; 16] = std::array::from_fn(|i| -(i as f32));
            let mask = F32x16::mask(0b1010_0000_1111_0001);
            let picked = F32x16::select(mask, F32x16::load(&a), F32x16::load(&b)).to_array();
            for i in 0..16 {
                let want = if 0b1010_0000_1111_0001 & (1 << i) != 0 {
                    a[i]
                } else {
                    b[i]
                };
                assert_eq!(picked[i], want, "lane {i}");
            }
        }
        if avx512::available() {
            // SAFETY: the CPU has AVX-512F.
            unsafe { check_sixteen() }
        } else {
            eprintln!("no AVX-512 on this CPU: sixteen lanes not checked");
        }
    }
}

#[cfg(all(target_arch = "x86_64", target_feature = "avx2", test))]
#[test]
fn eight_by_eight_transposes() {
    let rows: [F32x8; 8] =
        std::array::from_fn(|j| F32x8::from_array(std::array::from_fn(|i| (10 * j + i) as f32)));
    for (i, column) in F32x8::transpose(rows).iter().enumerate() {
        let want: [f32; 8] = std::array::from_fn(|j| (10 * j + i) as f32);
        assert_eq!(column.to_array(), want, "lane {i} of every row");
    }
}
