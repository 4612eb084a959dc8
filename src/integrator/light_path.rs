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
use crate::geometry::Frame;
use crate::geometry::Ray;
use crate::light::{LightLeSample, LightPoint, LightSet, LightSource, SceneSphere};
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
    let emitted = scene.lights.get(light).sample_le(u_pos, u_dir, wl)?;
    Some(leaving(scene, light, pmf, emitted, counters))
}

/// `start`, with every ray aimed at the sphere `aim` (around the glass
/// and metal that caustics come from; Jensen's projection maps, with one
/// sphere): `aimed` holds the scene's lights with those at infinity bounded
/// by `aim`, so they send rays from a disc of its cross-section, and a
/// light with a surface sends them uniformly into the cone that `aim`
/// subtends from the point (as `start` does from a point inside it).
/// Point and spot lights emit as in `start`. No ray that could reach the
/// sphere is left out, and each carries its own density.
#[allow(clippy::too_many_arguments)]
pub fn start_aimed(
    scene: &Scene,
    aimed: &LightSet,
    aim: SceneSphere,
    u_light: f32,
    u_pos: (f32, f32),
    u_dir: (f32, f32),
    wl: &SampledWavelengths,
    counters: &mut PathCounters,
) -> Option<LightPath> {
    let (light, pmf) = aimed.choose(u_light)?;
    let l = aimed.get(light);
    let mut emitted = l.sample_le(u_pos, u_dir, wl)?;
    if l.is_infinite() {
        // From the disc facing `aim`, back to outside the whole scene, so
        // that whatever lies between (a roof, a wall) still casts its shadow.
        let back = scene.sphere.radius + (aim.centre - scene.sphere.centre).length();
        emitted.point.p -= emitted.dir * back;
    } else if !l.is_delta() {
        if let Some((dir, pdf_dir)) = towards_sphere(emitted.point.p, aim, u_dir) {
            let n = emitted.point.n;
            emitted = LightLeSample {
                point: LightPoint {
                    n: if n.dot(dir) < 0.0 { -n } else { n },
                    ..emitted.point
                },
                dir,
                le: l.l(emitted.point.uv, dir, wl),
                pdf_dir,
                ..emitted
            };
            if emitted.le == SampledSpectrum::ZERO {
                return None;
            }
        }
    }
    Some(leaving(scene, light, pmf, emitted, counters))
}

/// A direction from `p` drawn uniformly in the cone of the sphere `s`,
/// with its solid-angle density; None when `p` lies inside it.
fn towards_sphere(p: Vec3, s: SceneSphere, u: (f32, f32)) -> Option<(Vec3, f32)> {
    let to = s.centre - p;
    let d2 = to.length_squared();
    let r2 = s.radius * s.radius;
    if !(d2 > r2) {
        return None;
    }
    // 1 − cos θmax without cancellation for a small, far sphere.
    let sin2 = r2 / d2;
    let one_minus_cos_max = sin2 / (1.0 + (1.0 - sin2).sqrt());
    let one_minus_cos = u.0 * one_minus_cos_max;
    let cos = 1.0 - one_minus_cos;
    let sin = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.1;
    let local = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
    let dir = Frame::from_normal(to / d2.sqrt())
        .to_world(local)
        .normalize();
    Some((dir, 1.0 / (2.0 * std::f32::consts::PI * one_minus_cos_max)))
}

/// The path that `emitted` (of light `light`, chosen with `pmf`) starts.
fn leaving(
    scene: &Scene,
    light: usize,
    pmf: f32,
    emitted: LightLeSample,
    counters: &mut PathCounters,
) -> LightPath {
    let l = scene.lights.get(light);
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
    LightPath {
        light,
        pmf,
        emitted,
        n,
        beta,
        ray,
        stack,
    }
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
    mut visit: impl FnMut(LightVertex<'_>),
) {
    walk_until(ctx, start, max_depth, rr_depth, |v| {
        visit(v);
        Flow::Go
    });
}

/// `walk`, where `visit` may end the path at a vertex (`Flow::End`).
pub fn walk_until(
    ctx: &mut PathContext,
    start: LightPath,
    max_depth: u32,
    rr_depth: u32,
    visit: impl FnMut(LightVertex<'_>) -> Flow,
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

impl<F: FnMut(LightVertex<'_>) -> Flow> Visitor for Visit<F> {
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
        })
    }
}
