//! Area lights: emissive triangles, chosen for light sampling in proportion
//! to their power and sampled uniformly by area.

use glam::{Vec2, Vec3};

use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum, LAMBDA_MAX, LAMBDA_MIN};
use crate::texture::TextureRef;

/// What an emitter sends out: a spectral radiance, times a colour texture
/// (in [0, 1]) over the surface when there is one.
#[derive(Clone, Debug)]
pub struct Emitter {
    pub spectrum: Spectrum,
    pub texture: Option<TextureRef>,
}

impl Emitter {
    fn mean(&self) -> f64 {
        let m = self.spectrum.average(LAMBDA_MIN, LAMBDA_MAX).max(0.0) as f64;
        match &self.texture {
            Some(t) => m * (t.texture.mean_rgb().element_sum() / 3.0).max(0.0) as f64,
            None => m,
        }
    }
}

/// An emissive triangle.
#[derive(Clone, Debug)]
pub struct AreaLight {
    /// Index of the triangle in the scene (build order).
    pub prim: u32,
    /// Index into [`LightSet::emitters`].
    pub emission: u32,
    pub two_sided: bool,
    pub area: f32,
}

/// A point sampled on a light.
#[derive(Clone, Copy, Debug)]
pub struct LightPoint {
    pub p: Vec3,
    pub p_err: Vec3,
    /// Unit normal of the light's front face.
    pub n: Vec3,
    /// Barycentric coordinates of `p` for vertices 1 and 2.
    pub b: [f32; 2],
}

#[derive(Clone, Debug, Default)]
pub struct LightSet {
    pub lights: Vec<AreaLight>,
    /// What each distinct emitter sends out.
    pub emitters: Vec<Emitter>,
    /// Cumulative selection probabilities (last = 1).
    cdf: Vec<f32>,
    /// Selection probability of each light.
    pmf: Vec<f32>,
}

impl LightSet {
    pub fn new(lights: Vec<AreaLight>, emitters: Vec<Emitter>) -> Self {
        // Power ∝ area · (π per emitting side) · mean spectral radiance. The
        // plain spectral mean (not luminance) keeps every light that emits
        // anything selectable, also where the eye barely sees it. Textured
        // emitters count with their texture's mean.
        let mean: Vec<f64> = emitters.iter().map(Emitter::mean).collect();
        let power: Vec<f64> = lights
            .iter()
            .map(|l| {
                l.area as f64 * if l.two_sided { 2.0 } else { 1.0 } * mean[l.emission as usize]
            })
            .collect();
        let total: f64 = power.iter().sum();
        let (mut cdf, mut pmf) = (
            Vec::with_capacity(lights.len()),
            Vec::with_capacity(lights.len()),
        );
        let mut acc = 0.0;
        for p in &power {
            // Lights of zero power are never chosen (and never need to be).
            let w = if total > 0.0 { p / total } else { 0.0 };
            acc += w;
            pmf.push(w as f32);
            cdf.push(acc as f32);
        }
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        Self {
            lights,
            emitters,
            cdf,
            pmf,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty() || self.cdf.is_empty() || self.pmf.iter().all(|&p| p == 0.0)
    }

    /// Chooses a light; returns its index and selection probability.
    pub fn choose(&self, u: f32) -> Option<(usize, f32)> {
        if self.is_empty() {
            return None;
        }
        let i = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.cdf.len() - 1);
        let pmf = self.pmf[i];
        (pmf > 0.0).then_some((i, pmf))
    }

    pub fn pmf(&self, light: usize) -> f32 {
        self.pmf[light]
    }

    /// Radiance leaving light `light` at a point with front normal `n` and
    /// texture coordinates `uv` towards direction `w` (unit, pointing away
    /// from the light).
    pub fn emitted(
        &self,
        light: usize,
        n: Vec3,
        w: Vec3,
        uv: Vec2,
        wl: &SampledWavelengths,
    ) -> SampledSpectrum {
        let l = &self.lights[light];
        if !l.two_sided && n.dot(w) <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        let e = &self.emitters[l.emission as usize];
        let le = e.spectrum.sample(wl);
        match &e.texture {
            Some(t) => le * t.spectrum(uv, wl),
            None => le,
        }
    }

    /// A uniformly distributed point on light `light`'s triangle `tri`.
    pub fn sample_point(tri: &[Vec3; 3], u: (f32, f32)) -> LightPoint {
        let su = u.0.sqrt();
        let b = [1.0 - su, u.1 * su];
        let b2 = 1.0 - b[0] - b[1];
        let p = tri[0] * b[0] + tri[1] * b[1] + tri[2] * b2;
        let p_err = (tri[0] * b[0]).abs() + (tri[1] * b[1]).abs() + (tri[2] * b2).abs();
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
        LightPoint {
            p,
            p_err: p_err * crate::geometry::gamma(6),
            n,
            b: [b[1], b2],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn emitter(v: f32) -> Emitter {
        Emitter {
            spectrum: Spectrum::Constant(v),
            texture: None,
        }
    }

    #[test]
    fn selection_follows_power() {
        let lights = vec![
            AreaLight {
                prim: 0,
                emission: 0,
                two_sided: false,
                area: 1.0,
            },
            AreaLight {
                prim: 1,
                emission: 1,
                two_sided: false,
                area: 1.0,
            },
            AreaLight {
                prim: 2,
                emission: 0,
                two_sided: true,
                area: 1.0,
            },
        ];
        let set = LightSet::new(lights, vec![emitter(1.0), emitter(3.0)]);
        let pmf: Vec<f32> = (0..3).map(|i| set.pmf(i)).collect();
        assert!((pmf[0] - 1.0 / 6.0).abs() < 1e-6);
        assert!((pmf[1] - 3.0 / 6.0).abs() < 1e-6);
        assert!((pmf[2] - 2.0 / 6.0).abs() < 1e-6);
        assert_eq!(set.choose(0.0).unwrap().0, 0);
        assert_eq!(set.choose(0.3).unwrap().0, 1);
        assert_eq!(set.choose(0.99).unwrap().0, 2);
        let dark = LightSet::new(
            vec![AreaLight {
                prim: 0,
                emission: 0,
                two_sided: false,
                area: 1.0,
            }],
            vec![emitter(0.0)],
        );
        assert!(dark.choose(0.5).is_none());
    }

    #[test]
    fn triangle_points_are_uniform() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let mut s = crate::sampler::Sampler::new(1, 2);
        let n = 100_000;
        let mut mean = Vec3::ZERO;
        for _ in 0..n {
            let p = LightSet::sample_point(&tri, s.next_2d()).p;
            assert!(p.x >= 0.0 && p.y >= 0.0 && p.x + p.y <= 1.0 + 1e-6);
            mean += p / n as f32;
        }
        // Centroid (1/3, 1/3); standard error ≈ 0.24/√n.
        assert!(
            (mean - Vec3::new(1.0 / 3.0, 1.0 / 3.0, 0.0)).length() < 4e-3,
            "{mean}"
        );
    }
}
