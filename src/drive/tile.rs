//! A tile's samples: every pixel's sample indices of a pass, each with the
//! sampler of its (seed, pixel, index), measured by the integrator.

use std::ops::Range;

use super::job::TileRect;
use super::{PathCounters, PixelSample, RenderJob};
use crate::film::FilmTile;
use crate::sampler::Sampler;

/// Mixed into the seed of the AOVs' samplers.
const AOV_SEED: u64 = 0xa0f5_3c1d_9e77_b4a1;

/// Renders the samples `indices(x, y)` of every pixel of `rect` into a new
/// tile for a pass of `pass_len` samples a pixel. `sample` measures one
/// sample of a pixel and may splat into the tile. Counts the samples, rays
/// and non-finite values into the job (once a tile: per pixel, every thread
/// would update the same counters hundreds of thousands of times a pass).
pub fn render_tile<S>(
    job: &RenderJob,
    rect: TileRect,
    pass_len: u32,
    indices: impl Fn(u32, u32) -> Range<u32>,
    sample: S,
) -> FilmTile
where
    S: Fn(u32, u32, &mut Sampler, &mut FilmTile, &mut PathCounters) -> PixelSample,
{
    let (x0, y0, w, h) = rect;
    let seed = job.options.seed;
    let mut tile = job.new_tile(rect, pass_len);
    let mut counters = PathCounters::default();
    let (mut bad, mut taken) = (0, 0);
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let range = indices(x, y);
            taken += range.len() as u64;
            let rays_before = counters.rays;
            for index in range {
                let mut sampler = Sampler::for_sample(seed, x, y, index as u64);
                let s = sample(x, y, &mut sampler, &mut tile, &mut counters);
                bad += add_sample(job, &mut tile, (x, y, index), &s);
            }
            tile.add_rays(x, y, counters.rays - rays_before);
        }
    }
    job.count(taken, &counters, bad + tile.non_finite_splats);
    tile
}

/// Adds sample `index` of pixel (`x`, `y`) to `tile`, with its AOVs when
/// the film records them; 1 if it was dropped (not finite), else 0.
pub(super) fn add_sample(
    job: &RenderJob,
    tile: &mut FilmTile,
    (x, y, index): (u32, u32, u32),
    s: &PixelSample,
) -> u64 {
    let bad = if s.l.is_finite() {
        tile.add_sample(x, y, s.l, &s.wl);
        0
    } else {
        tile.add_empty_sample(x, y);
        1
    };
    if let Some(aovs) = job.aovs {
        // A stream of its own: the image is the same with or without AOVs.
        let seed = job.options.seed ^ AOV_SEED;
        let mut s = Sampler::for_sample(seed, x, y, index as u64);
        let [dx, dy, _, _] = s.next_4d();
        let a = aovs.first_hit(job.scene, x as f32 + dx, y as f32 + dy, &mut s);
        tile.add_aov(x, y, &a);
    }
    bad
}
