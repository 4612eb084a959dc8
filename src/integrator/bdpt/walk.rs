//! A subpath's random walk: tracing, sampling and the densities each
//! vertex records.

use super::vertex::{Kind, Vertex};
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::integrator::interface::{bsdf_at, scatter, trace, Next};
use crate::integrator::ior_stack::IorStack;
use crate::integrator::volume::Flight;
use crate::integrator::PathCounters;
use crate::material::TransportMode;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// How a subpath walks: which quantity it carries and how far it goes.
pub(super) struct Walk {
    pub(super) mode: TransportMode,
    pub(super) max_vertices: usize,
    pub(super) rr_depth: u32,
}

impl Walk {
    /// Extends `path` (which holds its origin) by tracing `ray` and
    /// sampling the BSDF at each surface, recording both densities.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn run(
        &self,
        scene: &Scene,
        mut ray: Ray,
        mut beta: SampledSpectrum,
        mut pdf_dir: f32,
        mut stack: IorStack,
        path: &mut Vec<Vertex>,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        u_first: [f32; 4],
        counters: &mut PathCounters,
    ) {
        let mut bounces = 0;
        let mut flight = Flight::new(beta);
        // Product of η'² over transmissions (radiance only), which Russian
        // roulette must not mistake for a dim path.
        let mut eta_scale = 1.0f32;
        while path.len() < self.max_vertices {
            let prev = path.len() - 1;
            let next = trace(
                scene,
                &mut ray,
                &mut stack,
                wl,
                &mut flight,
                Some(&mut *sampler),
                counters,
            );
            beta = flight.beta;
            let (hit, eta, medium) = match next {
                Next::Surface { hit, eta, medium } => (hit, eta, medium),
                Next::Medium { p, phase } => {
                    let dir_in = ray.dir.normalize();
                    let mut v = Vertex::new(Kind::Medium, p, beta);
                    v.phase = Some(phase);
                    v.wo = -dir_in;
                    v.stack = stack;
                    v.r = flight.r;
                    v.pdf_fwd = path[prev].area_density(pdf_dir, &v, scene);
                    path.push(v);
                    if path.len() == self.max_vertices {
                        break;
                    }
                    let [u0, u1, _, u_rr] = if bounces == 0 {
                        u_first
                    } else {
                        sampler.next_4d()
                    };
                    bounces += 1;
                    let (wi, pdf) = phase.sample(dir_in, (u0, u1));
                    pdf_dir = pdf;
                    let cur = path.len() - 1;
                    // The phase function is symmetric: the reverse density is the same.
                    let rev = path[cur].area_density(pdf, &path[prev], scene);
                    path[prev].pdf_rev = rev;
                    ray = Ray::new(p, wi);
                    if !flight.roulette(wl, eta_scale, bounces, self.rr_depth, u_rr) {
                        break;
                    }
                    continue;
                }
                Next::Escaped => {
                    let sees_infinity = self.mode == TransportMode::Radiance
                        && scene.lights.infinite().next().is_some()
                        && scene.sphere.radius > 0.0;
                    if sees_infinity {
                        // A point far beyond the scene along the ray: only
                        // its direction matters.
                        let far =
                            2.0 * scene.sphere.radius + (ray.origin - scene.sphere.centre).length();
                        let mut v = Vertex::new(Kind::Light, ray.origin + ray.dir * far, beta);
                        v.r = flight.r;
                        v.pdf_fwd = pdf_dir;
                        path.push(v);
                    }
                    break;
                }
                Next::Lost => break,
            };
            let wo = -ray.dir;
            let bsdf = bsdf_at(scene, &hit, wo, wl, eta);
            let mut v = Vertex::new(Kind::Surface, hit.p, beta);
            v.stack = stack;
            v.crossing = medium;
            v.r = flight.r;
            v.p_err = hit.p_err;
            v.ng = hit.ng;
            v.uv = hit.uv;
            v.bsdf = Some(bsdf);
            v.light = hit.light;
            v.pdf_fwd = path[prev].area_density(pdf_dir, &v, scene);
            path.push(v);
            if path.len() == self.max_vertices {
                break;
            }

            let [u0, u1, uc, u_rr] = if bounces == 0 {
                u_first
            } else {
                sampler.next_4d()
            };
            bounces += 1;
            let Some(bs) = bsdf.sample(wo, uc, (u0, u1), self.mode) else {
                break;
            };
            flight.beta *= bs.f * (bsdf.cos_theta(bs.wi) / bs.pdf);
            // A Dirac lobe's density is a delta in solid angle: counted as
            // 1 in both directions, its conversions to area (cos / d²) stay
            // in the ratios of `mis_weight`, where they cancel between the
            // strategies as Veach's derivation has them. (Counting it as 1
            // per area instead, as pbrt does, weights strategies across a
            // specular chain by the wrong geometry: the caustic of a ball
            // lens then goes to camera paths that find the light by chance.)
            let pdf_rev_dir = if bs.is_specular() {
                let cur = path.len() - 1;
                path[cur].delta = true;
                pdf_dir = 1.0;
                1.0
            } else {
                pdf_dir = bs.pdf;
                bsdf.pdf(bs.wi, wo, self.mode)
            };
            let cur = path.len() - 1;
            let rev = path[cur].area_density(pdf_rev_dir, &path[prev], scene);
            path[prev].pdf_rev = rev;

            ray = Ray::new(offset_ray_origin(hit.p, hit.p_err, hit.ng, bs.wi), bs.wi);
            let crossed = scatter(&mut stack, medium, wo, bs.wi, hit.ng, counters);
            if crossed && medium.is_some() && self.mode == TransportMode::Radiance {
                eta_scale *= bs.eta * bs.eta;
            }

            // The survivors' weight keeps each strategy unbiased; the MIS
            // densities leave roulette out, which changes only how
            // strategies share a path.
            if !flight.roulette(wl, eta_scale, bounces, self.rr_depth, u_rr) {
                break;
            }
        }
    }
}
