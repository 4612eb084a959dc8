//! `prism render`: load a scene (with the command line's overrides), render
//! it, write NAME.exr, NAME.png and NAME.spectral.exr.

use super::Interrupts;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use anyhow::{bail, Result};

use super::tev::Tev;
use super::{check_writable, output_stem, suffixed};
use crate::film::display::{
    matrix_text, rgb_to_display, ATTR_DISPLAY, ATTR_GAMUT, ATTR_PNG_BITS, ATTR_RGB_TO_DISPLAY,
};
use crate::film::{output, spectral_exr};
use crate::film::{ColourTransform, Film, FilmSettings, Sampling};
use crate::integrator::ior_stack::CAPACITY;
use crate::integrator::Integrator;
use crate::load::{self, Loaded, Overrides};
use crate::memory::for_people;
use crate::merge::{ATTR_ADAPTIVE, ATTR_REGION, ATTR_SAMPLES, ATTR_SCENE_HASH, ATTR_SEED};
use crate::render::{
    memory_estimate, render, Packets, PassHook, RenderOptions, RenderSettings, RenderStats, Stop,
    Streams,
};

pub struct RenderJob {
    pub scene: PathBuf,
    /// Output path without extension; next to the scene when None.
    pub output: Option<PathBuf>,
    /// Values that replace the scene file's.
    pub overrides: Overrides,
    /// Samples per pixel (the scene's when None).
    pub spp: Option<u32>,
    /// Exactly these sample indices of every pixel, for `prism merge`.
    pub samples: Option<Range<u32>>,
    /// Only these pixels, X0,Y0,X1,Y1, for `prism merge`.
    pub tile: Option<[u32; 4]>,
    pub threads: Option<usize>,
    pub seed: Option<u64>,
    pub progress: bool,
    /// Set (by a signal handler) to stop early and write what exists.
    pub interrupts: Arc<Interrupts>,
    /// Stop when this much time is spent (`--time`).
    pub time_budget: Option<Duration>,
    /// Stop when the estimated relative MSE falls below this (`--target-error`).
    pub target_error: Option<f64>,
    /// Progress line interval where stderr is not a terminal.
    pub log_every: Duration,
    /// Rewrite NAME.preview.png this often while rendering
    /// (`--preview-every`).
    pub preview_every: Option<Duration>,
    /// Stream the image to tev at HOST:PORT (`--display`).
    pub display: Option<String>,
    /// `--adaptive` or `--uniform`; None: as the scene asks, where the
    /// render can (`RenderSettings::adaptive_for`).
    pub sampling: Option<Sampling>,
    /// Whether the path tracer's samples advance as a stream of paths.
    pub streams: Streams,
    /// Whether the path tracer's packet core may render the scene.
    pub packets: Packets,
}

/// How a render job ended (errors aside).
pub struct RenderOutcome {
    /// Stopped before every sample was taken; the files hold what was.
    pub interrupted: bool,
}

/// A pass hook that rewrites `png` (atomically: a reader sees the old or
/// the new picture, never half of one) when `every` has passed since the
/// last preview.
fn preview_writer(png: PathBuf, film: FilmSettings, every: Duration) -> PassHook {
    let last = Mutex::new(Instant::now());
    PassHook(Arc::new(move |result: &Film| {
        let mut last = last.lock().unwrap_or_else(|e| e.into_inner());
        if last.elapsed() < every {
            return;
        }
        if let Err(e) = output::write_png(result, &film, &png) {
            eprintln!("warning: preview not written: {e:#}");
        }
        *last = Instant::now();
    }))
}

/// A pass hook that sends the film's linear RGB to tev after every pass;
/// after a failed send (tev closed) it warns once and stops.
fn tev_streamer(tev: Tev, colour: ColourTransform) -> PassHook {
    let tev = Mutex::new(Some(tev));
    PassHook(Arc::new(move |result: &Film| {
        let mut guard = tev.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(t) = guard.as_mut() {
            if let Err(e) = t.update(&result.rgb(&colour)) {
                eprintln!("warning: the display stopped taking the image ({e}); rendering on");
                *guard = None;
            }
        }
    }))
}

/// Runs the job; progress and the report go to stderr.
pub fn render_files(job: &RenderJob) -> Result<RenderOutcome> {
    if job.spp == Some(0) {
        bail!("--spp must be at least 1");
    }
    if job.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    let partial = job.samples.is_some() || job.tile.is_some();
    if job.overrides.no_spectral && partial {
        bail!("--samples and --tile write a partial spectral EXR for `prism merge`: drop --no-spectral");
    }
    // A named output folder is checked before the scene loads (a large
    // asset can take a while), and again before rendering.
    let stem = output_stem(&job.scene, job.output.clone());
    if job.output.is_some() {
        check_writable(&stem)?;
    }
    let load_start = Instant::now();
    let loaded = load::load_with(&job.scene, &job.overrides)?;
    for w in &loaded.report.warnings {
        eprintln!("warning: {w}");
    }
    let (scene, settings) = (&loaded.scene, &loaded.settings);
    let mut options = render_options(job, settings)?;
    let estimate = memory_estimate(scene, settings, &options, loaded.report.peak_bytes);
    let parts = format!(
        "loading {}; then scene {}, film {}, passes {}, writing {}",
        for_people(estimate.loading),
        for_people(estimate.scene),
        for_people(estimate.film),
        for_people(estimate.passes),
        for_people(estimate.writing)
    );
    crate::memory::check("the render", estimate.total())
        .map_err(|e| anyhow::anyhow!("{e} ({parts}): use fewer pixels or spectral buckets"))?;

    check_writable(&stem)?;
    report_stale_temporaries(&stem);
    options.after_pass = pass_hooks(job, &stem, &settings.film);
    eprintln!(
        "loaded {} in {:.2} s: {} triangles ({} degenerate dropped), BVH {} nodes ({}), {} lights, {}x{}, {} integrator",
        job.scene.display(),
        load_start.elapsed().as_secs_f64(),
        scene.triangle_count(),
        scene.degenerate_triangles,
        scene.bvh().node_count(),
        for_people(scene.bvh().size_bytes() as u64),
        scene.lights.len(),
        settings.film.width,
        settings.film.height,
        settings.integrator.name()
    );
    eprintln!(
        "memory: about {} at the peak ({parts})",
        for_people(estimate.total())
    );
    if let Integrator::Sppm(p) = &settings.integrator {
        eprintln!(
            "photon mapping: {} photons per iteration, radius {:.4} (scene units) in the first",
            p.photons_per_iteration(scene),
            p.initial_radius(scene)
        );
    }
    if let Integrator::PathCaustics(p) = &settings.integrator {
        eprintln!("{}", p.summary(scene));
    }

    let (result, stats) = render(scene, settings, &options)?;
    report_render(&options, &result, &stats, &settings.film);
    if !job.interrupts.begin_writing() {
        // Interrupted twice: the signal handler is ending the process.
        return Ok(RenderOutcome { interrupted: true });
    }
    write_outputs(job, &loaded, &options, &stats, &result, &stem)?;
    Ok(RenderOutcome {
        interrupted: stats.interrupted,
    })
}

/// The render's options from the job's flags and the scene file's film.
fn render_options(job: &RenderJob, settings: &RenderSettings) -> Result<RenderOptions> {
    let film = &settings.film;
    if let Some(t) = job.tile {
        if t[2] > film.width || t[3] > film.height {
            bail!(
                "--tile {},{},{},{} reaches outside the {}x{} image",
                t[0],
                t[1],
                t[2],
                t[3],
                film.width,
                film.height
            );
        }
    }
    if let Some(t) = job.target_error {
        if !(t > 0.0 && t.is_finite()) {
            bail!("--target-error must be a positive relative MSE, such as 0.01");
        }
    }
    let mut options = settings.options();
    if let Some(spp) = job.spp {
        options.samples = 0..spp;
    }
    if let Some(s) = &job.samples {
        options.samples = s.clone();
    }
    if let Some(seed) = job.seed {
        options.seed = seed;
    }
    if let Some(t) = job.tile {
        options.region = t;
    }
    options.threads = job.threads;
    options.progress = job.progress;
    options.cancel = Some(job.interrupts.stop_flag());
    options.time_budget = job.time_budget;
    options.target_error = job.target_error;
    options.log_every = job.log_every;
    let part = job.samples.is_some() || job.tile.is_some();
    let explicit = job.sampling.map(|s| s == Sampling::Adaptive);
    let (adaptive, why_uniform) = settings.adaptive_for(explicit, part, job.target_error.is_some());
    if let Some(reason) = why_uniform {
        eprintln!("{reason}");
    }
    options.adaptive = adaptive;
    options.streams = job.streams;
    options.packets = job.packets;
    Ok(options)
}

/// Removes (or names) the hidden files an earlier, killed render of this
/// name left.
fn report_stale_temporaries(stem: &Path) {
    for (path, removed) in super::stale_temporaries(stem) {
        if removed {
            eprintln!(
                "removed {}, left by an earlier render of this name that was killed",
                path.display()
            );
        } else {
            eprintln!(
                "warning: {} may be left by an earlier render that was killed",
                path.display()
            );
        }
    }
}

/// What sees the film after every pass: the preview PNG, the tev display.
fn pass_hooks(job: &RenderJob, stem: &Path, film: &FilmSettings) -> Option<PassHook> {
    let mut hooks: Vec<PassHook> = Vec::new();
    if let Some(every) = job.preview_every {
        // Its own name: a preview beside the earlier render's EXRs would
        // mix two sets if the render never finished (SIGKILL).
        hooks.push(preview_writer(
            suffixed(stem, "preview.png"),
            film.clone(),
            every,
        ));
    }
    if let Some(address) = &job.display {
        let name = stem
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "prism".into());
        match Tev::connect(address, &name, film.width, film.height) {
            Ok(tev) => hooks.push(tev_streamer(tev, film.colour)),
            Err(e) => eprintln!("warning: {e:#}; rendering without a display"),
        }
    }
    (!hooks.is_empty()).then(|| {
        PassHook(Arc::new(move |f: &Film| {
            for hook in &hooks {
                (hook.0)(f);
            }
        }))
    })
}

/// The closing lines: samples, speed, error, warnings, why it stopped.
fn report_render(options: &RenderOptions, result: &Film, stats: &RenderStats, film: &FilmSettings) {
    let secs = stats.elapsed.as_secs_f64();
    eprintln!(
        "rendered {} samples ({}) in {:.2} s ({} code): {:.2} M samples/s, \
         {:.2} M rays/s{}{}",
        stats.samples,
        if options.adaptive {
            "adaptive".to_string()
        } else {
            format!("{} per pixel", stats.spp)
        },
        secs,
        crate::cpu::COMPILED_FOR,
        stats.samples as f64 / secs / 1e6,
        stats.rays as f64 / secs / 1e6,
        match stats.estimated_rel_mse {
            Some(e) if e.is_finite() => format!(", estimated relMSE {e:.2e}"),
            // One sample a pixel has no spread to estimate from.
            Some(_) => ", estimated relMSE unknown (one sample a pixel)".to_string(),
            None => String::new(),
        },
        if stats.non_finite > 0 {
            format!(", {} non-finite samples dropped", stats.non_finite)
        } else {
            String::new()
        }
    );
    if stats.stack_overflows > 0 {
        eprintln!(
            "warning: {} times a path was inside more than {CAPACITY} nested dielectrics; the extra media were ignored",
            stats.stack_overflows,
        );
    }
    if options.adaptive {
        report_adaptive_counts(result, stats, film);
    }
    // After an adaptive pilot, every pixel advances by the same share of
    // the rest of its own count.
    let requested = options.samples.len() as u32;
    let taken = if options.adaptive && stats.spp > stats.pilot_spp && requested > stats.pilot_spp {
        format!(
            "every pixel has its first {} samples and {:.0}% of the rest of its adaptive count",
            stats.pilot_spp,
            100.0 * f64::from(stats.spp - stats.pilot_spp) / f64::from(requested - stats.pilot_spp)
        )
    } else {
        format!("every pixel has {} samples", stats.spp)
    };
    match stats.stop {
        Stop::Complete => {}
        Stop::Interrupted => eprintln!("interrupted after the pass under way: {taken}"),
        Stop::TimeBudget => eprintln!("the time budget is spent: {taken}"),
        Stop::ErrorTarget => eprintln!("the estimated relMSE is below the target: {taken}"),
    }
}

fn report_adaptive_counts(result: &Film, stats: &RenderStats, film: &FilmSettings) {
    let counts: Vec<u64> = (0..film.height)
        .flat_map(|y| (0..film.width).map(move |x| (x, y)))
        .map(|(x, y)| result.sums(x, y).samples)
        .filter(|&n| n > 0)
        .collect();
    let (lo, hi) = (
        counts.iter().min().copied().unwrap_or(0),
        counts.iter().max().copied().unwrap_or(0),
    );
    eprintln!(
        "adaptive: {lo} to {hi} samples per pixel (mean {:.1}), counts chosen after a pilot of the first {} of every pixel",
        counts.iter().sum::<u64>() as f64 / counts.len().max(1) as f64,
        stats.pilot_spp
    );
}

/// Writes NAME.exr, NAME.png and NAME.spectral.exr as one set: they
/// replace an earlier render's all at once, or not at all (never an .exr
/// of this render beside a .spectral.exr of another).
fn write_outputs(
    job: &RenderJob,
    loaded: &Loaded,
    options: &RenderOptions,
    stats: &RenderStats,
    result: &Film,
    stem: &Path,
) -> Result<()> {
    let attributes = spectral_attributes(
        &job.scene.display().to_string(),
        &loaded.report.content_hash(),
        &loaded.settings,
        options,
        stats,
    );
    let film = &loaded.settings.film;
    write_set(stem, film, result, &attributes)?;
    eprintln!(
        "wrote {} and {}",
        suffixed(stem, "exr").display(),
        suffixed(stem, "png").display()
    );
    if film.spectral_output {
        eprintln!("wrote {}", suffixed(stem, "spectral.exr").display());
    }
    Ok(())
}

/// The spectral EXR's header attributes of a render of `scene` (its name
/// as given) whose inputs hash to `content_hash`: what `prism merge` and
/// `prism.read` need to know of it.
pub fn spectral_attributes(
    scene: &str,
    content_hash: &str,
    settings: &RenderSettings,
    options: &RenderOptions,
    stats: &RenderStats,
) -> Vec<(&'static str, String)> {
    let film = &settings.film;
    let samples = &options.samples;
    let mut extra = vec![
        ("prismScene", scene.to_string()),
        // The scene file and every file it loads: a part rendered
        // after a mesh or a spectrum changed is of another scene.
        (ATTR_SCENE_HASH, content_hash.to_string()),
        (ATTR_SEED, options.seed.to_string()),
        (ATTR_SAMPLES, format!("{}..{}", samples.start, samples.end)),
        (ATTR_REGION, options.region.map(|v| v.to_string()).join(",")),
        ("prismIntegrator", settings.integrator.name().to_string()),
        (ATTR_OBSERVER, film.observer.name().to_string()),
        // How the R, G, B channels came from XYZ (colour space and white
        // balance): `prism.read` inverts it.
        (ATTR_XYZ_TO_RGB, matrix_text(film.colour.matrix())),
        (
            ATTR_WHITE_BALANCE,
            film.white_balance.clone().unwrap_or_else(|| "none".into()),
        ),
        // How `prism merge` makes the PNG from the R, G, B channels.
        (ATTR_DISPLAY, film.display.name().to_string()),
        (ATTR_RGB_TO_DISPLAY, matrix_text(rgb_to_display(film))),
        (ATTR_GAMUT, format!("{:?}", film.gamut).to_lowercase()),
        (ATTR_PNG_BITS, film.png_bits.to_string()),
    ];
    if stats.stop != Stop::Complete {
        extra.push((ATTR_INTERRUPTED, "true".into()));
    }
    if options.adaptive {
        extra.push((ATTR_ADAPTIVE, "true".into()));
    }
    extra
}

use crate::film::spectral_exr::ATTR_OBSERVER;
pub use crate::film::spectral_exr::{ATTR_WHITE_BALANCE, ATTR_XYZ_TO_RGB};
/// Present ("true") when the render stopped before every sample was taken.
pub const ATTR_INTERRUPTED: &str = "prismInterrupted";

/// Writes `result` as NAME.exr, NAME.png and (where the film asks for it)
/// NAME.spectral.exr with `attributes`, as one set.
pub fn write_set(
    stem: &Path,
    film: &FilmSettings,
    result: &Film,
    attributes: &[(&str, String)],
) -> Result<()> {
    let exr = suffixed(stem, "exr");
    let png = suffixed(stem, "png");
    output::as_one_set(|| {
        // The preview's work is done: it goes when the set is in place.
        output::retire_in_set(&suffixed(stem, "preview.png"));
        output::write_film_exr(result, film, &exr)?;
        output::write_png(result, film, &png)?;
        if film.spectral_output {
            let spectral = suffixed(stem, "spectral.exr");
            spectral_exr::write(result, &film.colour, &spectral, attributes)?;
        } else {
            // An earlier render's spectral file is not of this image.
            output::retire_in_set(&suffixed(stem, "spectral.exr"));
        }
        Ok(())
    })
}
