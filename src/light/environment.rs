//! A constant environment: the same radiance from every direction at
//! infinity (a uniform sky, the white furnace). Rays that escape the scene
//! see it; light sampling picks directions uniformly over the sphere; light
//! paths start on a disc over the scene.

use std::f32::consts::PI;

use super::point::sphere_direction;
use glam::{Vec2, Vec3};

use super::{LightLeSample, LightLiSample, LightSource, SceneSphere};
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum, LAMBDA_MAX, LAMBDA_MIN};

#[derive(Clone, Debug)]
pub struct UniformEnvironment {
    radiance: Spectrum,
    scene: SceneSphere,
}

impl UniformEnvironment {
    pub fn new(radiance: Spectrum) -> Self {
        Self {
            radiance,
            scene: SceneSphere::default(),
        }
    }

    /// The same light for a scene within `scene`.
    pub fn with_scene(self, scene: SceneSphere) -> Self {
        Self { scene, ..self }
    }

    /// The emitted spectrum (its shape, for choosing wavelengths).
    pub fn spectrum(&self) -> &Spectrum {
        &self.radiance
    }

    /// Mean radiance × 4π × the scene's cross-section.
    pub fn power(&self) -> f64 {
        let l = self.radiance.average(LAMBDA_MIN, LAMBDA_MAX).max(0.0) as f64;
        let r = self.scene.radius;
        l * (4.0 * PI * PI * r * r) as f64
    }

    pub fn le(&self, wl: &SampledWavelengths) -> SampledSpectrum {
        self.radiance.sample(wl)
    }

    pub fn sample_li(&self, u: (f32, f32), wl: &SampledWavelengths) -> Option<LightLiSample> {
        let wi = sphere_direction(1.0 - 2.0 * u.0, u.1);
        LightLiSample::from_infinity(wi, self.radiance.sample(wl), self.pdf_li())
    }

    pub fn pdf_li(&self) -> f32 {
        1.0 / (4.0 * PI)
    }

    /// A ray into the scene: a uniform direction, from a uniform point of
    /// the disc of the scene's radius facing it, outside the scene.
    pub fn sample_le(
        &self,
        u_pos: (f32, f32),
        u_dir: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLeSample> {
        let dir = sphere_direction(1.0 - 2.0 * u_dir.0, u_dir.1);
        let (_, pdf_dir) = self.pdf_le();
        self.scene
            .ray_from_infinity(dir, u_pos, self.radiance.sample(wl), pdf_dir)
    }

    pub fn pdf_le(&self) -> (f32, f32) {
        if self.scene.radius > 0.0 {
            (self.scene.disc_pdf(), 1.0 / (4.0 * PI))
        } else {
            (0.0, 0.0)
        }
    }
}

/// What the light must answer whole: see `LightSource` (light/mod.rs).
impl LightSource for UniformEnvironment {
    fn is_delta(&self) -> bool {
        false
    }

    fn is_infinite(&self) -> bool {
        true
    }

    fn with_scene_bounds(self, sphere: SceneSphere) -> Self {
        self.with_scene(sphere)
    }

    fn power(&self) -> f64 {
        UniformEnvironment::power(self)
    }

    fn spectrum(&self) -> Option<&Spectrum> {
        Some(UniformEnvironment::spectrum(self))
    }

    #[inline]
    fn sample_li(&self, _: Vec3, u: (f32, f32), wl: &SampledWavelengths) -> Option<LightLiSample> {
        UniformEnvironment::sample_li(self, u, wl)
    }

    /// Only escaped rays (no point on the light) find it.
    #[inline]
    fn pdf_li(&self, _: Vec3, _: Vec3, p_light: Option<Vec3>) -> f32 {
        match p_light {
            None => UniformEnvironment::pdf_li(self),
            Some(_) => 0.0,
        }
    }

    #[inline]
    fn l(&self, _: Vec2, _: Vec3, _: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum::ZERO
    }

    #[inline]
    fn le(&self, _: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        UniformEnvironment::le(self, wl)
    }

    fn sample_le(
        &self,
        u_pos: (f32, f32),
        u_dir: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLeSample> {
        UniformEnvironment::sample_le(self, u_pos, u_dir, wl)
    }

    fn pdf_le(&self, _: Vec2, _: Vec3) -> (f32, f32) {
        UniformEnvironment::pdf_le(self)
    }
}
