//! The splatting driver: each sample launches a path that may add light to
//! any pixel (light tracing, bidirectional paths). Passes of uniform
//! samples over the whole film; the tiles of a pass are rendered a batch
//! at a time and added in tile order, so the image is the same for any
//! thread count. Per-pixel variances mean nothing here, so no error
//! target, no adaptive sampling, and no region: a pixel's light comes
//! from every other pixel's samples.

use rayon::prelude::*;

use super::job::RenderJob;
use super::{largest_pass, pass_size, tile, tiles_bytes, Outcome, PathCounters, PixelSample};
use super::{RenderError, RenderOptions, RenderStats, Stop, TILE_SIZE};
use crate::camera::Camera;
use crate::film::{tile_spectrum_bytes, Film, FilmSettings, FilmTile};
use crate::sampler::Sampler;
use crate::scene::Scene;

/// An integrator whose samples may add light to any pixel.
pub trait SplatEstimator: Sync {
    /// The name the scene file uses, for messages.
    fn name(&self) -> &'static str;

    /// The longest path it traces, in surface interactions (each vertex
    /// may splat).
    fn max_depth(&self) -> u32;

    /// One sample of pixel (`x`, `y`): what it measures there; splats go
    /// to `tile`.
    fn sample(
        &self,
        scene: &Scene,
        pixel: (u32, u32),
        sampler: &mut Sampler,
        tile: &mut FilmTile,
        counters: &mut PathCounters,
    ) -> PixelSample;
}

/// Refuses what this driver cannot do: a camera that light paths cannot
/// reach, a region, an error target, adaptive sampling.
pub fn check<E: SplatEstimator>(
    estimator: &E,
    camera: &Camera,
    film: &FilmSettings,
    options: &RenderOptions,
) -> Result<(), RenderError> {
    let name = estimator.name();
    if !camera.connectible() {
        return Err(RenderError::SplatOrthographic(name));
    }
    if options.region != [0, 0, film.width, film.height] {
        return Err(RenderError::SplatRegion(name));
    }
    if options.target_error.is_some() {
        return Err(RenderError::SplatTarget(name));
    }
    if options.adaptive {
        return Err(RenderError::SplatAdaptive(name));
    }
    Ok(())
}

/// Splats a sample is taken to make, for the memory estimate: one per
/// light-path vertex seen by the camera, which Russian roulette keeps to a
/// few; at most `max_depth + 1`.
const SPLATS_PER_SAMPLE: u64 = 8;

/// Bytes a splat holds: XYZ and its spectral entries of 12 bytes.
const SPLAT_BYTES: u64 = 16 + 4 * 12;

/// Bytes this driver holds beyond the film's sums: nothing on the film,
/// and a batch of tiles with their splats while rendering.
pub fn memory<E: SplatEstimator>(
    estimator: &E,
    film: &FilmSettings,
    options: &RenderOptions,
) -> (u64, u64) {
    let pass = largest_pass(options, false);
    let spectrum = tile_spectrum_bytes(film.kept_layout().count, pass);
    let splats = SPLATS_PER_SAMPLE.min(estimator.max_depth() as u64 + 1) * SPLAT_BYTES;
    let batch = tiles_per_batch(spectrum) as u64;
    (0, tiles_bytes(film, options, batch, pass, splats))
}

/// Tiles rendered before their results are added to the film: bounds the
/// memory that finished tiles hold (splats can be many) while keeping the
/// order of additions fixed. Fewer where each tile's spectral sums
/// (`spectrum` bytes a pixel) are large, so a batch's stay within
/// `BATCH_SPECTRUM_BYTES`; never fewer than 16, so many threads still
/// share a batch. The count depends on the scene and the pass alone, never
/// on the threads: the image is the same for any number of them.
fn tiles_per_batch(spectrum: u64) -> usize {
    let tile_bytes = (TILE_SIZE * TILE_SIZE) as u64 * spectrum.max(1);
    (BATCH_SPECTRUM_BYTES / tile_bytes).clamp(16, 256) as usize
}

/// What a batch of tiles may hold in spectral sums.
const BATCH_SPECTRUM_BYTES: u64 = 64 << 20;

/// Renders the job with `estimator`'s samples.
pub fn render<E: SplatEstimator>(job: RenderJob, estimator: &E) -> (Film, RenderStats) {
    let options = job.options;
    let samples = options.samples.clone();
    let mut film = job.new_film();
    let tiles = job.tiles();
    let cap = largest_pass(options, false);
    let layout = job.film.kept_layout();
    let (mut first, mut passes, mut stop) = (samples.start, 0, Stop::Complete);
    while first < samples.end {
        // Saturating: ranges may end at u32::MAX (split renders of any size).
        let range = first
            ..first
                .saturating_add(pass_size(passes, cap))
                .min(samples.end);
        let spectrum = tile_spectrum_bytes(layout.count, range.len() as u32);
        for batch in tiles.chunks(tiles_per_batch(spectrum)) {
            let results: Vec<FilmTile> = batch
                .par_iter()
                .with_max_len(1)
                .map(|&rect| {
                    let indices = |_, _| range.clone();
                    tile::render_tile(&job, rect, range.len() as u32, indices, |x, y, s, t, c| {
                        estimator.sample(job.scene, (x, y), s, t, c)
                    })
                })
                .collect();
            for tile in &results {
                film.add_tile(tile);
            }
        }
        first = range.end;
        passes += 1;
        job.after_pass(&film);
        if first < samples.end {
            if let Some(s) = job.stop_reason() {
                stop = s;
                break;
            }
        }
    }
    let outcome = Outcome {
        stop,
        spp: first - samples.start,
        estimated_rel_mse: None,
        pilot_spp: 0,
    };
    job.finish(film, outcome)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splat_batches_bound_their_spectral_sums() {
        // 40 buckets: dense, 40 KiB a tile.
        assert_eq!(tile_spectrum_bytes(40, 1), 160);
        assert_eq!(tiles_per_batch(tile_spectrum_bytes(40, 1)), 256);
        assert_eq!(tiles_per_batch(tile_spectrum_bytes(0, 16)), 256);
        // 1024 buckets at 16 samples a pixel: dense, 1 MiB a tile.
        assert_eq!(tile_spectrum_bytes(1024, 16), 4096);
        assert_eq!(tiles_per_batch(tile_spectrum_bytes(1024, 16)), 64);
        // 4096 buckets: entries, a few a sample.
        assert_eq!(tile_spectrum_bytes(4096, 16), 48 * 16);
        assert_eq!(tiles_per_batch(1 << 20), 16);
    }
}
