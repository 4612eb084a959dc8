//! Metals: Fresnel reflection with a complex index n(λ) + ik(λ), smooth
//! (a mirror) or rough (GGX microfacets, visible-normal sampling).

use glam::Vec3;

use super::microfacet::{reflect, Ggx};
use super::{facing_frame, fresnel, reflected_pair, BsdfSample, ShadingGeometry};
use crate::geometry::Frame;
use crate::spectrum::SampledSpectrum;

#[derive(Clone, Copy, Debug)]
pub struct ConductorBsdf {
    frame: Frame,
    ng: Vec3,
    wo: Vec3,
    eta: SampledSpectrum,
    k: SampledSpectrum,
    ggx: Ggx,
}

impl ConductorBsdf {
    pub fn new(
        eta: SampledSpectrum,
        k: SampledSpectrum,
        alpha: f32,
        geom: &ShadingGeometry,
    ) -> Self {
        let (frame, ng) = facing_frame(geom);
        Self {
            frame,
            ng,
            wo: frame.to_local(geom.wo),
            eta,
            k,
            ggx: Ggx::new(alpha),
        }
    }

    pub fn frame(&self) -> &Frame {
        &self.frame
    }

    pub fn is_specular(&self) -> bool {
        self.ggx.is_smooth()
    }

    fn fresnel(&self, cos: f32) -> SampledSpectrum {
        SampledSpectrum::new(
            fresnel::conductor(cos, self.eta.x, self.k.x),
            fresnel::conductor(cos, self.eta.y, self.k.y),
            fresnel::conductor(cos, self.eta.z, self.k.z),
            fresnel::conductor(cos, self.eta.w, self.k.w),
        )
    }

    fn local_pair(&self, wi: Vec3) -> Option<(Vec3, Vec3)> {
        if self.is_specular() {
            return None;
        }
        reflected_pair(&self.frame, self.ng, self.wo, wi)
    }

    pub fn eval(&self, wi: Vec3) -> SampledSpectrum {
        let Some((wo, wi)) = self.local_pair(wi) else {
            return SampledSpectrum::ZERO;
        };
        let wm = (wo + wi).normalize();
        self.fresnel(wo.dot(wm).abs()) * self.ggx.reflection(wo, wi, wm)
    }

    pub fn pdf(&self, wi: Vec3) -> f32 {
        let Some((wo, wi)) = self.local_pair(wi) else {
            return 0.0;
        };
        let wm = (wo + wi).normalize();
        self.ggx.reflection_pdf(wo, wm)
    }

    pub fn sample(&self, u: (f32, f32)) -> Option<BsdfSample> {
        let wo = self.wo;
        if wo.z <= 0.0 {
            return None;
        }
        if self.is_specular() {
            let wi = self.frame.to_world(Vec3::new(-wo.x, -wo.y, wo.z));
            if wi.dot(self.ng) <= 0.0 {
                return None;
            }
            return Some(BsdfSample {
                wi,
                f: self.fresnel(wo.z) / wo.z,
                pdf: 1.0,
                specular: true,
                eta: 1.0,
            });
        }
        let wm = self.ggx.sample_wm(wo, u);
        let wi_local = reflect(wo, wm);
        if wi_local.z <= 0.0 {
            return None;
        }
        let wi = self.frame.to_world(wi_local);
        let pdf = self.pdf(wi);
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            f: self.eval(wi),
            pdf,
            specular: false,
            eta: 1.0,
        })
    }
}
