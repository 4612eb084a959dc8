//! Lambertian reflection: f = R/π, sampled by cosine-weighted directions.

use std::f32::consts::FRAC_1_PI;

use glam::Vec3;

use super::bsdf::{to_side_of, BsdfEval, BsdfFlags, LobeSample, TransportMode};
use super::cosine_hemisphere;
use crate::spectrum::SampledSpectrum;

#[derive(Clone, Copy, Debug)]
pub struct DiffuseLobe {
    reflectance: SampledSpectrum,
}

impl DiffuseLobe {
    #[inline]
    pub fn new(reflectance: SampledSpectrum) -> Self {
        Self {
            reflectance: reflectance.clamp(SampledSpectrum::ZERO, SampledSpectrum::ONE),
        }
    }

    /// A Lambertian lobe of a total radiance factor, which fluorescence
    /// may raise above 1 at the wavelengths it emits (its energy comes
    /// from other wavelengths).
    #[inline]
    pub fn radiance_factor(factor: SampledSpectrum) -> Self {
        Self {
            reflectance: factor.max(SampledSpectrum::ZERO),
        }
    }

    pub fn flags(&self) -> BsdfFlags {
        BsdfFlags::REFLECTION | BsdfFlags::DIFFUSE
    }

    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3, _mode: TransportMode) -> BsdfEval {
        if wo.z * wi.z <= 0.0 {
            return BsdfEval::ZERO;
        }
        BsdfEval {
            f: self.reflectance * FRAC_1_PI,
            pdf: wi.z.abs() * FRAC_1_PI,
        }
    }

    #[inline]
    pub fn sample(
        &self,
        wo: Vec3,
        _uc: f32,
        u: (f32, f32),
        mode: TransportMode,
    ) -> Option<LobeSample> {
        let wi = to_side_of(wo, cosine_hemisphere(u));
        let e = self.eval(wo, wi, mode);
        Some(LobeSample::evaluated(wi, e, self.flags(), 1.0))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Material, ShadingGeometry, TransportMode};
    use crate::sampler::Sampler;
    use crate::spectrum::{SampledWavelengths, Spectrum};

    #[test]
    fn albedo_is_the_reflectance_and_sampling_matches_pdf() {
        let m = Material::Diffuse {
            reflectance: Spectrum::Constant(0.7).into(),
        };
        let geom = ShadingGeometry {
            ng: Vec3::Z,
            ns: Vec3::Z,
            wo: Vec3::new(0.3, 0.0, 0.9).normalize(),
        };
        let mode = TransportMode::Radiance;
        let bsdf = m.bsdf(
            &geom,
            glam::Vec2::ZERO,
            &mut SampledWavelengths::sample_visible(0.5),
            SampledSpectrum::ONE,
        );
        let mut s = Sampler::new(3, 4);
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let smp = bsdf.sample(geom.wo, 0.5, s.next_2d(), mode).unwrap();
            assert!((smp.pdf - bsdf.pdf(geom.wo, smp.wi, mode)).abs() < 1e-5);
            assert_eq!(smp.f, bsdf.f(geom.wo, smp.wi, mode));
            sum += (smp.f.x * bsdf.cos_theta(smp.wi) / smp.pdf) as f64;
        }
        assert!((sum / n as f64 - 0.7).abs() < 1e-4);
        // Back side of the surface: both faces reflect, light never passes.
        let back = ShadingGeometry {
            wo: -geom.wo,
            ..geom
        };
        let b = m.bsdf(
            &back,
            glam::Vec2::ZERO,
            &mut SampledWavelengths::sample_visible(0.5),
            SampledSpectrum::ONE,
        );
        assert!(b.f(back.wo, -Vec3::Z, mode).x > 0.0);
        assert_eq!(b.f(back.wo, Vec3::Z, mode).x, 0.0);
        // The BSDF built for the front answers for the back too.
        assert_eq!(
            bsdf.f(back.wo, -Vec3::Z, mode),
            b.f(back.wo, -Vec3::Z, mode)
        );
    }
}
