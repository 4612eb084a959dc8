//! Paths from lights, shared by every integrator that traces them (light
//! tracing, bidirectional path tracing, photon mapping): the start — a light
//! chosen by power, a ray sampled on it, the throughput that ray carries and
//! the media around the light — and, for integrators that only look at each
//! surface the path meets (light tracing, photons), the walk itself.

use glam::Vec3;

use super::interface::{bsdf_at, media_at, scatter, trace, Next};
use super::ior_stack::IorStack;
use super::{russian_roulette, PathCounters};
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::light::LightLeSample;
use crate::material::{Bsdf, TransportMode};
use crate::sampler::Sampler;
use crate::scene::{Scene, SurfaceHit};
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

pub struct LightPath {
    /// The light and the probability it was chosen with.
    pub light: usize,
    pub pmf: f32,
    pub emitted: LightLeSample,
    /// The light's surface normal; zero for lights without a surface
    /// (points, directions, the sky), where no cosine applies.
    pub n: Vec3,
    /// Le cos θ / (pmf · p_pos · p_dir): what the first ray carries.
    pub beta: SampledSpectrum,
    pub ray: Ray,
    /// The dielectrics that contain the light.
    pub stack: IorStack,
}

/// Chooses a light with `u_light`, samples a ray leaving it with `u_pos`
/// and `u_dir`; None when there is no light or it sends nothing that way.
pub fn start(
    scene: &Scene,
    u_light: f32,
    u_pos: (f32, f32),
    u_dir: (f32, f32),
    wl: &SampledWavelengths,
    counters: &mut PathCounters,
) -> Option<LightPath> {
    let (light, pmf) = scene.lights.choose(u_light)?;
    let l = scene.lights.get(light);
    let emitted = l.sample_le(u_pos, u_dir, wl)?;
    let lp = emitted.point;
    let n = if l.is_delta() || l.is_infinite() {
        Vec3::ZERO
    } else {
        lp.n
    };
    let cos = lp.n.dot(emitted.dir).abs();
    let beta = emitted.le * (cos / (pmf * emitted.pdf_pos * emitted.pdf_dir));
    let ray = Ray::new(
        offset_ray_origin(lp.p, lp.p_err, n, emitted.dir),
        emitted.dir,
    );
    let stack = media_at(scene, lp.p, lp.p_err, n, counters);
    Some(LightPath {
        light,
        pmf,
        emitted,
        n,
        beta,
        ray,
        stack,
    })
}

/// A surface a light path reached, offered to `walk`'s `visit`.
pub struct LightVertex<'a> {
    pub hit: &'a SurfaceHit,
    /// Towards where the path came from.
    pub wo: Vec3,
    pub bsdf: &'a Bsdf,
    /// The importance arriving here.
    pub beta: SampledSpectrum,
    pub wl: &'a SampledWavelengths,
    /// Surfaces met so far, this one included.
    pub depth: u32,
    pub sampler: &'a mut Sampler,
    pub counters: &'a mut PathCounters,
}

/// Traces a light path from `start` through up to `max_depth` surfaces,
/// carrying importance, and calls `visit` at each before sampling its BSDF
/// (one 4D point a bounce: direction, lobe, Russian roulette after
/// `rr_depth`). `wl` may lose its secondaries on the way.
#[allow(clippy::too_many_arguments)]
pub fn walk(
    scene: &Scene,
    start: LightPath,
    wl: &mut SampledWavelengths,
    max_depth: u32,
    rr_depth: u32,
    sampler: &mut Sampler,
    counters: &mut PathCounters,
    mut visit: impl FnMut(LightVertex<'_>),
) {
    let (mut beta, mut ray, mut stack) = (start.beta, start.ray, start.stack);
    let mut depth = 0;
    while depth < max_depth {
        let Next::Surface { hit, eta, medium } = trace(scene, &mut ray, &mut stack, wl, counters)
        else {
            break;
        };
        depth += 1;
        let wo = -ray.dir;
        let bsdf = bsdf_at(scene, &hit, wo, wl, eta);
        visit(LightVertex {
            hit: &hit,
            wo,
            bsdf: &bsdf,
            beta,
            wl,
            depth,
            sampler: &mut *sampler,
            counters: &mut *counters,
        });

        let [u0, u1, uc, u_rr] = sampler.next_4d();
        let Some(bs) = bsdf.sample(wo, uc, (u0, u1), TransportMode::Importance) else {
            break;
        };
        beta *= bs.f * (bsdf.cos_theta(bs.wi) / bs.pdf);
        ray = Ray::new(offset_ray_origin(hit.p, hit.p_err, hit.ng, bs.wi), bs.wi);
        scatter(&mut stack, medium, wo, bs.wi, hit.ng, counters);
        // Importance is not scaled at refraction: no η'² to undo.
        if !russian_roulette(&mut beta, 1.0, depth, rr_depth, u_rr) {
            break;
        }
    }
}
