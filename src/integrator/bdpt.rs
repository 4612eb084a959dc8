//! Bidirectional path tracing (Veach 1997, ch. 10; the vertex formulation
//! of pbrt-v4's BDPT). Each sample traces a camera subpath and a light
//! subpath, then joins every prefix of one to every prefix of the other:
//!
//! - s = 0: the camera subpath itself reached a light;
//! - s = 1: a point sampled on a light is joined to a camera vertex
//!   (next-event estimation);
//! - t = 1: a light vertex is joined to the camera and splats to whichever
//!   pixel it lands in (light tracing);
//! - s, t > 1: a shadow ray joins a light vertex to a camera vertex.
//!
//! Every path of n vertices can be made by up to n + 1 of these strategies;
//! each contribution is weighted by the power heuristic over all of them,
//! using each vertex's area density in both directions (`pdf_fwd` along its
//! own subpath, `pdf_rev` as the other subpath would have made it). A Dirac
//! lobe's density counts as 1 per solid angle, converted to area like any
//! other (its deltas cancel between strategies); strategies that would
//! connect at a Dirac vertex or start at a delta light cannot make the path
//! and are left out of the sum.
//!
//! Both subpaths share the sample's wavelengths: a smooth dispersive
//! interface met by either ends the secondaries for the whole path (every
//! contribution is weighed with the final wavelengths, after both walks).
//! Both carry an IOR stack: the camera's starts empty (as the path
//! tracer's), the light's with the dielectrics that contain the light
//! (`media_at`). The camera subpath carries radiance, the light subpath
//! importance (`TransportMode`), so refraction and shading normals are
//! handled as each direction of transport needs.

use std::cell::RefCell;

use glam::{Vec2, Vec3};

use super::interface::{bsdf_at, scatter, stack_towards, trace, transmittance, Next};
use super::ior_stack::{Entry, IorStack};
use super::light_path;
use super::volume::{mis_divisor, Flight};
use super::{camera_ray, lens_sample, PathCounters, PixelSample};
use super::{Integrate, IntegratorSpec};
use crate::camera::Camera;
use crate::drive::{
    splats::{self, SplatEstimator},
    RenderError, RenderJob, RenderOptions, RenderStats,
};
use crate::film::{Film, FilmSettings, FilmTile};
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::light::LightSource;
use crate::material::{Bsdf, TransportMode};
use crate::medium::HenyeyGreenstein;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Bdpt {
    /// Most bounces of a full path (s + t − 2).
    pub max_depth: u32,
    /// Bounces of a subpath before Russian roulette may end it.
    pub rr_depth: u32,
}

impl Default for Bdpt {
    fn default() -> Self {
        Self {
            max_depth: 16,
            rr_depth: 3,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Camera,
    /// A point on a light, or where a camera ray left the scene.
    Light,
    Surface,
    /// A scattering event inside a medium.
    Medium,
}

/// One vertex of a subpath.
#[derive(Clone, Copy, Debug)]
struct Vertex {
    kind: Kind,
    p: Vec3,
    p_err: Vec3,
    /// Geometric normal; zero off surfaces (the pinhole, a point light, a
    /// light at infinity), where no cosine converts densities.
    ng: Vec3,
    uv: Vec2,
    /// The subpath's throughput up to here, over its density.
    beta: SampledSpectrum,
    /// Surfaces only.
    bsdf: Option<Bsdf>,
    /// Medium vertices only, with the direction back along the subpath.
    phase: Option<HenyeyGreenstein>,
    wo: Vec3,
    /// The media the subpath arrived in, and (surfaces) what `trace` said
    /// of the surface: connections start in the media on their side.
    stack: IorStack,
    crossing: Option<(Entry, bool)>,
    /// The subpath's spectral-MIS density ratios up to here (`volume`).
    r: SampledSpectrum,
    /// The light this vertex lies on (an emissive surface or a sampled
    /// light). None on a `Light` vertex: a camera ray that escaped, which
    /// sees every light at infinity at once.
    light: Option<usize>,
    /// Reached through a Dirac lobe: no connection can make this vertex.
    delta: bool,
    /// Area density (solid angle for lights at infinity) of this vertex
    /// from its own subpath, and from the other direction.
    pdf_fwd: f32,
    pdf_rev: f32,
}

impl Vertex {
    fn new(kind: Kind, p: Vec3, beta: SampledSpectrum) -> Self {
        Self {
            kind,
            p,
            p_err: Vec3::ZERO,
            ng: Vec3::ZERO,
            uv: Vec2::ZERO,
            beta,
            bsdf: None,
            phase: None,
            wo: Vec3::ZERO,
            stack: IorStack::default(),
            crossing: None,
            r: SampledSpectrum::ONE,
            light: None,
            delta: false,
            pdf_fwd: 0.0,
            pdf_rev: 0.0,
        }
    }

    fn on_surface(&self) -> bool {
        self.ng != Vec3::ZERO
    }

    fn is_light(&self) -> bool {
        self.kind == Kind::Light || self.light.is_some()
    }

    fn is_infinite_light(&self, scene: &Scene) -> bool {
        self.kind == Kind::Light && self.light.is_none_or(|i| scene.lights.get(i).is_infinite())
    }

    fn is_delta_light(&self, scene: &Scene) -> bool {
        self.kind == Kind::Light && self.light.is_some_and(|i| scene.lights.get(i).is_delta())
    }

    /// Can a connection (a shadow ray) end at this subpath vertex? Only a
    /// surface with a lobe that has a density: connections to the camera
    /// and to lights sample fresh endpoints (t = 1, s = 1), and a camera ray
    /// that escaped has no point to aim at.
    fn connectible(&self) -> bool {
        match self.kind {
            Kind::Surface => self.bsdf.is_some_and(|b| b.flags().has_non_specular()),
            Kind::Medium => true,
            _ => false,
        }
    }

    /// The media a connection leaving this vertex towards `w` starts in.
    fn stack_towards(&self, w: Vec3) -> IorStack {
        match &self.bsdf {
            Some(b) => stack_towards(&self.stack, self.crossing, b.wo(), w, self.ng),
            None => self.stack,
        }
    }

    fn dir_to(&self, v: &Vertex) -> Vec3 {
        (v.p - self.p).normalize_or_zero()
    }

    /// Converts a solid-angle density at this vertex into the area density
    /// of `next`.
    fn area_density(&self, pdf_dir: f32, next: &Vertex, scene: &Scene) -> f32 {
        if next.is_infinite_light(scene) {
            return pdf_dir;
        }
        let w = next.p - self.p;
        let d2 = w.length_squared();
        if !(d2 > 0.0) {
            return 0.0;
        }
        let mut pdf = pdf_dir / d2;
        if next.on_surface() {
            pdf *= next.ng.dot(w).abs() / d2.sqrt();
        }
        pdf
    }

    /// The BSDF (or importance) value for leaving this vertex towards `next`.
    fn f(&self, next: &Vertex, mode: TransportMode) -> SampledSpectrum {
        match (&self.bsdf, &self.phase) {
            (Some(b), _) => b.f(b.wo(), self.dir_to(next), mode),
            (None, Some(phase)) => SampledSpectrum::splat(phase.p(-self.wo, self.dir_to(next))),
            _ => SampledSpectrum::ZERO,
        }
    }

    /// |cos| at this vertex towards `next`, by the shading normal (1 off surfaces).
    fn cos_to(&self, next: &Vertex) -> f32 {
        match &self.bsdf {
            Some(b) => b.cos_theta(self.dir_to(next)),
            None => 1.0,
        }
    }

    /// Area density with which this vertex, reached from `prev`, samples `next`.
    fn pdf(&self, scene: &Scene, prev: Option<&Vertex>, next: &Vertex) -> f32 {
        let pdf_dir = match self.kind {
            Kind::Light => return self.pdf_light(scene, next),
            Kind::Camera => scene.camera.pdf_we(self.p, self.dir_to(next)),
            Kind::Surface => match (prev, &self.bsdf) {
                (Some(prev), Some(b)) => b.pdf(
                    self.dir_to(prev),
                    self.dir_to(next),
                    TransportMode::Radiance,
                ),
                _ => 0.0,
            },
            Kind::Medium => match (prev, &self.phase) {
                (Some(prev), Some(phase)) => phase.p(prev.dir_to(self), self.dir_to(next)),
                _ => 0.0,
            },
        };
        self.area_density(pdf_dir, next, scene)
    }

    /// Area density with which this light vertex sends a ray to `next`.
    fn pdf_light(&self, scene: &Scene, next: &Vertex) -> f32 {
        let w = self.dir_to(next);
        let mut pdf = if self.is_infinite_light(scene) {
            // Rays from infinity start uniformly on the scene's disc.
            scene.sphere.disc_pdf()
        } else {
            let Some(i) = self.light else { return 0.0 };
            let d2 = (next.p - self.p).length_squared();
            if !(d2 > 0.0) {
                return 0.0;
            }
            scene.lights.get(i).pdf_le(self.uv, w).1 / d2
        };
        if next.on_surface() {
            pdf *= next.ng.dot(w).abs();
        }
        pdf
    }

    /// Density of choosing this light vertex as a light subpath's origin
    /// (solid angle of the direction for lights at infinity), given that
    /// the subpath goes on to `next`.
    fn pdf_light_origin(&self, scene: &Scene, next: &Vertex) -> f32 {
        let w = self.dir_to(next);
        if self.is_infinite_light(scene) {
            return infinite_density(scene, next.p, -w);
        }
        let Some(i) = self.light else { return 0.0 };
        scene.lights.pmf(i) * scene.lights.get(i).pdf_le(self.uv, w).0
    }

    /// Radiance this light vertex sends towards `to`.
    fn le(&self, scene: &Scene, to: &Vertex, wl: &SampledWavelengths) -> SampledSpectrum {
        if !self.is_light() {
            return SampledSpectrum::ZERO;
        }
        let w = self.dir_to(to);
        if self.is_infinite_light(scene) {
            let mut le = SampledSpectrum::ZERO;
            for (_, light) in scene.lights.infinite() {
                le += light.le(-w, wl);
            }
            return le;
        }
        match self.light {
            Some(i) => scene.lights.get(i).l(self.uv, w, wl),
            None => SampledSpectrum::ZERO,
        }
    }
}

/// Density (solid angle, selection included) with which the lights at
/// infinity would be sampled from `p` in direction `wi` (towards them).
fn infinite_density(scene: &Scene, p: Vec3, wi: Vec3) -> f32 {
    scene
        .lights
        .infinite()
        .map(|(i, light)| scene.lights.pmf(i) * light.pdf_li(p, wi, None))
        .sum()
}

impl Bdpt {
    pub fn from_spec(spec: &IntegratorSpec) -> Result<Self, String> {
        let d = Bdpt::default();
        Ok(Bdpt {
            max_depth: spec.max_depth.unwrap_or(d.max_depth),
            rr_depth: spec.rr_depth.unwrap_or(d.rr_depth),
        })
    }
}

impl SplatEstimator for Bdpt {
    fn name(&self) -> &'static str {
        "bdpt"
    }

    fn max_depth(&self) -> u32 {
        self.max_depth
    }

    fn sample(
        &self,
        scene: &Scene,
        (x, y): (u32, u32),
        sampler: &mut Sampler,
        tile: &mut FilmTile,
        counters: &mut PathCounters,
    ) -> PixelSample {
        self.trace(scene, x, y, sampler, tile, counters)
    }
}

impl Integrate for Bdpt {
    fn check(
        &self,
        camera: &Camera,
        film: &FilmSettings,
        options: &RenderOptions,
    ) -> Result<(), RenderError> {
        splats::check("bdpt", camera, film, options)
    }

    fn loop_memory(&self, _: &Scene, film: &FilmSettings, options: &RenderOptions) -> (u64, u64) {
        splats::memory(self, film, options)
    }

    fn render(&self, job: RenderJob) -> (Film, RenderStats) {
        splats::render(job, self)
    }

    fn max_depth(&self) -> u32 {
        self.max_depth
    }
}

thread_local! {
    /// The two subpaths of the sample being traced, reused so that no
    /// sample allocates.
    static SUBPATHS: RefCell<(Vec<Vertex>, Vec<Vertex>)> = const { RefCell::new((Vec::new(), Vec::new())) };
}

impl Bdpt {
    /// One sample of pixel (x, y): its measurement, with the light-tracing
    /// connections (t = 1) splatted into `tile`.
    pub fn trace(
        &self,
        scene: &Scene,
        x: u32,
        y: u32,
        sampler: &mut Sampler,
        tile: &mut FilmTile,
        counters: &mut PathCounters,
    ) -> PixelSample {
        // The first sets of the low-discrepancy sequence go to the most
        // important decisions: the camera ray and wavelengths, the light's
        // ray, the first bounce of each subpath, the first light sample.
        let [dx, dy, u_lambda, u_light] = sampler.next_4d();
        let u_le = sampler.next_4d();
        let u_camera_bounce = sampler.next_4d();
        let u_light_bounce = sampler.next_4d();
        let u_direct = sampler.next_4d();
        let mut wl = scene.wavelengths.sample(u_lambda);
        SUBPATHS.with(|cell| {
            let mut guard = cell.borrow_mut();
            let (camera_path, light_path) = &mut *guard;
            camera_path.clear();
            light_path.clear();
            let ray = camera_ray(scene, x as f32 + dx, y as f32 + dy, sampler);
            self.camera_subpath(
                scene,
                ray,
                camera_path,
                &mut wl,
                sampler,
                u_camera_bounce,
                counters,
            );
            self.light_subpath(
                scene,
                u_light,
                u_le,
                light_path,
                &mut wl,
                sampler,
                u_light_bounce,
                counters,
            );

            // Every strategy, with the wavelengths both walks left.
            let mut l = SampledSpectrum::ZERO;
            for t in 1..=camera_path.len() {
                for s in 0..=light_path.len() {
                    let depth = s as i64 + t as i64 - 2;
                    // (1, 1) is the light seen directly, which (0, 2) finds.
                    if (s == 1 && t == 1) || depth < 0 || depth > self.max_depth as i64 {
                        continue;
                    }
                    let u = if t == 2 { Some(u_direct) } else { None };
                    let c = connect(
                        scene,
                        light_path,
                        camera_path,
                        s,
                        t,
                        &wl,
                        sampler,
                        u,
                        counters,
                    );
                    match c.raster {
                        Some(r) => {
                            let px = (r.x as u32).min(scene.camera.resolution().0 - 1);
                            let py = (r.y as u32).min(scene.camera.resolution().1 - 1);
                            tile.add_splat(px, py, c.l, &wl);
                        }
                        None => l += c.l,
                    }
                }
            }
            PixelSample { l, wl }
        })
    }

    /// The camera subpath: the camera, then up to max_depth + 1 surfaces
    /// (and a last vertex at infinity when a ray escapes to lights there).
    #[allow(clippy::too_many_arguments)]
    fn camera_subpath(
        &self,
        scene: &Scene,
        ray: Ray,
        path: &mut Vec<Vertex>,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        u_first: [f32; 4],
        counters: &mut PathCounters,
    ) {
        let camera = Vertex::new(Kind::Camera, ray.origin, SampledSpectrum::ONE);
        path.push(camera);
        // A pinhole with a box filter: W_e / p = 1 for every camera ray.
        let pdf_dir = scene.camera.pdf_we(ray.origin, ray.dir);
        let walk = Walk {
            mode: TransportMode::Radiance,
            max_vertices: self.max_depth as usize + 2,
            rr_depth: self.rr_depth,
        };
        walk.run(
            scene,
            ray,
            SampledSpectrum::ONE,
            pdf_dir,
            IorStack::default(),
            path,
            wl,
            sampler,
            u_first,
            counters,
        );
    }

    /// The light subpath: a point on a light, then up to max_depth surfaces.
    #[allow(clippy::too_many_arguments)]
    fn light_subpath(
        &self,
        scene: &Scene,
        u_light: f32,
        u_le: [f32; 4],
        path: &mut Vec<Vertex>,
        wl: &mut SampledWavelengths,
        sampler: &mut Sampler,
        u_first: [f32; 4],
        counters: &mut PathCounters,
    ) {
        let Some(start) = light_path::start(
            scene,
            u_light,
            (u_le[0], u_le[1]),
            (u_le[2], u_le[3]),
            wl,
            counters,
        ) else {
            return;
        };
        let light = scene.lights.get(start.light);
        let les = start.emitted;
        let lp = les.point;
        let pdf_origin = start.pmf * les.pdf_pos;
        let mut origin = Vertex::new(Kind::Light, lp.p, les.le / pdf_origin);
        origin.p_err = lp.p_err;
        origin.uv = lp.uv;
        origin.light = Some(start.light);
        origin.ng = start.n;
        origin.pdf_fwd = if light.is_infinite() {
            infinite_density(scene, lp.p, -les.dir)
        } else {
            pdf_origin
        };
        path.push(origin);

        let walk = Walk {
            mode: TransportMode::Importance,
            max_vertices: self.max_depth as usize + 1,
            rr_depth: self.rr_depth,
        };
        walk.run(
            scene,
            start.ray,
            start.beta,
            les.pdf_dir,
            start.stack,
            path,
            wl,
            sampler,
            u_first,
            counters,
        );
        // From infinity the first hit's density is the disc's, per area.
        if light.is_infinite() && path.len() > 1 {
            let v = &mut path[1];
            v.pdf_fwd = les.pdf_pos;
            if v.on_surface() {
                v.pdf_fwd *= v.ng.dot(les.dir).abs();
            }
        }
    }
}

/// How a subpath walks: which quantity it carries and how far it goes.
struct Walk {
    mode: TransportMode,
    max_vertices: usize,
    rr_depth: u32,
}

impl Walk {
    /// Extends `path` (which holds its origin) by tracing `ray` and
    /// sampling the BSDF at each surface, recording both densities.
    #[allow(clippy::too_many_arguments)]
    fn run(
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

/// What one strategy contributes: to the sample's own pixel, or (t = 1)
/// to the pixel at `raster`.
struct Contribution {
    l: SampledSpectrum,
    raster: Option<Vec2>,
}

/// The contribution of strategy (s, t), MIS weight included. `u_direct`
/// are the numbers for s = 1 (drawn from `sampler` when None).
#[allow(clippy::too_many_arguments)]
fn connect(
    scene: &Scene,
    light_path: &[Vertex],
    camera_path: &[Vertex],
    s: usize,
    t: usize,
    wl: &SampledWavelengths,
    sampler: &mut Sampler,
    u_direct: Option<[f32; 4]>,
    counters: &mut PathCounters,
) -> Contribution {
    let none = Contribution {
        l: SampledSpectrum::ZERO,
        raster: None,
    };
    let mut sampled: Option<Vertex> = None;
    let mut raster = None;
    let l = if s == 0 {
        // The camera subpath hit a light.
        let pt = &camera_path[t - 1];
        if !pt.is_light() {
            return none;
        }
        pt.le(scene, &camera_path[t - 2], wl) * pt.beta
    } else if t == 1 {
        // A light vertex seen by the camera.
        let qs = &light_path[s - 1];
        if !qs.connectible() {
            return none;
        }
        let Some(cs) = scene.camera.sample_wi(qs.p, lens_sample(scene, sampler)) else {
            return none;
        };
        let camera = Vertex::new(Kind::Camera, cs.p_lens, SampledSpectrum::splat(cs.weight));
        let l =
            qs.beta * qs.f(&camera, TransportMode::Importance) * camera.beta * qs.cos_to(&camera);
        if l == SampledSpectrum::ZERO {
            return none;
        }
        let origin = offset_ray_origin(qs.p, qs.p_err, qs.ng, cs.wi);
        let shadow = Ray::towards(origin, cs.p_lens);
        let tr = transmittance(scene, &shadow, &qs.stack_towards(cs.wi), wl, counters);
        if tr == SampledSpectrum::ZERO {
            return none;
        }
        sampled = Some(camera);
        raster = Some(cs.raster);
        l * tr
    } else if s == 1 {
        // A point sampled on a light, joined to a camera vertex.
        let pt = &camera_path[t - 1];
        if !pt.connectible() {
            return none;
        }
        let [p0, p1, u_light, _] = u_direct.unwrap_or_else(|| sampler.next_4d());
        let Some((index, pmf)) = scene.lights.choose(u_light) else {
            return none;
        };
        let light = scene.lights.get(index);
        let Some(ls) = light.sample_li(pt.p, (p0, p1), wl) else {
            return none;
        };
        let p = match ls.point {
            Some(lp) => lp.p,
            None => {
                let far = 2.0 * scene.sphere.radius + (pt.p - scene.sphere.centre).length();
                pt.p + ls.wi * far
            }
        };
        let mut v = Vertex::new(Kind::Light, p, ls.li / (pmf * ls.pdf));
        v.light = Some(index);
        if let Some(lp) = ls.point.filter(|_| !light.is_delta()) {
            v.ng = lp.n;
            v.uv = lp.uv;
            v.p_err = lp.p_err;
        }
        v.pdf_fwd = v.pdf_light_origin(scene, pt);
        let l = pt.beta * pt.f(&v, TransportMode::Radiance) * v.beta * pt.cos_to(&v);
        if l == SampledSpectrum::ZERO {
            return none;
        }
        let origin = offset_ray_origin(pt.p, pt.p_err, pt.ng, ls.wi);
        let shadow = match ls.point {
            Some(lp) => Ray::towards(origin, offset_ray_origin(lp.p, lp.p_err, lp.n, -ls.wi)),
            None => Ray::new(origin, ls.wi),
        };
        let tr = transmittance(scene, &shadow, &pt.stack_towards(ls.wi), wl, counters);
        if tr == SampledSpectrum::ZERO {
            return none;
        }
        sampled = Some(v);
        l * tr
    } else {
        // A shadow ray between a light vertex and a camera vertex.
        let (qs, pt) = (&light_path[s - 1], &camera_path[t - 1]);
        if !qs.connectible() || !pt.connectible() {
            return none;
        }
        let l = qs.beta
            * qs.f(pt, TransportMode::Importance)
            * pt.f(qs, TransportMode::Radiance)
            * pt.beta;
        if l == SampledSpectrum::ZERO {
            return none;
        }
        let d2 = (qs.p - pt.p).length_squared();
        if !(d2 > 0.0) {
            return none;
        }
        let g = qs.cos_to(pt) * pt.cos_to(qs) / d2;
        if g == 0.0 {
            return none;
        }
        let w = pt.dir_to(qs);
        let from = offset_ray_origin(pt.p, pt.p_err, pt.ng, w);
        let to = offset_ray_origin(qs.p, qs.p_err, qs.ng, -w);
        let tr = transmittance(
            scene,
            &Ray::towards(from, to),
            &pt.stack_towards(w),
            wl,
            counters,
        );
        if tr == SampledSpectrum::ZERO {
            return none;
        }
        l * g * tr
    };
    if l == SampledSpectrum::ZERO {
        return none;
    }
    let w = mis_weight(scene, light_path, camera_path, sampled.as_ref(), s, t);
    // Spectral MIS over both subpaths' free flights: their densities multiply.
    let r_light = if s > 1 {
        light_path[s - 1].r
    } else {
        SampledSpectrum::ONE
    };
    let r_camera = if t > 1 {
        camera_path[t - 1].r
    } else {
        SampledSpectrum::ONE
    };
    let divisor = mis_divisor(r_light * r_camera, wl);
    Contribution {
        l: l * (w / divisor),
        raster,
    }
}

/// The power-heuristic weight of strategy (s, t) among every strategy that
/// could have made the same path. Walks from the connection outwards along
/// each subpath, multiplying the ratio of the density of the strategy that
/// moves the connection one vertex further to that of the current one.
/// `sampled` stands in for the subpath's end vertex when s = 1 or t = 1.
fn mis_weight(
    scene: &Scene,
    light_path: &[Vertex],
    camera_path: &[Vertex],
    sampled: Option<&Vertex>,
    s: usize,
    t: usize,
) -> f32 {
    if s + t == 2 {
        return 1.0;
    }
    let qs = match s {
        0 => None,
        1 => sampled,
        _ => Some(&light_path[s - 1]),
    };
    let pt = if t == 1 {
        sampled.expect("t = 1 samples the camera")
    } else {
        &camera_path[t - 1]
    };
    let qs_minus = (s > 1).then(|| &light_path[s - 2]);
    let pt_minus = (t > 1).then(|| &camera_path[t - 2]);

    // The reverse densities that the connection defines.
    let pt_rev = match qs {
        Some(qs) => qs.pdf(scene, qs_minus, pt),
        None => pt.pdf_light_origin(scene, pt_minus.expect("s = 0 needs t > 1")),
    };
    let pt_minus_rev = pt_minus.map(|pm| match qs {
        Some(qs) => pt.pdf(scene, Some(qs), pm),
        None => pt.pdf_light(scene, pm),
    });
    let qs_rev = qs.map(|qs| pt.pdf(scene, pt_minus, qs));
    let qs_minus_rev = qs_minus.map(|qm| qs.expect("s > 1").pdf(scene, Some(pt), qm));

    let remap = |f: f32| if f != 0.0 { f } else { 1.0 };
    let sq = |r: f32| r * r;
    let mut sum = 0.0f32;

    // Camera side: vertex i moves to the light subpath.
    let mut ri = 1.0f32;
    for i in (1..t).rev() {
        let (v, rev, delta) = if i == t - 1 {
            (pt, pt_rev, false)
        } else if i == t - 2 {
            let v = &camera_path[i];
            (v, pt_minus_rev.unwrap_or(v.pdf_rev), v.delta)
        } else {
            let v = &camera_path[i];
            (v, v.pdf_rev, v.delta)
        };
        ri *= sq(remap(rev) / remap(v.pdf_fwd));
        if !delta && !camera_path[i - 1].delta {
            sum += ri;
        }
    }

    // Light side: vertex i moves to the camera subpath.
    let mut ri = 1.0f32;
    for i in (0..s).rev() {
        let (v, rev, delta) = if i == s - 1 {
            (qs.expect("s > 0"), qs_rev.unwrap_or(0.0), false)
        } else if i == s - 2 {
            let v = &light_path[i];
            (v, qs_minus_rev.unwrap_or(v.pdf_rev), v.delta)
        } else {
            let v = &light_path[i];
            (v, v.pdf_rev, v.delta)
        };
        ri *= sq(remap(rev) / remap(v.pdf_fwd));
        let delta_before = if i > 0 {
            light_path[i - 1].delta
        } else {
            v.is_delta_light(scene)
        };
        if !delta && !delta_before {
            sum += ri;
        }
    }
    let w = 1.0 / (1.0 + sum);
    if w.is_finite() {
        w
    } else {
        0.0
    }
}
