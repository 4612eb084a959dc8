//! A directional light: parallel light of one direction from infinitely far
//! away (the sun, as a Dirac delta in direction), given by the irradiance
//! it makes on a surface facing it. Rays never hit it; next-event
//! estimation and light paths find it. Light paths start on a disc that
//! covers the scene, so it needs the scene's bounds (`with_scene`).

use glam::{Vec2, Vec3};

use super::{LightLeSample, LightLiSample, LightSource, SceneSphere};
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum, LAMBDA_MAX, LAMBDA_MIN};

#[derive(Clone, Debug)]
pub struct DirectionalLight {
    /// Unit direction the light travels in.
    direction: Vec3,
    /// Spectral irradiance on a surface facing the light (W·m⁻²·nm⁻¹, or
    /// the scene's emission units).
    irradiance: Spectrum,
    scene: SceneSphere,
}

impl DirectionalLight {
    pub fn new(direction: Vec3, irradiance: Spectrum) -> Self {
        Self {
            direction: direction.normalize(),
            irradiance,
            scene: SceneSphere::default(),
        }
    }

    /// The same light for a scene within `scene`.
    pub fn with_scene(self, scene: SceneSphere) -> Self {
        Self { scene, ..self }
    }

    /// The emitted spectrum (its shape, for choosing wavelengths).
    pub fn spectrum(&self) -> &Spectrum {
        &self.irradiance
    }

    /// Mean spectral irradiance × the scene's cross-section.
    pub fn power(&self) -> f64 {
        let e = self.irradiance.average(LAMBDA_MIN, LAMBDA_MAX).max(0.0) as f64;
        e * self.scene.disc_area() as f64
    }

    pub fn sample_li(&self, wl: &SampledWavelengths) -> Option<LightLiSample> {
        // A delta in direction: density 1 by convention.
        LightLiSample::from_infinity(-self.direction, self.irradiance.sample(wl), 1.0)
    }

    /// A ray towards the scene from a uniform point of a disc of the
    /// scene's radius, outside the scene, facing along the light.
    pub fn sample_le(&self, u: (f32, f32), wl: &SampledWavelengths) -> Option<LightLeSample> {
        let le = self.irradiance.sample(wl);
        self.scene.ray_from_infinity(self.direction, u, le, 1.0)
    }

    /// (per-area, per-solid-angle): the direction is a delta.
    pub fn pdf_le(&self) -> (f32, f32) {
        (self.scene.disc_pdf(), 0.0)
    }
}

/// What the light must answer whole: see `LightSource` (light/mod.rs).
impl LightSource for DirectionalLight {
    fn is_delta(&self) -> bool {
        true
    }

    fn is_infinite(&self) -> bool {
        true
    }

    fn with_scene_bounds(self, sphere: SceneSphere) -> Self {
        self.with_scene(sphere)
    }

    fn power(&self) -> f64 {
        DirectionalLight::power(self)
    }

    fn spectrum(&self) -> Option<&Spectrum> {
        Some(DirectionalLight::spectrum(self))
    }

    #[inline]
    fn sample_li(&self, _: Vec3, _: (f32, f32), wl: &SampledWavelengths) -> Option<LightLiSample> {
        DirectionalLight::sample_li(self, wl)
    }

    /// No ray finds a single direction.
    #[inline]
    fn pdf_li(&self, _: Vec3, _: Vec3, _: Option<Vec3>) -> f32 {
        0.0
    }

    #[inline]
    fn l(&self, _: Vec2, _: Vec3, _: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum::ZERO
    }

    /// It has no extent: no escaped ray sees it.
    #[inline]
    fn le(&self, _: Vec3, _: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum::ZERO
    }

    fn sample_le(
        &self,
        u_pos: (f32, f32),
        _: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLeSample> {
        DirectionalLight::sample_le(self, u_pos, wl)
    }

    fn pdf_le(&self, _: Vec2, _: Vec3) -> (f32, f32) {
        DirectionalLight::pdf_le(self)
    }
}
