//! How the path tracer's camera samples are taken: as packets of paths
//! where the scene needs only what the packet core models (`path_packet`,
//! the same image in distribution), else one at a time, or as a stream of
//! paths whose rays are traced together (`drive::stream`) where the
//! scene's tree outgrows the caches (the same image, bit for bit).

use super::path::Gather;
use super::path_packet;
use super::walk::{self, Flow, PathContext, Walk};
use super::{camera_ray, PathCounters, PathTracer, PixelSample};
use crate::drive::pixels::{one_at_a_time, PixelEstimator};
use crate::drive::stream::{self, StreamEstimator};
use crate::drive::{Packets, RenderJob, TileRect};
use crate::film::FilmTile;
use crate::geometry::Ray;
use crate::integrator::interface::FirstHit;
use crate::sampler::Sampler;
use crate::scene::{Scene, SurfaceHit};
use crate::spectrum::SampledWavelengths;

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
        let (ray, mut wl) = self.camera_sample(scene, (x, y), sampler);
        let seen = wl.lambda;
        let l = self.radiance(scene, ray, &mut wl, sampler, counters);
        // Fluorescence may have moved the wavelengths the path carries;
        // the film bins the light at those the camera saw.
        wl.lambda = seen;
        PixelSample { l, wl }
    }

    fn render_tile(
        &self,
        job: &RenderJob,
        rect: TileRect,
        pass_len: u32,
        indices: impl Fn(u32, u32) -> std::ops::Range<u32>,
        shared: &(),
    ) -> FilmTile {
        let packets = job.options.packets == Packets::Auto && path_packet::models(self, job.scene);
        if packets {
            return path_packet::render_tile(self, job, rect, pass_len, indices);
        }
        if stream::wanted(job) {
            stream::render_tile(job, rect, pass_len, indices, self)
        } else {
            one_at_a_time(self, job, rect, pass_len, indices, shared)
        }
    }
}

renders_by_pixels!(PathTracer);

impl PathTracer {
    /// A camera sample's ray through pixel (`x`, `y`) and its wavelengths.
    pub(super) fn camera_sample(
        &self,
        scene: &Scene,
        (x, y): (u32, u32),
        sampler: &mut Sampler,
    ) -> (Ray, SampledWavelengths) {
        let [dx, dy, u_lambda, _] = sampler.next_4d();
        let wl = scene.wavelengths.sample(u_lambda);
        let ray = camera_ray(scene, x as f32 + dx, y as f32 + dy, sampler);
        (ray, wl)
    }
}

/// A camera sample in a stream: `PixelEstimator::sample`'s path, paused
/// where it waits for the closest surface along `walk.ray`.
pub struct StreamPath<'t> {
    sampler: Sampler,
    wl: SampledWavelengths,
    seen: glam::Vec4,
    walk: Walk,
    gather: Gather<'t, 't>,
}

impl StreamEstimator for PathTracer {
    type Path<'a> = StreamPath<'a>;

    fn start<'a>(
        &'a self,
        scene: &Scene,
        pixel: (u32, u32),
        mut sampler: Sampler,
    ) -> StreamPath<'a> {
        let (ray, wl) = self.camera_sample(scene, pixel, &mut sampler);
        let mut gather = Gather::new(self, None, self.split);
        gather.defers_shadows = true;
        StreamPath {
            sampler,
            wl,
            seen: wl.lambda,
            walk: self.camera_walk(ray),
            gather,
        }
    }

    fn ray<'p>(&self, path: &'p StreamPath<'_>) -> &'p Ray {
        &path.walk.ray
    }

    fn advance(
        &self,
        scene: &Scene,
        path: &mut StreamPath<'_>,
        hit: Option<SurfaceHit>,
        counters: &mut PathCounters,
    ) -> bool {
        let mut ctx = PathContext {
            scene,
            wl: &mut path.wl,
            sampler: &mut path.sampler,
            counters,
        };
        let first = FirstHit::Known(hit);
        walk::step(&mut ctx, &mut path.walk, first, &mut path.gather) == Flow::Go
    }

    fn shadow<'p>(&self, path: &'p StreamPath<'_>) -> Option<&'p Ray> {
        path.gather.shadow.as_ref()
    }

    fn resolve_shadow(&self, path: &mut StreamPath<'_>, blocked: bool) {
        let g = &mut path.gather;
        g.shadow = None;
        if !blocked {
            g.l += g.unblocked;
        }
    }

    fn finish(&self, path: StreamPath<'_>) -> PixelSample {
        let mut wl = path.wl;
        wl.lambda = path.seen;
        PixelSample {
            l: path.gather.l,
            wl,
        }
    }
}
