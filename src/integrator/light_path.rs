//! The start of a path from a light, shared by every integrator that traces
//! them (light tracing, bidirectional path tracing, photon mapping): a light
//! chosen by power, a ray sampled on it, the throughput that ray carries and
//! the media around the light.

use glam::Vec3;

use super::interface::media_at;
use super::ior_stack::IorStack;
use super::PathCounters;
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::light::LightLeSample;
use crate::scene::Scene;
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
