//! The sun of the Hosek–Wilkie model: a disc at infinity of angular
//! diameter 0.5358° (or `sun_aperture`), whose spectral radiance is the
//! extraterrestrial solar spectrum attenuated along the line of sight (the
//! model's solar radiance function, which depends on the elevation seen),
//! darkened towards the limb. A larger aperture keeps the irradiance and
//! stretches the limb darkening over the larger disc.
//!
//! Rays that hit the disc see it; light sampling picks directions uniformly
//! in its cone (MIS with BSDF sampling, as for any light with extent).

use std::f32::consts::PI;
use std::sync::Arc;

use glam::Vec3;

use super::hosek_wilkie::{band_weights, SkyModel, BANDS, SUN_DIAMETER_DEGREES};
use super::{LightLeSample, LightLiSample, SceneSphere};
use crate::geometry::Frame;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

#[derive(Clone, Debug)]
pub struct Sun {
    model: Arc<SkyModel>,
    /// z axis: the unit direction towards the disc's centre.
    frame: Frame,
    /// 1 − cos α and sin α of the half-angle α, from sin²(α/2) so that
    /// they keep their precision for a disc this small.
    one_minus_cos: f32,
    sin_alpha: f32,
    /// The user's scale times the ratio of the model's disc to this one.
    scale: f32,
    /// Spectral-mean irradiance at normal incidence (for the light's power).
    irradiance: f64,
    scene: SceneSphere,
}

/// 1 − cos α for a half-angle α, without cancellation.
fn one_minus_cos(alpha: f64) -> f64 {
    2.0 * (0.5 * alpha).sin().powi(2)
}

impl Sun {
    /// The sun of `model` towards `direction` (unit), of angular diameter
    /// `aperture_degrees`, times `scale`.
    pub fn new(model: Arc<SkyModel>, direction: Vec3, aperture_degrees: f32, scale: f32) -> Self {
        let half = 0.5 * (aperture_degrees as f64).to_radians();
        let k = one_minus_cos(half);
        let model_k = one_minus_cos(0.5 * (SUN_DIAMETER_DEGREES as f64).to_radians());
        let mut sun = Self {
            model,
            frame: Frame::from_normal(direction),
            one_minus_cos: k as f32,
            sin_alpha: (k * (2.0 - k)).sqrt() as f32,
            scale: (scale as f64 * model_k / k) as f32,
            irradiance: 0.0,
            scene: SceneSphere::default(),
        };
        let mean = band_weights(|_| 1.0);
        sun.irradiance = (0..BANDS).map(|b| mean[b] * sun.band_irradiance(b)).sum();
        sun
    }

    /// The same light for a scene within `scene`.
    pub fn with_scene(self, scene: SceneSphere) -> Self {
        Self { scene, ..self }
    }

    /// Unit direction towards the disc's centre.
    pub fn direction(&self) -> Vec3 {
        self.frame.n
    }

    /// Irradiance of band `b` on a surface facing the sun: ∫ L cos γ dω =
    /// π sin²α ∫∫ L ds dφ/2π over the disc, with s = sin²γ / sin²α (so
    /// cos ψ = √(1 − s)) by the midpoint rule, the elevation seen varying
    /// across the disc as it does for the rays.
    pub fn band_irradiance(&self, b: usize) -> f64 {
        let (rings, spokes) = (64, 16);
        let sin_alpha = self.sin_alpha as f64;
        let mut sum = 0.0;
        for i in 0..rings {
            let s = (i as f64 + 0.5) / rings as f64;
            let darkening = SkyModel::limb_darkening(b, (1.0 - s).sqrt());
            let sin_gamma = s.sqrt() * sin_alpha;
            let cos_gamma = (1.0 - sin_gamma * sin_gamma).sqrt();
            for k in 0..spokes {
                let phi = 2.0 * std::f64::consts::PI * (k as f64 + 0.5) / spokes as f64;
                let n = self.frame.n.as_dvec3();
                let w = n * cos_gamma
                    + (self.frame.s.as_dvec3() * phi.cos() + self.frame.t.as_dvec3() * phi.sin())
                        * sin_gamma;
                if w.y >= 0.0 {
                    sum += self.model.sun_band(b, w.y.asin()) * darkening;
                }
            }
        }
        PI as f64 * sin_alpha * sin_alpha * sum / (rings * spokes) as f64 * self.scale as f64
    }

    /// Spectral-mean irradiance × the scene's cross-section.
    pub fn power(&self) -> f64 {
        self.irradiance * self.scene.disc_area() as f64
    }

    /// cos ψ where direction `w` (unit, towards the sky) meets the disc;
    /// None off the disc.
    #[inline]
    fn on_disc(&self, w: Vec3) -> Option<f32> {
        let local = self.frame.to_local(w);
        let sin2_gamma = local.x * local.x + local.y * local.y;
        let s = sin2_gamma / (self.sin_alpha * self.sin_alpha);
        (local.z > 0.0 && s <= 1.0).then(|| (1.0 - s).sqrt())
    }

    /// Radiance arriving from direction `w` (unit, towards the sky).
    #[inline]
    pub fn radiance(&self, w: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        match self.on_disc(w) {
            Some(cos_psi) if w.y >= 0.0 => self.disc_radiance(w, cos_psi, wl),
            _ => SampledSpectrum::ZERO,
        }
    }

    fn disc_radiance(&self, w: Vec3, cos_psi: f32, wl: &SampledWavelengths) -> SampledSpectrum {
        let elevation = (w.y.min(1.0) as f64).asin();
        let l = self
            .model
            .sun(wl.lambda.to_array(), elevation, cos_psi as f64)
            .map(|v| v as f32);
        SampledSpectrum::from_array(l) * self.scale
    }

    /// Solid-angle density of `sample_li` for direction `w`.
    pub fn pdf_li(&self, w: Vec3) -> f32 {
        if self.on_disc(w).is_some() {
            self.cone_pdf()
        } else {
            0.0
        }
    }

    /// `radiance(w)` and `pdf_li(w)`.
    pub fn radiance_and_pdf(&self, w: Vec3, wl: &SampledWavelengths) -> (SampledSpectrum, f32) {
        (self.radiance(w, wl), self.pdf_li(w))
    }

    fn cone_pdf(&self) -> f32 {
        1.0 / (2.0 * PI * self.one_minus_cos)
    }

    /// A uniform direction in the disc's cone.
    fn sample_direction(&self, u: (f32, f32)) -> Vec3 {
        // 1 − cos θ uniform in [0, 1 − cos α]; sin²θ = d (2 − d).
        let d = u.0 * self.one_minus_cos;
        let sin_t = (d * (2.0 - d)).sqrt();
        let phi = 2.0 * PI * u.1;
        self.frame
            .to_world(Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), 1.0 - d))
            .normalize()
    }

    pub fn sample_li(&self, u: (f32, f32), wl: &SampledWavelengths) -> Option<LightLiSample> {
        let wi = self.sample_direction(u);
        LightLiSample::from_infinity(wi, self.radiance(wi, wl), self.cone_pdf())
    }

    /// A ray into the scene: a direction in the cone, from a uniform point
    /// of the disc of the scene's radius facing it.
    pub fn sample_le(
        &self,
        u_pos: (f32, f32),
        u_dir: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLeSample> {
        let wi = self.sample_direction(u_dir);
        self.scene
            .ray_from_infinity(-wi, u_pos, self.radiance(wi, wl), self.cone_pdf())
    }

    /// Densities of `sample_le` for a ray travelling along `dir`.
    pub fn pdf_le(&self, dir: Vec3) -> (f32, f32) {
        (self.scene.disc_pdf(), self.pdf_li(-dir))
    }
}

// The sky model's spectrum varies over the dome: it counts as flat.
light_at_infinity!(Sun, |_l| None);

#[cfg(test)]
mod tests {
    use super::*;

    fn sun(elevation_deg: f32, aperture: f32) -> Sun {
        let e = elevation_deg.to_radians();
        let model = Arc::new(SkyModel::new(e, 3.0, [0.3; BANDS]));
        Sun::new(model, Vec3::new(e.cos(), e.sin(), 0.0), aperture, 1.0)
    }

    #[test]
    fn samples_fall_on_the_disc_with_the_cone_density() {
        let s = sun(40.0, SUN_DIAMETER_DEGREES);
        let wl = SampledWavelengths::sample_visible(0.4);
        let mut rng = crate::sampler::Sampler::new(1, 1);
        let mut hits = 0;
        for _ in 0..10_000 {
            let smp = s.sample_li(rng.next_2d(), &wl).unwrap();
            assert_eq!(smp.pdf, s.pdf_li(smp.wi));
            hits += 1;
        }
        assert_eq!(hits, 10_000);
        // The cone's solid angle 2π(1 − cos α) for α = 0.2679°.
        let omega = 2.0 * std::f64::consts::PI * one_minus_cos((0.2679f64).to_radians());
        assert!((1.0 / s.cone_pdf() as f64 / omega - 1.0).abs() < 1e-3);
        // Just outside the rim: nothing.
        let off = (s.direction() + 0.0048 * s.frame.s).normalize();
        assert_eq!(s.pdf_li(off), 0.0);
        assert_eq!(s.radiance(off, &wl), SampledSpectrum::ZERO);
    }

    #[test]
    fn a_larger_disc_keeps_the_irradiance() {
        let (small, large) = (sun(30.0, SUN_DIAMETER_DEGREES), sun(30.0, 5.0));
        for b in 1..BANDS {
            let (a, c) = (small.band_irradiance(b), large.band_irradiance(b));
            assert!((a / c - 1.0).abs() < 2e-3, "band {b}: {a} vs {c}");
        }
        // Limb darkening: the centre outshines the rim.
        let wl = SampledWavelengths::sample_visible(0.5);
        let centre = small.radiance(small.direction(), &wl);
        let rim = small.radiance(
            (small.direction() + 0.00465 * small.frame.s).normalize(),
            &wl,
        );
        assert!(rim.to_array()[0] < 0.8 * centre.to_array()[0]);
    }
}
