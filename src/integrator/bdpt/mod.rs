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

use super::ior_stack::IorStack;
use super::light_path;
use super::walk::PathContext;
use super::{camera_ray, PathCounters, PixelSample};
use super::{CommonParams, Configure, NoParams};
use crate::drive::splats::SplatEstimator;
use crate::film::FilmTile;
use crate::geometry::Ray;
use crate::light::LightSource;
use crate::material::TransportMode;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::SampledSpectrum;

mod connect;
mod vertex;
mod walk;

use connect::connect;
use vertex::{infinite_density, Kind, Vertex};
use walk::{Start, Subpath};

#[derive(Clone, Debug, PartialEq)]
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

impl Configure for Bdpt {
    type Params = NoParams;

    fn configure(common: &CommonParams, _: NoParams) -> Result<Self, String> {
        let d = Bdpt::default();
        Ok(Bdpt {
            max_depth: common.max_depth.unwrap_or(d.max_depth),
            rr_depth: common.rr_depth.unwrap_or(d.rr_depth),
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

renders_by_splats!(Bdpt);

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
            let mut ctx = PathContext {
                scene,
                wl: &mut wl,
                sampler: &mut *sampler,
                counters: &mut *counters,
            };
            self.camera_subpath(&mut ctx, ray, camera_path, u_camera_bounce);
            self.light_subpath(&mut ctx, u_light, u_le, light_path, u_light_bounce);

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
                    let c = connect(&mut ctx, light_path, camera_path, s, t, u);
                    match c.raster {
                        Some(r) => {
                            let px = (r.x as u32).min(scene.camera.resolution().0 - 1);
                            let py = (r.y as u32).min(scene.camera.resolution().1 - 1);
                            tile.add_splat(px, py, c.l, ctx.wl);
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
    fn camera_subpath(
        &self,
        ctx: &mut PathContext,
        ray: Ray,
        path: &mut Vec<Vertex>,
        u_first: [f32; 4],
    ) {
        let camera = Vertex::new(Kind::Camera, ray.origin, SampledSpectrum::ONE);
        path.push(camera);
        let subpath = Subpath {
            mode: TransportMode::Radiance,
            max_vertices: self.max_depth as usize + 2,
            rr_depth: self.rr_depth,
        };
        let start = Start {
            ray,
            beta: SampledSpectrum::ONE,
            // A pinhole with a box filter: W_e / p = 1 for every camera ray.
            pdf_dir: ctx.scene.camera.pdf_we(ray.origin, ray.dir),
            stack: IorStack::default(),
        };
        subpath.run(ctx, start, path, u_first);
    }

    /// The light subpath: a point on a light, then up to max_depth surfaces.
    fn light_subpath(
        &self,
        ctx: &mut PathContext,
        u_light: f32,
        u_le: [f32; 4],
        path: &mut Vec<Vertex>,
        u_first: [f32; 4],
    ) {
        let scene = ctx.scene;
        let Some(start) = light_path::start(
            scene,
            u_light,
            (u_le[0], u_le[1]),
            (u_le[2], u_le[3]),
            ctx.wl,
            ctx.counters,
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

        let subpath = Subpath {
            mode: TransportMode::Importance,
            max_vertices: self.max_depth as usize + 1,
            rr_depth: self.rr_depth,
        };
        let first = Start {
            ray: start.ray,
            beta: start.beta,
            pdf_dir: les.pdf_dir,
            stack: start.stack,
        };
        subpath.run(ctx, first, path, u_first);
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
