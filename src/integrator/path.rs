//! The path tracer: unidirectional paths from the camera with next-event
//! estimation, combined with BSDF sampling by multiple importance sampling
//! (power heuristic), and Russian roulette. Each path carries the stack of
//! dielectric media it is inside.

use super::interface::{bsdf_at, scatter, stack_towards, trace, transmittance, Next};
use super::ior_stack::{Entry, IorStack};
use super::volume::Flight;
use super::{camera_ray, Integrate, IntegratorSpec, PixelSample, MAX_SPLIT};
use super::{power_heuristic, PathCounters, Strategy};
use crate::camera::Camera;
use crate::drive::{
    pixels::{self, PixelEstimator},
    RenderError, RenderJob, RenderOptions, RenderStats,
};
use crate::film::{Film, FilmSettings};
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::light::LightPoint;
use crate::light::LightSource;
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
    /// Continuations per camera sample from its first surface.
    pub split: u32,
}

impl Default for PathTracer {
    fn default() -> Self {
        Self {
            max_depth: 16,
            rr_depth: 3,
            strategy: Strategy::Mis,
            split: 1,
        }
    }
}

/// The surface a path scatters from: the hit, the direction back along
/// the path, the BSDF there and what `trace` said of the media.
#[derive(Clone, Copy)]
struct Scattering<'a> {
    hit: &'a SurfaceHit,
    wo: glam::Vec3,
    bsdf: &'a Bsdf,
    medium: Option<(Entry, bool)>,
}

/// Where a camera path is: the ray it follows and what it carries.
#[derive(Clone)]
struct PathState {
    ray: Ray,
    flight: Flight,
    /// The last bounce was a Dirac one (or there was none: the camera ray
    /// sees emitters as a specular bounce would, no light sampling competes).
    specular: bool,
    prev_bsdf_pdf: f32,
    /// Surfaces and scattering events met so far.
    depth: u32,
    stack: IorStack,
    /// Product of η'² over transmissions: radiance scales by 1/η'² entering
    /// a denser medium, which Russian roulette must not mistake for a dim path.
    eta_scale: f32,
}

impl PathState {
    fn new(ray: Ray) -> Self {
        Self {
            ray,
            flight: Flight::new(SampledSpectrum::ONE),
            specular: true,
            prev_bsdf_pdf: 0.0,
            depth: 0,
            stack: IorStack::default(),
            eta_scale: 1.0,
        }
    }
}

impl PathTracer {
    pub fn from_spec(spec: &IntegratorSpec) -> Result<Self, String> {
        let d = PathTracer::default();
        let split = spec.split.unwrap_or(d.split);
        if !(1..=MAX_SPLIT).contains(&split) {
            return Err(format!(
                "`integrator.split` must be between 1 and {MAX_SPLIT}, not {split}"
            ));
        }
        Ok(PathTracer {
            max_depth: spec.max_depth.unwrap_or(d.max_depth),
            rr_depth: spec.rr_depth.unwrap_or(d.rr_depth),
            strategy: spec.strategy.unwrap_or(d.strategy),
            split,
        })
    }
}

impl PixelEstimator for PathTracer {
    type Shared = ();

    fn prepares(&self) -> bool {
        false
    }

    fn prepare(&self, _: &Scene, _: u64, _: u32) -> ((), PathCounters) {
        ((), PathCounters::default())
    }

    fn shared_bytes(&self, _: &Scene) -> u64 {
        0
    }

    fn sample(
        &self,
        scene: &Scene,
        (x, y): (u32, u32),
        sampler: &mut Sampler,
        _: &(),
        counters: &mut PathCounters,
    ) -> PixelSample {
        let [dx, dy, u_lambda, _] = sampler.next_4d();
        let mut wl = scene.wavelengths.sample(u_lambda);
        let ray = camera_ray(scene, x as f32 + dx, y as f32 + dy, sampler);
        let l = self.radiance(scene, ray, &mut wl, sampler, counters);
        PixelSample { l, wl }
    }
}

impl Integrate for PathTracer {
    fn check(
        &self,
        _: &Camera,
        _: &FilmSettings,
        options: &RenderOptions,
    ) -> Result<(), RenderError> {
        pixels::check(options)
    }

    fn loop_memory(
        &self,
        scene: &Scene,
        film: &FilmSettings,
        options: &RenderOptions,
    ) -> (u64, u64) {
        pixels::memory(self, scene, film, options)
    }

    fn render(&self, job: RenderJob) -> (Film, RenderStats) {
        pixels::render(job, self)
    }

    fn max_depth(&self) -> u32 {
        self.max_depth
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
        let st = PathState::new(ray);
        self.walk(scene, st, wl, sampler, counters, &mut |_| None, self.split)
    }

    /// `radiance`, where `stop` may end the path at a surface with an
    /// estimate of the light it reflects (photon mapping ends camera paths
    /// at their first diffuse surface). Emission at the surface is already
    /// counted; the estimate is weighted by the path's throughput. Paths
    /// do not split here.
    pub fn radiance_until(
        &self,
        scene: &Scene,
        ray: Ray,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        counters: &mut PathCounters,
        mut stop: impl FnMut(Stop<'_>) -> Option<SampledSpectrum>,
    ) -> SampledSpectrum {
        self.walk(
            scene,
            PathState::new(ray),
            wl,
            sampler,
            counters,
            &mut stop,
            1,
        )
    }

    /// The path from `st` on: the radiance it gathers until it ends. With
    /// `split` > 1 it splits at the first surface it scatters from.
    #[allow(clippy::too_many_arguments)]
    fn walk<F: FnMut(Stop<'_>) -> Option<SampledSpectrum>>(
        &self,
        scene: &Scene,
        mut st: PathState,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        counters: &mut PathCounters,
        stop: &mut F,
        split: u32,
    ) -> SampledSpectrum {
        let mut l = SampledSpectrum::ZERO;
        loop {
            let next = trace(
                scene,
                &mut st.ray,
                &mut st.stack,
                wl,
                &mut st.flight,
                Some(&mut *sampler),
                counters,
            );
            let (hit, eta, medium) = match next {
                Next::Surface { hit, eta, medium } => (hit, eta, medium),
                Next::Medium { p, phase } => {
                    if st.depth == self.max_depth {
                        break;
                    }
                    st.depth += 1;
                    let dir_in = st.ray.dir.normalize();
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
                            |_| st.stack,
                            wl,
                            sampler,
                            counters,
                        );
                        l += st.flight.weight(wl) * direct;
                    } else {
                        sampler.skip_4d();
                    }
                    let [u0, u1, _, u_rr] = sampler.next_4d();
                    let (wi, pdf) = phase.sample(dir_in, (u0, u1));
                    st.specular = false;
                    st.prev_bsdf_pdf = pdf;
                    st.ray = Ray::new(p, wi);
                    if !st
                        .flight
                        .roulette(wl, st.eta_scale, st.depth, self.rr_depth, u_rr)
                    {
                        break;
                    }
                    continue;
                }
                Next::Escaped => {
                    // Only lights at infinity are seen.
                    for (i, light) in scene.lights.infinite() {
                        let le = light.le(st.ray.dir, wl);
                        let weight = self.emission_weight(st.specular, st.prev_bsdf_pdf, || {
                            scene.lights.pmf(i) * light.pdf_li(st.ray.origin, st.ray.dir, None)
                        });
                        l += st.flight.weight(wl) * le * weight;
                    }
                    break;
                }
                Next::Lost => break,
            };
            let wo = -st.ray.dir;

            if let Some(i) = hit.light {
                let light = scene.lights.get(i);
                let le = light.l(hit.uv, wo, wl);
                if le != SampledSpectrum::ZERO {
                    let weight = self.emission_weight(st.specular, st.prev_bsdf_pdf, || {
                        scene.lights.pmf(i) * light.pdf_li(st.ray.origin, st.ray.dir, Some(hit.p))
                    });
                    l += st.flight.weight(wl) * le * weight;
                }
            }

            if st.depth == self.max_depth {
                break;
            }
            st.depth += 1;

            let bsdf = bsdf_at(scene, &hit, wo, wl, eta);
            let at = Stop {
                hit: &hit,
                wo,
                bsdf: &bsdf,
                wl,
                depth: st.depth,
                sampler: &mut *sampler,
                counters: &mut *counters,
                stack: &st.stack,
                medium,
            };
            if let Some(reflected) = stop(at) {
                l += st.flight.weight(wl) * reflected;
                break;
            }

            let surface = Scattering {
                hit: &hit,
                wo,
                bsdf: &bsdf,
                medium,
            };
            l += self.direct(scene, &st, &surface, wl, sampler, counters);

            if split > 1 {
                // The first surface: the sample splits into `split`
                // continuations, each with its own copy of the path. Its
                // direct light stays one estimate: light sampling in every
                // branch lowered the Cornell Box's variance 3-9% for 9-18%
                // more time.
                l += self.branches(scene, &st, &surface, wl, sampler, counters, split);
                break;
            }
            if !self.scatter(&mut st, &surface, wl, sampler, counters) {
                break;
            }
        }
        l
    }

    /// `split` continuations of a path at `surface`, each a BSDF sample and
    /// the walk from there with its own copy of the path, sampler branch
    /// and wavelengths, averaged. Each branch's radiance counts per
    /// wavelength over its own density (a branch through a dispersive
    /// interface keeps only its hero), so the average is returned at the
    /// path's unchanged wavelengths.
    #[allow(clippy::too_many_arguments)]
    fn branches(
        &self,
        scene: &Scene,
        st: &PathState,
        surface: &Scattering<'_>,
        wl: &SampledWavelengths,
        sampler: &Sampler,
        counters: &mut PathCounters,
        split: u32,
    ) -> SampledSpectrum {
        let mut per_density = SampledSpectrum::ZERO;
        for k in 0..split {
            let mut branch = st.clone();
            let mut wl_k = *wl;
            let mut sampler_k = sampler.branch(k, split);
            let l = if self.scatter(&mut branch, surface, &wl_k, &mut sampler_k, counters) {
                self.walk(
                    scene,
                    branch,
                    &mut wl_k,
                    &mut sampler_k,
                    counters,
                    &mut |_| None,
                    1,
                )
            } else {
                SampledSpectrum::ZERO
            };
            let live = wl_k.pdf.cmpgt(SampledSpectrum::ZERO);
            per_density += SampledSpectrum::select(live, l / wl_k.pdf, SampledSpectrum::ZERO);
        }
        per_density * wl.pdf / split as f32
    }

    /// Next-event estimation at the path's `surface`, weighted by what
    /// the path carries (zero, with its numbers skipped, where the strategy
    /// or a Dirac BSDF rules it out).
    fn direct(
        &self,
        scene: &Scene,
        st: &PathState,
        surface: &Scattering<'_>,
        wl: &SampledWavelengths,
        sampler: &mut Sampler,
        counters: &mut PathCounters,
    ) -> SampledSpectrum {
        if self.strategy != Strategy::Bsdf && !surface.bsdf.is_specular() {
            let direct = self.sample_direct(
                scene,
                surface.hit,
                surface.wo,
                surface.bsdf,
                &st.stack,
                surface.medium,
                wl,
                sampler,
                counters,
            );
            st.flight.weight(wl) * direct
        } else {
            // Keep the dimensions of later bounces aligned across samples.
            sampler.skip_4d();
            SampledSpectrum::ZERO
        }
    }

    /// The BSDF sample that continues the path at `surface`, and Russian
    /// roulette: whether the path goes on.
    fn scatter(
        &self,
        st: &mut PathState,
        surface: &Scattering<'_>,
        wl: &SampledWavelengths,
        sampler: &mut Sampler,
        counters: &mut PathCounters,
    ) -> bool {
        let Scattering {
            hit,
            wo,
            bsdf,
            medium,
        } = *surface;
        // One 4D point per bounce: the BSDF's direction (2D), its lobe
        // choice, and Russian roulette.
        let [u0, u1, uc, u_rr] = sampler.next_4d();
        let Some(bs) = bsdf.sample(wo, uc, (u0, u1), TransportMode::Radiance) else {
            return false;
        };
        st.flight.beta *= bs.f * (bsdf.cos_theta(bs.wi) / bs.pdf);
        st.specular = bs.is_specular();
        st.prev_bsdf_pdf = bs.pdf;
        st.ray = Ray::new(offset_ray_origin(hit.p, hit.p_err, hit.ng, bs.wi), bs.wi);
        // Transmission through a dielectric moves the path into or out of it.
        if scatter(&mut st.stack, medium, wo, bs.wi, hit.ng, counters) && medium.is_some() {
            st.eta_scale *= bs.eta * bs.eta;
        }
        st.flight
            .roulette(wl, st.eta_scale, st.depth, self.rr_depth, u_rr)
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
