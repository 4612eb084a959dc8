//! Drives the integrator over the image: tiles in parallel (rayon), in
//! passes of a few samples per pixel so that a progress bar can tell the
//! time left and an interruption leaves every pixel with whole samples.

use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

use crate::film::{Film, FilmTile, SpectralLayout};
use crate::integrator::{radiance, PathCounters};
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::SampledWavelengths;

const TILE_SIZE: u32 = 16;

#[derive(Clone, Debug, Default)]
pub struct RenderOptions {
    /// Samples per pixel; the scene's when None.
    pub spp: Option<u32>,
    /// Render exactly these sample indices of every pixel (instead of
    /// 0..spp), for splitting a render across processes or machines.
    pub samples: Option<Range<u32>>,
    /// Render only the pixels in [x0, x1) × [y0, y1); the others get no samples.
    pub region: Option<[u32; 4]>,
    /// Seed; the scene's when None.
    pub seed: Option<u64>,
    /// Worker threads; all cores when None.
    pub threads: Option<usize>,
    /// Show a progress bar on the terminal.
    pub progress: bool,
    /// Set to stop early: finished samples are kept.
    pub cancel: Option<Arc<AtomicBool>>,
}

#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    /// Camera samples taken (pixels × samples per pixel when complete).
    pub samples: u64,
    /// Rays traced (camera, bounce and shadow rays).
    pub rays: u64,
    /// Samples whose radiance was NaN or infinite: counted, recorded as zero.
    pub non_finite: u64,
    /// Media not entered because a path's IOR stack was full.
    pub stack_overflows: u64,
    pub elapsed: Duration,
    /// True when the render stopped before every sample was taken.
    pub interrupted: bool,
}

/// Renders the scene. Deterministic: the result depends only on the scene,
/// the seed and the samples taken, never on threads or timing.
pub fn render(scene: &Scene, options: &RenderOptions) -> (Film, RenderStats) {
    let pool = {
        let mut b = rayon::ThreadPoolBuilder::new();
        if let Some(n) = options.threads {
            b = b.num_threads(n);
        }
        b.build().expect("a thread pool")
    };
    pool.install(|| render_in_pool(scene, options))
}

fn render_in_pool(scene: &Scene, options: &RenderOptions) -> (Film, RenderStats) {
    let s = &scene.settings;
    let samples = options
        .samples
        .clone()
        .unwrap_or(0..options.spp.unwrap_or(s.spp));
    let seed = options.seed.unwrap_or(s.seed);
    let [rx0, ry0, rx1, ry1] = options.region.unwrap_or([0, 0, s.width, s.height]);
    let (rx1, ry1) = (rx1.min(s.width), ry1.min(s.height));
    let layout = SpectralLayout {
        min: s.spectral_range[0],
        max: s.spectral_range[1],
        count: s.spectral_buckets,
    };
    let mut film = Film::new(s.width, s.height, layout);
    let tiles: Vec<(u32, u32, u32, u32)> = (ry0..ry1)
        .step_by(TILE_SIZE as usize)
        .flat_map(|y| (rx0..rx1).step_by(TILE_SIZE as usize).map(move |x| (x, y)))
        .map(|(x, y)| (x, y, TILE_SIZE.min(rx1 - x), TILE_SIZE.min(ry1 - y)))
        .collect();

    let spp = samples.len() as u32;
    let pixels = rx1.saturating_sub(rx0) as u64 * ry1.saturating_sub(ry0) as u64;
    let total = pixels * spp as u64;
    let bar = if options.progress {
        let bar = ProgressBar::new(total);
        bar.set_style(
            ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {wide_bar} {percent:>3}%  {human_pos}/{human_len} samples  {rate}  ETA {eta}",
            )
            .expect("valid template")
            .with_key("rate", |state: &indicatif::ProgressState, w: &mut dyn std::fmt::Write| {
                let _ = write!(w, "{:.2} M samples/s", state.per_sec() / 1e6);
            }),
        );
        bar
    } else {
        ProgressBar::hidden()
    };

    let start = Instant::now();
    let rays = AtomicU64::new(0);
    let non_finite = AtomicU64::new(0);
    let overflows = AtomicU64::new(0);
    let cancelled = || {
        options
            .cancel
            .as_ref()
            .is_some_and(|c| c.load(Ordering::Relaxed))
    };
    // Passes of a sixteenth of the samples (at most 16 each) keep the progress
    // bar moving and bound how much work an interruption waits for.
    let pass = spp.div_ceil(16).clamp(1, 16);
    let mut first = samples.start;
    while first < samples.end && !cancelled() {
        let range = first..(first + pass).min(samples.end);
        let results: Vec<FilmTile> = tiles
            .par_iter()
            .filter_map(|&(x0, y0, w, h)| {
                if cancelled() {
                    return None;
                }
                let mut tile = FilmTile::new(x0, y0, w, h, layout);
                let mut counters = PathCounters::default();
                let mut bad = 0;
                for y in y0..y0 + h {
                    for x in x0..x0 + w {
                        for index in range.clone() {
                            let mut sampler = Sampler::for_sample(seed, x, y, index as u64);
                            let [dx, dy, u_lambda, _] = sampler.next_4d();
                            let mut wl = SampledWavelengths::sample_visible(u_lambda);
                            let ray = scene.camera.generate_ray(x as f32 + dx, y as f32 + dy);
                            let l = radiance(scene, ray, &mut wl, &mut sampler, &mut counters);
                            if l.is_finite() {
                                tile.add_sample(x, y, l, &wl);
                            } else {
                                bad += 1;
                                tile.add_empty_sample(x, y);
                            }
                        }
                    }
                }
                rays.fetch_add(counters.rays, Ordering::Relaxed);
                overflows.fetch_add(counters.stack_overflows, Ordering::Relaxed);
                non_finite.fetch_add(bad, Ordering::Relaxed);
                bar.inc((w * h) as u64 * range.len() as u64);
                Some(tile)
            })
            .collect();
        for tile in &results {
            film.add_tile(tile);
        }
        first = range.end;
    }
    bar.finish_and_clear();
    let samples = film.total_samples();
    let stats = RenderStats {
        samples,
        rays: rays.into_inner(),
        non_finite: non_finite.into_inner(),
        stack_overflows: overflows.into_inner(),
        elapsed: start.elapsed(),
        interrupted: samples < total,
    };
    (film, stats)
}
