//! Glass and other dielectrics: Fresnel reflection and refraction between
//! two media, smooth (Dirac lobes) or rough (Walter, Marschner, Li &
//! Torrance 2007, with GGX visible-normal sampling). The relative index
//! η = n_inside / n_outside is per wavelength: a dispersive interface.

use glam::Vec3;

use super::bsdf::{BsdfEval, BsdfFlags, LobeSample, TransportMode};
use super::fresnel;
use super::microfacet::{reflect, Ggx};
use crate::spectrum::SampledSpectrum;

#[derive(Clone, Copy, Debug)]
pub struct DielectricLobe {
    /// n_inside / n_outside at each wavelength (local +z points outside).
    eta: SampledSpectrum,
    ggx: Ggx,
    /// Rough and dispersive: keep all wavelengths, each weighted by the
    /// average density over the four (Wilkie et al. 2014, hero MIS).
    spectral_mis: bool,
    /// Multiplies transmission at each crossing (glTF's base colour on a
    /// transmissive material); 1 for clear glass.
    tint: SampledSpectrum,
    /// η = 1 at every wavelength (an index-matched boundary).
    index_matched: bool,
}

/// Refracts `wi` through a surface with normal `n` (either side) and relative
/// index `eta` (inside / outside, n pointing outside). Returns the direction
/// and the η' of the crossing (n_transmitted / n_incident), or None (TIR).
pub fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<(Vec3, f32)> {
    let (mut n, mut eta) = (n, eta);
    let mut cos_i = n.dot(wi);
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
        n = -n;
    }
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some((-wi / eta + (cos_i / eta - cos_t) * n, eta))
}

/// Whether a relative index differs between the path's wavelengths: the
/// interface disperses them.
pub fn is_dispersive(eta: SampledSpectrum) -> bool {
    eta.x != eta.y || eta.x != eta.z || eta.x != eta.w
}

impl DielectricLobe {
    /// `secondaries_alive`: the path still carries all four wavelengths
    /// (spectral MIS must not average over terminated ones).
    pub fn new(eta: SampledSpectrum, alpha: f32, secondaries_alive: bool) -> Self {
        let ggx = Ggx::new(alpha);
        let index_matched = eta.to_array().iter().all(|&e| (e - 1.0).abs() <= 1e-6);
        Self {
            eta,
            ggx,
            spectral_mis: is_dispersive(eta) && !ggx.is_smooth() && secondaries_alive,
            tint: SampledSpectrum::ONE,
            index_matched,
        }
    }

    /// The lobe with its transmission multiplied by `tint` (in [0, 1]: a
    /// filter at the surface, symmetric in both directions).
    pub fn tinted(mut self, tint: SampledSpectrum) -> Self {
        self.tint = tint;
        self
    }

    /// Smooth, or index-matched: at η = 1 no microfacet bends light, so
    /// however rough the surface, light passes straight through (Fresnel
    /// reflects nothing) and only the tint acts.
    pub fn is_specular(&self) -> bool {
        self.ggx.is_smooth() || self.index_matched
    }

    pub fn flags(&self) -> BsdfFlags {
        let both = BsdfFlags::REFLECTION | BsdfFlags::TRANSMISSION;
        if self.is_specular() {
            both | BsdfFlags::SPECULAR
        } else {
            both | BsdfFlags::GLOSSY
        }
    }

    /// f and density of the rough lobes at one wavelength.
    fn rough(&self, wo: Vec3, wi: Vec3, eta: f32, mode: TransportMode) -> (f32, f32) {
        let (co, ci) = (wo.z, wi.z);
        if co == 0.0 || ci == 0.0 {
            return (0.0, 0.0);
        }
        let reflect = co * ci > 0.0;
        let etap = if reflect {
            1.0
        } else if co > 0.0 {
            eta
        } else {
            1.0 / eta
        };
        let wm = wi * etap + wo;
        if wm.length_squared() == 0.0 {
            return (0.0, 0.0);
        }
        let mut wm = wm.normalize();
        if wm.z < 0.0 {
            wm = -wm;
        }
        // Microfacets seen from behind contribute nothing.
        if wm.dot(wi) * ci < 0.0 || wm.dot(wo) * co < 0.0 {
            return (0.0, 0.0);
        }
        let r = fresnel::dielectric(wo.dot(wm), eta);
        let t = 1.0 - r;
        let (d, g) = (self.ggx.d(wm), self.ggx.g(wo, wi));
        if reflect {
            let f = d * g * r / (4.0 * ci * co).abs();
            let pdf = self.ggx.reflection_pdf(wo, wm) * r;
            (f, pdf)
        } else {
            let denom = wi.dot(wm) + wo.dot(wm) / etap;
            let denom = denom * denom;
            if denom == 0.0 {
                return (0.0, 0.0);
            }
            let f = d * g * t * (wi.dot(wm) * wo.dot(wm) / (ci * co * denom)).abs();
            let pdf = self.ggx.d_visible(wo, wm) * wi.dot(wm).abs() / denom * t;
            (f / radiance_scale(etap, mode), pdf)
        }
    }

    /// The density of sampling `wi`: the hero's, or with spectral MIS the
    /// average over the four wavelengths (any of which could be the hero).
    fn combined_pdf(&self, pdf: SampledSpectrum) -> f32 {
        if self.spectral_mis {
            pdf.element_sum() * 0.25
        } else {
            pdf.x
        }
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> BsdfEval {
        if self.is_specular() {
            return BsdfEval::ZERO;
        }
        let mut f = [0.0; 4];
        let mut pdf = [0.0; 4];
        for k in 0..4 {
            (f[k], pdf[k]) = self.rough(wo, wi, self.eta[k], mode);
        }
        let mut f = SampledSpectrum::from_array(f);
        if wo.z * wi.z < 0.0 {
            f *= self.tint;
        }
        BsdfEval {
            f,
            pdf: self.combined_pdf(SampledSpectrum::from_array(pdf)),
        }
    }

    pub fn sample(
        &self,
        wo: Vec3,
        uc: f32,
        u: (f32, f32),
        mode: TransportMode,
    ) -> Option<LobeSample> {
        self.sample_choosing(wo, |r| uc < r, u, mode)
            .map(|(sample, _)| sample)
    }

    /// Whether both lobes may be taken: not an index-matched boundary,
    /// which only transmits.
    pub fn has_two_lobes(&self) -> bool {
        !self.index_matched
    }

    /// The sample of one lobe, reflection (`reflect`) or transmission,
    /// with the probability `sample` would have given that lobe: weighted
    /// by it, the two lobes' samples together estimate what one of them
    /// drawn by `sample` does (the hero's Fresnel factor, at the sampled
    /// microfacet where the glass is rough).
    pub fn sample_lobe(
        &self,
        wo: Vec3,
        reflect: bool,
        u: (f32, f32),
        mode: TransportMode,
    ) -> Option<(LobeSample, f32)> {
        let (sample, r) = self.sample_choosing(wo, |_| reflect, u, mode)?;
        Some((sample, if reflect { r } else { 1.0 - r }))
    }

    /// A sample, the lobe chosen by `reflects(r)` where r is the hero's
    /// probability of reflection; with that r.
    #[inline(always)]
    fn sample_choosing(
        &self,
        wo: Vec3,
        reflects: impl FnOnce(f32) -> bool,
        u: (f32, f32),
        mode: TransportMode,
    ) -> Option<(LobeSample, f32)> {
        let eta = self.eta.x;
        if self.is_specular() {
            let r = fresnel::dielectric(wo.z, eta);
            if reflects(r) {
                let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                let f = self
                    .eta
                    .to_array()
                    .map(|e| fresnel::dielectric(wo.z, e) / wi.z.abs());
                let sample = LobeSample {
                    wi,
                    f: SampledSpectrum::from_array(f),
                    pdf: r,
                    flags: BsdfFlags::REFLECTION | BsdfFlags::SPECULAR,
                    eta: 1.0,
                };
                return Some((sample, r));
            }
            let (wi, etap) = refract(wo, Vec3::Z, eta)?;
            if wi.z == 0.0 {
                return None;
            }
            // A smooth dispersive interface has terminated the secondary
            // wavelengths: only the hero's value matters; the others get
            // their own Fresnel factor for the non-dispersive case.
            let scale = radiance_scale(etap, mode);
            let f = self
                .eta
                .to_array()
                .map(|e| (1.0 - fresnel::dielectric(wo.z, e)) / wi.z.abs() / scale);
            let sample = LobeSample {
                wi,
                f: SampledSpectrum::from_array(f) * self.tint,
                pdf: 1.0 - r,
                flags: BsdfFlags::TRANSMISSION | BsdfFlags::SPECULAR,
                eta: etap,
            };
            return Some((sample, r));
        }
        let wm = self.ggx.sample_wm(wo, u);
        let r = fresnel::dielectric(wo.dot(wm), eta);
        if reflects(r) {
            let wi = reflect(wo, wm);
            if wi.z * wo.z <= 0.0 {
                return None;
            }
            let flags = BsdfFlags::REFLECTION | BsdfFlags::GLOSSY;
            let sample = LobeSample::evaluated(wi, self.eval(wo, wi, mode), flags, 1.0);
            Some((sample, r))
        } else {
            let (wi, etap) = refract(wo, wm, eta)?;
            if wi.z * wo.z >= 0.0 || wi.z == 0.0 {
                return None;
            }
            let flags = BsdfFlags::TRANSMISSION | BsdfFlags::GLOSSY;
            let sample = LobeSample::evaluated(wi, self.eval(wo, wi, mode), flags, etap);
            Some((sample, r))
        }
    }
}

/// Radiance is compressed into the denser medium: it scales by 1/η'² on
/// refraction. Importance is not (the adjoint BSDF has no such factor).
fn radiance_scale(etap: f32, mode: TransportMode) -> f32 {
    match mode {
        TransportMode::Radiance => etap * etap,
        TransportMode::Importance => 1.0,
    }
}
