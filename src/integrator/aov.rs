//! Arbitrary output variables (AOVs) for compositing and denoisers: what a
//! camera ray first meets, independent of the integrator. Per sample, a
//! camera ray of its own through the same pixel finds the first real
//! surface (passing index-matched and false dielectric boundaries as paths
//! do) and records
//! - its depth: the distance along the ray (0 where the ray escapes);
//! - its shading normal, world space, turned to face the ray;
//! - its albedo: one BSDF sample's weight f·|cos θ|/pdf, an unbiased
//!   estimate of the directional albedo (reflection and transmission, any
//!   material; glass and mirrors come out near 1, as denoisers expect),
//!   as the colour of that reflectance under D65 (XYZ, white = Y 1).

use glam::Vec3;

use super::interface::{bsdf_at, trace, FirstHit, Next};
use super::ior_stack::IorStack;
use super::volume::Flight;
use super::{camera_ray, PathCounters};
use crate::drive::AovTracer;
use crate::film::AovSample;
use crate::material::TransportMode;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::cie::{ColourMatching, Observer};
use crate::spectrum::{cie, SampledSpectrum, Spectrum};

/// What the AOVs of one render share: the film's observer and the
/// normalisation of D65 under it.
#[derive(Clone, Copy)]
pub struct Aovs {
    cmfs: &'static ColourMatching,
    d65_scale: f32,
}

impl Aovs {
    pub fn new(observer: Observer) -> Self {
        let cmfs = observer.cmfs();
        let d65 = Spectrum::Table(cie::d65().clone());
        Self {
            cmfs,
            // D65 normalised to Y = 1, so a white albedo has Y = 1.
            d65_scale: 1.0 / cmfs.spectrum_to_xyz(&d65).y,
        }
    }
}

impl AovTracer for Aovs {
    /// The AOVs of a camera ray through film position (`x`, `y`).
    fn first_hit(&self, scene: &Scene, x: f32, y: f32, sampler: &mut Sampler) -> AovSample {
        let [u_lambda, uc, u0, u1] = sampler.next_4d();
        let mut wl = scene.wavelengths.sample(u_lambda);
        let mut ray = camera_ray(scene, x, y, sampler);
        let origin = ray.origin;
        let mut counters = PathCounters::default();
        let Next::Surface { hit, eta, .. } = trace(
            scene,
            &mut ray,
            FirstHit::Unknown,
            true,
            &mut IorStack::default(),
            &wl,
            &mut Flight::new(SampledSpectrum::ONE),
            None,
            &mut counters,
        ) else {
            return AovSample::default();
        };
        let wo = -ray.dir;
        let bsdf = bsdf_at(scene, &hit, wo, &mut wl, eta);
        // Importance transport: no 1/η² on transmission, so smooth glass has
        // albedo 1, as denoisers want.
        let albedo = match bsdf.sample(wo, uc, (u0, u1), TransportMode::Importance) {
            Some(s) if s.pdf > 0.0 => {
                let weight = s.f * (bsdf.cos_theta(s.wi).abs() / s.pdf);
                let d65 = cie::d65();
                let illuminant = glam::Vec4::from_array(wl.lambda.to_array().map(|l| d65.eval(l)));
                self.cmfs
                    .sampled_to_xyz(weight * illuminant * self.d65_scale, &wl)
            }
            _ => Vec3::ZERO,
        };
        let ns = hit.ns;
        AovSample {
            albedo,
            normal: if ns.dot(wo) < 0.0 { -ns } else { ns },
            depth: (hit.p - origin).length(),
        }
    }
}
