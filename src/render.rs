//! Drives the integrator over the image: tiles in parallel (rayon), in
//! progressive passes over the whole image, each adding samples to every
//! pixel (1, 1, 2, 4, … up to a sixteenth of the samples, at most 16). A
//! render that stops early (Ctrl-C, a time budget, an error target)
//! finishes the pass under way, so every pixel has the same number of
//! samples: a complete, evenly converged picture.

use std::io::IsTerminal;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

use crate::film::convergence::PrefixError;
use crate::film::{Film, FilmTile};
use crate::integrator::aov::Aovs;
use crate::integrator::PathCounters;
use crate::sampler::Sampler;
use crate::scene::Scene;

const TILE_SIZE: u32 = 16;

/// Mixed into the seed of the AOVs' samplers.
const AOV_SEED: u64 = 0xa0f5_3c1d_9e77_b4a1;

/// One render of a loaded scene: which samples, where, on how many threads.
/// `RenderOptions::new` takes the scene file's defaults; a caller changes
/// its options, never the scene.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    /// The sample indices taken in every pixel: 0..spp for a whole render,
    /// a sub-range for a part of a render split across processes.
    pub samples: Range<u32>,
    /// Seed of every random decision.
    pub seed: u64,
    /// Render only the pixels in [x0, x1) × [y0, y1); the others get no samples.
    pub region: [u32; 4],
    /// Worker threads; all cores when None.
    pub threads: Option<usize>,
    /// Show a progress bar on the terminal.
    pub progress: bool,
    /// Set to stop early: the pass under way finishes, and is kept.
    pub cancel: Option<Arc<AtomicBool>>,
    /// Stop after the pass during which this much time has passed.
    pub time_budget: Option<Duration>,
    /// Stop after the first pass whose estimated relative MSE
    /// ([`Film::estimated_rel_mse`]) is below this.
    pub target_error: Option<f64>,
    /// Where no progress bar can be drawn (stderr is not a terminal), print
    /// a progress line this often.
    pub log_every: Duration,
    /// Called with the film after every pass (a preview writer).
    pub after_pass: Option<PassHook>,
    /// Spend the samples (`samples.len()` per pixel on average) where a
    /// pilot render finds the relative error high ([`adaptive_targets`]).
    pub adaptive: bool,
}

/// A function the render calls with the film after each pass: every pixel
/// then has the same samples, so the film is a complete picture.
#[derive(Clone)]
pub struct PassHook(pub Arc<dyn Fn(&Film) + Send + Sync>);

impl std::fmt::Debug for PassHook {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("PassHook")
    }
}

impl RenderOptions {
    /// The whole film at the scene file's samples per pixel and seed.
    pub fn new(scene: &Scene) -> Self {
        let f = &scene.film;
        Self {
            samples: 0..f.spp,
            seed: f.seed,
            region: [0, 0, f.width, f.height],
            threads: None,
            progress: false,
            cancel: None,
            time_budget: None,
            target_error: None,
            log_every: Duration::from_secs(5),
            after_pass: None,
            adaptive: false,
        }
    }

    /// The same, with `spp` samples per pixel.
    pub fn with_spp(scene: &Scene, spp: u32) -> Self {
        Self {
            samples: 0..spp,
            ..Self::new(scene)
        }
    }
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
    /// True when a cancel (Ctrl-C) stopped the render before every sample
    /// was taken.
    pub interrupted: bool,
    /// Why the render ended.
    pub stop: Stop,
    /// Samples every pixel of the region has (all have the same).
    pub spp: u32,
    /// The film's estimated relative MSE at the end (None for integrators
    /// that splat, whose per-pixel variances say nothing).
    pub estimated_rel_mse: Option<f64>,
    /// Samples per pixel of the adaptive pilot (the first of every
    /// pixel's samples, which chose the counts); 0 without adaptive sampling.
    pub pilot_spp: u32,
}

/// Why a render ended.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Stop {
    /// Every sample was taken.
    #[default]
    Complete,
    /// Cancelled (Ctrl-C).
    Interrupted,
    /// The time budget was spent.
    TimeBudget,
    /// The estimated error fell below the target.
    ErrorTarget,
}

/// Why a render cannot run as asked.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("cannot start {threads} worker threads: {reason}")]
    Threads { threads: usize, reason: String },
    #[error(
        "the {0} integrator adds light to every pixel: it renders the whole film, not a region"
    )]
    SplatRegion(&'static str),
    #[error(
        "an error target needs per-pixel variances, and the {0} integrator's splats make them meaningless: use a sample count or a time budget"
    )]
    SplatTarget(&'static str),
    #[error(
        "adaptive sampling needs per-pixel variances, and the {0} integrator's splats make them meaningless"
    )]
    SplatAdaptive(&'static str),
    #[error("adaptive sampling spreads a whole render's samples: it takes no --samples range")]
    AdaptiveRange,
}

/// Renders the scene. Deterministic: the result depends only on the scene,
/// the seed and the samples taken, never on threads or timing.
pub fn render(scene: &Scene, options: &RenderOptions) -> Result<(Film, RenderStats), RenderError> {
    let f = &scene.film;
    if scene.integrator.splats() && options.region != [0, 0, f.width, f.height] {
        return Err(RenderError::SplatRegion(scene.integrator.name()));
    }
    if scene.integrator.splats() && options.target_error.is_some() {
        return Err(RenderError::SplatTarget(scene.integrator.name()));
    }
    if options.adaptive && scene.integrator.splats() {
        return Err(RenderError::SplatAdaptive(scene.integrator.name()));
    }
    if options.adaptive && options.samples.start != 0 {
        return Err(RenderError::AdaptiveRange);
    }
    let mut b = rayon::ThreadPoolBuilder::new();
    if let Some(n) = options.threads {
        check_address_space(n)?;
        b = b.num_threads(n);
    }
    let pool = b.build().map_err(|e| RenderError::Threads {
        threads: options.threads.unwrap_or(0),
        reason: e.to_string(),
    })?;
    Ok(pool.install(|| render_in_pool(scene, options)))
}

/// Address space a worker thread takes: its 2 MiB stack (Rust's default),
/// guard page and signal stack, rounded up.
const THREAD_ADDRESS_SPACE: u64 = 4 << 20;

/// Refuses more threads than the process's address-space limit allows
/// (with half of it left for the scene and film). Past that limit a thread
/// can start and then fail to allocate its signal stack, which the standard
/// library can only abort on.
fn check_address_space(threads: usize) -> Result<(), RenderError> {
    // SAFETY: getrlimit only writes the struct it is given.
    let limit = unsafe {
        let mut r = std::mem::zeroed::<libc::rlimit>();
        if libc::getrlimit(libc::RLIMIT_AS, &mut r) != 0 {
            return Ok(());
        }
        r.rlim_cur
    };
    if limit == libc::RLIM_INFINITY {
        return Ok(());
    }
    let need = threads as u64 * THREAD_ADDRESS_SPACE;
    if need > limit / 2 {
        return Err(RenderError::Threads {
            threads,
            reason: format!(
                "they need about {} MiB of address space and the process may use {} MiB in all (ulimit -v)",
                need >> 20,
                limit >> 20
            ),
        });
    }
    Ok(())
}

/// What a render will hold at its peak, in bytes, by part: estimated from
/// the sizes of what it allocates and checked against the memory budget
/// before the first sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryEstimate {
    /// The peak of loading: images, meshes and the BVH build (before the
    /// film exists).
    pub loading: u64,
    /// Geometry, BVH, lights and decoded images.
    pub scene: u64,
    /// The film's sums (and an adaptive render's pilot film).
    pub film: u64,
    /// Tiles of one batch with a pass's samples in them, and the photon
    /// map: held while rendering.
    pub passes: u64,
    /// The images being encoded: held while writing, once the passes are
    /// done.
    pub writing: u64,
}

impl MemoryEstimate {
    pub fn total(&self) -> u64 {
        PROCESS_BYTES + self.loading.max(self.rendering())
    }

    /// What rendering and writing add to the loaded scene, at their peak.
    pub fn rendering(&self) -> u64 {
        self.scene + self.film + self.passes.max(self.writing)
    }
}

/// An AOV pixel's sums.
const AOV_BYTES: u64 = std::mem::size_of::<crate::film::AovSums>() as u64;

/// The process itself: code, tables, threads (measured: 40 MiB peak for a
/// 256² Cornell Box).
const PROCESS_BYTES: u64 = 48 << 20;

/// Splats a sample of a splatting integrator is taken to make, for the
/// estimate: one per light-path vertex seen by the camera, which Russian
/// roulette keeps to a few; at most `max_depth + 1`.
const SPLATS_PER_SAMPLE: u64 = 8;

/// Bytes a film of `pixels` holds with `buckets` spectral sums a pixel
/// (none where no spectral EXR is written), and what writing it adds: the
/// spectral planes (4 bytes a bucket), the sample counts, R, G, B and the
/// PNG's display values (measured: 1.55 GiB peak for 2048², 40 buckets, with a
/// film of 0.85 GiB).
pub fn film_bytes(pixels: u64, buckets: u32, spectral: bool, aovs: bool) -> (u64, u64) {
    let per_pixel = std::mem::size_of::<crate::film::PixelSums>() as u64
        + 4 * buckets as u64
        + if aovs { AOV_BYTES } else { 0 };
    let writing = if spectral { 4 * buckets as u64 + 4 } else { 0 } + 12 + 12 + 8;
    (
        pixels.saturating_mul(per_pixel),
        pixels.saturating_mul(writing),
    )
}

/// The memory `scene` rendered with `options` will hold at its peak.
pub fn memory_estimate(scene: &Scene, options: &RenderOptions) -> MemoryEstimate {
    let f = &scene.film;
    let aovs = f.aovs.traced();
    let pixels = f.width as u64 * f.height as u64;
    let buckets = f.kept_layout().count;
    let (mut film, writing) = film_bytes(pixels, buckets, f.spectral_output, aovs);
    if options.adaptive {
        // Each pixel's sample count.
        film += 4 * pixels;
    } else if !scene.integrator.splats() {
        // The error estimate's images at the last doublings.
        film += crate::film::convergence::BYTES_PER_PIXEL * pixels;
    }
    let [x0, y0, x1, y1] = options.region;
    let region =
        (x1.min(f.width).saturating_sub(x0) as u64) * (y1.min(f.height).saturating_sub(y0) as u64);
    // Tiles in flight: a batch of them for splatting integrators (added in
    // order), else one a thread (each adds itself when done).
    let pass = largest_pass(scene, options);
    let spectrum = crate::film::tile_spectrum_bytes(buckets, pass);
    let tiles = if scene.integrator.splats() {
        tiles_per_batch(spectrum) as u64
    } else {
        options.threads.unwrap_or_else(rayon::current_num_threads) as u64
    };
    let batch = region.min(tiles * (TILE_SIZE as u64).pow(2));
    // Per sample: splats add XYZ and spectral entries of 12 bytes.
    let mut per_sample = 0;
    if scene.integrator.splats() {
        let depth = scene.integrator.max_depth() as u64 + 1;
        per_sample += SPLATS_PER_SAMPLE.min(depth) * (16 + 4 * 12);
    }
    let per_pixel = std::mem::size_of::<crate::film::PixelSums>() as u64
        + spectrum
        + if aovs { AOV_BYTES } else { 0 }
        + per_sample * pass as u64;
    MemoryEstimate {
        loading: scene.load_peak_bytes,
        scene: scene.memory_bytes(),
        film,
        passes: batch * per_pixel + scene.integrator.prepared_bytes(scene),
        writing,
    }
}

/// Tiles of a splatting integrator rendered before their results are
/// added to the film: bounds the memory that finished tiles hold (splats
/// can be many) while keeping the order of additions fixed. Fewer where
/// each tile's spectral sums (`spectrum` bytes a pixel) are large, so a
/// batch's stay within `BATCH_SPECTRUM_BYTES`; never fewer than 16, so
/// many threads still share a batch. The count depends on the scene and
/// the pass alone, never on the threads: the image is the same for any
/// number of them.
fn tiles_per_batch(spectrum: u64) -> usize {
    let tile_bytes = (TILE_SIZE * TILE_SIZE) as u64 * spectrum.max(1);
    (BATCH_SPECTRUM_BYTES / tile_bytes).clamp(16, 256) as usize
}

/// What a batch of tiles may hold in spectral sums.
const BATCH_SPECTRUM_BYTES: u64 = 64 << 20;

fn render_in_pool(scene: &Scene, options: &RenderOptions) -> (Film, RenderStats) {
    let f = &scene.film;
    let samples = options.samples.clone();
    let seed = options.seed;
    let [rx0, ry0, rx1, ry1] = options.region;
    let (rx1, ry1) = (rx1.min(f.width), ry1.min(f.height));
    let layout = f.kept_layout();
    let mut film = Film::new(f.width, f.height, layout);
    let aovs = f.aovs.traced().then(|| Aovs::new(f.observer));
    if aovs.is_some() {
        film = film.with_aovs();
    }
    let tiles: Vec<(u32, u32, u32, u32)> = (ry0..ry1)
        .step_by(TILE_SIZE as usize)
        .flat_map(|y| (rx0..rx1).step_by(TILE_SIZE as usize).map(move |x| (x, y)))
        .map(|(x, y)| (x, y, TILE_SIZE.min(rx1 - x), TILE_SIZE.min(ry1 - y)))
        .collect();

    let region_width = rx1.saturating_sub(rx0);
    // Adaptive sampling: the first `pilot` samples of every pixel (passes
    // end there) decide how many samples each pixel takes in all.
    let requested_spp = samples.len() as u32;
    let pilot = options.adaptive.then(|| pilot_spp(requested_spp));
    let mut targets: Option<Vec<u32>> = None;
    // A uniform render's error from its images at doublings of samples;
    // passes end at every power of two so that they are seen.
    let mut prefix = (!scene.integrator.splats() && !options.adaptive)
        .then(|| PrefixError::new([rx0, ry0, rx1, ry1]));
    let pixels = rx1.saturating_sub(rx0) as u64 * ry1.saturating_sub(ry0) as u64;
    // An adaptive render's counts average the requested samples.
    let total = AtomicU64::new(pixels * samples.len() as u64);
    let bar = if options.progress {
        let bar = ProgressBar::new(total.load(Ordering::Relaxed));
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
    let done = AtomicU64::new(0);
    let cancelled = || {
        options
            .cancel
            .as_ref()
            .is_some_and(|c| c.load(Ordering::Relaxed))
    };
    let out_of_time = || options.time_budget.is_some_and(|t| start.elapsed() >= t);
    let cap = largest_pass(scene, options);
    let logging = options.progress && !std::io::stderr().is_terminal();
    let (mut passes, mut rel_mse, mut stop) = (0u32, None, Stop::Complete);
    let mut first = samples.start;
    let finished = AtomicBool::new(false);
    std::thread::scope(|threads| {
        if logging {
            threads.spawn(|| log_progress(&done, &total, start, options.log_every, &finished));
        }
        while first < samples.end {
            // Saturating: ranges may end at u32::MAX (split renders of any size).
            let mut range = first
                ..first
                    .saturating_add(pass_size(passes, cap))
                    .min(samples.end);
            if let (Some(p), None) = (pilot, &targets) {
                range.end = range.end.min(p);
            }
            if prefix.is_some() {
                if let Some(next) = (first - samples.start + 1).checked_next_power_of_two() {
                    range.end = range.end.min(samples.start.saturating_add(next));
                }
            }
            let (prepared, prepare_counters) = scene.integrator.prepare(scene, seed, range.start);
            rays.fetch_add(prepare_counters.rays, Ordering::Relaxed);
            overflows.fetch_add(prepare_counters.stack_overflows, Ordering::Relaxed);
            let render_tile = |&(x0, y0, w, h): &(u32, u32, u32, u32)| {
                let mut tile = FilmTile::new(x0, y0, w, h, f.width, layout)
                    .with_observer(f.observer)
                    .for_samples(range.len() as u32);
                if aovs.is_some() {
                    tile = tile.with_aovs();
                }
                let mut counters = PathCounters::default();
                let mut bad = 0;
                // Progress is counted per tile: per pixel, every thread
                // would update the same counters hundreds of thousands of
                // times a pass.
                let mut taken = 0;
                for y in y0..y0 + h {
                    for x in x0..x0 + w {
                        let (start, end) = match (&targets, pilot) {
                            (Some(t), Some(p)) => {
                                let target = t[((y - ry0) * region_width + x - rx0) as usize];
                                let at = |k| adaptive_progress(k, target, p, requested_spp);
                                (at(range.start), at(range.end))
                            }
                            _ => (range.start, range.end),
                        };
                        taken += end.saturating_sub(start) as u64;
                        for index in start..end {
                            let mut sampler = Sampler::for_sample(seed, x, y, index as u64);
                            let s = scene.integrator.sample(
                                scene,
                                x,
                                y,
                                &mut sampler,
                                &prepared,
                                &mut tile,
                                &mut counters,
                            );
                            if s.l.is_finite() {
                                tile.add_sample(x, y, s.l, &s.wl);
                            } else {
                                bad += 1;
                                tile.add_empty_sample(x, y);
                            }
                            if let Some(aovs) = &aovs {
                                // A stream of its own: the image is
                                // the same with or without AOVs.
                                let mut s =
                                    Sampler::for_sample(seed ^ AOV_SEED, x, y, index as u64);
                                let [dx, dy, _, _] = s.next_4d();
                                let a = aovs.first_hit(scene, x as f32 + dx, y as f32 + dy, &mut s);
                                tile.add_aov(x, y, &a);
                            }
                        }
                    }
                }
                done.fetch_add(taken, Ordering::Relaxed);
                bar.inc(taken);
                bad += tile.non_finite_splats;
                rays.fetch_add(counters.rays, Ordering::Relaxed);
                overflows.fetch_add(counters.stack_overflows, Ordering::Relaxed);
                non_finite.fetch_add(bad, Ordering::Relaxed);
                tile
            };
            if scene.integrator.splats() {
                // Splats land anywhere: tiles are added in a fixed order,
                // a batch at a time, so the image is the same for any
                // thread count.
                let spectrum = crate::film::tile_spectrum_bytes(layout.count, range.len() as u32);
                for batch in tiles.chunks(tiles_per_batch(spectrum)) {
                    let results: Vec<FilmTile> =
                        batch.par_iter().with_max_len(1).map(render_tile).collect();
                    for tile in &results {
                        film.add_tile(tile);
                    }
                }
            } else {
                // A pass adds one tile to each pixel: tiles add to the film
                // as they finish, each into its band of rows, by the thread
                // that rendered it (a pixel's sums are the same in any order
                // of tiles, and no thread waits for a batch).
                let bands = film.bands(ry0, TILE_SIZE);
                // Every tile a job of its own that an idle thread can take:
                // left to itself rayon cuts the list into a few long runs
                // per thread, and a run of costly tiles (the Cornell Box's
                // ceiling, or where adaptive counts are high) then keeps
                // one thread busy while the others have nothing to steal.
                tiles.par_iter().with_max_len(1).for_each(|t| {
                    let tile = render_tile(t);
                    let band = &bands[((t.1 - ry0) / TILE_SIZE) as usize];
                    band.lock().expect("no panic while adding").add_tile(&tile);
                });
            }
            first = range.end;
            passes += 1;
            if let (Some(p), None) = (pilot, &targets) {
                if first >= p {
                    let t = adaptive_targets(&film, [rx0, ry0, rx1, ry1], requested_spp, p);
                    let sum = t.iter().map(|&n| n as u64).sum();
                    total.store(sum, Ordering::Relaxed);
                    bar.set_length(sum);
                    targets = Some(t);
                }
            }
            if let Some(hook) = &options.after_pass {
                (hook.0)(&film);
            }
            if let Some(p) = &mut prefix {
                p.record(&film, (first - samples.start) as u64);
            }
            // Estimated between passes only where it decides when to stop.
            if !scene.integrator.splats() && options.target_error.is_some() {
                rel_mse = Some(estimated_rel_mse(
                    &film,
                    prefix.as_ref(),
                    first - samples.start,
                    [rx0, ry0, rx1, ry1],
                ));
            }
            let reached = options
                .target_error
                .is_some_and(|t| rel_mse.is_some_and(|e| e <= t));
            if first < samples.end {
                stop = if cancelled() {
                    Stop::Interrupted
                } else if out_of_time() {
                    Stop::TimeBudget
                } else if reached {
                    Stop::ErrorTarget
                } else {
                    continue;
                };
                break;
            }
        }
        finished.store(true, Ordering::Relaxed);
    });
    bar.finish_and_clear();
    if !scene.integrator.splats() {
        rel_mse = Some(estimated_rel_mse(
            &film,
            prefix.as_ref(),
            first - samples.start,
            [rx0, ry0, rx1, ry1],
        ));
    }
    let taken = film.total_samples();
    let stats = RenderStats {
        samples: taken,
        rays: rays.into_inner(),
        non_finite: non_finite.into_inner(),
        stack_overflows: overflows.into_inner(),
        elapsed: start.elapsed(),
        interrupted: stop == Stop::Interrupted,
        stop,
        spp: first - samples.start,
        estimated_rel_mse: rel_mse,
        pilot_spp: pilot.unwrap_or(0),
    };
    (film, stats)
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

/// Samples per pixel of the adaptive pilot for an average of `spp`: a
/// sixteenth, at least 4, at most 64, and at most `spp` (the pilot's
/// samples are the image's first); below 8 samples, 2, which leaves
/// something to spend (a pixel's count follows its ~80 neighbours'
/// errors, so two samples each are enough to go by). Cornell 512², two
/// seeds: at 4 spp a pilot of 2 lowers the variance 10% (a pilot of 4 is
/// every sample: uniform); at 8 spp 2 and 4 are within 1.5%; at 16 spp 2
/// is 1.7% worse than 4.
pub fn pilot_spp(spp: u32) -> u32 {
    let pilot = if spp < 8 { 2 } else { (spp / 16).clamp(4, 64) };
    pilot.min(spp)
}

/// Where an adaptive pixel with `target` samples stands when the render has
/// advanced `k` of its `spp` samples a pixel (the index its samples reach):
/// during the pilot, at `k`; after it, at the same share of its own count
/// past the pilot as the render is of `spp`, reaching `target` at `spp`.
/// So every pass spreads over the whole image (a pass that advanced only
/// the pixels still short of their counts would leave threads idle on the
/// few tiles holding them), and a render stopped early by a time budget or
/// an error target is adaptive already, each pixel with its share.
pub fn adaptive_progress(k: u32, target: u32, pilot: u32, spp: u32) -> u32 {
    if k <= pilot || spp <= pilot {
        return k.min(target);
    }
    let past = u64::from(target.saturating_sub(pilot)) * u64::from(k - pilot);
    pilot + (past / u64::from(spp - pilot)) as u32
}

/// Pixels on each side of a pixel whose pilot errors decide its count
/// (Cornell Box, 64 spp: radius 1, 3 and 6 lowered the variance 6%, 9%
/// and 10%).
const ADAPTIVE_RADIUS: i64 = 4;

/// Counts follow the relative error per sample to this power. The
/// Lagrange optimum for independent samples (variance σ²/n) is 1; Sobol
/// points converge faster (variance ∝ n^-α, α > 1), which flattens the
/// optimum to 2/(1 + α). Cornell Box, 64 spp: 0.7 and 1 lowered the
/// variance 10% and 9%, 1.4 only 4%.
const ADAPTIVE_POWER: f64 = 0.75;

/// Adaptive sampling: how many samples each pixel of `region` takes so
/// that they average `spp`, from a film holding the first `pilot` samples
/// of every pixel. Each pixel gets at least a quarter of `spp` (and the
/// pilot); the rest goes in proportion to a power (`ADAPTIVE_POWER`) of
/// the relative error per sample, σ / √(mean² + 0.01) (luminance, the ε
/// of the relMSE), to lower the summed relative variance σ²/(n (mean² + ε))
/// for the budget; at most 16 × `spp`.
///
/// A pixel's error is the mean of its neighbours' (the pixels within
/// `ADAPTIVE_RADIUS`, itself left out): a few pilot samples give a noisy
/// error per pixel, and a count that followed it would chase the noise.
/// Leaving the pixel out keeps the image unbiased with the pilot in it:
/// a pixel's count does not depend on its own samples, so its value is
/// the mean of a number of samples fixed independently of them.
pub fn adaptive_targets(film: &Film, region: [u32; 4], spp: u32, pilot: u32) -> Vec<u32> {
    let [x0, y0, x1, y1] = region;
    let (w, h) = (
        x1.saturating_sub(x0) as usize,
        y1.saturating_sub(y0) as usize,
    );
    let errors: Vec<f64> = (y0..y1)
        .flat_map(|y| (x0..x1).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (m, var_of_mean) = film.luminance_and_variance(x, y);
            let n = film.sums(x, y).samples as f64;
            let sigma = (var_of_mean * n).max(0.0).sqrt();
            let e = sigma / (m * m + crate::bench::REL_MSE_EPSILON).sqrt();
            if e.is_finite() {
                e
            } else {
                0.0
            }
        })
        .collect();
    // Summed-area table: each window's sum in four lookups.
    let mut table = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0.0;
        for x in 0..w {
            row += errors[y * w + x];
            table[(y + 1) * (w + 1) + x + 1] = table[y * (w + 1) + x + 1] + row;
        }
    }
    let r = ADAPTIVE_RADIUS;
    let smoothed: Vec<f64> = (0..h as i64)
        .flat_map(|y| (0..w as i64).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (ax, bx) = ((x - r).max(0) as usize, (x + r + 1).min(w as i64) as usize);
            let (ay, by) = ((y - r).max(0) as usize, (y + r + 1).min(h as i64) as usize);
            let at = |x: usize, y: usize| table[y * (w + 1) + x];
            let sum = at(bx, by) - at(ax, by) - at(bx, ay) + at(ax, ay);
            let count = ((bx - ax) * (by - ay)) as f64 - 1.0;
            let own = errors[y as usize * w + x as usize];
            if count > 0.0 {
                ((sum - own) / count).max(0.0).powf(ADAPTIVE_POWER)
            } else {
                0.0
            }
        })
        .collect();
    let floor = (spp / 4).max(pilot).max(1).min(spp.max(1));
    let cap = spp.saturating_mul(16).max(floor);
    let spare = (spp - floor.min(spp)) as f64 * smoothed.len() as f64;
    let total: f64 = smoothed.iter().sum();
    smoothed
        .iter()
        .map(|&e| {
            let share = if total > 0.0 {
                spare * e / total
            } else {
                (spp - floor.min(spp)) as f64
            };
            (floor + share.round() as u32).min(cap)
        })
        .collect()
}

/// Samples per pixel of pass `k`: 1, 1, 2, 4, 8, … up to `cap`. The first
/// passes are quick, so a render stopped early soon has a complete image.
/// Samples per pixel in a render's largest pass (passes double up to it).
fn largest_pass(scene: &Scene, options: &RenderOptions) -> u32 {
    if scene.integrator.prepares() || options.time_budget.is_some() {
        // Photons are prepared per sample index; a time budget stops soonest
        // after a pass of one sample.
        1
    } else {
        (options.samples.len() as u32).div_ceil(16).clamp(1, 16)
    }
}

fn pass_size(k: u32, cap: u32) -> u32 {
    let doubling = if k == 0 { 1 } else { 1u32 << (k - 1).min(16) };
    doubling.clamp(1, cap)
}

/// A progress line every `every` until `finished`: for logs, where no bar
/// can be drawn.
fn log_progress(
    done: &AtomicU64,
    total: &AtomicU64,
    start: Instant,
    every: Duration,
    finished: &AtomicBool,
) {
    let mut next = every;
    while !finished.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(50).min(every));
        let elapsed = start.elapsed();
        if elapsed < next {
            continue;
        }
        next += every;
        let d = done.load(Ordering::Relaxed);
        let total = total.load(Ordering::Relaxed);
        let rate = d as f64 / elapsed.as_secs_f64();
        let eta = if d > 0 {
            format!("{:.0} s", (total - d.min(total)) as f64 / rate)
        } else {
            "unknown".into()
        };
        eprintln!(
            "progress: {:.1}% ({d} of {total} samples), {:.2} M samples/s, {:.0} s elapsed, ETA {eta}",
            100.0 * d as f64 / total.max(1) as f64,
            rate / 1e6,
            elapsed.as_secs_f64(),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_start_small_and_grow_to_the_cap() {
        let sizes: Vec<u32> = (0..8).map(|k| pass_size(k, 16)).collect();
        assert_eq!(sizes, [1, 1, 2, 4, 8, 16, 16, 16]);
        assert_eq!((0..4).map(|k| pass_size(k, 1)).collect::<Vec<_>>(), [1; 4]);
        assert_eq!(pass_size(40, 4), 4);
    }

    #[test]
    fn pilots_leave_samples_to_spend() {
        let pilots: Vec<u32> = [1, 2, 4, 7, 8, 16, 64, 256, 1024, 4096]
            .map(pilot_spp)
            .to_vec();
        assert_eq!(pilots, [1, 2, 2, 2, 4, 4, 4, 16, 64, 64]);
    }

    #[test]
    fn splat_batches_bound_their_spectral_sums() {
        use crate::film::tile_spectrum_bytes;
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

    #[test]
    fn adaptive_passes_advance_every_pixel_by_its_share() {
        let (pilot, spp) = (4, 64);
        let targets = [16, 64, 100, 142, 1024];
        for &t in &targets {
            // The pilot as it is; the whole count at the end; never back.
            for k in 0..=pilot {
                assert_eq!(adaptive_progress(k, t, pilot, spp), k);
            }
            assert_eq!(adaptive_progress(spp, t, pilot, spp), t);
            let steps: Vec<u32> = (0..=spp)
                .map(|k| adaptive_progress(k, t, pilot, spp))
                .collect();
            assert!(steps.windows(2).all(|w| w[0] <= w[1]), "{steps:?}");
        }
        // Halfway through the rest, each pixel is halfway through its own rest.
        let half = pilot + (spp - pilot) / 2;
        assert_eq!(adaptive_progress(half, 142, pilot, spp), 4 + 69);
        assert_eq!(adaptive_progress(half, 16, pilot, spp), 4 + 6);
        // A pass's samples spread over the pixels in proportion to their
        // counts: counts averaging 64 take the pass's 16 samples a pixel on
        // average (within rounding), not 16 each until some are full.
        let counts = [16u32, 40, 64, 88, 112];
        let taken: u32 = counts
            .iter()
            .map(|&t| adaptive_progress(36, t, pilot, spp) - adaptive_progress(20, t, pilot, spp))
            .sum();
        assert!((taken as i32 - 16 * 5).abs() <= 5, "{taken}");
        // Budgets no bigger than the pilot: every pixel takes them all.
        assert_eq!(adaptive_progress(3, 4, 4, 4), 3);
    }

    /// A film whose pixels have `n` samples of luminance `value(x, y)`
    /// half the time and 0 otherwise (variance from the spread).
    fn pilot_film(w: u32, h: u32, n: u64, value: impl Fn(u32, u32) -> f64) -> Film {
        Film::from_pixel_sums(w, h, |x, y| {
            let v = value(x, y);
            crate::film::PixelSums {
                xyz: glam::DVec3::splat(v * n as f64 / 2.0),
                y_squared: v * v * n as f64 / 2.0,
                samples: n,
            }
        })
    }

    #[test]
    fn adaptive_counts_follow_the_neighbours_error_never_the_pixels_own() {
        // The left half is noisy, the right half has no spread.
        let (w, h, spp, pilot) = (32, 16, 64, 4);
        let base = pilot_film(w, h, pilot as u64, |x, _| if x < w / 2 { 1.0 } else { 0.0 });
        let t = adaptive_targets(&base, [0, 0, w, h], spp, pilot);
        let mean = t.iter().map(|&n| n as f64).sum::<f64>() / t.len() as f64;
        assert!((mean - spp as f64).abs() < 1.0, "mean {mean}");
        assert!(t.iter().all(|&n| (spp / 4..=16 * spp).contains(&n)));
        // Far from the edge: noisy pixels take the floor and nearly twice
        // the spare samples (half the pixels share most of them), quiet
        // ones the floor.
        assert!(
            t[8 * w as usize + 2] >= 16 + 3 * 48 / 2,
            "{}",
            t[8 * w as usize + 2]
        );
        assert_eq!(t[8 * w as usize + 29], spp / 4);
        // Making one pixel's own samples wildly noisier changes no count
        // of its own, only its neighbours'.
        let (px, py) = (24u32, 8u32);
        let changed = pilot_film(w, h, pilot as u64, |x, y| {
            if (x, y) == (px, py) {
                50.0
            } else if x < w / 2 {
                1.0
            } else {
                0.0
            }
        });
        let u = adaptive_targets(&changed, [0, 0, w, h], spp, pilot);
        let i = (py * w + px) as usize;
        assert_eq!(u[i], t[i]);
        assert!(
            u[i + 1] > t[i + 1],
            "a neighbour: {} vs {}",
            u[i + 1],
            t[i + 1]
        );
    }
}
