//! The path tracer: unidirectional paths from the camera with next-event
//! estimation to area lights, combined with BSDF sampling by multiple
//! importance sampling (power heuristic), and Russian roulette.

use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::light::LightSet;
use crate::material::{Bsdf, ShadingGeometry};
use crate::sampler::Sampler;
use crate::scene::{Scene, Strategy, SurfaceHit};
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// Shadow rays stop this fraction short of the (already offset) light point.
const SHADOW_EPSILON: f32 = 1e-6;

/// Counts kept per path, summed by the renderer.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathCounters {
    /// Closest-hit and shadow rays traced.
    pub rays: u64,
}

/// Veach's power heuristic (β = 2) for two strategies with one sample each.
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a.is_infinite() {
        return 1.0;
    }
    if a + b == 0.0 {
        0.0
    } else {
        a / (a + b)
    }
}

/// Radiance arriving along `ray` (unit direction) at the path's wavelengths.
pub fn radiance(
    scene: &Scene,
    mut ray: Ray,
    wl: &mut SampledWavelengths,
    sampler: &mut Sampler,
    counters: &mut PathCounters,
) -> SampledSpectrum {
    let settings = &scene.settings;
    let strategy = settings.strategy;
    let mut l = SampledSpectrum::ZERO;
    let mut beta = SampledSpectrum::ONE;
    // The camera ray sees emitters as a specular bounce would: no light sampling competes.
    let mut specular = true;
    let mut prev_bsdf_pdf = 0.0;
    let mut depth = 0;
    loop {
        counters.rays += 1;
        let Some(hit) = scene.intersect(&ray) else {
            break;
        };
        let wo = -ray.dir;

        if let Some(light) = hit.light {
            let le = scene.lights.emitted(light, hit.ng, wo, wl);
            if le != SampledSpectrum::ZERO {
                let weight = if specular || strategy == Strategy::Bsdf {
                    1.0
                } else if strategy == Strategy::Nee {
                    0.0
                } else {
                    let area = scene.lights.lights[light].area;
                    let cos = hit.ng.dot(wo).abs();
                    let light_pdf = scene.lights.pmf(light) * hit.t * hit.t / (cos * area);
                    power_heuristic(prev_bsdf_pdf, light_pdf)
                };
                l += beta * le * weight;
            }
        }

        if depth == settings.max_depth {
            break;
        }
        depth += 1;

        let geom = ShadingGeometry {
            ng: hit.ng,
            ns: hit.ns,
            wo,
        };
        let bsdf = scene.materials[hit.material as usize].bsdf(&geom, wl);

        if strategy != Strategy::Bsdf {
            l += beta * sample_direct(scene, &hit, &bsdf, wl, sampler, counters);
        }

        let Some(bs) = bsdf.sample(sampler.next_2d()) else {
            break;
        };
        beta *= bs.f * (bsdf.cos_theta(bs.wi) / bs.pdf);
        specular = bs.specular;
        prev_bsdf_pdf = bs.pdf;
        ray = Ray::new(offset_ray_origin(hit.p, hit.p_err, hit.ng, bs.wi), bs.wi);

        // Russian roulette: end dim paths with probability 1 − max(β), and
        // reweight the survivors so the estimate stays unbiased.
        let u = sampler.next_f32();
        let max_beta = beta.max_element();
        if depth >= settings.rr_depth && max_beta < 1.0 {
            let q = (1.0 - max_beta).max(0.0);
            if u < q {
                break;
            }
            beta /= 1.0 - q;
        }
        if max_beta <= 0.0 {
            break;
        }
    }
    l
}

/// Next-event estimation: light arriving directly from a point sampled on
/// a light, weighted against BSDF sampling when the strategy is MIS.
fn sample_direct(
    scene: &Scene,
    hit: &SurfaceHit,
    bsdf: &Bsdf,
    wl: &SampledWavelengths,
    sampler: &mut Sampler,
    counters: &mut PathCounters,
) -> SampledSpectrum {
    // Draw all three numbers whatever happens, so each path uses a fixed
    // number of samples per bounce.
    let u_light = sampler.next_f32();
    let u_point = sampler.next_2d();
    let Some((light, pmf)) = scene.lights.choose(u_light) else {
        return SampledSpectrum::ZERO;
    };
    let area = scene.lights.lights[light].area;
    let lp = LightSet::sample_point(scene.triangle(scene.lights.lights[light].prim), u_point);
    let to_light = lp.p - hit.p;
    let dist2 = to_light.length_squared();
    if dist2 == 0.0 {
        return SampledSpectrum::ZERO;
    }
    let wi = to_light / dist2.sqrt();
    let le = scene.lights.emitted(light, lp.n, -wi, wl);
    let cos_light = lp.n.dot(wi).abs();
    if le == SampledSpectrum::ZERO || cos_light == 0.0 {
        return SampledSpectrum::ZERO;
    }
    let f = bsdf.eval(wi) * bsdf.cos_theta(wi);
    if f == SampledSpectrum::ZERO {
        return SampledSpectrum::ZERO;
    }
    let origin = offset_ray_origin(hit.p, hit.p_err, hit.ng, wi);
    let target = offset_ray_origin(lp.p, lp.p_err, lp.n, -wi);
    let shadow = Ray {
        origin,
        dir: target - origin,
        t_max: 1.0 - SHADOW_EPSILON,
    };
    counters.rays += 1;
    if scene.occluded(&shadow) {
        return SampledSpectrum::ZERO;
    }
    let light_pdf = pmf * dist2 / (cos_light * area);
    let weight = if scene.settings.strategy == Strategy::Mis {
        power_heuristic(light_pdf, bsdf.pdf(wi))
    } else {
        1.0
    };
    f * le * (weight / light_pdf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0, 2.0), (0.3, 0.0), (5.0, 5.0)] {
            assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-6);
        }
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
    }
}
