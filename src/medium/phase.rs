//! The Henyey–Greenstein phase function (1941): one parameter g, the mean
//! cosine of the scattering angle (g > 0 forward, g < 0 backward, 0
//! isotropic). Normalised over the sphere, sampled exactly (value = density).

use std::f32::consts::PI;

use glam::Vec3;

use crate::geometry::Frame;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HenyeyGreenstein {
    pub g: f32,
}

impl HenyeyGreenstein {
    /// The density for light travelling along `dir_in` to leave along
    /// `dir_out` (both unit, in the direction of propagation).
    #[inline]
    pub fn p(&self, dir_in: Vec3, dir_out: Vec3) -> f32 {
        hg(dir_in.dot(dir_out), self.g)
    }

    /// Samples an outgoing direction for light travelling along `dir_in`;
    /// returns it with its density (equal to `p`).
    #[inline]
    pub fn sample(&self, dir_in: Vec3, u: (f32, f32)) -> (Vec3, f32) {
        let g = self.g;
        let cos = if g.abs() < 1e-3 {
            1.0 - 2.0 * u.0
        } else {
            let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u.0);
            (1.0 + g * g - s * s) / (2.0 * g)
        }
        .clamp(-1.0, 1.0);
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = 2.0 * PI * u.1;
        let local = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
        let dir_out = Frame::from_normal(dir_in).to_world(local).normalize();
        (dir_out, hg(cos, g))
    }
}

#[inline]
fn hg(cos: f32, g: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos;
    (1.0 - g * g) / (4.0 * PI * denom * denom.max(1e-12).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_to_one_and_has_mean_cosine_g() {
        for g in [-0.7, 0.0, 0.3, 0.9] {
            let n = 200_000;
            let (mut total, mut mean) = (0.0f64, 0.0f64);
            for i in 0..n {
                let cos = -1.0 + 2.0 * (i as f32 + 0.5) / n as f32;
                let w = hg(cos, g) as f64 * 2.0 * PI as f64 * (2.0 / n as f64);
                total += w;
                mean += w * cos as f64;
            }
            assert!((total - 1.0).abs() < 1e-3, "g {g}: ∫p = {total}");
            assert!((mean - g as f64).abs() < 2e-3, "g {g}: mean cos = {mean}");
        }
    }

    #[test]
    fn sampling_matches_the_density() {
        let hgf = HenyeyGreenstein { g: 0.6 };
        let dir = Vec3::new(0.3, -0.2, 0.9).normalize();
        let n = 100_000;
        let mut mean_cos = 0.0f64;
        for i in 0..n {
            let u = ((i as f32 + 0.5) / n as f32, (i as f32 * 0.618_034).fract());
            let (w, pdf) = hgf.sample(dir, u);
            assert!((w.length() - 1.0).abs() < 1e-4);
            assert!((pdf - hgf.p(dir, w)).abs() <= 1e-3 * pdf.max(1.0));
            mean_cos += dir.dot(w) as f64;
        }
        assert!((mean_cos / n as f64 - 0.6).abs() < 3e-3);
    }
}
