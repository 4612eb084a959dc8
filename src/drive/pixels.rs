//! The per-pixel driver: each sample measures its own pixel. Progressive
//! passes over the whole region (1, 1, 2, 4, … samples a pixel, at most
//! 16), each a tile per rayon job; a finished tile adds itself to its band
//! of film rows, so no thread waits and the image is the same for any
//! thread count. Passes end at every power of two so that the error can be
//! estimated from the last doubling; an adaptive render's pilot chooses
//! each pixel's count. A stop (cancel, time budget, error target) ends
//! after the pass under way: every pixel then has the same samples.

use std::ops::Range;

use rayon::prelude::*;

use super::adaptive::{pilot_spp, progress, targets};
use super::job::{RenderJob, TileRect};
use super::{largest_pass, pass_size, tile, Outcome, PathCounters, PixelSample, RenderError};
use super::{RenderOptions, RenderStats, Stop, TILE_SIZE};
use crate::film::convergence::{PrefixError, BYTES_PER_PIXEL};
use crate::film::{Film, FilmSettings, FilmTile};
use crate::sampler::Sampler;
use crate::scene::Scene;

/// An integrator whose samples each measure their own pixel.
pub trait PixelEstimator: Sync {
    /// Work every pixel's sample of one index shares (photon mapping's
    /// photons); `()` where there is none.
    type Shared: Sync;

    /// Whether each sample index needs `prepare`: passes then take one
    /// index at a time.
    fn prepares(&self) -> bool;

    /// The work shared by every pixel's sample `index`.
    fn prepare(&self, scene: &Scene, seed: u64, index: u32) -> (Self::Shared, PathCounters);

    /// Bytes `prepare`'s result holds (estimated).
    fn shared_bytes(&self, scene: &Scene) -> u64;

    /// One sample of pixel (`x`, `y`).
    fn sample(
        &self,
        scene: &Scene,
        pixel: (u32, u32),
        sampler: &mut Sampler,
        shared: &Self::Shared,
        counters: &mut PathCounters,
    ) -> PixelSample;

    /// The samples `indices(x, y)` of every pixel of `rect` in a tile of a
    /// pass of `pass_len`: one sample at a time ([`one_at_a_time`]) unless
    /// the estimator advances them otherwise (as a stream).
    fn render_tile(
        &self,
        job: &RenderJob,
        rect: TileRect,
        pass_len: u32,
        indices: impl Fn(u32, u32) -> Range<u32>,
        shared: &Self::Shared,
    ) -> FilmTile {
        one_at_a_time(self, job, rect, pass_len, indices, shared)
    }
}

/// A tile's samples, one at a time (`tile::render_tile`).
pub fn one_at_a_time<E: PixelEstimator + ?Sized>(
    estimator: &E,
    job: &RenderJob,
    rect: TileRect,
    pass_len: u32,
    indices: impl Fn(u32, u32) -> Range<u32>,
    shared: &E::Shared,
) -> FilmTile {
    tile::render_tile(job, rect, pass_len, indices, |x, y, s, _, c| {
        estimator.sample(job.scene, (x, y), s, shared, c)
    })
}

/// Refuses what this driver cannot do: adaptive sample ranges.
pub fn check(options: &RenderOptions) -> Result<(), RenderError> {
    if options.adaptive && options.samples.start != 0 {
        return Err(RenderError::AdaptiveRange);
    }
    Ok(())
}

/// Bytes this driver holds beyond the film's sums: the film's extra
/// planes (adaptive counts, or the error estimate's images), and what the
/// tiles in flight and the shared work hold.
pub fn memory<E: PixelEstimator>(
    estimator: &E,
    scene: &Scene,
    film: &FilmSettings,
    options: &RenderOptions,
) -> (u64, u64) {
    let pixels = film.width as u64 * film.height as u64;
    let planes = if options.adaptive {
        4 * pixels
    } else {
        BYTES_PER_PIXEL * pixels
    };
    let pass = largest_pass(options, estimator.prepares());
    let threads = options.threads.unwrap_or_else(rayon::current_num_threads) as u64;
    let tiles = super::tiles_bytes(film, options, threads, pass, 0);
    (planes, tiles + estimator.shared_bytes(scene))
}

/// The pass loop's place: samples so far, passes, the adaptive counts.
struct Schedule {
    first: u32,
    passes: u32,
    cap: u32,
    pilot: Option<u32>,
    targets: Option<Vec<u32>>,
}

impl Schedule {
    /// The sample indices of the next pass: doubling up to the cap, ending
    /// at the pilot and (for the error estimate) at powers of two.
    fn next_pass(&self, options: &RenderOptions, prefix: bool) -> std::ops::Range<u32> {
        let samples = &options.samples;
        // Saturating: ranges may end at u32::MAX (split renders of any size).
        let mut range = self.first
            ..self
                .first
                .saturating_add(pass_size(self.passes, self.cap))
                .min(samples.end);
        if let (Some(p), None) = (self.pilot, &self.targets) {
            range.end = range.end.min(p);
        }
        if prefix {
            if let Some(next) = (self.first - samples.start + 1).checked_next_power_of_two() {
                range.end = range.end.min(samples.start.saturating_add(next));
            }
        }
        range
    }

    /// The sample indices of pixel (x, y) in `range`: all of them, or its
    /// adaptive share.
    fn indices(
        &self,
        range: &std::ops::Range<u32>,
        region: [u32; 4],
        spp: u32,
        x: u32,
        y: u32,
    ) -> std::ops::Range<u32> {
        match (&self.targets, self.pilot) {
            (Some(t), Some(p)) => {
                let [rx0, ry0, rx1, _] = region;
                let target = t[((y - ry0) * (rx1 - rx0) + x - rx0) as usize];
                progress(range.start, target, p, spp)..progress(range.end, target, p, spp)
            }
            _ => range.clone(),
        }
    }
}

/// Renders the job with `estimator`'s samples.
pub fn render<E: PixelEstimator>(job: RenderJob, estimator: &E) -> (Film, RenderStats) {
    let options = job.options;
    let samples = options.samples.clone();
    let region = job.region();
    let mut film = job.new_film();
    let tiles = job.tiles();
    let requested_spp = samples.len() as u32;
    let mut at = Schedule {
        first: samples.start,
        passes: 0,
        cap: largest_pass(options, estimator.prepares()),
        pilot: options.adaptive.then(|| pilot_spp(requested_spp)),
        targets: None,
    };
    // A uniform render's error from its images at doublings of samples.
    let mut prefix = (!options.adaptive).then(|| PrefixError::new(region));
    let (mut rel_mse, mut stop) = (None, Stop::Complete);
    while at.first < samples.end {
        let range = at.next_pass(options, prefix.is_some());
        let (shared, counters) = estimator.prepare(job.scene, options.seed, range.start);
        job.count(0, &counters, 0);
        let bands = film.bands(region[1], TILE_SIZE);
        // Every tile a job of its own that an idle thread can take: left
        // to itself rayon cuts the list into a few long runs per thread,
        // and a run of costly tiles (the Cornell Box's ceiling, or where
        // adaptive counts are high) keeps one thread busy while the others
        // have nothing to steal.
        tiles.par_iter().with_max_len(1).for_each(|&rect| {
            let indices = |x, y| at.indices(&range, region, requested_spp, x, y);
            let t = estimator.render_tile(&job, rect, range.len() as u32, indices, &shared);
            let band = &bands[((rect.1 - region[1]) / TILE_SIZE) as usize];
            band.lock().expect("no panic while adding").add_tile(&t);
        });
        drop(bands);
        at.first = range.end;
        at.passes += 1;
        if let (Some(p), None) = (at.pilot, &at.targets) {
            if at.first >= p {
                let t = targets(&film, region, requested_spp, p);
                job.set_total_samples(t.iter().map(|&n| n as u64).sum());
                at.targets = Some(t);
            }
        }
        job.after_pass(&film);
        if let Some(p) = &mut prefix {
            p.record(&film, (at.first - samples.start) as u64);
        }
        // Estimated between passes only where it decides when to stop.
        if options.target_error.is_some() {
            rel_mse = Some(estimated_rel_mse(
                &film,
                prefix.as_ref(),
                at.first - samples.start,
                region,
            ));
        }
        let reached = options
            .target_error
            .is_some_and(|t| rel_mse.is_some_and(|e| e <= t));
        if at.first < samples.end {
            match job.stop_reason() {
                Some(s) => stop = s,
                None if reached => stop = Stop::ErrorTarget,
                None => continue,
            }
            break;
        }
    }
    let spp = at.first - samples.start;
    let outcome = Outcome {
        stop,
        spp,
        estimated_rel_mse: Some(estimated_rel_mse(&film, prefix.as_ref(), spp, region)),
        pilot_spp: at.pilot.unwrap_or(0),
    };
    job.finish(film, outcome)
}

/// The relMSE of a film whose pixels have `spp` samples each: from its
/// last doubling where two powers of two are recorded, else from the
/// spread of each pixel's samples (which overstates the error of Sobol
/// samples).
fn estimated_rel_mse(film: &Film, prefix: Option<&PrefixError>, spp: u32, region: [u32; 4]) -> f64 {
    prefix
        .and_then(|p| p.estimate(film, spp as u64))
        .unwrap_or_else(|| film.estimated_rel_mse(region))
}
