//! Cosine-weighted directions on the hemisphere: what diffuse lobes
//! sample and diffuse lights emit.

use glam::Vec3;

/// Cosine-weighted direction on the +z hemisphere (Malley's method over a
/// concentric disk sample).
///
/// Shirley and Chiu's concentric map: the wedge |x| > |y| takes the angle
/// π/4·(y/x), the other π/2 − π/4·(x/y), whose cosine and sine are the
/// sine and cosine of π/4·(x/y). Both angles are in [−π/4, π/4], where
/// Taylor polynomials of degree 9 (sine) and 8 (cosine) are exact to
/// single precision: no libm call. (Choosing the wedge by vector selects
/// instead of the branches the compiler makes of these measured the same.)
#[inline(always)]
pub fn cosine_hemisphere(u: (f32, f32)) -> Vec3 {
    let (ox, oy) = (2.0 * u.0 - 1.0, 2.0 * u.1 - 1.0);
    let first_wedge = ox.abs() > oy.abs();
    let (r, other) = if first_wedge { (ox, oy) } else { (oy, ox) };
    // r is 0 only at the disk's centre (then both are), where any angle will do.
    let t = if r == 0.0 { 0.0 } else { other / r };
    let phi = std::f32::consts::FRAC_PI_4 * t;
    let p2 = phi * phi;
    let sin = phi
        * (1.0
            + p2 * (-1.0 / 6.0
                + p2 * (1.0 / 120.0 + p2 * (-1.0 / 5040.0 + p2 * (1.0 / 362_880.0)))));
    let cos = 1.0 + p2 * (-0.5 + p2 * (1.0 / 24.0 + p2 * (-1.0 / 720.0 + p2 * (1.0 / 40_320.0))));
    let (x, y) = if first_wedge {
        (r * cos, r * sin)
    } else {
        (r * sin, r * cos)
    };
    // x² + y² is r²: z from r alone, without waiting on the polynomials.
    Vec3::new(x, y, (1.0 - r * r).max(0.0).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The concentric map with libm's sine and cosine, as it was written
    /// before the polynomials.
    fn with_libm(u: (f32, f32)) -> Vec3 {
        let (ox, oy) = (2.0 * u.0 - 1.0, 2.0 * u.1 - 1.0);
        let (r, phi) = if ox == 0.0 && oy == 0.0 {
            (0.0, 0.0)
        } else if ox.abs() > oy.abs() {
            (ox, std::f32::consts::FRAC_PI_4 * (oy / ox))
        } else {
            (
                oy,
                std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (ox / oy),
            )
        };
        let (x, y) = (r * phi.cos(), r * phi.sin());
        Vec3::new(x, y, (1.0 - x * x - y * y).max(0.0).sqrt())
    }

    #[test]
    fn the_polynomials_agree_with_libm_to_single_precision() {
        let n = 257;
        let mut worst = 0.0f32;
        for i in 0..n {
            for j in 0..n {
                let u = (i as f32 / (n - 1) as f32, j as f32 / (n - 1) as f32);
                let u = (u.0.min(0.999_999_94), u.1.min(0.999_999_94));
                let (a, b) = (cosine_hemisphere(u), with_libm(u));
                // z is a square root of 1 − x² − y², which near the rim
                // is a small difference: compare its square.
                worst = worst
                    .max((a.x - b.x).abs())
                    .max((a.y - b.y).abs())
                    .max((a.z * a.z - b.z * b.z).abs());
                assert!((a.length() - 1.0).abs() < 1e-6, "{u:?}: |{a}| ≠ 1");
                assert!(a.z >= 0.0);
            }
        }
        // A few units in the last place of numbers up to 1.
        assert!(worst < 1e-6, "largest difference {worst}");
    }

    #[test]
    fn the_centre_and_the_wedges_borders_map_where_they_should() {
        assert_eq!(cosine_hemisphere((0.5, 0.5)), Vec3::Z);
        let d = cosine_hemisphere((1.0, 1.0));
        let s = std::f32::consts::FRAC_1_SQRT_2;
        assert!((d - Vec3::new(s, s, 0.0)).length() < 1e-6, "{d}");
        let d = cosine_hemisphere((0.0, 1.0));
        assert!((d - Vec3::new(-s, s, 0.0)).length() < 1e-6, "{d}");
    }
}
