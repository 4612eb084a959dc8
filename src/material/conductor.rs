//! Metals: Fresnel reflection with a complex index n(λ) + ik(λ), smooth
//! (a mirror) or rough (GGX microfacets, visible-normal sampling).

use glam::Vec3;

use super::bsdf::{to_side_of, upper, BsdfEval, BsdfFlags, LobeSample, TransportMode};
use super::fresnel;
use super::microfacet::{reflect, Ggx};
use crate::spectrum::SampledSpectrum;

#[derive(Clone, Copy, Debug)]
pub struct ConductorLobe {
    eta: SampledSpectrum,
    k: SampledSpectrum,
    ggx: Ggx,
}

impl ConductorLobe {
    pub fn new(eta: SampledSpectrum, k: SampledSpectrum, alpha: f32) -> Self {
        Self {
            eta,
            k,
            ggx: Ggx::new(alpha),
        }
    }

    pub fn flags(&self) -> BsdfFlags {
        if self.ggx.is_smooth() {
            BsdfFlags::REFLECTION | BsdfFlags::SPECULAR
        } else {
            BsdfFlags::REFLECTION | BsdfFlags::GLOSSY
        }
    }

    fn fresnel(&self, cos: f32) -> SampledSpectrum {
        SampledSpectrum::new(
            fresnel::conductor(cos, self.eta.x, self.k.x),
            fresnel::conductor(cos, self.eta.y, self.k.y),
            fresnel::conductor(cos, self.eta.z, self.k.z),
            fresnel::conductor(cos, self.eta.w, self.k.w),
        )
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3, _mode: TransportMode) -> BsdfEval {
        let (wo, wi) = upper(wo, wi);
        if self.ggx.is_smooth() || wi.z <= 0.0 {
            return BsdfEval::ZERO;
        }
        let wm = (wo + wi).normalize();
        BsdfEval {
            f: self.fresnel(wo.dot(wm).abs()) * self.ggx.reflection(wo, wi, wm),
            pdf: self.ggx.reflection_pdf(wo, wm),
        }
    }

    pub fn sample(
        &self,
        wo: Vec3,
        _uc: f32,
        u: (f32, f32),
        mode: TransportMode,
    ) -> Option<LobeSample> {
        let (up, _) = upper(wo, wo);
        if self.ggx.is_smooth() {
            return Some(LobeSample {
                wi: Vec3::new(-wo.x, -wo.y, wo.z),
                f: self.fresnel(up.z) / up.z,
                pdf: 1.0,
                flags: self.flags(),
                eta: 1.0,
            });
        }
        let wi = reflect(up, self.ggx.sample_wm(up, u));
        if wi.z <= 0.0 {
            return None;
        }
        let wi = to_side_of(wo, wi);
        Some(LobeSample::evaluated(
            wi,
            self.eval(wo, wi, mode),
            self.flags(),
            1.0,
        ))
    }
}
