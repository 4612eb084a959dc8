//! The glTF 2.0 metallic-roughness BRDF, evaluated per wavelength:
//!
//! f = (1 − m)·[f_diffuse + F_d·S] + m·F_c·S
//!
//! with S = D·G / (4 |cos θo| |cos θi|) a GGX specular lobe (α = roughness²),
//! F_d = Schlick's Fresnel with F0 = ((η − 1)/(η + 1))² for the dielectric
//! coat, F_c = C + (1 − C)(1 − |ωo·ωm|)⁵ for the metal (both at the half
//! vector), C the base colour spectrum and m the metalness — the lobes of
//! the glTF specification's Appendix B.
//!
//! One deliberate difference: the specification weights the diffuse base by
//! (1 − F_d(ωo·ωm)), which gains energy at grazing angles (a white base
//! reflects 1.106 of the light at 70°: measured by tests/bsdf.rs). We couple
//! the base to the coat as Ashikhmin & Shirley (2000) do instead,
//! f_diffuse = 28/(23π)·C·(1 − F0)·(1 − (1 − cos θi/2)⁵)·(1 − (1 − cos θo/2)⁵),
//! which is reciprocal and never reflects more than arrives.
//! Sampling picks the specular lobe (visible normals) or the diffuse one
//! (cosine) by their estimated weights.

use std::f32::consts::{FRAC_1_PI, PI};

use glam::Vec3;

use super::bsdf::{to_side_of, upper, BsdfEval, BsdfFlags, LobeSample, TransportMode};
use super::cosine_hemisphere;
use super::microfacet::{reflect, Ggx};
use crate::spectrum::SampledSpectrum;

/// Smallest α used: below it the specular lobe would be a Dirac delta and a
/// mixture of a delta and a diffuse lobe cannot be MIS-weighted per sample.
pub const MIN_ALPHA: f32 = 2e-3;

#[derive(Clone, Copy, Debug)]
pub struct PbrLobe {
    base: SampledSpectrum,
    metallic: f32,
    f0: f32,
    ggx: Ggx,
    mean_base: f32,
}

fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

impl PbrLobe {
    /// `base` in [0, 1] per wavelength, `metallic` in [0, 1], `ior` of the
    /// dielectric coat (glTF's default is 1.5).
    pub fn new(base: SampledSpectrum, metallic: f32, alpha: f32, ior: f32) -> Self {
        let base = base.clamp(SampledSpectrum::ZERO, SampledSpectrum::ONE);
        Self {
            base,
            metallic: metallic.clamp(0.0, 1.0),
            f0: ((ior - 1.0) / (ior + 1.0)).powi(2),
            ggx: Ggx::new(alpha.max(MIN_ALPHA)),
            mean_base: base.element_sum() * 0.25,
        }
    }

    pub fn flags(&self) -> BsdfFlags {
        if self.metallic < 1.0 {
            BsdfFlags::REFLECTION | BsdfFlags::DIFFUSE | BsdfFlags::GLOSSY
        } else {
            BsdfFlags::REFLECTION | BsdfFlags::GLOSSY
        }
    }

    /// Probability of sampling the specular lobe, from the lobes' weights
    /// as seen from `wo` (macro-normal Fresnel estimate).
    fn p_specular(&self, wo: Vec3) -> f32 {
        let (metallic, f0, mean_base) = (self.metallic, self.f0, self.mean_base);
        let w = schlick_weight(wo.z.abs());
        let spec = metallic * (mean_base + (1.0 - mean_base) * w)
            + (1.0 - metallic) * (f0 + (1.0 - f0) * w);
        let diff = (1.0 - metallic) * (1.0 - f0) * mean_base;
        if spec + diff > 0.0 {
            // Never starve either lobe entirely while it contributes.
            let p = spec / (spec + diff);
            if diff > 0.0 {
                p.clamp(0.1, 0.9)
            } else {
                1.0
            }
        } else {
            1.0
        }
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3, _mode: TransportMode) -> BsdfEval {
        let (wo, wi) = upper(wo, wi);
        if wi.z <= 0.0 {
            return BsdfEval::ZERO;
        }
        let wm = (wo + wi).normalize();
        let w = schlick_weight(wo.dot(wm).abs());
        let s = self.ggx.reflection(wo, wi, wm);
        let f_d = self.f0 + (1.0 - self.f0) * w;
        let f_c = self.base + (SampledSpectrum::ONE - self.base) * w;
        let coupling = 28.0 / (23.0 * PI)
            * (1.0 - self.f0)
            * (1.0 - schlick_weight(0.5 * wi.z))
            * (1.0 - schlick_weight(0.5 * wo.z));
        let dielectric = self.base * coupling + SampledSpectrum::splat(f_d * s);
        let p_specular = self.p_specular(wo);
        BsdfEval {
            f: dielectric * (1.0 - self.metallic) + f_c * (self.metallic * s),
            pdf: p_specular * self.ggx.reflection_pdf(wo, wm)
                + (1.0 - p_specular) * wi.z * FRAC_1_PI,
        }
    }

    pub fn sample(
        &self,
        wo: Vec3,
        uc: f32,
        u: (f32, f32),
        mode: TransportMode,
    ) -> Option<LobeSample> {
        let (up, _) = upper(wo, wo);
        let (wi, lobe) = if uc < self.p_specular(up) {
            (reflect(up, self.ggx.sample_wm(up, u)), BsdfFlags::GLOSSY)
        } else {
            (cosine_hemisphere(u), BsdfFlags::DIFFUSE)
        };
        if wi.z <= 0.0 {
            return None;
        }
        let wi = to_side_of(wo, wi);
        let e = self.eval(wo, wi, mode);
        Some(LobeSample::evaluated(
            wi,
            e,
            BsdfFlags::REFLECTION | lobe,
            1.0,
        ))
    }
}
