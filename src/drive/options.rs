//! What a render is asked to do ([`RenderOptions`]), how it ended
//! ([`RenderStats`], [`Stop`]) and why it could not start ([`RenderError`]).

use std::ops::Range;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use super::progress::ProgressCounts;
use crate::film::{Film, FilmSettings};

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
    /// Where the render counts its samples as it goes, for a caller that
    /// shows progress its own way.
    pub progress_counts: Option<Arc<ProgressCounts>>,
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
    /// pilot render finds the relative error high ([`super::adaptive::targets`]).
    pub adaptive: bool,
    /// Whether the path tracer advances a tile's samples as a stream of
    /// paths ([`super::stream`]); the image is the same either way.
    pub streams: Streams,
    /// Whether the path tracer may advance a tile's samples as packets of
    /// paths (`integrator::path_packet`), where the scene needs only what
    /// the packet core models.
    pub packets: Packets,
}

/// When camera samples advance as a stream of paths, their rays traced
/// together: the same image, faster only where the scene's tree outgrows
/// the caches.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Streams {
    /// Where the tree is larger than [`super::stream::STREAM_ABOVE_BYTES`].
    #[default]
    Auto,
    Always,
    Never,
}

/// Whether the path tracer's packet core renders the scenes it models (the
/// image is the same in distribution, not bit for bit).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Packets {
    #[default]
    Auto,
    Never,
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
    /// The whole film at the scene file's samples per pixel and seed,
    /// sampled uniformly (`RenderSettings::options` reads `film.sampling`).
    pub fn new(f: &FilmSettings) -> Self {
        Self {
            samples: 0..f.spp,
            seed: f.seed,
            region: [0, 0, f.width, f.height],
            threads: None,
            progress: false,
            progress_counts: None,
            cancel: None,
            time_budget: None,
            target_error: None,
            log_every: Duration::from_secs(5),
            after_pass: None,
            adaptive: false,
            streams: Streams::Auto,
            packets: Packets::Auto,
        }
    }

    /// The same, with `spp` samples per pixel.
    pub fn with_spp(film: &FilmSettings, spp: u32) -> Self {
        Self {
            samples: 0..spp,
            ..Self::new(film)
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
    #[error(
        "the {0} integrator connects light paths to the camera, which an orthographic camera's parallel rays cannot receive: use `path` or `sppm`"
    )]
    SplatOrthographic(&'static str),
    #[error(
        "the scene has fluorescent materials, which only the `path` integrator renders (the {0} integrator's light paths would change wavelength in the other direction): use `path`"
    )]
    Fluorescence(&'static str),
    #[error("adaptive sampling spreads a whole render's samples: it takes no --samples range")]
    AdaptiveRange,
    #[error("the film is {film:?} pixels and the scene's camera was made for {camera:?}: load the scene at the film's resolution")]
    Resolution {
        film: (u32, u32),
        camera: (u32, u32),
    },
}
