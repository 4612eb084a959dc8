//! Area lights: emissive triangles with a spectral radiance (times a colour
//! texture where there is one), one- or two-sided, sampled uniformly by area.
//! A triangle of a cut-out material emits only where it is present.

use std::sync::Arc;

use glam::{Vec2, Vec3};

use super::{
    cosine_emission, cosine_emission_pdf, Emitter, LightLeSample, LightLiSample, LightPoint,
    LightSource, SceneSphere,
};
use crate::geometry::gamma;
use crate::material::cutout::Cutout;
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum};

#[derive(Clone, Debug)]
pub struct AreaLight {
    tri: [Vec3; 3],
    /// Texture coordinates of the vertices, if the mesh has them.
    uvs: Option<[Vec2; 3]>,
    /// Unit normal of the front face (counter-clockwise winding).
    n: Vec3,
    area: f32,
    two_sided: bool,
    emitter: Arc<Emitter>,
    /// The material's cut-out, if it has one: where the surface is absent
    /// rays pass it and find no emission, so samples of the light must
    /// not count emission there either.
    cutout: Option<Arc<Cutout>>,
}

impl AreaLight {
    pub fn new(
        tri: [Vec3; 3],
        uvs: Option<[Vec2; 3]>,
        emitter: Arc<Emitter>,
        two_sided: bool,
    ) -> Self {
        Self {
            tri,
            uvs,
            n: (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize(),
            area: crate::geometry::triangle::area(&tri),
            two_sided,
            emitter,
            cutout: None,
        }
    }

    /// The same triangle sending out `emitter`.
    pub fn with_emitter(&self, emitter: Arc<Emitter>, two_sided: bool) -> Self {
        Self {
            emitter,
            two_sided,
            ..self.clone()
        }
    }

    /// The light of a cut-out material's triangle.
    pub fn with_cutout(self, cutout: Arc<Cutout>) -> Self {
        Self {
            cutout: Some(cutout),
            ..self
        }
    }

    /// Radiance leaving a sampled point towards `w`: what a ray arriving
    /// there finds on average, the emission times the chance the surface is
    /// present (a ray that finds it absent passes and sees no emission).
    #[inline]
    fn sampled_l(
        &self,
        uv: Vec2,
        w: Vec3,
        wl: &SampledWavelengths,
        sample: impl FnOnce(&Spectrum) -> SampledSpectrum,
    ) -> SampledSpectrum {
        if !self.emits_towards(w) {
            return SampledSpectrum::ZERO;
        }
        self.front_emission_by(uv, wl, sample)
    }

    /// `sampled_l` on the emitting side (seen from the side it emits to, or
    /// from either where the light is two-sided), which the packet core
    /// looks up before it knows the side: the same bits.
    #[inline]
    pub fn front_emission_by(
        &self,
        uv: Vec2,
        wl: &SampledWavelengths,
        sample: impl FnOnce(&Spectrum) -> SampledSpectrum,
    ) -> SampledSpectrum {
        let share = self.cutout.as_ref().map_or(1.0, |c| c.coverage(uv));
        if share == 0.0 {
            return SampledSpectrum::ZERO;
        }
        self.emitter.radiance_by(uv, wl, sample) * share
    }

    /// Whether both faces emit.
    pub fn two_sided(&self) -> bool {
        self.two_sided
    }

    /// Whether light leaves towards `w`: the front face's side, or either
    /// where the light is two-sided.
    #[inline]
    fn emits_towards(&self, w: Vec3) -> bool {
        self.two_sided || !(self.n.dot(w) <= 0.0)
    }

    pub fn emitter(&self) -> &Emitter {
        &self.emitter
    }

    pub fn area(&self) -> f32 {
        self.area
    }

    /// The emitted spectrum (its shape, for choosing wavelengths; a
    /// texture's colour is left out).
    pub fn spectrum(&self) -> &Spectrum {
        &self.emitter.spectrum
    }

    /// Relative power for light selection: area · emitting sides · mean radiance.
    pub fn power(&self) -> f64 {
        self.area as f64 * if self.two_sided { 2.0 } else { 1.0 } * self.emitter.mean()
    }

    /// Radiance leaving a point with texture coordinates `uv` towards `w`
    /// (pointing away from the light; only its side counts, not its length).
    #[inline]
    pub fn l(&self, uv: Vec2, w: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        self.l_by(uv, w, wl, |s| s.sample(wl))
    }

    /// `l`, the emitted spectrum at `wl` told by `sample` (a caller that
    /// remembers spectra, `SpectrumMemo`).
    #[inline]
    pub fn l_by(
        &self,
        uv: Vec2,
        w: Vec3,
        wl: &SampledWavelengths,
        sample: impl FnOnce(&Spectrum) -> SampledSpectrum,
    ) -> SampledSpectrum {
        if !self.emits_towards(w) {
            return SampledSpectrum::ZERO;
        }
        self.emitter.radiance_by(uv, wl, sample)
    }

    /// A uniformly distributed point on the triangle.
    #[inline]
    pub fn sample_point(&self, u: (f32, f32)) -> LightPoint {
        let tri = &self.tri;
        let su = u.0.sqrt();
        let b = [1.0 - su, u.1 * su];
        let b2 = 1.0 - b[0] - b[1];
        let p = tri[0] * b[0] + tri[1] * b[1] + tri[2] * b2;
        let p_err = (tri[0] * b[0]).abs() + (tri[1] * b[1]).abs() + (tri[2] * b2).abs();
        let uv = match &self.uvs {
            Some(uv) => uv[0] * (1.0 - b[1] - b2) + uv[1] * b[1] + uv[2] * b2,
            None => Vec2::ZERO,
        };
        LightPoint {
            p,
            p_err: p_err * gamma(6),
            n: self.n,
            uv,
        }
    }

    #[inline]
    pub fn sample_li(
        &self,
        p_ref: Vec3,
        u: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLiSample> {
        self.sample_li_by(p_ref, u, wl, |s| s.sample(wl))
    }

    /// `sample_li`, the emitted spectrum at `wl` told by `sample`.
    #[inline]
    pub fn sample_li_by(
        &self,
        p_ref: Vec3,
        u: (f32, f32),
        wl: &SampledWavelengths,
        sample: impl FnOnce(&Spectrum) -> SampledSpectrum,
    ) -> Option<LightLiSample> {
        self.li_from(self.sample_point(u), p_ref, wl, sample)
    }

    /// `sample_li_by` from `lp`, the point [`AreaLight::sample_point`] drew
    /// (which a caller may draw early: it needs only its numbers).
    #[inline]
    pub fn li_from(
        &self,
        lp: LightPoint,
        p_ref: Vec3,
        wl: &SampledWavelengths,
        sample: impl FnOnce(&Spectrum) -> SampledSpectrum,
    ) -> Option<LightLiSample> {
        let to_light = lp.p - p_ref;
        let dist2 = to_light.length_squared();
        if dist2 == 0.0 {
            return None;
        }
        let wi = to_light / dist2.sqrt();
        // Which side the light leaves from is the sign of -to_light's
        // cosine, the same as -wi's: the emission need not wait on the
        // division.
        let li = self.sampled_l(lp.uv, -to_light, wl, sample);
        let cos_light = lp.n.dot(wi).abs();
        if li == SampledSpectrum::ZERO || cos_light == 0.0 {
            return None;
        }
        Some(LightLiSample {
            wi,
            li,
            pdf: dist2 / (cos_light * self.area),
            point: Some(lp),
        })
    }

    /// Solid-angle density of `sample_li` from `p_ref` for the point
    /// `p_light` on the light.
    #[inline]
    pub fn pdf_li(&self, p_ref: Vec3, p_light: Vec3) -> f32 {
        let d = p_light - p_ref;
        let dist2 = d.length_squared();
        let cos = self.n.dot(d).abs() / dist2.sqrt();
        if cos == 0.0 || dist2 == 0.0 {
            return 0.0;
        }
        dist2 / (cos * self.area)
    }

    /// A ray leaving the light: a uniform point, a cosine-weighted
    /// direction on an emitting side (either side, evenly, when two-sided).
    pub fn sample_le(
        &self,
        u_pos: (f32, f32),
        u_dir: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLeSample> {
        let lp = self.sample_point(u_pos);
        let (dir, n) = cosine_emission(self.n, self.two_sided, u_dir);
        let le = self.sampled_l(lp.uv, dir, wl, |s| s.sample(wl));
        let (pdf_pos, pdf_dir) = self.pdf_le(dir);
        if le == SampledSpectrum::ZERO || pdf_dir == 0.0 {
            return None;
        }
        Some(LightLeSample {
            point: LightPoint { n, ..lp },
            dir,
            le,
            pdf_pos,
            pdf_dir,
        })
    }

    /// Densities of `sample_le` for a ray leaving in `dir`: per area, per
    /// solid angle.
    pub fn pdf_le(&self, dir: Vec3) -> (f32, f32) {
        let pdf_dir = cosine_emission_pdf(self.n, self.two_sided, dir);
        (1.0 / self.area, pdf_dir)
    }
}

/// What the light must answer whole: see `LightSource` (light/mod.rs).
impl LightSource for AreaLight {
    fn is_delta(&self) -> bool {
        false
    }

    fn is_infinite(&self) -> bool {
        false
    }

    fn with_scene_bounds(self, _: SceneSphere) -> Self {
        self
    }

    fn power(&self) -> f64 {
        AreaLight::power(self)
    }

    fn spectrum(&self) -> Option<&Spectrum> {
        Some(AreaLight::spectrum(self))
    }

    #[inline]
    fn sample_li(
        &self,
        p_ref: Vec3,
        u: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLiSample> {
        AreaLight::sample_li(self, p_ref, u, wl)
    }

    #[inline]
    fn pdf_li(&self, p_ref: Vec3, _: Vec3, p_light: Option<Vec3>) -> f32 {
        p_light.map_or(0.0, |p| AreaLight::pdf_li(self, p_ref, p))
    }

    #[inline]
    fn l(&self, uv: Vec2, w: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        AreaLight::l(self, uv, w, wl)
    }

    #[inline]
    fn le(&self, _: Vec3, _: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum::ZERO
    }

    fn sample_le(
        &self,
        u_pos: (f32, f32),
        u_dir: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLeSample> {
        AreaLight::sample_le(self, u_pos, u_dir, wl)
    }

    fn pdf_le(&self, _: Vec2, dir: Vec3) -> (f32, f32) {
        AreaLight::pdf_le(self, dir)
    }
}
