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
//!
//! Layers of the glTF extensions ([`LobeLayers`]):
//! - KHR_materials_specular: the dielectric Fresnel becomes
//!   s·(F0·c + (1 − F0·c)·w) (specularFactor s, specularColor c), the base
//!   coupled by (1 − s·F0·c): energy stays below 1 (s scales the coat, the
//!   rest goes to the base as for s = 1);
//! - KHR_materials_iridescence: a thin film over the coat and the metal;
//!   their Fresnel factors blend towards the film's Airy reflectance,
//!   evaluated exactly per wavelength (`thin_film`), the metal's base index
//!   taken from its colour;
//! - KHR_materials_sheen: the Charlie sheen lobe (`sheen`) over the base,
//!   which keeps 1 − max(colour)·E of the light, E the sheen's tabulated
//!   directional albedo (the smaller of the two directions' shares, so the
//!   sum is reciprocal and never above 1);
//! - KHR_materials_clearcoat: a GGX coat of index 1.5 over everything,
//!   f = (1 − c·F_cc)·f_base + c·F_cc·S_cc with F_cc Schlick's (F0 = 0.04) at
//!   the half vector, as the extension defines it; sampled in proportion to
//!   its estimated weight.

use std::f32::consts::{FRAC_1_PI, PI};

use glam::{Vec2, Vec3};

use super::bsdf::{to_side_of, upper, BsdfEval, BsdfFlags, LobeSample, TransportMode};
use super::cosine_hemisphere;
use super::microfacet::{reflect, Ggx};
use super::{facing_frame, microfacet, Bsdf, Lobe, PbrLayers, PbrMaterial, ShadingGeometry};
use super::{sheen, thin_film};
use crate::spectrum::{SampledSpectrum, SampledWavelengths};
use crate::texture::TextureRef;

/// Smallest α used: below it the specular lobe would be a Dirac delta and a
/// mixture of a delta and a diffuse lobe cannot be MIS-weighted per sample.
pub const MIN_ALPHA: f32 = 2e-3;

#[derive(Clone, Copy, Debug)]
pub struct PbrLobe {
    base: SampledSpectrum,
    metallic: f32,
    /// The coat's normal-incidence reflectance per wavelength (specular
    /// colour included), before the specular weight.
    f0: SampledSpectrum,
    /// The coat's index (for the thin film's base).
    ior: f32,
    ggx: Ggx,
    mean_base: f32,
    layers: LobeLayers,
}

/// The glTF extension layers at one hit, for the path's wavelengths.
#[derive(Clone, Copy, Debug)]
pub struct LobeLayers {
    /// specularFactor: the coat's weight (and F90).
    pub specular_weight: f32,
    /// specularColorFactor × texture, per wavelength: tints the coat's F0.
    pub specular_colour: SampledSpectrum,
    /// Thin film: weight, index, thickness (nm), at these wavelengths.
    pub film: Option<FilmAt>,
    /// Clear coat: weight and GGX α.
    pub clearcoat: Option<(f32, f32)>,
    /// Sheen: colour per wavelength and roughness.
    pub sheen: Option<(SampledSpectrum, f32)>,
}

impl Default for LobeLayers {
    fn default() -> Self {
        Self {
            specular_weight: 1.0,
            specular_colour: SampledSpectrum::ONE,
            film: None,
            clearcoat: None,
            sheen: None,
        }
    }
}

/// A thin film as one hit sees it.
#[derive(Clone, Copy, Debug)]
pub struct FilmAt {
    pub weight: f32,
    pub ior: f32,
    pub thickness: f32,
    pub lambda: glam::Vec4,
}

impl FilmAt {
    /// The film's reflectance per wavelength at `cos`, over a base of
    /// index `base` per wavelength.
    fn reflectance(&self, cos: f32, base: SampledSpectrum) -> SampledSpectrum {
        let mut r = [0.0; 4];
        for (k, r) in r.iter_mut().enumerate() {
            *r = thin_film::reflectance(cos, self.lambda[k], self.ior, self.thickness, base[k]);
        }
        SampledSpectrum::from_array(r)
    }

    /// `plain` blended towards the film's `film` by the film's weight.
    fn blend(&self, plain: SampledSpectrum, film: SampledSpectrum) -> SampledSpectrum {
        plain + (film - plain) * self.weight
    }
}

/// Index of refraction of the clear coat (the extension fixes it).
const CLEARCOAT_F0: f32 = 0.04;

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
            f0: SampledSpectrum::splat(((ior - 1.0) / (ior + 1.0)).powi(2)),
            ior,
            ggx: Ggx::new(alpha.max(MIN_ALPHA)),
            mean_base: base.element_sum() * 0.25,
            layers: LobeLayers::default(),
        }
    }

    /// The lobe with the glTF extension layers.
    pub fn with_layers(mut self, layers: LobeLayers) -> Self {
        self.f0 =
            (self.f0 * layers.specular_colour.max(SampledSpectrum::ZERO)).min(SampledSpectrum::ONE);
        self.layers = LobeLayers {
            specular_weight: layers.specular_weight.clamp(0.0, 1.0),
            clearcoat: layers
                .clearcoat
                .filter(|c| c.0 > 0.0)
                .map(|(w, a)| (w.min(1.0), a.max(MIN_ALPHA))),
            film: layers.film.filter(|f| f.weight > 0.0),
            sheen: layers
                .sheen
                .map(|(c, r)| (c.clamp(SampledSpectrum::ZERO, SampledSpectrum::ONE), r))
                .filter(|(c, _)| c.max_element() > 0.0),
            ..layers
        };
        self
    }

    /// The coat's Fresnel factor per wavelength at `cos` (to the half
    /// vector): specular weight, colour and thin film applied.
    fn coat_fresnel(&self, cos: f32) -> SampledSpectrum {
        let s = self.layers.specular_weight;
        let w = schlick_weight(cos);
        let plain = (self.f0 + (SampledSpectrum::ONE - self.f0) * w) * s;
        match &self.layers.film {
            Some(film) => film.blend(
                plain,
                film.reflectance(cos, SampledSpectrum::splat(self.ior)) * s,
            ),
            None => plain,
        }
    }

    /// The metal's Fresnel factor per wavelength at `cos`.
    fn metal_fresnel(&self, cos: f32) -> SampledSpectrum {
        let plain = self.base + (SampledSpectrum::ONE - self.base) * schlick_weight(cos);
        match &self.layers.film {
            Some(film) => {
                let n =
                    SampledSpectrum::from_array(self.base.to_array().map(thin_film::ior_from_f0));
                film.blend(plain, film.reflectance(cos, n))
            }
            None => plain,
        }
    }

    /// The clear coat's weight c·F_cc at `cos`, and its GGX.
    fn clearcoat(&self, cos: f32) -> Option<(f32, Ggx)> {
        let (weight, alpha) = self.layers.clearcoat?;
        let f = CLEARCOAT_F0 + (1.0 - CLEARCOAT_F0) * schlick_weight(cos);
        Some((weight * f, Ggx::new(alpha)))
    }

    /// What the base keeps under the sheen seen from `cos` (1 − max(colour)
    /// · E(μ)), and the sheen's probability of being sampled.
    fn under_sheen(&self, cos: f32) -> f32 {
        self.layers
            .sheen
            .map_or(1.0, |(c, r)| 1.0 - c.max_element() * sheen::albedo(cos, r))
    }

    fn p_sheen(&self, wo: Vec3) -> f32 {
        self.layers.sheen.map_or(0.0, |_| {
            (1.0 - self.under_sheen(wo.z.abs())).clamp(0.05, 0.5)
        })
    }

    /// Probability of sampling the clear coat from `wo` (0 without one).
    fn p_clearcoat(&self, wo: Vec3) -> f32 {
        self.clearcoat(wo.z.abs())
            .map_or(0.0, |(w, _)| w.clamp(0.05, 0.5))
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
        let f0 = self.f0.element_sum() * 0.25 * self.layers.specular_weight;
        let (metallic, mean_base) = (self.metallic, self.mean_base);
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
        let cos_h = wo.dot(wm).abs();
        let s = self.ggx.reflection(wo, wi, wm);
        let f_d = self.coat_fresnel(cos_h);
        let f_c = self.metal_fresnel(cos_h);
        let coupling = 28.0 / (23.0 * PI)
            * (1.0 - schlick_weight(0.5 * wi.z))
            * (1.0 - schlick_weight(0.5 * wo.z));
        // The base loses the coat's normal-incidence reflectance.
        let dielectric =
            self.base * (SampledSpectrum::ONE - self.coat_fresnel(1.0)) * coupling + f_d * s;
        let p_specular = self.p_specular(wo);
        let mut f = dielectric * (1.0 - self.metallic) + f_c * (self.metallic * s);
        let mut pdf =
            p_specular * self.ggx.reflection_pdf(wo, wm) + (1.0 - p_specular) * wi.z * FRAC_1_PI;
        if let Some((colour, r)) = self.layers.sheen {
            // The base keeps what the sheen leaves from either side (the
            // smaller share: reciprocal, and never more than arrives).
            let keep = self.under_sheen(wo.z).min(self.under_sheen(wi.z));
            f = f * keep + colour * sheen::value(wo, wi, r);
            let p = self.p_sheen(wo);
            pdf = p * wi.z * FRAC_1_PI + (1.0 - p) * pdf;
        }
        if let Some((c, coat)) = self.clearcoat(cos_h) {
            f = f * (1.0 - c) + SampledSpectrum::splat(c * coat.reflection(wo, wi, wm));
            let p = self.p_clearcoat(wo);
            pdf = p * coat.reflection_pdf(wo, wm) + (1.0 - p) * pdf;
        }
        BsdfEval { f, pdf }
    }

    pub fn sample(
        &self,
        wo: Vec3,
        uc: f32,
        u: (f32, f32),
        mode: TransportMode,
    ) -> Option<LobeSample> {
        let (up, _) = upper(wo, wo);
        let p_coat = self.p_clearcoat(up);
        if uc < p_coat {
            let (_, coat) = self.clearcoat(up.z)?;
            let wi = reflect(up, coat.sample_wm(up, u));
            if wi.z <= 0.0 {
                return None;
            }
            let wi = to_side_of(wo, wi);
            let e = self.eval(wo, wi, mode);
            return Some(LobeSample::evaluated(
                wi,
                e,
                BsdfFlags::REFLECTION | BsdfFlags::GLOSSY,
                1.0,
            ));
        }
        // The rest of `uc` picks the sheen (cosine-sampled) or the base's lobe.
        let uc = (uc - p_coat) / (1.0 - p_coat);
        let p_sheen = self.p_sheen(up);
        let (wi, lobe) = if uc < p_sheen {
            (cosine_hemisphere(u), BsdfFlags::GLOSSY)
        } else if (uc - p_sheen) / (1.0 - p_sheen) < self.p_specular(up) {
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

/// The glTF metallic-roughness BSDF of `m` at `uv`.
pub(super) fn bsdf(
    m: &PbrMaterial,
    geom: &ShadingGeometry,
    uv: Vec2,
    wl: &SampledWavelengths,
) -> Bsdf {
    let (mut metallic, mut roughness) = (m.metallic, m.roughness);
    if let Some(t) = &m.metallic_roughness {
        let v = t.linear(uv);
        roughness *= v.y;
        metallic *= v.z;
    }
    let (frame, ng) = facing_frame(geom);
    let mut lobe = PbrLobe::new(
        m.base_color.sample(uv, wl),
        metallic,
        microfacet::alpha_from_roughness(roughness),
        m.ior,
    );
    if m.layers != PbrLayers::default() {
        lobe = lobe.with_layers(lobe_layers(&m.layers, uv, wl));
    }
    Bsdf::new(frame, ng, Lobe::Pbr(lobe), geom.wo)
}

/// The extension layers at `uv` for the path's wavelengths.
fn lobe_layers(layers: &PbrLayers, uv: Vec2, wl: &SampledWavelengths) -> LobeLayers {
    // A texture's channel at `uv`, 1 without the texture.
    let channel = |t: &Option<TextureRef>, k: usize| t.as_ref().map_or(1.0, |t| t.linear(uv)[k]);
    let mut at = LobeLayers::default();
    if let Some(s) = &layers.specular {
        at.specular_weight = s.weight * channel(&s.texture, 3);
        at.specular_colour = s.colour.sample(uv, wl);
    }
    if let Some(s) = &layers.sheen {
        let r = s.roughness * channel(&s.roughness_texture, 3);
        at.sheen = Some((s.colour.sample(uv, wl), r * r));
    }
    if let Some(c) = &layers.clearcoat {
        let roughness = c.roughness * channel(&c.roughness_texture, 1);
        at.clearcoat = Some((
            c.weight * channel(&c.texture, 0),
            microfacet::alpha_from_roughness(roughness),
        ));
    }
    if let Some(i) = &layers.iridescence {
        let t = channel(&i.thickness_texture, 1);
        at.film = Some(FilmAt {
            weight: i.weight * channel(&i.texture, 0),
            ior: i.ior,
            thickness: i.thickness[0] + (i.thickness[1] - i.thickness[0]) * t,
            lambda: wl.lambda,
        });
    }
    at
}
