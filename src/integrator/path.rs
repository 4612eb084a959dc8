//! The path tracer: unidirectional paths from the camera with next-event
//! estimation, combined with BSDF sampling by multiple importance sampling
//! (power heuristic), and Russian roulette. Each path carries the stack of
//! dielectric media it is inside.

use super::interface::{bsdf_at, scatter, stack_towards, trace, transmittance, Next};
use super::ior_stack::{Entry, IorStack};
use super::volume::Flight;
use super::{power_heuristic, PathCounters, Strategy};
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::light::LightPoint;
use crate::material::{Bsdf, TransportMode};
use crate::sampler::Sampler;
use crate::scene::{Scene, SurfaceHit};
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// A surface a camera path reached, offered to `radiance_until`'s `stop`.
pub struct Stop<'a> {
    pub hit: &'a SurfaceHit,
    /// Towards where the path came from.
    pub wo: glam::Vec3,
    pub bsdf: &'a Bsdf,
    pub wl: &'a SampledWavelengths,
    /// Surfaces met so far, this one included.
    pub depth: u32,
    pub sampler: &'a mut Sampler,
    pub counters: &'a mut PathCounters,
    /// The media the path arrived in, and what `trace` said of the surface.
    pub stack: &'a IorStack,
    pub medium: Option<(Entry, bool)>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PathTracer {
    /// Most bounces: 1 is direct lighting only.
    pub max_depth: u32,
    /// Bounces before Russian roulette may end a path.
    pub rr_depth: u32,
    /// How direct light is found.
    pub strategy: Strategy,
}

impl Default for PathTracer {
    fn default() -> Self {
        Self {
            max_depth: 16,
            rr_depth: 3,
            strategy: Strategy::Mis,
        }
    }
}

impl PathTracer {
    /// Radiance arriving along `ray` (unit direction) at the path's wavelengths.
    pub fn radiance(
        &self,
        scene: &Scene,
        ray: Ray,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        counters: &mut PathCounters,
    ) -> SampledSpectrum {
        self.radiance_until(scene, ray, wl, sampler, counters, |_| None)
    }

    /// `radiance`, where `stop` may end the path at a surface with an
    /// estimate of the light it reflects (photon mapping ends camera paths
    /// at their first diffuse surface). Emission at the surface is already
    /// counted; the estimate is weighted by the path's throughput.
    pub fn radiance_until(
        &self,
        scene: &Scene,
        mut ray: Ray,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        counters: &mut PathCounters,
        mut stop: impl FnMut(Stop<'_>) -> Option<SampledSpectrum>,
    ) -> SampledSpectrum {
        let mut l = SampledSpectrum::ZERO;
        let mut flight = Flight::new(SampledSpectrum::ONE);
        // The camera ray sees emitters as a specular bounce would: no light sampling competes.
        let mut specular = true;
        let mut prev_bsdf_pdf = 0.0;
        let mut depth = 0;
        let mut stack = IorStack::default();
        // Product of η'² over transmissions: radiance scales by 1/η'² entering a
        // denser medium, which Russian roulette must not mistake for a dim path.
        let mut eta_scale = 1.0f32;
        loop {
            let next = trace(
                scene,
                &mut ray,
                &mut stack,
                wl,
                &mut flight,
                Some(&mut *sampler),
                counters,
            );
            let (hit, eta, medium) = match next {
                Next::Surface { hit, eta, medium } => (hit, eta, medium),
                Next::Medium { p, phase } => {
                    if depth == self.max_depth {
                        break;
                    }
                    depth += 1;
                    let dir_in = ray.dir.normalize();
                    if self.strategy != Strategy::Bsdf {
                        let direct = self.sample_direct_from(
                            scene,
                            p,
                            |wi| {
                                let f = phase.p(dir_in, wi);
                                (SampledSpectrum::splat(f), f)
                            },
                            |wi, to| match to {
                                Some(lp) => {
                                    Ray::towards(p, offset_ray_origin(lp.p, lp.p_err, lp.n, -wi))
                                }
                                None => Ray::new(p, wi),
                            },
                            |_| stack,
                            wl,
                            sampler,
                            counters,
                        );
                        l += flight.weight(wl) * direct;
                    } else {
                        sampler.skip_4d();
                    }
                    let [u0, u1, _, u_rr] = sampler.next_4d();
                    let (wi, pdf) = phase.sample(dir_in, (u0, u1));
                    specular = false;
                    prev_bsdf_pdf = pdf;
                    ray = Ray::new(p, wi);
                    if !flight.roulette(wl, eta_scale, depth, self.rr_depth, u_rr) {
                        break;
                    }
                    continue;
                }
                Next::Escaped => {
                    // Only lights at infinity are seen.
                    for (i, light) in scene.lights.infinite() {
                        let le = light.le(ray.dir, wl);
                        let weight = self.emission_weight(specular, prev_bsdf_pdf, || {
                            scene.lights.pmf(i) * light.pdf_li(ray.origin, ray.dir, None)
                        });
                        l += flight.weight(wl) * le * weight;
                    }
                    break;
                }
                Next::Lost => break,
            };
            let wo = -ray.dir;

            if let Some(i) = hit.light {
                let light = scene.lights.get(i);
                let le = light.l(hit.uv, wo, wl);
                if le != SampledSpectrum::ZERO {
                    let weight = self.emission_weight(specular, prev_bsdf_pdf, || {
                        scene.lights.pmf(i) * light.pdf_li(ray.origin, ray.dir, Some(hit.p))
                    });
                    l += flight.weight(wl) * le * weight;
                }
            }

            if depth == self.max_depth {
                break;
            }
            depth += 1;

            let bsdf = bsdf_at(scene, &hit, wo, wl, eta);
            let at = Stop {
                hit: &hit,
                wo,
                bsdf: &bsdf,
                wl,
                depth,
                sampler: &mut *sampler,
                counters: &mut *counters,
                stack: &stack,
                medium,
            };
            if let Some(reflected) = stop(at) {
                l += flight.weight(wl) * reflected;
                break;
            }

            if self.strategy != Strategy::Bsdf && !bsdf.is_specular() {
                let direct = self.sample_direct(
                    scene, &hit, wo, &bsdf, &stack, medium, wl, sampler, counters,
                );
                l += flight.weight(wl) * direct;
            } else {
                // Keep the dimensions of later bounces aligned across samples.
                sampler.skip_4d();
            }

            // One 4D point per bounce: the BSDF's direction (2D), its lobe
            // choice, and Russian roulette.
            let [u0, u1, uc, u_rr] = sampler.next_4d();
            let Some(bs) = bsdf.sample(wo, uc, (u0, u1), TransportMode::Radiance) else {
                break;
            };
            flight.beta *= bs.f * (bsdf.cos_theta(bs.wi) / bs.pdf);
            specular = bs.is_specular();
            prev_bsdf_pdf = bs.pdf;
            ray = Ray::new(offset_ray_origin(hit.p, hit.p_err, hit.ng, bs.wi), bs.wi);

            // Transmission through a dielectric moves the path into or out of it.
            if scatter(&mut stack, medium, wo, bs.wi, hit.ng, counters) && medium.is_some() {
                eta_scale *= bs.eta * bs.eta;
            }

            if !flight.roulette(wl, eta_scale, depth, self.rr_depth, u_rr) {
                break;
            }
        }
        l
    }

    /// The weight of emission that the path found by BSDF sampling: all of
    /// it after a Dirac bounce or with BSDF sampling alone, none when light
    /// sampling alone counts it, else MIS against the light's density
    /// (`light_pdf`, computed only then).
    fn emission_weight(
        &self,
        specular: bool,
        bsdf_pdf: f32,
        light_pdf: impl FnOnce() -> f32,
    ) -> f32 {
        if specular || self.strategy == Strategy::Bsdf {
            1.0
        } else if self.strategy == Strategy::Nee {
            0.0
        } else {
            power_heuristic(bsdf_pdf, light_pdf())
        }
    }

    /// Next-event estimation at a surface `hit` seen from `wo`, which the
    /// path reached with the media `stack` (`medium`: what `trace` said of
    /// the surface).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn sample_direct(
        &self,
        scene: &Scene,
        hit: &SurfaceHit,
        wo: glam::Vec3,
        bsdf: &Bsdf,
        stack: &IorStack,
        medium: Option<(Entry, bool)>,
        wl: &SampledWavelengths,
        sampler: &mut Sampler,
        counters: &mut PathCounters,
    ) -> SampledSpectrum {
        self.sample_direct_from(
            scene,
            hit.p,
            |wi| {
                let e = bsdf.eval(wo, wi, TransportMode::Radiance);
                (e.f * bsdf.cos_theta(wi), e.pdf)
            },
            |wi, to| {
                let origin = offset_ray_origin(hit.p, hit.p_err, hit.ng, wi);
                match to {
                    Some(lp) => Ray::towards(origin, offset_ray_origin(lp.p, lp.p_err, lp.n, -wi)),
                    None => Ray::new(origin, wi),
                }
            },
            |wi| stack_towards(stack, medium, wo, wi, hit.ng),
            wl,
            sampler,
            counters,
        )
    }

    /// Next-event estimation: light arriving directly at `p` from a point
    /// sampled on a light, weighted against BSDF (or phase) sampling when
    /// the strategy is MIS. `scattering(wi)` gives the value (BSDF times
    /// cosine, or the phase function) and its density; `shadow(wi, point)`
    /// the ray to the light (its point, or a direction to infinity);
    /// `stack` the media that ray starts in.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn sample_direct_from(
        &self,
        scene: &Scene,
        p: glam::Vec3,
        scattering: impl Fn(glam::Vec3) -> (SampledSpectrum, f32),
        shadow: impl Fn(glam::Vec3, Option<LightPoint>) -> Ray,
        stack: impl Fn(glam::Vec3) -> IorStack,
        wl: &SampledWavelengths,
        sampler: &mut Sampler,
        counters: &mut PathCounters,
    ) -> SampledSpectrum {
        // Draw the numbers whatever happens, so each path uses a fixed number
        // of dimensions per bounce: the point on the light (2D), which light.
        let [p0, p1, u_light, _] = sampler.next_4d();
        let u_point = (p0, p1);
        let Some((light, pmf)) = scene.lights.choose(u_light) else {
            return SampledSpectrum::ZERO;
        };
        let light = scene.lights.get(light);
        let Some(ls) = light.sample_li(p, u_point, wl) else {
            return SampledSpectrum::ZERO;
        };
        let wi = ls.wi;
        let (f, scattering_pdf) = scattering(wi);
        if f == SampledSpectrum::ZERO {
            return SampledSpectrum::ZERO;
        }
        let tr = transmittance(scene, &shadow(wi, ls.point), &stack(wi), wl, counters);
        if tr == SampledSpectrum::ZERO {
            return SampledSpectrum::ZERO;
        }
        let light_pdf = pmf * ls.pdf;
        let weight = if self.strategy == Strategy::Mis && !light.is_delta() {
            power_heuristic(light_pdf, scattering_pdf)
        } else {
            1.0
        };
        f * tr * ls.li * (weight / light_pdf)
    }
}
