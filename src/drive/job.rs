//! [`RenderJob`]: one render under way, as an integrator's loop sees it.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use super::progress::Progress;
use super::{AovTracer, PathCounters, RenderOptions, RenderStats, Stop, TILE_SIZE};
use crate::film::{Film, FilmSettings, FilmTile};
use crate::scene::Scene;

/// A render under way: what to render and how far, the progress shown,
/// and the counters summed over its paths. Every loop gets its film from
/// `new_film`, checks `stop_reason` between passes, calls `after_pass`
/// with each complete film, and ends with `finish`.
pub struct RenderJob<'a> {
    pub scene: &'a Scene,
    pub film: &'a FilmSettings,
    pub options: &'a RenderOptions,
    /// Traces the AOVs beside each camera sample, where the film records them.
    pub aovs: Option<&'a dyn AovTracer>,
    progress: Progress,
    start: Instant,
    rays: AtomicU64,
    non_finite: AtomicU64,
    overflows: AtomicU64,
}

/// How a loop ended: why, how far every pixel got, the error estimate.
#[derive(Clone, Copy, Debug)]
pub struct Outcome {
    pub stop: Stop,
    /// Samples every pixel of the region has (the pass count for an
    /// adaptive render).
    pub spp: u32,
    pub estimated_rel_mse: Option<f64>,
    /// Samples per pixel of the adaptive pilot; 0 without one.
    pub pilot_spp: u32,
}

/// A rectangle of the region rendered as one job: x, y, width, height.
pub type TileRect = (u32, u32, u32, u32);

impl<'a> RenderJob<'a> {
    pub fn new(
        scene: &'a Scene,
        film: &'a FilmSettings,
        options: &'a RenderOptions,
        aovs: Option<&'a dyn AovTracer>,
    ) -> Self {
        let start = Instant::now();
        let [x0, y0, x1, y1] = clamp_region(options.region, film);
        let pixels = x1.saturating_sub(x0) as u64 * y1.saturating_sub(y0) as u64;
        let total = pixels * options.samples.len() as u64;
        Self {
            scene,
            film,
            options,
            aovs,
            progress: Progress::new(
                total,
                options.progress,
                options.log_every,
                start,
                options.progress_counts.clone(),
            ),
            start,
            rays: AtomicU64::new(0),
            non_finite: AtomicU64::new(0),
            overflows: AtomicU64::new(0),
        }
    }

    /// The pixels rendered, [x0, y0, x1, y1), within the film.
    pub fn region(&self) -> [u32; 4] {
        clamp_region(self.options.region, self.film)
    }

    /// An empty film of the settings' size, layout and AOVs.
    pub fn new_film(&self) -> Film {
        let film = Film::new(self.film.width, self.film.height, self.film.kept_layout());
        if self.aovs.is_some() {
            film.with_aovs()
        } else {
            film
        }
    }

    /// An empty tile for `rect` of a pass of `samples` samples a pixel.
    pub fn new_tile(&self, (x0, y0, w, h): TileRect, samples: u32) -> FilmTile {
        let tile = FilmTile::new(x0, y0, w, h, self.film.width, self.film.kept_layout())
            .with_observer(self.film.observer)
            .for_samples(samples);
        if self.aovs.is_some() {
            tile.with_aovs()
        } else {
            tile
        }
    }

    /// The region cut into tiles, row by row.
    pub fn tiles(&self) -> Vec<TileRect> {
        let [rx0, ry0, rx1, ry1] = self.region();
        (ry0..ry1)
            .step_by(TILE_SIZE as usize)
            .flat_map(|y| (rx0..rx1).step_by(TILE_SIZE as usize).map(move |x| (x, y)))
            .map(|(x, y)| (x, y, TILE_SIZE.min(rx1 - x), TILE_SIZE.min(ry1 - y)))
            .collect()
    }

    /// Why the render should stop after the pass just done (cancelled, out
    /// of time), if it should.
    pub fn stop_reason(&self) -> Option<Stop> {
        let o = self.options;
        if o.cancel
            .as_ref()
            .is_some_and(|c| c.load(std::sync::atomic::Ordering::Relaxed))
        {
            Some(Stop::Interrupted)
        } else if o.time_budget.is_some_and(|t| self.start.elapsed() >= t) {
            Some(Stop::TimeBudget)
        } else {
            None
        }
    }

    /// Adds a tile's (or a prepared step's) counts to the render's:
    /// `samples` taken, their paths' counters and the samples dropped as
    /// not finite.
    pub fn count(&self, samples: u64, counters: &PathCounters, non_finite: u64) {
        if samples > 0 {
            self.progress.add(samples);
        }
        self.rays.fetch_add(counters.rays, Ordering::Relaxed);
        self.overflows
            .fetch_add(counters.stack_overflows, Ordering::Relaxed);
        self.non_finite.fetch_add(non_finite, Ordering::Relaxed);
    }

    /// The samples the render will take in all changed (adaptive counts).
    pub fn set_total_samples(&self, total: u64) {
        self.progress.set_total(total);
    }

    /// Shows `film`, complete after a pass, to the options' hook.
    pub fn after_pass(&self, film: &Film) {
        if let Some(hook) = &self.options.after_pass {
            (hook.0)(film);
        }
    }

    /// The film and the render's statistics.
    pub fn finish(mut self, film: Film, outcome: Outcome) -> (Film, RenderStats) {
        self.progress.finish();
        let stats = RenderStats {
            samples: film.total_samples(),
            rays: self.rays.into_inner(),
            non_finite: self.non_finite.into_inner(),
            stack_overflows: self.overflows.into_inner(),
            elapsed: self.start.elapsed(),
            interrupted: outcome.stop == Stop::Interrupted,
            stop: outcome.stop,
            spp: outcome.spp,
            estimated_rel_mse: outcome.estimated_rel_mse,
            pilot_spp: outcome.pilot_spp,
        };
        (film, stats)
    }
}

fn clamp_region([x0, y0, x1, y1]: [u32; 4], film: &FilmSettings) -> [u32; 4] {
    [x0, y0, x1.min(film.width), y1.min(film.height)]
}
