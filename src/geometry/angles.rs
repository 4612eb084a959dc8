//! The angles of directions, for texture coordinates on spheres and
//! latitude-longitude maps: atan2 in f32, inline and without libm's call
//! (libm's atan2f and acosf were 4% of a render under an environment map
//! with spheres). Both polar angles come from atan2 of the sine and the
//! cosine, which keeps its precision near the poles, where acos of the
//! cosine loses it.

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// tan(π/8): above it, atan(t) is taken as π/4 + atan((t − 1)/(t + 1)).
const TAN_PI_8: f32 = 0.414_213_57;

/// atan(t) for t in [0, 1], within 2e-7 radians.
#[inline]
fn atan_unit(t: f32) -> f32 {
    let (base, x) = if t > TAN_PI_8 {
        (FRAC_PI_4, (t - 1.0) / (t + 1.0))
    } else {
        (0.0, t)
    };
    // |x| ≤ tan(π/8): Cephes' atanf polynomial (S. L. Moshier).
    let z = x * x;
    let p = ((0.080_537_446 * z - 0.138_776_85) * z + 0.199_777_11) * z - 0.333_329_5;
    base + (p * z * x + x)
}

/// The angle of (x, y) from +x towards +y, in [−π, π], as `f32::atan2`
/// gives it, within two ulps of π (4.8e-7 radians). (0, 0) gives 0.
#[inline]
pub fn atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    if hi == 0.0 {
        return 0.0;
    }
    // The angle in the first octant, then unfolded: about the diagonal,
    // the y axis and the x axis.
    let mut a = atan_unit(lo / hi);
    if ay > ax {
        a = FRAC_PI_2 - a;
    }
    if x < 0.0 {
        a = PI - a;
    }
    a.copysign(y)
}

/// The angle between unit vector `w` and the axis whose component is
/// `cos` (the other two components `a`, `b`): acos(cos), but from atan2
/// of the sine and cosine, exact near the poles too.
#[inline]
pub fn polar_angle(cos: f32, a: f32, b: f32) -> f32 {
    atan2((a * a + b * b).sqrt(), cos)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan2_agrees_with_libm_within_two_ulps_of_pi() {
        let mut worst = 0.0f32;
        let n = 2000;
        for i in 0..n {
            // Every direction of the circle, and radii from tiny to huge.
            let phi = (i as f32 + 0.37) / n as f32 * 2.0 * PI - PI;
            for r in [1e-30f32, 1e-3, 1.0, 7.5, 1e20] {
                let (y, x) = (r * phi.sin(), r * phi.cos());
                worst = worst.max((atan2(y, x) - y.atan2(x)).abs());
            }
        }
        assert!(worst <= 4.8e-7, "{worst}");
        // The axes and the diagonals within one ulp of π, and the sign
        // that libm gives signed zeros.
        for (y, x) in [
            (0.0f32, 1.0f32),
            (1.0, 0.0),
            (0.0, -1.0),
            (-1.0, 0.0),
            (1.0, 1.0),
            (-1.0, -1.0),
            (-0.0, -1.0),
            (-0.0, 1.0),
        ] {
            assert!((atan2(y, x) - y.atan2(x)).abs() <= 2.4e-7, "({y}, {x})");
            assert_eq!(
                atan2(y, x).is_sign_negative(),
                y.atan2(x).is_sign_negative()
            );
        }
        assert_eq!(atan2(0.0, 0.0), 0.0);
    }

    #[test]
    fn polar_angle_recovers_the_angle_of_a_direction() {
        for i in 0..=1000 {
            let theta = i as f32 / 1000.0 * PI;
            let (s, c) = theta.sin_cos();
            let (a, b) = (s * 0.6, s * 0.8);
            let got = polar_angle(c, a, b);
            assert!((got - theta).abs() <= 4e-7, "θ {theta}: {got}");
        }
    }
}
