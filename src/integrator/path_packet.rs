//! The path tracer's packet core: a tile's camera samples advance as a
//! packet of as many paths as the CPU's packet of rays holds (sixteen with
//! AVX-512, else eight: `packet_width`), each stage run for every path of the
//! packet before the next (closest hits, emission found, light samples,
//! bounces, then the shadow rays), and a path that ends leaves its lane to
//! the tile's next sample.
//!
//! It models what a scene of surfaces that only reflect needs (diffuse,
//! fluorescent, metal, glTF's metallic-roughness, single-sided or not): no
//! media, no glass, no splitting ([`models`]). What it drops is
//! the one-at-a-time walk's generality (the visitor, the IOR stack, free
//! flights, dispersion), which such a scene pays for without using.
//! Diffuse surfaces take a lean BSDF of their own ([`Diffuse`]); the
//! others the general one. Where every surface is diffuse, the samples of
//! each 2 × 2 block of pixels reuse each other's paths past their first
//! bounce ([`reuse`], in the groups of [`groups`]). The estimator is the path tracer's
//! (`path`): next-event estimation and BSDF sampling weighed by the power
//! heuristic, the same Russian roulette, the same numbers of the sample's
//! sequence for the same decisions. Images agree with the one-at-a-time
//! tracer's in distribution (`tests/packet.rs`); the sums differ in their
//! last bits. Samples are added in the tile's order (`InOrder`), so the
//! image is the same for any thread count.

mod diffuse_lanes;
mod groups;
mod reuse;
mod surface;

use std::ops::Range;

use glam::{Vec3, Vec4};

use super::{power_heuristic, russian_roulette, PathCounters, PathTracer, PixelSample, Strategy};
use crate::drive::in_order::InOrder;
use crate::drive::stream;
use crate::drive::{RenderJob, TileRect};
use crate::film::FilmTile;
use crate::geometry::bvh::{packet_width, MAX_PACKET_WIDTH};
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::integrator::interface::{bsdf_at, MAX_FALSE_INTERSECTIONS};
use crate::light::{Light, LightPoint, LightSource};
use crate::material::{Material, Reflectance};
use crate::sampler::Sampler;
use crate::scene::{Scene, SurfaceHit};
use crate::spectrum::memo::SpectrumMemo;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};
use diffuse_lanes::{Bounced, DiffuseBounce, DiffuseBounces};
use groups::{reuses, tile_samples, Grouped, PendingGroups};
use reuse::{FirstBounce, Member, SecondVertex};
use surface::{Diffuse, General, Surface};

impl PathTracer {
    /// Whether this tracer's renders of `scene` advance their samples as
    /// packets (unless `RenderOptions::packets` says never).
    pub fn models_in_packets(&self, scene: &Scene) -> bool {
        models(self, scene)
    }

    /// Whether its packets reuse paths between the pixels of 2 × 2 blocks
    /// (`reuse`).
    pub fn reuses_paths(&self, scene: &Scene) -> bool {
        reuses(self, scene)
    }
}

/// Whether the packet core models everything `scene` needs under `tracer`:
/// surfaces that reflect and never transmit (so no IOR stack), in no media.
pub fn models(tracer: &PathTracer, scene: &Scene) -> bool {
    tracer.split == 1
        && !scene.has_media()
        && scene.materials.iter().all(|m| {
            matches!(
                m,
                Material::Diffuse { .. }
                    | Material::Fluorescent { .. }
                    | Material::Conductor { .. }
                    | Material::Pbr(_)
            )
        })
}

/// A camera sample in its lane.
struct Lane {
    /// Its place in the tile's order, its pixel and index.
    order: u64,
    sample: (u32, u32, u32),
    sampler: Sampler,
    wl: SampledWavelengths,
    /// The wavelengths the camera sees, which the film gets (fluorescence
    /// moves the path's own, `wl`, to where light was absorbed).
    seen: Vec4,
    /// The spectra met so far at `wl` (reflectances, the lamps' emission).
    spectra: SpectrumMemo,
    /// The ray whose closest surface the path waits on.
    ray: Ray,
    /// Path value over path density (no media: no spectral-MIS ratios).
    beta: SampledSpectrum,
    /// The light gathered so far.
    l: SampledSpectrum,
    /// Surfaces scattered from so far.
    depth: u32,
    /// Back faces of single-sided surfaces the camera's ray has passed (as
    /// `interface::trace` does; the ray is the camera's while `depth` is 0).
    passed: u32,
    /// The last bounce was a Dirac one, or there was none: emission found
    /// now has no light sample competing.
    specular: bool,
    /// The density of the last bounce's direction.
    prev_pdf: f32,
    /// The light sample's shadow ray, and the light it brings if nothing
    /// blocks it.
    shadow: Option<Ray>,
    unblocked: SampledSpectrum,
    counters: PathCounters,
    goes_on: bool,
    /// The group of samples that share their first bounces (`reuse`), and
    /// what this path leaves them: its first surface where it is diffuse,
    /// and the point its bounce from there reached.
    group: Option<u64>,
    first: Option<FirstBounce>,
    second: Option<SecondVertex>,
}

/// `tile::render_tile` for the path tracer on a scene it `models`: the
/// same samples, added in the same order, advanced as packets.
pub fn render_tile(
    tracer: &PathTracer,
    job: &RenderJob,
    rect: TileRect,
    pass_len: u32,
    indices: impl Fn(u32, u32) -> Range<u32>,
) -> FilmTile {
    let scene = job.scene;
    let mut tile = job.new_tile(rect, pass_len);
    let mut samples = tile_samples(reuses(tracer, scene), rect, &indices);
    let mut pending = PendingGroups::default();
    let mut in_order = InOrder::default();
    let width = packet_width();
    let mut lanes: Vec<Lane> = Vec::with_capacity(width);
    // A tree that outgrows the caches: the packet's walks interleaved as a
    // stream's, so that their waits for memory overlap.
    let streams = stream::wanted(job);
    let mut rays = [Ray::new(Vec3::ZERO, Vec3::Z); MAX_PACKET_WIDTH];
    let mut triangles = [None; MAX_PACKET_WIDTH];
    let mut hits: [Option<SurfaceHit>; MAX_PACKET_WIDTH] = [None; MAX_PACKET_WIDTH];
    let mut blocked = [false; MAX_PACKET_WIDTH];
    let mut diffuse = DiffuseBounces::default();
    loop {
        while lanes.len() < width {
            let Some(Grouped { sample, group }) = samples.next() else {
                break;
            };
            let mut lane = Lane::start(tracer, job, sample, group.is_some(), in_order.start());
            if let Some(group) = group {
                lane.wl = pending.start(group, lane.order, lane.wl);
                lane.seen = lane.wl.lambda;
                lane.group = Some(group.0);
            }
            lanes.push(lane);
        }
        if lanes.is_empty() {
            break;
        }
        let n = lanes.len();
        for (ray, lane) in rays.iter_mut().zip(&mut lanes) {
            lane.counters.rays += 1;
            *ray = lane.ray;
        }
        if streams {
            scene.intersect_stream(&rays[..n], &mut triangles[..n], &mut hits[..n]);
        } else {
            scene.intersect_packet(&rays[..n], &mut hits[..n]);
        }
        for (k, (lane, hit)) in lanes.iter_mut().zip(&hits).enumerate() {
            lane.goes_on = match hit {
                Some(hit)
                    if lane.depth == 0
                        && scene.hides_back_face(hit.material, hit.ng, lane.ray.dir) =>
                {
                    lane.pass(hit)
                }
                Some(hit) => lane.scatter(tracer, scene, hit, (&mut diffuse, k)),
                None => lane.escape(tracer, scene),
            };
        }
        diffuse.finish(|k, bounced| lanes[k].bounced(bounced));
        // The light samples' shadow rays, traced together.
        let mut m = 0;
        for lane in &lanes {
            if let Some(shadow) = lane.shadow {
                rays[m] = shadow;
                m += 1;
            }
        }
        if streams {
            scene.occluded_stream(&rays[..m], &mut blocked[..m]);
        } else {
            scene.occluded_packet(&rays[..m], &mut blocked[..m]);
        }
        let mut answers = blocked[..m].iter();
        for lane in &mut lanes {
            if lane.shadow.take().is_some() {
                let &blocked = answers.next().expect("one answer per shadow ray");
                if !blocked {
                    lane.l += lane.unblocked;
                }
            }
        }
        // Ended paths leave their lanes (the last takes each one's place,
        // so go from the back).
        for k in (0..lanes.len()).rev() {
            if !lanes[k].goes_on {
                let member = lanes.swap_remove(k).ended();
                let Some(seq) = member.group else {
                    member.end(&mut in_order);
                    continue;
                };
                let occluded = |rays: &[Ray], blocked: &mut [bool]| {
                    scene.occluded_packet(rays, blocked);
                };
                for m in pending.end(seq, member, occluded) {
                    m.end(&mut in_order);
                }
            }
        }
        in_order.commit(job, &mut tile);
    }
    in_order.finish(job, &tile);
    tile
}

impl Member {
    /// Adds the sample to the tile's in `in_order`.
    fn end(&self, in_order: &mut InOrder) {
        let measured = PixelSample {
            l: self.l,
            wl: self.wl,
        };
        in_order.end(self.order, self.sample, measured, &self.counters);
    }
}

impl Lane {
    /// What the film and the lane's group take of its ended path (the
    /// film gets the wavelengths the camera saw).
    fn ended(self) -> Member {
        let mut wl = self.wl;
        wl.lambda = self.seen;
        Member {
            order: self.order,
            sample: self.sample,
            group: self.group,
            l: self.l,
            wl,
            counters: self.counters,
            first: self.first,
            second: self.second,
        }
    }

    /// Sample `index` of pixel (`x`, `y`), its camera ray drawn; its
    /// numbers past the first surface its block's where it is `grouped`.
    fn start(
        tracer: &PathTracer,
        job: &RenderJob,
        (x, y, index): (u32, u32, u32),
        grouped: bool,
        order: u64,
    ) -> Lane {
        let seed = job.options.seed;
        let mut sampler = if grouped {
            Sampler::for_block_sample(seed, x, y, index as u64)
        } else {
            Sampler::for_sample(seed, x, y, index as u64)
        };
        let (ray, wl) = tracer.camera_sample(job.scene, (x, y), &mut sampler);
        Lane {
            order,
            sample: (x, y, index),
            sampler,
            wl,
            seen: wl.lambda,
            spectra: SpectrumMemo::default(),
            ray,
            beta: SampledSpectrum::ONE,
            l: SampledSpectrum::ZERO,
            depth: 0,
            passed: 0,
            specular: true,
            prev_pdf: 0.0,
            shadow: None,
            unblocked: SampledSpectrum::ZERO,
            counters: PathCounters::default(),
            goes_on: true,
            group: None,
            first: None,
            second: None,
        }
    }

    /// The path reached `hit`: the emission found there, the light sample,
    /// the bounce and Russian roulette; whether the path goes on. A diffuse
    /// bounce that samples an area light is left to the packet's `diffuse`
    /// slots (as lane `k`), which answer after every lane has scattered.
    fn scatter(
        &mut self,
        tracer: &PathTracer,
        scene: &Scene,
        hit: &SurfaceHit,
        (diffuse, k): (&mut DiffuseBounces, usize),
    ) -> bool {
        if let Some(i) = hit.light {
            self.add_emission(tracer, scene, hit, i);
        }
        let material = &scene.materials[hit.material as usize];
        if self.depth == 1 && self.first.is_some() {
            let diffuse = matches!(material, Material::Diffuse { .. });
            self.second = Some(SecondVertex::new(hit, diffuse, self.l, self.beta));
        }
        if self.depth == tracer.max_depth {
            return false;
        }
        self.depth += 1;
        let wo = -self.ray.dir;
        match material {
            Material::Diffuse { reflectance } => {
                if self.depth == 1 && self.group.is_some() {
                    let f = Diffuse::f(reflectance, hit, &self.wl, &mut self.spectra);
                    self.first = Some(FirstBounce::new(hit, wo, f));
                }
                // The light sample's and the bounce's numbers, and what they
                // decide alone, first: they overlap with the surface's work.
                let light = LightDrawn::new(scene, self.sampler.next_4d());
                let u_bounce = self.sampler.next_4d();
                if let (Strategy::Mis, Some(area_light)) = (tracer.strategy, light) {
                    if let Some(bounce) =
                        self.diffuse_bounce(tracer, hit, reflectance, area_light, u_bounce)
                    {
                        // The slots answer whether it goes on (`finish`).
                        diffuse.push(k, bounce);
                        return true;
                    }
                }
                let drawn = Diffuse::draw(u_bounce);
                let surface = Diffuse::at(reflectance, hit, wo, &self.wl, &mut self.spectra);
                self.bounce(tracer, hit, &surface, (light, drawn, u_bounce[3]))
            }
            material => {
                let bsdf = bsdf_at(scene, hit, wo, &mut self.wl, SampledSpectrum::ONE);
                if material.is_fluorescent() {
                    // As in the one-path walk (`walk::at_surface`): the BSDF
                    // at the wavelengths seen, then the path moves to those
                    // where the light was absorbed, which light samples and
                    // the rest of the path see.
                    let u = self.sampler.next_4d();
                    self.beta *= material.fluoresce(hit.uv, &mut self.wl, u);
                    self.spectra.forget();
                }
                let light = LightDrawn::new(scene, self.sampler.next_4d());
                let u_bounce = self.sampler.next_4d();
                let drawn = General::draw(u_bounce);
                let surface = General { bsdf, wo };
                self.bounce(tracer, hit, &surface, (light, drawn, u_bounce[3]))
            }
        }
    }

    /// From `hit`, whose BSDF is `surface`: the light sample from `light`,
    /// the bounce from `drawn` and Russian roulette with `u_rr`; whether
    /// the path goes on. The light sample's numbers are drawn whatever
    /// happens, as the one-path walk draws them, so later bounces use the
    /// same ones. The caller draws both, and takes the steps that need only
    /// the numbers (the light and its point, the bounce's local direction),
    /// before it makes the surface: that work then overlaps with the
    /// surface's and the light sample's instead of waiting behind their
    /// branches and divisions (Cornell Box CPU −4%).
    #[inline(always)]
    fn bounce<S: Surface>(
        &mut self,
        tracer: &PathTracer,
        hit: &SurfaceHit,
        surface: &S,
        (light, drawn, u_rr): (Option<LightDrawn>, S::Drawn, f32),
    ) -> bool {
        if tracer.strategy != Strategy::Bsdf && !surface.is_specular() {
            self.sample_light(tracer, hit, surface, light);
        }
        let Some((wi, weight, pdf, specular)) = surface.sample(drawn) else {
            return false;
        };
        self.beta *= weight;
        (self.specular, self.prev_pdf) = (specular, pdf);
        self.ray = Ray::new(offset_ray_origin(hit.p, hit.p_err, hit.ng, wi), wi);
        russian_roulette(&mut self.beta, 1.0, self.depth, tracer.rr_depth, u_rr)
    }

    /// What the packet's diffuse slots need for this lane's bounce at
    /// `hit`, where `light` is an area light's point (None elsewhere).
    #[inline(always)]
    fn diffuse_bounce<'h>(
        &mut self,
        tracer: &PathTracer,
        hit: &'h SurfaceHit,
        reflectance: &Reflectance,
        light: LightDrawn,
        u: [f32; 4],
    ) -> Option<DiffuseBounce<'h>> {
        let (Light::Area(area), Some(point)) = (light.light, light.point) else {
            return None;
        };
        let f = Diffuse::f(reflectance, hit, &self.wl, &mut self.spectra);
        let (spectra, wl) = (&mut self.spectra, &self.wl);
        let emission = area.front_emission_by(point.uv, wl, |s| spectra.sample(s, wl));
        Some(DiffuseBounce {
            hit,
            wo: -self.ray.dir,
            f,
            beta: self.beta,
            point,
            emission,
            two_sided: area.two_sided(),
            area: area.area(),
            pmf: light.pmf,
            u: (u[0], u[1]),
            u_rr: u[3],
            roulette: self.depth >= tracer.rr_depth,
        })
    }

    /// What the packet's diffuse slots left this lane.
    fn bounced(&mut self, Bounced { shadow, next }: Bounced) {
        if let Some((ray, unblocked)) = shadow {
            self.counters.rays += 1;
            self.shadow = Some(ray);
            self.unblocked = unblocked;
        }
        self.goes_on = match next {
            Some((ray, beta, pdf)) => {
                (self.ray, self.beta, self.specular, self.prev_pdf) = (ray, beta, false, pdf);
                true
            }
            None => false,
        };
    }

    /// Adds the emission of light `i` at `hit`, which the path's ray found,
    /// weighed against the light sample that could have found it.
    fn add_emission(&mut self, tracer: &PathTracer, scene: &Scene, hit: &SurfaceHit, i: usize) {
        let light = scene.lights.get(i);
        let le = match light {
            Light::Area(area) => {
                let spectra = &mut self.spectra;
                area.l_by(hit.uv, -self.ray.dir, &self.wl, |s| {
                    spectra.sample(s, &self.wl)
                })
            }
            _ => light.l(hit.uv, -self.ray.dir, &self.wl),
        };
        if le != SampledSpectrum::ZERO {
            let weight = tracer.emission_weight(self.specular, self.prev_pdf, || {
                let pdf = light.pdf_li(self.ray.origin, self.ray.dir, Some(hit.p));
                scene.lights.pmf(i) * pdf
            });
            self.l += self.beta * le * weight;
        }
    }

    /// Next-event estimation at `hit` from the light `drawn` (None where
    /// there is none to choose): a point on it, weighed against BSDF
    /// sampling, its shadow ray left to trace.
    fn sample_light(
        &mut self,
        tracer: &PathTracer,
        hit: &SurfaceHit,
        surface: &impl Surface,
        drawn: Option<LightDrawn>,
    ) {
        let Some(LightDrawn {
            light,
            pmf,
            u,
            point,
        }) = drawn
        else {
            return;
        };
        let sampled = match (light, point) {
            (Light::Area(area), Some(lp)) => {
                let spectra = &mut self.spectra;
                area.li_from(lp, hit.p, &self.wl, |s| spectra.sample(s, &self.wl))
            }
            _ => light.sample_li(hit.p, u, &self.wl),
        };
        let Some(ls) = sampled else {
            return;
        };
        let (f, scattering_pdf) = surface.eval(ls.wi);
        if f == SampledSpectrum::ZERO {
            return;
        }
        let origin = offset_ray_origin(hit.p, hit.p_err, hit.ng, ls.wi);
        let shadow = match ls.point {
            Some(lp) => Ray::towards(origin, offset_ray_origin(lp.p, lp.p_err, lp.n, -ls.wi)),
            None => Ray::new(origin, ls.wi),
        };
        self.counters.rays += 1;
        let light_pdf = pmf * ls.pdf;
        let weight = if tracer.strategy == Strategy::Mis && !light.is_delta() {
            power_heuristic(light_pdf, scattering_pdf)
        } else {
            1.0
        };
        self.shadow = Some(shadow);
        self.unblocked = self.beta * (f * ls.li * (weight / light_pdf));
    }

    /// The camera's ray goes on past the back of a single-sided surface,
    /// unless it has passed as many false intersections as a path may.
    fn pass(&mut self, hit: &SurfaceHit) -> bool {
        if self.passed == MAX_FALSE_INTERSECTIONS {
            return false;
        }
        self.passed += 1;
        let origin = offset_ray_origin(hit.p, hit.p_err, hit.ng, self.ray.dir);
        self.ray = Ray::new(origin, self.ray.dir);
        true
    }

    /// The path left the scene: the lights at infinity it sees.
    fn escape(&mut self, tracer: &PathTracer, scene: &Scene) -> bool {
        for (i, light) in scene.lights.infinite() {
            let (le, pdf_li) = light.le_and_pdf_li(self.ray.origin, self.ray.dir, &self.wl);
            let weight = tracer.emission_weight(self.specular, self.prev_pdf, || {
                scene.lights.pmf(i) * pdf_li
            });
            self.l += self.beta * le * weight;
        }
        false
    }
}

/// A light sample's steps that need only its numbers: the light, the
/// probability of choosing it and, on an area light, the point.
#[derive(Clone, Copy)]
struct LightDrawn<'s> {
    light: &'s Light,
    pmf: f32,
    /// The point's numbers (for lights other than area lights).
    u: (f32, f32),
    point: Option<LightPoint>,
}

impl<'s> LightDrawn<'s> {
    /// With the numbers [p₀, p₁, u_light, _]; None where the scene has no
    /// light to choose.
    #[inline(always)]
    fn new(scene: &'s Scene, [p0, p1, u_light, _]: [f32; 4]) -> Option<LightDrawn<'s>> {
        let (i, pmf) = scene.lights.choose(u_light)?;
        let light = scene.lights.get(i);
        let point = match light {
            Light::Area(area) => Some(area.sample_point((p0, p1))),
            _ => None,
        };
        Some(LightDrawn {
            light,
            pmf,
            u: (p0, p1),
            point,
        })
    }
}
