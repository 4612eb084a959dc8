//! A tile's samples as a stream of paths: up to [`IN_FLIGHT`] camera paths
//! advance together, one step each in turn, and the rays they wait on are
//! traced together in between (`Scene::intersect_stream`), so that on a
//! mesh that outgrows the caches one ray's wait for memory overlaps the
//! others'; so are the shadow rays of the light samples the steps took. A
//! path that ends leaves the stream and the tile's next sample
//! takes its place. Each sample keeps its own sampler, and samples are
//! added to the tile in the order the one-at-a-time loop (`tile`) adds
//! them: the image is the same, bit for bit.

use std::ops::Range;

use super::in_order::InOrder;
use super::job::TileRect;
use super::pixels::PixelEstimator;
use super::{PathCounters, PixelSample, RenderJob, Streams};
use crate::film::FilmTile;
use crate::geometry::triangle::TriangleHit;
use crate::geometry::Ray;
use crate::sampler::Sampler;
use crate::scene::{Scene, SurfaceHit};

/// Paths in flight in a tile's stream (a 2M-triangle scene, one thread:
/// 64 and 32 alike, 16 slower, 8 no faster than one at a time).
pub const IN_FLIGHT: usize = 64;

/// Trees (nodes and triangles) of more bytes than this are traced as a
/// stream: smaller ones stay in the caches, where a ray hardly waits for
/// memory and the stream's bookkeeping is a cost. Cave of two terrains,
/// 2 threads, against one path at a time: a 1.8 MiB tree −2 to +16%, 8 MiB
/// −20 to +5%, 21 MiB −9 to −12%, 41 MiB −5 to −16%, 116 MiB −17 to −32%
/// (docs/performance.md).
pub const STREAM_ABOVE_BYTES: usize = 16 << 20;

/// Whether the job's rays are traced as streams: as `--stream` says, or
/// (`auto`) where the tree is larger than `STREAM_ABOVE_BYTES`.
pub fn wanted(job: &RenderJob) -> bool {
    match job.options.streams {
        Streams::Always => true,
        Streams::Never => false,
        Streams::Auto => job.scene.bvh().size_bytes() > STREAM_ABOVE_BYTES,
    }
}

/// An integrator whose camera samples can advance as a stream: each
/// sample a path that waits on the closest surface along one ray at a
/// time.
pub trait StreamEstimator: PixelEstimator {
    /// A sample in flight: its sampler, its path and what it gathered.
    type Path<'a>
    where
        Self: 'a;

    /// Starts a sample of pixel (`x`, `y`) with its `sampler`.
    fn start<'a>(&'a self, scene: &Scene, pixel: (u32, u32), sampler: Sampler) -> Self::Path<'a>;

    /// The ray whose closest surface the path waits on.
    fn ray<'p>(&self, path: &'p Self::Path<'_>) -> &'p Ray;

    /// Takes the path one step on from `hit`, the closest surface along
    /// its ray; false once the path has ended.
    fn advance(
        &self,
        scene: &Scene,
        path: &mut Self::Path<'_>,
        hit: Option<SurfaceHit>,
        counters: &mut PathCounters,
    ) -> bool;

    /// The shadow ray the path's last step left to be traced, if any.
    fn shadow<'p>(&self, path: &'p Self::Path<'_>) -> Option<&'p Ray>;

    /// Gives the path its shadow ray's answer: whether a surface blocks it.
    fn resolve_shadow(&self, path: &mut Self::Path<'_>, blocked: bool);

    /// What the ended path measured.
    fn finish(&self, path: Self::Path<'_>) -> PixelSample;
}

/// A sample in flight: its place in the tile's order, its pixel and index,
/// its path, and its own counters (its pixel's rays).
struct InFlight<P> {
    order: u64,
    sample: (u32, u32, u32),
    path: P,
    counters: PathCounters,
    /// Whether its last step left it going on.
    goes_on: bool,
}

/// `tile::render_tile` for a `StreamEstimator`: the same samples, added in
/// the same order, advanced as a stream.
pub fn render_tile<E: StreamEstimator>(
    job: &RenderJob,
    rect: TileRect,
    pass_len: u32,
    indices: impl Fn(u32, u32) -> Range<u32>,
    estimator: &E,
) -> FilmTile {
    let (x0, y0, w, h) = rect;
    let (scene, seed) = (job.scene, job.options.seed);
    let mut tile = job.new_tile(rect, pass_len);
    let mut samples = (y0..y0 + h)
        .flat_map(|y| (x0..x0 + w).map(move |x| (x, y)))
        .flat_map(|(x, y)| indices(x, y).map(move |i| (x, y, i)));
    let mut flying: Vec<InFlight<E::Path<'_>>> = Vec::with_capacity(IN_FLIGHT);
    let mut in_order = InOrder::default();
    let mut rays = Vec::with_capacity(IN_FLIGHT);
    let mut triangles: [Option<(u32, TriangleHit)>; IN_FLIGHT] = [None; IN_FLIGHT];
    let mut hits: [Option<SurfaceHit>; IN_FLIGHT] = [None; IN_FLIGHT];
    let mut blocked = [false; IN_FLIGHT];
    loop {
        // Refill the stream from the tile's next samples.
        while flying.len() < IN_FLIGHT {
            let Some((x, y, index)) = samples.next() else {
                break;
            };
            let sampler = Sampler::for_sample(seed, x, y, index as u64);
            flying.push(InFlight {
                order: in_order.start(),
                sample: (x, y, index),
                path: estimator.start(scene, (x, y), sampler),
                counters: PathCounters::default(),
                goes_on: true,
            });
        }
        if flying.is_empty() {
            break;
        }
        rays.clear();
        rays.extend(flying.iter().map(|f| *estimator.ray(&f.path)));
        let n = rays.len();
        scene.intersect_stream(&rays, &mut triangles[..n], &mut hits[..n]);
        for (f, hit) in flying.iter_mut().zip(&hits) {
            f.goes_on = estimator.advance(scene, &mut f.path, *hit, &mut f.counters);
        }
        // The shadow rays the steps left, traced together.
        rays.clear();
        rays.extend(flying.iter().filter_map(|f| estimator.shadow(&f.path)));
        let m = rays.len();
        scene.occluded_stream(&rays, &mut blocked[..m]);
        let mut answers = blocked[..m].iter();
        for f in flying.iter_mut() {
            if estimator.shadow(&f.path).is_some() {
                let &b = answers.next().expect("one answer per shadow ray");
                estimator.resolve_shadow(&mut f.path, b);
            }
        }
        // Ended paths leave the stream (the last takes each one's place,
        // so go from the back).
        for k in (0..n).rev() {
            if flying[k].goes_on {
                continue;
            }
            let f = flying.swap_remove(k);
            let measured = estimator.finish(f.path);
            in_order.end(f.order, f.sample, measured, &f.counters);
        }
        in_order.commit(job, &mut tile);
    }
    in_order.finish(job, &tile);
    tile
}
