//! The path tracer: unidirectional paths from the camera with next-event
//! estimation, combined with BSDF sampling by multiple importance sampling
//! (power heuristic), and Russian roulette. Each path carries the stack of
//! dielectric media it is inside.

use super::interface::{stack_towards, transmittance};
use super::ior_stack::{Entry, IorStack};
use super::walk::{self, Dispersion, Event, Flow, PathContext, Scatterer, Visitor, Walk};
use super::{power_heuristic, PathCounters, Strategy};
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::light::LightPoint;
use crate::light::LightSource;
use crate::material::{Bsdf, BsdfFlags, TransportMode};
use crate::sampler::Sampler;
use crate::scene::{Scene, SurfaceHit};
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

mod branches;
mod look_ahead;
mod params;

pub(super) use params::check_split;

/// A surface a camera path reached, offered to `radiance_until`'s `stop`.
pub struct Stop<'a, 'c> {
    pub hit: &'a SurfaceHit,
    /// Towards where the path came from.
    pub wo: glam::Vec3,
    pub bsdf: &'a Bsdf,
    /// Surfaces met so far, this one included.
    pub depth: u32,
    /// The path's scene, wavelengths, sampler and counters.
    pub ctx: &'a mut PathContext<'c>,
    /// The media the path arrived in, and what `trace` said of the surface.
    pub stack: &'a IorStack,
    pub medium: Option<(Entry, bool)>,
}

/// Caustics estimated apart (`path_caustics`: a photon map of light that
/// crossed glass or met metal before a diffuse surface). The path tracer
/// adds the estimate at each diffuse surface it meets and leaves out the
/// light it would itself find after one through surfaces without a diffuse
/// lobe, so each path is counted once.
pub trait Caustics {
    /// Caustic light reflected towards `wo` at `hit`, for a path that has
    /// met `depth` surfaces (this one included).
    fn reflected(
        &self,
        hit: &SurfaceHit,
        wo: glam::Vec3,
        bsdf: &Bsdf,
        wl: &SampledWavelengths,
        depth: u32,
    ) -> SampledSpectrum;
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PathTracer {
    /// Most bounces: 1 is direct lighting only.
    pub max_depth: u32,
    /// Bounces before Russian roulette may end a path.
    pub rr_depth: u32,
    /// How direct light is found.
    pub strategy: Strategy,
    /// Continuations per camera sample from its first surface that is not
    /// a Dirac one.
    pub split: u32,
    /// At the first smooth dispersive interface, follow each wavelength on
    /// its own instead of the hero alone (`Gather::disperse`).
    pub split_dispersion: bool,
    /// At the first surface, where it is glass (both reflects and
    /// transmits), follow both lobes, each weighted by the probability of
    /// choosing it (`Gather::lobe_branches`).
    pub split_glass: bool,
    /// At smooth glass past the first surface of a path through mirrors
    /// and smooth glass alone, trace ahead the lobes that leave every
    /// object: the light each meets first is counted exactly, and the path
    /// goes on along one lobe (`Gather::look_ahead`).
    pub look_ahead: bool,
    /// In the packet core, the samples of a 2 × 2 block of pixels reuse
    /// each other's paths from their first bounce on (`path_packet::reuse`);
    /// None: where every surface of the scene is diffuse.
    pub reuse: Option<bool>,
}

impl Default for PathTracer {
    fn default() -> Self {
        Self {
            max_depth: 16,
            rr_depth: 3,
            strategy: Strategy::Mis,
            split: 1,
            split_dispersion: true,
            split_glass: true,
            look_ahead: false,
            reuse: None,
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
        let mut ctx = PathContext {
            scene,
            wl,
            sampler,
            counters,
        };
        self.gather(&mut ctx, self.camera_walk(ray), None, self.split)
    }

    /// `radiance`, where `stop` may end the path at a surface with an
    /// estimate of the light it reflects (photon mapping ends camera paths
    /// at their first diffuse surface). Emission at the surface is already
    /// counted; the estimate is weighted by the path's throughput. Paths
    /// do not split here.
    pub fn radiance_until(
        &self,
        ctx: &mut PathContext,
        ray: Ray,
        mut stop: impl FnMut(Stop<'_, '_>) -> Option<SampledSpectrum>,
    ) -> SampledSpectrum {
        self.gather(ctx, self.camera_walk(ray), Some(&mut stop), 1)
    }

    /// `radiance` with the caustics that `caustics` estimates in place of
    /// those the path would find itself (the trait's contract).
    pub fn radiance_with(
        &self,
        ctx: &mut PathContext,
        ray: Ray,
        caustics: &dyn Caustics,
    ) -> SampledSpectrum {
        let mut visitor = Gather::new(self, None, self.split);
        visitor.caustics = Some(caustics);
        walk::walk(ctx, &mut self.camera_walk(ray), &mut visitor);
        visitor.l
    }

    /// A walk from the camera: radiance, nothing around it yet.
    pub(super) fn camera_walk(&self, ray: Ray) -> Walk {
        Walk::from_camera(ray, IorStack::default(), self.rr_depth)
    }

    /// The light the path from `walk` on gathers until it ends. With
    /// `split` > 1 it splits at the first surface it scatters from whose
    /// BSDF is not a Dirac one (a mirror or smooth glass would send every
    /// branch one of at most two ways).
    fn gather(
        &self,
        ctx: &mut PathContext,
        mut walk: Walk,
        stop: Option<StopAt<'_>>,
        split: u32,
    ) -> SampledSpectrum {
        let mut visitor = Gather::new(self, stop, split);
        walk::walk(ctx, &mut walk, &mut visitor);
        visitor.l
    }

    /// Next-event estimation at `event` (a surface, or a point in a
    /// medium), weighted by what the path carries (zero, with its numbers
    /// skipped, where the strategy or a Dirac BSDF rules it out).
    /// With `defer`, a shadow ray that only a surface could block is not
    /// traced but left there, and the light returned is what arrives if
    /// nothing blocks it.
    fn direct(
        &self,
        ctx: &mut PathContext,
        walk: &Walk,
        event: &Event,
        defer: Option<&mut Option<Ray>>,
    ) -> SampledSpectrum {
        let ruled_out = self.strategy == Strategy::Bsdf
            || matches!(event.at, Scatterer::Surface { bsdf, .. } if bsdf.is_specular());
        if ruled_out {
            // Keep the dimensions of later bounces aligned across samples.
            ctx.sampler.skip_4d();
            return SampledSpectrum::ZERO;
        }
        let direct = match event.at {
            Scatterer::Surface { hit, bsdf, medium } => {
                let at = (hit, event.wo, bsdf);
                self.sample_direct(ctx, at, &walk.stack, medium, defer)
            }
            Scatterer::Medium { p, phase } => {
                let dir_in = -event.wo;
                self.sample_direct_from(
                    ctx,
                    p,
                    |wi| {
                        let f = phase.p(dir_in, wi);
                        (SampledSpectrum::splat(f), f)
                    },
                    |wi, to| {
                        match to {
                            Some(lp) => {
                                Ray::towards(p, offset_ray_origin(lp.p, lp.p_err, lp.n, -wi))
                            }
                            None => Ray::new(p, wi),
                        }
                        .starting_in_free_space(true)
                    },
                    |_| walk.stack,
                    None,
                )
            }
        };
        walk.flight.weight(ctx.wl) * direct
    }

    /// The weight of emission that the path found by BSDF sampling: all of
    /// it after a Dirac bounce or with BSDF sampling alone, none when light
    /// sampling alone counts it, else MIS against the light's density
    /// (`light_pdf`, computed only then).
    pub(super) fn emission_weight(
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
    /// the surface; `defer` as in `direct`).
    pub(super) fn sample_direct(
        &self,
        ctx: &mut PathContext,
        (hit, wo, bsdf): (&SurfaceHit, glam::Vec3, &Bsdf),
        stack: &IorStack,
        medium: Option<(Entry, bool)>,
        defer: Option<&mut Option<Ray>>,
    ) -> SampledSpectrum {
        self.sample_direct_from(
            ctx,
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
            defer,
        )
    }

    /// Next-event estimation: light arriving directly at `p` from a point
    /// sampled on a light, weighted against BSDF (or phase) sampling when
    /// the strategy is MIS. `scattering(wi)` gives the value (BSDF times
    /// cosine, or the phase function) and its density; `shadow(wi, point)`
    /// the ray to the light (its point, or a direction to infinity);
    /// `stack` the media that ray starts in; `defer` as in `direct`.
    pub(super) fn sample_direct_from(
        &self,
        ctx: &mut PathContext,
        p: glam::Vec3,
        scattering: impl Fn(glam::Vec3) -> (SampledSpectrum, f32),
        shadow: impl Fn(glam::Vec3, Option<LightPoint>) -> Ray,
        stack: impl Fn(glam::Vec3) -> IorStack,
        defer: Option<&mut Option<Ray>>,
    ) -> SampledSpectrum {
        let (scene, wl) = (ctx.scene, &*ctx.wl);
        // Draw the numbers whatever happens, so each path uses a fixed number
        // of dimensions per bounce: the point on the light (2D), which light.
        let [p0, p1, u_light, _] = ctx.sampler.next_4d();
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
        let shadow = shadow(wi, ls.point);
        let tr = match defer {
            // Without media only a surface can block it: all or nothing.
            Some(slot) if !scene.has_media() => {
                ctx.counters.rays += 1;
                *slot = Some(shadow);
                SampledSpectrum::ONE
            }
            _ => transmittance(scene, &shadow, &stack(wi), wl, ctx.counters),
        };
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

/// What may end a camera path at a surface (`radiance_until`).
pub(super) type StopAt<'s> = &'s mut dyn FnMut(Stop<'_, '_>) -> Option<SampledSpectrum>;

/// The path tracer's visitor: the light a camera path gathers (emission
/// found by BSDF sampling, next-event estimates), and its splitting.
pub(super) struct Gather<'t, 's> {
    tracer: &'t PathTracer,
    pub(super) l: SampledSpectrum,
    /// The last bounce was a Dirac one (or there was none).
    specular: bool,
    prev_bsdf_pdf: f32,
    stop: Option<StopAt<'s>>,
    split: u32,
    /// Caustics estimated apart, and what the path owes them: a diffuse
    /// surface was met and only surfaces without a diffuse lobe since (no
    /// medium scattering), the last of them just now, so light found now is
    /// a caustic's.
    caustics: Option<&'s dyn Caustics>,
    met_diffuse: bool,
    in_caustic: bool,
    /// The path may still split at a dispersive interface.
    disperses: bool,
    /// No surface met yet, and glass met first is to be split by lobe.
    splits_glass: bool,
    /// Leave light samples' shadow rays to be traced later (a stream's),
    /// the light in `unblocked` until then.
    pub(super) defers_shadows: bool,
    pub(super) shadow: Option<Ray>,
    pub(super) unblocked: SampledSpectrum,
    /// No surface met so far has a diffuse lobe (mirrors, glass and
    /// metal, smooth or rough): what the path finds is bright light seen
    /// as in a mirror, and looking ahead pays.
    no_diffuse: bool,
    /// The emission of the surface the path arrives at next was counted
    /// when the path looked ahead to it (`look_ahead`).
    counted_emission: bool,
}

impl<'t, 's> Gather<'t, 's> {
    pub(super) fn new(tracer: &'t PathTracer, stop: Option<StopAt<'s>>, split: u32) -> Self {
        // `stop` is not carried into branches.
        let splits_glass = tracer.split_glass && stop.is_none();
        Gather {
            tracer,
            l: SampledSpectrum::ZERO,
            // The camera ray sees emitters as a specular bounce would: no
            // light sampling competes.
            specular: true,
            prev_bsdf_pdf: 0.0,
            stop,
            split,
            caustics: None,
            met_diffuse: false,
            in_caustic: false,
            disperses: tracer.split_dispersion,
            splits_glass,
            defers_shadows: false,
            shadow: None,
            unblocked: SampledSpectrum::ZERO,
            no_diffuse: true,
            counted_emission: false,
        }
    }

    /// Adds the light sampled at `event`, or keeps it until its shadow ray
    /// is traced (`defers_shadows`; not where the path splits after it).
    fn add_direct(&mut self, ctx: &mut PathContext, walk: &Walk, event: &Event, splits: bool) {
        let defer = (self.defers_shadows && !splits).then_some(&mut self.shadow);
        let direct = self.tracer.direct(ctx, walk, event, defer);
        if self.shadow.is_some() {
            self.unblocked = direct;
        } else {
            self.l += direct;
        }
    }

    /// At a surface with `bsdf`: adds the caustics estimated there (a
    /// diffuse surface) and notes whether light found next is theirs (the
    /// surfaces since the last diffuse one have no diffuse lobe: mirrors,
    /// glass, metal, smooth or rough).
    fn caustics_at(
        &mut self,
        ctx: &mut PathContext,
        walk: &Walk,
        hit: &SurfaceHit,
        wo: glam::Vec3,
        bsdf: &Bsdf,
    ) {
        let Some(caustics) = self.caustics else {
            return;
        };
        if bsdf.flags().contains(BsdfFlags::DIFFUSE) {
            let reflected = caustics.reflected(hit, wo, bsdf, ctx.wl, walk.depth);
            self.l += walk.flight.weight(ctx.wl) * reflected;
            (self.met_diffuse, self.in_caustic) = (true, false);
        } else {
            self.in_caustic = self.met_diffuse;
        }
    }
}

impl Gather<'_, '_> {
    /// Adds the emission of `hit`, which `walk.ray` reached, as BSDF
    /// sampling found it (none where the path is in a caustic).
    fn add_emission(&mut self, ctx: &mut PathContext, walk: &Walk, hit: &SurfaceHit) {
        let Some(i) = hit.light.filter(|_| !self.in_caustic) else {
            return;
        };
        let light = ctx.scene.lights.get(i);
        let le = light.l(hit.uv, -walk.ray.dir, ctx.wl);
        if le != SampledSpectrum::ZERO {
            let tracer = self.tracer;
            let weight = tracer.emission_weight(self.specular, self.prev_bsdf_pdf, || {
                let pdf = light.pdf_li(walk.ray.origin, walk.ray.dir, Some(hit.p));
                ctx.scene.lights.pmf(i) * pdf
            });
            self.l += walk.flight.weight(ctx.wl) * le * weight;
        }
    }
}

impl Visitor for Gather<'_, '_> {
    fn mode(&self) -> TransportMode {
        TransportMode::Radiance
    }

    fn arrive(&mut self, ctx: &mut PathContext, walk: &Walk, hit: Option<&SurfaceHit>) -> Flow {
        if let Some(hit) = hit.filter(|_| !std::mem::take(&mut self.counted_emission)) {
            self.add_emission(ctx, walk, hit);
        }
        if walk.depth == self.tracer.max_depth {
            Flow::End
        } else {
            Flow::Go
        }
    }

    fn scatter_from(&mut self, ctx: &mut PathContext, walk: &Walk, event: &Event) -> Flow {
        let tracer = self.tracer;
        match event.at {
            Scatterer::Medium { .. } => {
                (self.met_diffuse, self.in_caustic) = (false, false);
                self.no_diffuse = false;
                self.splits_glass = false;
                self.l += tracer.direct(ctx, walk, event, None);
                Flow::Go
            }
            Scatterer::Surface { hit, bsdf, medium } => {
                if let Some(stop) = self.stop.as_mut() {
                    let at = Stop {
                        hit,
                        wo: event.wo,
                        bsdf,
                        depth: walk.depth,
                        ctx: &mut *ctx,
                        stack: &walk.stack,
                        medium,
                    };
                    if let Some(reflected) = stop(at) {
                        self.l += walk.flight.weight(ctx.wl) * reflected;
                        return Flow::End;
                    }
                }
                self.caustics_at(ctx, walk, hit, event.wo, bsdf);
                if self.no_diffuse {
                    self.no_diffuse = !bsdf.flags().contains(BsdfFlags::DIFFUSE);
                }
                let by_lobe = std::mem::take(&mut self.splits_glass) && bsdf.has_two_lobes();
                let by_split = self.split > 1 && !bsdf.is_specular();
                if self.in_caustic {
                    // Keep the dimensions of later bounces aligned.
                    ctx.sampler.skip_4d();
                } else {
                    self.add_direct(ctx, walk, event, by_lobe || by_split);
                }
                if by_lobe {
                    // Which of reflection and refraction the first glass
                    // takes is much of the noise where one lobe shows a
                    // bright light (a softbox in a diamond's facet): both
                    // are followed.
                    self.l += self.lobe_branches(ctx, walk, event);
                    return Flow::End;
                }
                if by_split {
                    // The first surface that is not a Dirac one: the sample
                    // splits into `split` continuations, each with its own copy of the path. Its
                    // direct light stays one estimate: light sampling in every
                    // branch lowered the Cornell Box's variance 3-9% for 9-18%
                    // more time.
                    self.l += self.branches(ctx, walk, event);
                    return Flow::End;
                }
                Flow::Go
            }
        }
    }

    fn scattered(
        &mut self,
        _: &Scene,
        _: &Walk,
        _: &Event,
        _: glam::Vec3,
        pdf: f32,
        specular: bool,
    ) {
        self.specular = specular;
        self.prev_bsdf_pdf = pdf;
    }

    fn splits_dispersion(&self) -> bool {
        self.disperses
    }

    fn takes_bounce(&mut self, ctx: &mut PathContext, walk: &Walk, event: &Event) -> bool {
        let Scatterer::Surface { bsdf, .. } = event.at else {
            return false;
        };
        let looks = self.looks_ahead(ctx, bsdf);
        if looks {
            self.look_ahead(ctx, walk, event);
        }
        looks
    }

    fn disperse(&mut self, ctx: &mut PathContext, walk: &Walk, at: &Dispersion) {
        // Glass met first: its two lobes are followed apart.
        let by_lobe = std::mem::take(&mut self.splits_glass);
        self.l += self.dispersion_branches(ctx, walk, at, by_lobe);
    }

    fn escaped(&mut self, ctx: &mut PathContext, walk: &Walk) {
        if self.in_caustic {
            return;
        }
        // Only lights at infinity are seen.
        for (i, light) in ctx.scene.lights.infinite() {
            let (le, pdf_li) = light.le_and_pdf_li(walk.ray.origin, walk.ray.dir, ctx.wl);
            let weight = self
                .tracer
                .emission_weight(self.specular, self.prev_bsdf_pdf, || {
                    ctx.scene.lights.pmf(i) * pdf_li
                });
            self.l += walk.flight.weight(ctx.wl) * le * weight;
        }
    }
}
