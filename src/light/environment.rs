//! A constant environment: the same radiance from every direction at
//! infinity (a uniform sky, the white furnace). Rays that escape the scene
//! see it; light sampling picks directions uniformly over the sphere; light
//! paths start on a disc over the scene.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::point::sphere_direction;
use super::{LightLeSample, LightLiSample, LightPoint};
use crate::geometry::Frame;
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum, LAMBDA_MAX, LAMBDA_MIN};

#[derive(Clone, Debug)]
pub struct UniformEnvironment {
    radiance: Spectrum,
    /// The scene's bounding sphere.
    centre: Vec3,
    radius: f32,
}

impl UniformEnvironment {
    pub fn new(radiance: Spectrum) -> Self {
        Self {
            radiance,
            centre: Vec3::ZERO,
            radius: 0.0,
        }
    }

    pub fn with_scene(self, centre: Vec3, radius: f32) -> Self {
        Self {
            centre,
            radius,
            ..self
        }
    }

    /// Mean radiance × 4π × the scene's cross-section.
    pub fn power(&self) -> f64 {
        let l = self.radiance.average(LAMBDA_MIN, LAMBDA_MAX).max(0.0) as f64;
        l * (4.0 * PI * PI * self.radius * self.radius) as f64
    }

    pub fn le(&self, wl: &SampledWavelengths) -> SampledSpectrum {
        self.radiance.sample(wl)
    }

    pub fn sample_li(&self, u: (f32, f32), wl: &SampledWavelengths) -> Option<LightLiSample> {
        let li = self.radiance.sample(wl);
        if li == SampledSpectrum::ZERO {
            return None;
        }
        Some(LightLiSample {
            wi: sphere_direction(1.0 - 2.0 * u.0, u.1),
            li,
            pdf: self.pdf_li(),
            point: None,
        })
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
        if !(self.radius > 0.0) {
            return None;
        }
        let le = self.radiance.sample(wl);
        if le == SampledSpectrum::ZERO {
            return None;
        }
        let dir = sphere_direction(1.0 - 2.0 * u_dir.0, u_dir.1);
        let r = self.radius * u_pos.0.sqrt();
        let phi = 2.0 * PI * u_pos.1;
        let on_disc =
            Frame::from_normal(dir).to_world(Vec3::new(r * phi.cos(), r * phi.sin(), 0.0));
        let (pdf_pos, pdf_dir) = self.pdf_le();
        Some(LightLeSample {
            point: LightPoint {
                p: self.centre - dir * self.radius + on_disc,
                p_err: Vec3::ZERO,
                n: dir,
                uv: Vec2::ZERO,
            },
            dir,
            le,
            pdf_pos,
            pdf_dir,
        })
    }

    pub fn pdf_le(&self) -> (f32, f32) {
        if self.radius > 0.0 {
            (1.0 / (PI * self.radius * self.radius), 1.0 / (4.0 * PI))
        } else {
            (0.0, 0.0)
        }
    }
}
