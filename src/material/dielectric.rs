//! Glass and other dielectrics: Fresnel reflection and refraction between
//! two media, smooth (Dirac lobes) or rough (Walter, Marschner, Li &
//! Torrance 2007, with GGX visible-normal sampling). The relative index
//! η = n_inside / n_outside is per wavelength: a dispersive interface.

use glam::Vec3;

use super::microfacet::{reflect, Ggx};
use super::{fresnel, BsdfSample, ShadingGeometry};
use crate::geometry::Frame;
use crate::spectrum::SampledSpectrum;

#[derive(Clone, Copy, Debug)]
pub struct DielectricBsdf {
    /// Shading frame on the front (outside) face: +z points outside.
    frame: Frame,
    ng: Vec3,
    wo: Vec3,
    /// n_inside / n_outside at each wavelength.
    eta: SampledSpectrum,
    ggx: Ggx,
    /// Rough and dispersive: keep all wavelengths, each weighted by the
    /// average density over the four (Wilkie et al. 2014, hero MIS).
    spectral_mis: bool,
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

impl DielectricBsdf {
    /// `geom.ng` must be the front-face normal (not flipped towards `wo`).
    /// `secondaries_alive`: the path still carries all four wavelengths
    /// (spectral MIS must not average over terminated ones).
    pub fn new(
        eta: SampledSpectrum,
        alpha: f32,
        geom: &ShadingGeometry,
        secondaries_alive: bool,
    ) -> Self {
        let ns = if geom.ns.dot(geom.ng) < 0.0 {
            -geom.ns
        } else {
            geom.ns
        };
        let frame = Frame::from_normal(ns);
        let ggx = Ggx::new(alpha);
        let dispersive = is_dispersive(eta);
        Self {
            frame,
            ng: geom.ng,
            wo: frame.to_local(geom.wo),
            eta,
            ggx,
            spectral_mis: dispersive && !ggx.is_smooth() && secondaries_alive,
        }
    }

    pub fn frame(&self) -> &Frame {
        &self.frame
    }

    pub fn is_specular(&self) -> bool {
        self.ggx.is_smooth()
    }

    /// Reflection must stay on the side of the geometric surface it came
    /// from and transmission must cross it, whatever the shading normal says.
    fn geometry_agrees(&self, wi: Vec3, reflect: bool) -> bool {
        let wo_world = self.frame.to_world(self.wo);
        let same_side = wo_world.dot(self.ng) * wi.dot(self.ng) > 0.0;
        same_side == reflect
    }

    /// f and density of the rough lobes at one wavelength (local directions).
    fn rough(&self, wo: Vec3, wi: Vec3, eta: f32) -> (f32, f32) {
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
            // Radiance is compressed into the denser medium: divide by η'².
            let f = d * g * t * (wi.dot(wm) * wo.dot(wm) / (ci * co * denom)).abs() / (etap * etap);
            let pdf = self.ggx.d_visible(wo, wm) * wi.dot(wm).abs() / denom * t;
            (f, pdf)
        }
    }

    fn rough_all(&self, wi_world: Vec3) -> (SampledSpectrum, SampledSpectrum) {
        let wi = self.frame.to_local(wi_world);
        let reflect = self.wo.z * wi.z > 0.0;
        if !self.geometry_agrees(wi_world, reflect) {
            return (SampledSpectrum::ZERO, SampledSpectrum::ZERO);
        }
        let mut f = [0.0; 4];
        let mut pdf = [0.0; 4];
        for k in 0..4 {
            (f[k], pdf[k]) = self.rough(self.wo, wi, self.eta[k]);
        }
        (
            SampledSpectrum::from_array(f),
            SampledSpectrum::from_array(pdf),
        )
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

    pub fn eval(&self, wi: Vec3) -> SampledSpectrum {
        if self.is_specular() {
            return SampledSpectrum::ZERO;
        }
        self.rough_all(wi).0
    }

    pub fn pdf(&self, wi: Vec3) -> f32 {
        if self.is_specular() {
            return 0.0;
        }
        self.combined_pdf(self.rough_all(wi).1)
    }

    pub fn sample(&self, uc: f32, u: (f32, f32)) -> Option<BsdfSample> {
        let wo = self.wo;
        let eta = self.eta.x;
        if self.is_specular() {
            let r = fresnel::dielectric(wo.z, eta);
            if uc < r {
                let wi = Vec3::new(-wo.x, -wo.y, wo.z);
                let f = self
                    .eta
                    .to_array()
                    .map(|e| fresnel::dielectric(wo.z, e) / wi.z.abs());
                let wi = self.frame.to_world(wi);
                return self.geometry_agrees(wi, true).then_some(BsdfSample {
                    wi,
                    f: SampledSpectrum::from_array(f),
                    pdf: r,
                    specular: true,
                    eta: 1.0,
                });
            }
            let (wi, etap) = refract(wo, Vec3::Z, eta)?;
            if wi.z == 0.0 {
                return None;
            }
            // A smooth dispersive interface has terminated the secondary
            // wavelengths: only the hero's value matters; the others get
            // their own Fresnel factor for the non-dispersive case.
            let f = self
                .eta
                .to_array()
                .map(|e| (1.0 - fresnel::dielectric(wo.z, e)) / wi.z.abs() / (etap * etap));
            let wi_world = self.frame.to_world(wi);
            return self.geometry_agrees(wi_world, false).then_some(BsdfSample {
                wi: wi_world,
                f: SampledSpectrum::from_array(f),
                pdf: 1.0 - r,
                specular: true,
                eta: etap,
            });
        }
        let wm = self.ggx.sample_wm(wo, u);
        let r = fresnel::dielectric(wo.dot(wm), eta);
        let (wi, etap) = if uc < r {
            let wi = reflect(wo, wm);
            if wi.z * wo.z <= 0.0 {
                return None;
            }
            (wi, 1.0)
        } else {
            let (wi, etap) = refract(wo, wm, eta)?;
            if wi.z * wo.z >= 0.0 || wi.z == 0.0 {
                return None;
            }
            (wi, etap)
        };
        let wi_world = self.frame.to_world(wi);
        let (f, pdfs) = self.rough_all(wi_world);
        let pdf = self.combined_pdf(pdfs);
        if pdf <= 0.0 || !pdf.is_finite() {
            return None;
        }
        Some(BsdfSample {
            wi: wi_world,
            f,
            pdf,
            specular: false,
            eta: etap,
        })
    }
}
