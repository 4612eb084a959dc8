//! Paths from lights, shared by every integrator that traces them (light
//! tracing, bidirectional path tracing, photon mapping): the start — a light
//! chosen by power, a ray sampled on it, the throughput that ray carries and
//! the media around the light — and, for integrators that only look at each
//! surface the path meets (light tracing, photons), the walk itself.

use glam::Vec3;

use super::interface::{media_at, stack_towards, transmittance_to_camera};
use super::ior_stack::IorStack;
use super::walk::{Event, Flow, PathContext, Visitor, Walk};
use super::PathCounters;

pub use super::walk::Scatterer;
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::light::LightLeSample;
use crate::light::LightSource;
use crate::material::TransportMode;
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

/// A vertex a light path reached, offered to `walk`'s `visit`.
pub struct LightVertex<'a> {
    pub at: Scatterer<'a>,
    /// Towards where the path came from.
    pub wo: Vec3,
    /// The importance arriving here (spectral MIS applied).
    pub beta: SampledSpectrum,
    /// The media the path arrived in.
    pub stack: &'a IorStack,
    pub wl: &'a SampledWavelengths,
    /// Vertices met so far (surfaces and scattering events), this one included.
    pub depth: u32,
    pub sampler: &'a mut Sampler,
    pub counters: &'a mut PathCounters,
}

impl LightVertex<'_> {
    /// What arrives at the camera sample `cs` from this vertex: the
    /// importance times the scattering towards the camera and the
    /// transmittance of the way there (zero when blocked or when a Dirac
    /// lobe cannot turn that way).
    pub fn towards_camera(
        &mut self,
        scene: &Scene,
        cs: &crate::camera::CameraSample,
    ) -> SampledSpectrum {
        let (f, shadow, stack) = match self.at {
            // The camera does not see a single-sided surface's back face.
            Scatterer::Surface { hit, .. }
                if scene.hides_back_face(hit.material, hit.ng, -cs.wi) =>
            {
                return SampledSpectrum::ZERO;
            }
            Scatterer::Surface { hit, bsdf, medium } => {
                let f = bsdf.f(self.wo, cs.wi, TransportMode::Importance) * bsdf.cos_theta(cs.wi);
                let origin = offset_ray_origin(hit.p, hit.p_err, hit.ng, cs.wi);
                (
                    f,
                    Ray::towards(origin, cs.p_lens),
                    stack_towards(self.stack, medium, self.wo, cs.wi, hit.ng),
                )
            }
            Scatterer::Medium { p, phase } => {
                let f = SampledSpectrum::splat(phase.p(-self.wo, cs.wi));
                let ray = Ray::towards(p, cs.p_lens).starting_in_free_space(true);
                (f, ray, *self.stack)
            }
        };
        if f == SampledSpectrum::ZERO {
            return f;
        }
        let tr = transmittance_to_camera(scene, &shadow, &stack, self.wl, self.counters);
        self.beta * f * tr * cs.weight
    }

    /// The point of the vertex.
    pub fn p(&self) -> Vec3 {
        match self.at {
            Scatterer::Surface { hit, .. } => hit.p,
            Scatterer::Medium { p, .. } => p,
        }
    }
}

/// Traces a light path from `start` through up to `max_depth` vertices
/// (surfaces and scattering events in media), carrying importance, and
/// calls `visit` at each before its direction is drawn (the shared walk,
/// `walk::walk`). `ctx.wl` may lose its secondaries on the way.
pub fn walk(
    ctx: &mut PathContext,
    start: LightPath,
    max_depth: u32,
    rr_depth: u32,
    visit: impl FnMut(LightVertex<'_>),
) {
    if max_depth == 0 {
        return;
    }
    let mut path = Walk::new(start.ray, start.stack, start.beta, rr_depth);
    super::walk::walk(ctx, &mut path, &mut Visit { max_depth, visit });
}

/// `walk`'s visitor: each vertex offered to the caller, up to the depth.
struct Visit<F> {
    max_depth: u32,
    visit: F,
}

impl<F: FnMut(LightVertex<'_>)> Visitor for Visit<F> {
    fn mode(&self) -> TransportMode {
        TransportMode::Importance
    }

    fn arrive(&mut self, _: &mut PathContext, walk: &Walk, _: Option<&SurfaceHit>) -> Flow {
        if walk.depth == self.max_depth {
            Flow::End
        } else {
            Flow::Go
        }
    }

    fn scatter_from(&mut self, ctx: &mut PathContext, walk: &Walk, event: &Event) -> Flow {
        (self.visit)(LightVertex {
            at: event.at,
            wo: event.wo,
            beta: walk.flight.weight(ctx.wl),
            stack: &walk.stack,
            wl: ctx.wl,
            depth: walk.depth,
            sampler: &mut *ctx.sampler,
            counters: &mut *ctx.counters,
        });
        Flow::Go
    }
}
