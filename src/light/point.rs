//! Point and spot lights: all their light leaves one point (a Dirac delta
//! in position), so rays never hit them and only next-event estimation
//! (or a light path) finds them. A spot light is a point light whose
//! intensity falls off smoothly from `cos_falloff_start` to zero at
//! `cos_falloff_end` about its axis (pbrt-v4's smoothstep falloff).

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use super::{LightLeSample, LightLiSample, LightPoint, LightSource, SceneSphere};
use crate::geometry::Frame;
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum, LAMBDA_MAX, LAMBDA_MIN};

/// A cone about `axis` (unit): full intensity inside `cos_falloff_start`,
/// none outside `cos_falloff_end`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    pub axis: Vec3,
    pub cos_falloff_start: f32,
    pub cos_falloff_end: f32,
}

impl Cone {
    /// The fraction of the intensity sent towards `w` (unit).
    pub fn falloff(&self, w: Vec3) -> f32 {
        let c = self.axis.dot(w);
        let (lo, hi) = (self.cos_falloff_end, self.cos_falloff_start);
        if c >= hi {
            return 1.0;
        }
        if c <= lo {
            return 0.0;
        }
        let t = (c - lo) / (hi - lo);
        t * t * (3.0 - 2.0 * t)
    }

    /// ∫ falloff dω over the sphere, over 2π: 1 − (cos_start + cos_end)/2
    /// (exact for a linear ramp, pbrt-v4's estimate for the smoothstep).
    fn solid_angle_fraction(&self) -> f32 {
        1.0 - 0.5 * (self.cos_falloff_start + self.cos_falloff_end)
    }
}

#[derive(Clone, Debug)]
pub struct PointLight {
    position: Vec3,
    /// Radiant intensity per nm (W·sr⁻¹·nm⁻¹, or the scene's emission units).
    intensity: Spectrum,
    /// A spot light's cone; None: every direction alike.
    cone: Option<Cone>,
}

impl PointLight {
    pub fn new(position: Vec3, intensity: Spectrum, cone: Option<Cone>) -> Self {
        Self {
            position,
            intensity,
            cone,
        }
    }

    /// Intensity towards `w` (unit, away from the light).
    fn intensity(&self, w: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        let i = self.intensity.sample(wl);
        match &self.cone {
            Some(cone) => i * cone.falloff(w),
            None => i,
        }
    }

    /// The emitted spectrum (its shape, for choosing wavelengths).
    pub fn spectrum(&self) -> &Spectrum {
        &self.intensity
    }

    /// Mean spectral intensity × the solid angle it fills.
    pub fn power(&self) -> f64 {
        let i = self.intensity.average(LAMBDA_MIN, LAMBDA_MAX).max(0.0) as f64;
        let solid_angle = match &self.cone {
            Some(cone) => 2.0 * PI * cone.solid_angle_fraction(),
            None => 4.0 * PI,
        };
        i * solid_angle as f64
    }

    pub fn sample_li(&self, p_ref: Vec3, wl: &SampledWavelengths) -> Option<LightLiSample> {
        let d = self.position - p_ref;
        let dist2 = d.length_squared();
        if !(dist2 > 0.0) {
            return None;
        }
        let wi = d / dist2.sqrt();
        let li = self.intensity(-wi, wl) / dist2;
        if li == SampledSpectrum::ZERO {
            return None;
        }
        Some(LightLiSample {
            wi,
            li,
            pdf: 1.0,
            point: Some(LightPoint {
                p: self.position,
                p_err: Vec3::ZERO,
                n: -wi,
                uv: Vec2::ZERO,
            }),
        })
    }

    /// A ray leaving the light: uniform over the sphere, or over the cone.
    pub fn sample_le(&self, u: (f32, f32), wl: &SampledWavelengths) -> Option<LightLeSample> {
        let (dir, pdf_dir) = match &self.cone {
            None => {
                let z = 1.0 - 2.0 * u.0;
                (sphere_direction(z, u.1), 1.0 / (4.0 * PI))
            }
            Some(cone) => {
                let cos_max = cone.cos_falloff_end;
                let z = 1.0 - u.0 * (1.0 - cos_max);
                let local = sphere_direction(z, u.1);
                let dir = Frame::from_normal(cone.axis).to_world(local);
                (dir, 1.0 / (2.0 * PI * (1.0 - cos_max)))
            }
        };
        let le = self.intensity(dir, wl);
        if le == SampledSpectrum::ZERO {
            return None;
        }
        Some(LightLeSample {
            // The "normal" is the ray itself: no cosine at a point.
            point: LightPoint {
                p: self.position,
                p_err: Vec3::ZERO,
                n: dir,
                uv: Vec2::ZERO,
            },
            dir,
            le,
            pdf_pos: 1.0,
            pdf_dir,
        })
    }

    /// (per-area, per-solid-angle) densities of `sample_le` for `dir`: the
    /// position is a delta (density 0 in a bidirectional weight).
    pub fn pdf_le(&self, dir: Vec3) -> (f32, f32) {
        let pdf_dir = match &self.cone {
            None => 1.0 / (4.0 * PI),
            Some(cone) if cone.axis.dot(dir) >= cone.cos_falloff_end => {
                1.0 / (2.0 * PI * (1.0 - cone.cos_falloff_end))
            }
            Some(_) => 0.0,
        };
        (0.0, pdf_dir)
    }
}

/// The unit direction with z = `z` and azimuth 2π·`u`.
pub(super) fn sphere_direction(z: f32, u: f32) -> Vec3 {
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// What the light must answer whole: see `LightSource` (light/mod.rs).
impl LightSource for PointLight {
    fn is_delta(&self) -> bool {
        true
    }

    fn is_infinite(&self) -> bool {
        false
    }

    fn with_scene_bounds(self, _: SceneSphere) -> Self {
        self
    }

    fn power(&self) -> f64 {
        PointLight::power(self)
    }

    fn spectrum(&self) -> Option<&Spectrum> {
        Some(PointLight::spectrum(self))
    }

    #[inline]
    fn sample_li(
        &self,
        p_ref: Vec3,
        _: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLiSample> {
        PointLight::sample_li(self, p_ref, wl)
    }

    /// No ray finds a point.
    #[inline]
    fn pdf_li(&self, _: Vec3, _: Vec3, _: Option<Vec3>) -> f32 {
        0.0
    }

    #[inline]
    fn l(&self, _: Vec2, _: Vec3, _: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum::ZERO
    }

    #[inline]
    fn le(&self, _: Vec3, _: &SampledWavelengths) -> SampledSpectrum {
        SampledSpectrum::ZERO
    }

    fn sample_le(
        &self,
        _: (f32, f32),
        u_dir: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLeSample> {
        PointLight::sample_le(self, u_dir, wl)
    }

    fn pdf_le(&self, _: Vec2, dir: Vec3) -> (f32, f32) {
        PointLight::pdf_le(self, dir)
    }
}
