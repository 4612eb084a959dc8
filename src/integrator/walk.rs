//! The one random walk every integrator's paths take: camera paths of the
//! path tracer, light paths of the light tracer and of photon mapping, and
//! both subpaths of bdpt. The walk traces to the next event (a surface, a
//! scattering point in a medium, an escape), builds the BSDF, draws one 4D
//! point a bounce (direction, lobe, Russian roulette), moves the IOR stack
//! across interfaces and plays Russian roulette; a [`Visitor`] says what
//! the integrator does at each event (gather light, record a vertex,
//! connect to the camera) and may end the walk.
//!
//! The order of random numbers is fixed here: a bounce's own numbers come
//! after whatever the visitor drew at the event (light samples), so a
//! transport change made here is made once for every integrator.

use glam::Vec3;

use super::interface::{bsdf_at, scatter, trace, FirstHit, Next};
use super::ior_stack::{Entry, IorStack};
use super::volume::Flight;
use super::PathCounters;
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::material::{Bsdf, TransportMode};
use crate::medium::HenyeyGreenstein;
use crate::sampler::Sampler;
use crate::scene::{Scene, SurfaceHit};
use crate::spectrum::{lanes_led_by, SampledSpectrum, SampledWavelengths};

/// What every step of a path uses: the scene, the path's wavelengths (a
/// dispersive interface may end the secondaries), its sampler and the
/// render's counters.
pub struct PathContext<'a> {
    pub scene: &'a Scene,
    pub wl: &'a mut SampledWavelengths,
    pub sampler: &'a mut Sampler,
    pub counters: &'a mut PathCounters,
}

/// Where a path is: the ray it follows, the media it is in, what it
/// carries, and how far it came.
#[derive(Clone)]
pub struct Walk {
    pub ray: Ray,
    pub stack: IorStack,
    pub flight: Flight,
    /// Scattering events so far (surfaces and points in media), the one
    /// being visited included.
    pub depth: u32,
    /// Product of η'² over transmissions for radiance: refraction scales
    /// radiance by 1/η'², which Russian roulette must not mistake for a
    /// dim path (1 for importance, which refraction does not scale).
    pub eta_scale: f32,
    /// Events before Russian roulette may end the path.
    pub rr_depth: u32,
    /// The ray leaves the camera (cleared once traced): single-sided
    /// surfaces seen from behind are not there for it.
    pub camera_ray: bool,
}

impl Walk {
    pub fn new(ray: Ray, stack: IorStack, beta: SampledSpectrum, rr_depth: u32) -> Self {
        Self {
            ray,
            stack,
            flight: Flight::new(beta),
            depth: 0,
            eta_scale: 1.0,
            rr_depth,
            camera_ray: false,
        }
    }

    /// A walk from the camera along `ray` (radiance, nothing around it).
    pub fn from_camera(ray: Ray, stack: IorStack, rr_depth: u32) -> Self {
        Self {
            camera_ray: true,
            ..Self::new(ray, stack, SampledSpectrum::ONE, rr_depth)
        }
    }
}

/// Where a path scatters.
#[derive(Clone, Copy)]
pub enum Scatterer<'a> {
    Surface {
        hit: &'a SurfaceHit,
        bsdf: &'a Bsdf,
        /// What `trace` said of the surface (the dielectric it bounds).
        medium: Option<(Entry, bool)>,
    },
    /// A point inside a medium, with its phase function.
    Medium { p: Vec3, phase: HenyeyGreenstein },
}

/// A scattering event: where, and the direction back along the path.
#[derive(Clone, Copy)]
pub struct Event<'a> {
    pub at: Scatterer<'a>,
    pub wo: Vec3,
}

/// Whether the walk goes on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    Go,
    End,
}

/// What an integrator does along a walk.
pub trait Visitor {
    /// What the path carries: radiance (from the camera) or importance
    /// (from a light). A constant for most visitors, which lets the
    /// compiler specialise the BSDF's sampling to it.
    fn mode(&self) -> TransportMode;

    /// The walk reached a surface (`Some`, before its BSDF is built) or a
    /// scattering point in a medium (`None`); `walk.depth` does not count
    /// it yet. End here to stop at a depth limit.
    fn arrive(&mut self, ctx: &mut PathContext, walk: &Walk, hit: Option<&SurfaceHit>) -> Flow;

    /// At a scattering event, before its direction is drawn (`walk.depth`
    /// counts it): gather, record, connect; end the walk if it is done.
    fn scatter_from(&mut self, ctx: &mut PathContext, walk: &Walk, event: &Event) -> Flow;

    /// At a surface, after `scatter_from`, where the walk would draw one
    /// BSDF sample: the visitor may take the bounce itself and walk the
    /// path on to its end (true). Not asked where a caller follows one
    /// lobe (`Dispersion::follow_refraction`, `reflect_all`) or draws a
    /// branch's bounce itself (`scatter_from_surface`).
    fn takes_bounce(&mut self, _ctx: &mut PathContext, _walk: &Walk, _event: &Event) -> bool {
        false
    }

    /// The numbers of the bounce from the event just visited.
    fn numbers(&mut self, ctx: &mut PathContext, _walk: &Walk) -> [f32; 4] {
        ctx.sampler.next_4d()
    }

    /// A direction `wi` was drawn from `event` with density `pdf` (a
    /// Dirac lobe's: `specular`).
    fn scattered(
        &mut self,
        _scene: &Scene,
        _walk: &Walk,
        _event: &Event,
        _wi: Vec3,
        _pdf: f32,
        _specular: bool,
    ) {
    }

    /// The path left the scene.
    fn escaped(&mut self, _ctx: &mut PathContext, _walk: &Walk) {}

    /// Whether a surface that would end the secondary wavelengths (a
    /// smooth dispersive interface) hands the path to `disperse` instead.
    fn splits_dispersion(&self) -> bool {
        false
    }

    /// At such a surface (`walk.depth` counts it; `ctx.wl` as it arrived,
    /// every wavelength live): the visitor continues the path itself, once
    /// per wavelength (`Dispersion::follow`); the walk ends here.
    fn disperse(&mut self, _ctx: &mut PathContext, _walk: &Walk, _at: &Dispersion) {}
}

/// A surface where the path's wavelengths part: what following one of
/// them from it needs.
pub struct Dispersion<'a> {
    pub hit: &'a SurfaceHit,
    /// η per wavelength, in the order the path arrived with.
    pub eta: SampledSpectrum,
    pub medium: Option<(Entry, bool)>,
}

impl Dispersion<'_> {
    /// Follows wavelength `k` of `wl` (as the path arrived) alone from this
    /// surface: `walk` and `wl` become the path led by it, which scatters
    /// here and walks on with `visitor` until it ends.
    pub fn follow(
        &self,
        ctx: &mut PathContext,
        walk: &mut Walk,
        k: usize,
        visitor: &mut impl Visitor,
    ) {
        let bsdf = self.led_by(ctx, walk, k);
        if at_surface(ctx, walk, self.hit, &bsdf, self.medium, visitor) {
            self::walk(ctx, walk, visitor);
        }
    }

    /// `follow`, along the refraction alone, weighted by the probability
    /// one sample would have refracted: with `reflect_all`, the surface's
    /// two lobes followed apart.
    pub fn follow_refraction(
        &self,
        ctx: &mut PathContext,
        walk: &mut Walk,
        k: usize,
        visitor: &mut impl Visitor,
    ) {
        let bsdf = self.led_by(ctx, walk, k);
        self.follow_lobe(ctx, walk, &bsdf, false, visitor);
    }

    /// The reflection from this surface, which does not disperse: one path
    /// keeps all four wavelengths (`ctx.wl` as the path arrived), weighted
    /// by the probability one sample would have reflected.
    pub fn reflect_all(&self, ctx: &mut PathContext, walk: &mut Walk, visitor: &mut impl Visitor) {
        // Building a dispersive BSDF ends the secondaries, which only
        // refraction must: the copy's ending is dropped.
        let mut wl = *ctx.wl;
        let bsdf = bsdf_at(ctx.scene, self.hit, -walk.ray.dir, &mut wl, self.eta);
        self.follow_lobe(ctx, walk, &bsdf, true, visitor);
    }

    /// Turns `walk` and `ctx.wl` into the path led by wavelength `k`; the
    /// surface's BSDF for it.
    fn led_by(&self, ctx: &mut PathContext, walk: &mut Walk, k: usize) -> Bsdf {
        *ctx.wl = ctx.wl.led_by(k);
        walk.flight.beta = lanes_led_by(walk.flight.beta, k);
        let eta = lanes_led_by(self.eta, k);
        bsdf_at(ctx.scene, self.hit, -walk.ray.dir, ctx.wl, eta)
    }

    fn follow_lobe(
        &self,
        ctx: &mut PathContext,
        walk: &mut Walk,
        bsdf: &Bsdf,
        reflect: bool,
        visitor: &mut impl Visitor,
    ) {
        let event = Event {
            at: Scatterer::Surface {
                hit: self.hit,
                bsdf,
                medium: self.medium,
            },
            wo: -walk.ray.dir,
        };
        if visitor.scatter_from(ctx, walk, &event) == Flow::End {
            return;
        }
        let u = visitor.numbers(ctx, walk);
        if scatter_along_lobe(ctx, walk, &event, reflect, u, visitor) {
            self::walk(ctx, walk, visitor);
        }
    }
}

/// Walks the path from `walk` until it escapes, is absorbed, loses Russian
/// roulette or the visitor ends it.
#[inline]
pub fn walk(ctx: &mut PathContext, walk: &mut Walk, visitor: &mut impl Visitor) {
    while step(ctx, walk, FirstHit::Unknown, visitor) == Flow::Go {}
}

/// One step of `walk`: traces `walk.ray` (whose closest surface `first`
/// may already hold) to the next event and takes it; `Go` while the walk
/// goes on (along the new `walk.ray`). A stream of paths advances each
/// path by steps, with their rays traced together in between.
#[inline(always)]
pub fn step(
    ctx: &mut PathContext,
    walk: &mut Walk,
    first: FirstHit,
    visitor: &mut impl Visitor,
) -> Flow {
    let next = trace(
        ctx.scene,
        &mut walk.ray,
        first,
        std::mem::take(&mut walk.camera_ray),
        &mut walk.stack,
        ctx.wl,
        &mut walk.flight,
        Some(&mut *ctx.sampler),
        ctx.counters,
    );
    take(ctx, walk, next, visitor)
}

/// Takes the event `next` that tracing `walk.ray` reached (`step`'s
/// second half, for a ray traced elsewhere): `Go` while the walk goes on.
#[inline(always)]
pub fn take(
    ctx: &mut PathContext,
    walk: &mut Walk,
    next: Next,
    visitor: &mut impl Visitor,
) -> Flow {
    match next {
        Next::Surface { hit, eta, medium } => {
            if visitor.arrive(ctx, walk, Some(&hit)) == Flow::End {
                return Flow::End;
            }
            walk.depth += 1;
            // Only glass of a dispersive index may end the secondaries.
            let arrived = (visitor.splits_dispersion()
                && ctx.scene.materials[hit.material as usize]
                    .ior()
                    .is_some_and(|ior| ior.is_dispersive()))
            .then_some(*ctx.wl);
            let bsdf = bsdf_at(ctx.scene, &hit, -walk.ray.dir, ctx.wl, eta);
            // Not after a chromatic medium's spectral MIS (r ≠ 1): a
            // wavelength the hero drew no flights for cannot go alone.
            if let Some(arrived) = arrived.filter(|a| {
                ctx.wl.secondary_terminated()
                    && !a.secondary_terminated()
                    && walk.flight.r == SampledSpectrum::ONE
            }) {
                *ctx.wl = arrived;
                let at = Dispersion {
                    hit: &hit,
                    eta,
                    medium,
                };
                visitor.disperse(ctx, walk, &at);
                return Flow::End;
            }
            go_on(at_surface(ctx, walk, &hit, &bsdf, medium, visitor))
        }
        Next::Medium { p, phase } => {
            if visitor.arrive(ctx, walk, None) == Flow::End {
                return Flow::End;
            }
            walk.depth += 1;
            let dir_in = walk.ray.dir.normalize();
            let event = Event {
                at: Scatterer::Medium { p, phase },
                wo: -dir_in,
            };
            if visitor.scatter_from(ctx, walk, &event) == Flow::End {
                return Flow::End;
            }
            let [u0, u1, _, u_rr] = visitor.numbers(ctx, walk);
            let (wi, pdf) = phase.sample(dir_in, (u0, u1));
            visitor.scattered(ctx.scene, walk, &event, wi, pdf, false);
            walk.ray = Ray::new(p, wi).starting_in_free_space(true);
            let (eta_scale, depth, rr_depth) = (walk.eta_scale, walk.depth, walk.rr_depth);
            go_on(
                walk.flight
                    .roulette(ctx.wl, eta_scale, depth, rr_depth, u_rr),
            )
        }
        Next::Escaped => {
            visitor.escaped(ctx, walk);
            Flow::End
        }
        Next::Lost => Flow::End,
    }
}

/// `Go` if `goes_on`.
#[inline(always)]
fn go_on(goes_on: bool) -> Flow {
    if goes_on {
        Flow::Go
    } else {
        Flow::End
    }
}

/// At a surface `hit` with its `bsdf`: fluorescence, the visitor, and the
/// BSDF sample that continues the walk; whether it goes on.
#[inline(always)]
fn at_surface(
    ctx: &mut PathContext,
    walk: &mut Walk,
    hit: &SurfaceHit,
    bsdf: &Bsdf,
    medium: Option<(Entry, bool)>,
    visitor: &mut impl Visitor,
) -> bool {
    let material = &ctx.scene.materials[hit.material as usize];
    if material.is_fluorescent() {
        // The light this bounce carries comes from where it was absorbed:
        // light samples and the rest of the path see those wavelengths.
        // (Only camera paths meet fluorescence:
        // `Integrator::handles_fluorescence`.)
        debug_assert!(visitor.mode() == TransportMode::Radiance);
        let u = ctx.sampler.next_4d();
        walk.flight.beta *= material.fluoresce(hit.uv, ctx.wl, u);
    }
    let event = Event {
        at: Scatterer::Surface { hit, bsdf, medium },
        wo: -walk.ray.dir,
    };
    if visitor.scatter_from(ctx, walk, &event) == Flow::End
        || visitor.takes_bounce(ctx, walk, &event)
    {
        return false;
    }
    let u = visitor.numbers(ctx, walk);
    scatter_from_surface(ctx, walk, &event, u, visitor)
}

/// The BSDF sample that continues `walk` from the surface `event` with the
/// numbers `u`, the IOR stack across it, and Russian roulette: whether the
/// walk goes on. (The path tracer's branches take this step themselves.)
#[inline(always)]
pub fn scatter_from_surface(
    ctx: &mut PathContext,
    walk: &mut Walk,
    event: &Event,
    u: [f32; 4],
    visitor: &mut impl Visitor,
) -> bool {
    let [u0, u1, uc, u_rr] = u;
    let mode = visitor.mode();
    let sample = |bsdf: &Bsdf| {
        bsdf.sample(event.wo, uc, (u0, u1), mode)
            .map(|bs| (bs, 1.0))
    };
    scatter_by(ctx, walk, event, sample, u_rr, visitor)
}

/// `scatter_from_surface` along one lobe of a BSDF that `has_two_lobes`:
/// reflection (`reflect`) or transmission, weighted by the probability
/// one sample would have taken it (`Bsdf::sample_lobe`). A path that
/// follows both estimates what one sample does.
pub fn scatter_along_lobe(
    ctx: &mut PathContext,
    walk: &mut Walk,
    event: &Event,
    reflect: bool,
    [u0, u1, _, u_rr]: [f32; 4],
    visitor: &mut impl Visitor,
) -> bool {
    let mode = visitor.mode();
    let sample = |bsdf: &Bsdf| bsdf.sample_lobe(event.wo, reflect, (u0, u1), mode);
    scatter_by(ctx, walk, event, sample, u_rr, visitor)
}

/// The rest of a bounce once `sample` has drawn the direction from the
/// event's BSDF (with a weight the sample's value also carries).
#[inline(always)]
fn scatter_by(
    ctx: &mut PathContext,
    walk: &mut Walk,
    event: &Event,
    sample: impl FnOnce(&Bsdf) -> Option<(crate::material::BsdfSample, f32)>,
    u_rr: f32,
    visitor: &mut impl Visitor,
) -> bool {
    bounce_by(ctx, walk, event, sample, visitor).is_some() && roulette(ctx, walk, u_rr)
}

/// `scatter_along_lobe` without Russian roulette: `walk` leaves the
/// surface along the lobe, weighted by its probability, which is returned
/// (None where the lobe carries nothing).
pub fn bounce_along_lobe(
    ctx: &mut PathContext,
    walk: &mut Walk,
    event: &Event,
    reflect: bool,
    (u0, u1): (f32, f32),
    visitor: &mut impl Visitor,
) -> Option<f32> {
    let mode = visitor.mode();
    let sample = |bsdf: &Bsdf| bsdf.sample_lobe(event.wo, reflect, (u0, u1), mode);
    bounce_by(ctx, walk, event, sample, visitor)
}

/// Russian roulette after a bounce, with the number `u_rr`: whether the
/// walk goes on (its throughput raised if it does).
#[inline(always)]
pub fn roulette(ctx: &mut PathContext, walk: &mut Walk, u_rr: f32) -> bool {
    let (eta_scale, depth, rr_depth) = (walk.eta_scale, walk.depth, walk.rr_depth);
    walk.flight
        .roulette(ctx.wl, eta_scale, depth, rr_depth, u_rr)
}

/// The bounce itself: the throughput, the new ray, and the IOR stack
/// across the surface; the sample's weight, None if there was none.
#[inline(always)]
fn bounce_by(
    ctx: &mut PathContext,
    walk: &mut Walk,
    event: &Event,
    sample: impl FnOnce(&Bsdf) -> Option<(crate::material::BsdfSample, f32)>,
    visitor: &mut impl Visitor,
) -> Option<f32> {
    let Scatterer::Surface { hit, bsdf, medium } = event.at else {
        return None;
    };
    let mode = visitor.mode();
    let (bs, weight) = sample(bsdf)?;
    walk.flight.beta *= bs.f * (weight * bsdf.cos_theta(bs.wi) / bs.pdf);
    visitor.scattered(ctx.scene, walk, event, bs.wi, bs.pdf, bs.is_specular());
    walk.ray = Ray::new(offset_ray_origin(hit.p, hit.p_err, hit.ng, bs.wi), bs.wi);
    // Transmission through a dielectric moves the path into or out of it.
    let crossed = scatter(
        &mut walk.stack,
        medium,
        event.wo,
        bs.wi,
        hit.ng,
        ctx.counters,
    );
    if crossed && medium.is_some() && mode == TransportMode::Radiance {
        walk.eta_scale *= bs.eta * bs.eta;
    }
    Some(weight)
}
