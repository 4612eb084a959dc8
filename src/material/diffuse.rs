//! Lambertian reflection: f = R/π, sampled by cosine-weighted directions.

use std::f32::consts::FRAC_1_PI;

use glam::Vec3;

use super::{cosine_hemisphere, facing_frame, BsdfSample, ShadingGeometry};
use crate::geometry::Frame;
use crate::spectrum::SampledSpectrum;

#[derive(Clone, Copy, Debug)]
pub struct DiffuseBsdf {
    reflectance: SampledSpectrum,
    frame: Frame,
    /// Geometric normal on the side of `wo`: light never passes through.
    ng: Vec3,
}

impl DiffuseBsdf {
    pub fn new(reflectance: SampledSpectrum, geom: &ShadingGeometry) -> Self {
        let (frame, ng) = facing_frame(geom);
        Self {
            reflectance: reflectance.clamp(SampledSpectrum::ZERO, SampledSpectrum::ONE),
            frame,
            ng,
        }
    }

    pub fn frame(&self) -> &Frame {
        &self.frame
    }

    pub fn eval(&self, wi: Vec3) -> SampledSpectrum {
        if wi.dot(self.ng) <= 0.0 || wi.dot(self.frame.n) <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        self.reflectance * FRAC_1_PI
    }

    pub fn pdf(&self, wi: Vec3) -> f32 {
        if wi.dot(self.ng) <= 0.0 {
            return 0.0;
        }
        wi.dot(self.frame.n).max(0.0) * FRAC_1_PI
    }

    pub fn sample(&self, u: (f32, f32)) -> Option<BsdfSample> {
        let local = cosine_hemisphere(u);
        let wi = self.frame.to_world(local);
        let pdf = self.pdf(wi);
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            f: self.reflectance * FRAC_1_PI,
            pdf,
            specular: false,
            eta: 1.0,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{Bsdf, Material};
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
            let smp = bsdf.sample(0.5, s.next_2d()).unwrap();
            assert!((smp.pdf - bsdf.pdf(smp.wi)).abs() < 1e-5);
            assert_eq!(smp.f, bsdf.eval(smp.wi));
            sum += (smp.f.x * bsdf.cos_theta(smp.wi) / smp.pdf) as f64;
        }
        assert!((sum / n as f64 - 0.7).abs() < 1e-4);
        // Back side of the surface: the frame flips, reflection still works.
        let back = ShadingGeometry {
            wo: -geom.wo,
            ..geom
        };
        let Bsdf::Diffuse(b) = m.bsdf(
            &back,
            glam::Vec2::ZERO,
            &mut SampledWavelengths::sample_visible(0.5),
            SampledSpectrum::ONE,
        ) else {
            panic!("a diffuse material gives a diffuse BSDF");
        };
        assert!(b.eval(-Vec3::Z).x > 0.0 && b.eval(Vec3::Z).x == 0.0);
    }
}
