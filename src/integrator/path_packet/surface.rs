//! The surfaces the packet core shades: a diffuse one by a lean BSDF of
//! its own ([`Diffuse`]), the others that only reflect by the general one
//! ([`General`]), both behind [`Surface`].

use std::f32::consts::FRAC_1_PI;

use glam::Vec3;

use crate::geometry::frame::Frame;
use crate::material::{
    cosine_hemisphere, facing_frame, Bsdf, Reflectance, ShadingGeometry, TransportMode,
};
use crate::scene::SurfaceHit;
use crate::spectrum::memo::SpectrumMemo;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// What a bounce needs of the surface a path scatters from: a diffuse
/// one (the lean [`Diffuse`]) or another that only reflects ([`General`]).
/// Each gets a bounce of its own (`Lane::bounce` is generic), so a scene of
/// diffuse surfaces alone pays nothing for the others.
pub(super) trait Surface {
    /// A mirror: no light sample can find light it reflects.
    fn is_specular(&self) -> bool;

    /// f·|cos θ| towards `wi` and the density of sampling `wi`.
    fn eval(&self, wi: Vec3) -> (SampledSpectrum, f32);

    /// What a bounce starts from: the steps it takes with its numbers
    /// alone.
    type Drawn: Copy;

    /// Those steps, with the numbers `u` (u₀, u₁ for the direction, u₂ for
    /// the lobe).
    fn draw(u: [f32; 4]) -> Self::Drawn;

    /// A direction drawn from `drawn`: the direction, f·|cos θ|/pdf, the
    /// density and whether a Dirac lobe drew it; None where the path ends.
    fn sample(&self, drawn: Self::Drawn) -> Option<(Vec3, SampledSpectrum, f32, bool)>;
}

/// A metal, glTF's metallic-roughness or a fluorescent surface, by the
/// general BSDF, met by a path arriving from `wo`.
pub(super) struct General {
    pub(super) bsdf: Bsdf,
    pub(super) wo: Vec3,
}

impl Surface for General {
    #[inline(always)]
    fn is_specular(&self) -> bool {
        self.bsdf.is_specular()
    }

    #[inline(always)]
    fn eval(&self, wi: Vec3) -> (SampledSpectrum, f32) {
        let e = self.bsdf.eval(self.wo, wi, TransportMode::Radiance);
        (e.f * self.bsdf.cos_theta(wi), e.pdf)
    }

    type Drawn = [f32; 4];

    #[inline(always)]
    fn draw(u: [f32; 4]) -> [f32; 4] {
        u
    }

    #[inline(always)]
    fn sample(&self, [u0, u1, uc, _]: [f32; 4]) -> Option<(Vec3, SampledSpectrum, f32, bool)> {
        let bs = self
            .bsdf
            .sample(self.wo, uc, (u0, u1), TransportMode::Radiance)?;
        let weight = bs.f * (self.bsdf.cos_theta(bs.wi) / bs.pdf);
        Some((bs.wi, weight, bs.pdf, bs.is_specular()))
    }
}

/// A diffuse surface as a path arriving from `wo` meets it: `Material::
/// bsdf`'s frame (the shading normal turned to the side of the geometric
/// normal that faces `wo`) and `Bsdf`'s rules (a reflection stays on
/// `wo`'s side of both normals), with f = R/π.
pub(super) struct Diffuse {
    frame: Frame,
    /// The geometric normal, on `wo`'s side.
    ng: Vec3,
    wo: Vec3,
    wo_local: Vec3,
    f: SampledSpectrum,
}

impl Diffuse {
    #[inline(always)]
    pub(super) fn at(
        reflectance: &Reflectance,
        hit: &SurfaceHit,
        wo: Vec3,
        wl: &SampledWavelengths,
        spectra: &mut SpectrumMemo,
    ) -> Diffuse {
        let geometry = ShadingGeometry {
            ng: hit.ng,
            ns: hit.ns,
            wo,
        };
        let (frame, ng) = facing_frame(&geometry);
        Diffuse {
            frame,
            ng,
            wo,
            wo_local: frame.to_local(wo),
            f: Diffuse::f(reflectance, hit, wl, spectra),
        }
    }

    /// f = R/π at `hit`, R looked up through the path's memo (as
    /// `Material::bsdf` clamps it, to [0, 1]).
    #[inline(always)]
    pub(super) fn f(
        reflectance: &Reflectance,
        hit: &SurfaceHit,
        wl: &SampledWavelengths,
        spectra: &mut SpectrumMemo,
    ) -> SampledSpectrum {
        let r = reflectance.sample_by(hit.uv, wl, |s| spectra.sample(s, wl));
        r.clamp(SampledSpectrum::ZERO, SampledSpectrum::ONE) * FRAC_1_PI
    }

    /// `wi` leaves on `wo`'s side of the shading and the geometric normal.
    #[inline(always)]
    fn reflects(&self, wi: Vec3, wi_local: Vec3) -> bool {
        self.wo_local.z * wi_local.z > 0.0 && self.wo.dot(self.ng) * wi.dot(self.ng) > 0.0
    }
}

impl Surface for Diffuse {
    #[inline(always)]
    fn is_specular(&self) -> bool {
        false
    }

    /// Both zero where `wi` is not a reflection on `wo`'s side.
    #[inline(always)]
    fn eval(&self, wi: Vec3) -> (SampledSpectrum, f32) {
        let wi_local = self.frame.to_local(wi);
        if !self.reflects(wi, wi_local) {
            return (SampledSpectrum::ZERO, 0.0);
        }
        // |cos θ| is the local z (`Bsdf::cos_theta`'s n·wi, bit for bit).
        let cos = wi_local.z.abs();
        (self.f * cos, cos * FRAC_1_PI)
    }

    /// The cosine-weighted direction in the local frame, before it is
    /// turned to `wo`'s side.
    type Drawn = Vec3;

    #[inline(always)]
    fn draw([u0, u1, _, _]: [f32; 4]) -> Vec3 {
        cosine_hemisphere((u0, u1))
    }

    /// The cosine-weighted direction turned to `wo`'s side; None where it
    /// is not a reflection on `wo`'s side.
    #[inline(always)]
    fn sample(&self, mut wi_local: Vec3) -> Option<(Vec3, SampledSpectrum, f32, bool)> {
        if self.wo_local.z < 0.0 {
            wi_local.z = -wi_local.z;
        }
        let wi = self.frame.to_world(wi_local);
        if !self.reflects(wi, wi_local) {
            return None;
        }
        let pdf = wi_local.z.abs() * FRAC_1_PI;
        // `Bsdf::cos_theta`'s n·wi, as the one-path walk weighs the bounce.
        let weight = self.f * (self.frame.n.dot(wi).abs() / pdf);
        (pdf > 0.0 && pdf.is_finite()).then_some((wi, weight, pdf, false))
    }
}
