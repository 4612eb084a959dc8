//! A directional light: parallel light of one direction from infinitely far
//! away (the sun, as a Dirac delta in direction), given by the irradiance
//! it makes on a surface facing it. Rays never hit it; next-event
//! estimation and light paths find it. Light paths start on a disc that
//! covers the scene, so it needs the scene's bounds (`with_scene`).

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::{LightLeSample, LightLiSample, LightPoint};
use crate::geometry::Frame;
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum, LAMBDA_MAX, LAMBDA_MIN};

#[derive(Clone, Debug)]
pub struct DirectionalLight {
    /// Unit direction the light travels in.
    direction: Vec3,
    /// Spectral irradiance on a surface facing the light (W·m⁻²·nm⁻¹, or
    /// the scene's emission units).
    irradiance: Spectrum,
    /// The scene's bounding sphere.
    centre: Vec3,
    radius: f32,
}

impl DirectionalLight {
    pub fn new(direction: Vec3, irradiance: Spectrum) -> Self {
        Self {
            direction: direction.normalize(),
            irradiance,
            centre: Vec3::ZERO,
            radius: 0.0,
        }
    }

    /// The same light for a scene within the sphere (`centre`, `radius`).
    pub fn with_scene(self, centre: Vec3, radius: f32) -> Self {
        Self {
            centre,
            radius,
            ..self
        }
    }

    /// Mean spectral irradiance × the scene's cross-section.
    pub fn power(&self) -> f64 {
        let e = self.irradiance.average(LAMBDA_MIN, LAMBDA_MAX).max(0.0) as f64;
        e * (PI * self.radius * self.radius) as f64
    }

    pub fn sample_li(&self, wl: &SampledWavelengths) -> Option<LightLiSample> {
        let li = self.irradiance.sample(wl);
        if li == SampledSpectrum::ZERO {
            return None;
        }
        Some(LightLiSample {
            wi: -self.direction,
            li,
            pdf: 1.0,
            point: None,
        })
    }

    /// A ray towards the scene from a uniform point of a disc of the
    /// scene's radius, outside the scene, facing along the light.
    pub fn sample_le(&self, u: (f32, f32), wl: &SampledWavelengths) -> Option<LightLeSample> {
        if !(self.radius > 0.0) {
            return None;
        }
        let le = self.irradiance.sample(wl);
        if le == SampledSpectrum::ZERO {
            return None;
        }
        let frame = Frame::from_normal(self.direction);
        let r = self.radius * u.0.sqrt();
        let phi = 2.0 * PI * u.1;
        let on_disc = frame.to_world(Vec3::new(r * phi.cos(), r * phi.sin(), 0.0));
        let p = self.centre - self.direction * self.radius + on_disc;
        Some(LightLeSample {
            point: LightPoint {
                p,
                p_err: Vec3::ZERO,
                n: self.direction,
                uv: Vec2::ZERO,
            },
            dir: self.direction,
            le,
            pdf_pos: 1.0 / (PI * self.radius * self.radius),
            pdf_dir: 1.0,
        })
    }

    /// (per-area, per-solid-angle): the direction is a delta.
    pub fn pdf_le(&self) -> (f32, f32) {
        if self.radius > 0.0 {
            (1.0 / (PI * self.radius * self.radius), 0.0)
        } else {
            (0.0, 0.0)
        }
    }
}
