//! The `prism` command line.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::{Parser, Subcommand};

use prism::film::{Gamut, Sampling, Tonemap};
use prism::integrator::{IntegratorKind, Strategy};
use prism::job::{
    describe, describe_spectrum, merge_files, render_files, Interrupts, MergeJob, Reaction,
    RenderJob, SpectrumQuery,
};
use prism::load::Overrides;
use prism::render::{Packets, Streams};

/// prism: a spectral, physically based path tracer.
#[derive(Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// The memory budget (such as 4G or 512M): what the inputs decode into
    /// and what a render will hold (film, tiles, output buffers) is checked
    /// against it before it is allocated, and refused with a message when
    /// it would not fit. Default: the memory available when prism starts.
    #[arg(long, global = true, value_name = "SIZE", value_parser = prism::memory::parse_size)]
    max_memory: Option<u64>,
}

/// `prism render --help` ends with these (docs/command-line.md has them all).
const RENDER_EXAMPLES: &str = "Examples:
  prism render scenes/cornell-box.toml                        64 spp at 512x512, next to the scene
  prism render scenes/cornell-box.toml --spp 16 -o out/cbox   a quick look, into out/
  prism render scenes/cornell-box.toml --time 30s             stop after 30 s (at most 64 spp)
  prism render scenes/gem.toml --integrator sppm              a diamond's caustics, by photon mapping
  prism render scenes/cornell-box.toml --samples 0..64 -o out/part-a
                                                              one part of a render, for `prism merge`
  prism render scenes/sunset.toml --display 127.0.0.1:14158   watch it in tev while it renders

Scene files: docs/scene-format.md. Exit status: 0 done, 1 bad input or a failed
write (the message names the file, line and key), 2 a bad command line, 130
interrupted (the image so far is written).";

#[derive(Subcommand)]
enum Command {
    /// Render a TOML scene to OpenEXR (linear sRGB), PNG (sRGB, tone mapped)
    /// and spectral OpenEXR (Fichet 2021 layout, NAME.spectral.exr).
    ///
    /// Example: prism render scenes/cornell-box.toml --spp 256
    #[command(after_long_help = RENDER_EXAMPLES)]
    Render {
        /// The scene file (TOML).
        scene: PathBuf,
        /// Output path without extension (or with .exr/.png); NAME.exr,
        /// NAME.png and NAME.spectral.exr are written. Default: next to the
        /// scene, named like it.
        #[arg(short, long, value_name = "PATH")]
        output: Option<PathBuf>,
        /// Image size as WIDTHxHEIGHT (overrides film.resolution).
        #[arg(long, value_name = "WxH", value_parser = parse_resolution)]
        resolution: Option<(u32, u32)>,
        /// Samples per pixel (overrides the scene's film.spp).
        #[arg(long, value_name = "N", conflicts_with = "samples")]
        spp: Option<u32>,
        /// Render exactly the sample indices START..END (END exclusive) of
        /// every pixel, for merging later with `prism merge`.
        #[arg(long, value_name = "START..END", value_parser = parse_samples)]
        samples: Option<std::ops::Range<u32>>,
        /// Render only the pixels X0..X1 × Y0..Y1 (X1, Y1 exclusive); the
        /// rest of the image gets no samples. For merging with `prism merge`.
        #[arg(long, value_name = "X0,Y0,X1,Y1", value_parser = parse_tile)]
        tile: Option<[u32; 4]>,
        /// Worker threads (default: all cores).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        /// Random seed (overrides film.seed); the same seed gives the same image.
        #[arg(long, value_name = "S")]
        seed: Option<u64>,
        /// Exposure of the PNG in stops (overrides film.exposure).
        #[arg(long, value_name = "STOPS", allow_hyphen_values = true)]
        exposure: Option<f32>,
        /// Tone map of the PNG (overrides film.tonemap).
        #[arg(long, value_enum)]
        tonemap: Option<TonemapArg>,
        /// Out-of-gamut colours of the PNG: clip each channel, or map them
        /// in by chroma reduction in OKLCh (overrides film.gamut).
        #[arg(long, value_enum)]
        gamut: Option<GamutArg>,
        /// Integrator (overrides integrator.type): path tracing from the
        /// camera, light tracing (paths from the lights, for caustics seen
        /// directly), or bidirectional path tracing (both, joined by MIS).
        #[arg(long, value_enum)]
        integrator: Option<IntegratorKind>,
        /// Direct-lighting strategy of the path tracer (overrides integrator.strategy).
        #[arg(long, value_enum)]
        strategy: Option<StrategyArg>,
        /// Continuations per camera sample from its first surface that is
        /// not a Dirac one, for the path tracers (overrides integrator.split).
        #[arg(long, value_name = "N")]
        split: Option<u32>,
        /// Wavelength range of the spectral buckets in nm, as MIN,MAX
        /// (overrides film.spectral_range).
        #[arg(long, value_name = "MIN,MAX", value_parser = parse_range)]
        spectral_range: Option<[f32; 2]>,
        /// Number of spectral buckets (overrides film.spectral_buckets).
        #[arg(long, value_name = "N")]
        spectral_buckets: Option<u32>,
        /// Do not write the spectral OpenEXR (NAME.spectral.exr).
        #[arg(long)]
        no_spectral: bool,
        /// Stop when this much time is spent (90s, 5m, 1.5h; plain numbers
        /// are seconds) and write what exists: the pass under way finishes,
        /// so every pixel has the same samples (at most --spp).
        #[arg(long, value_name = "DURATION", value_parser = parse_duration)]
        time: Option<std::time::Duration>,
        /// Stop when the relative MSE estimated from the pixels' variances
        /// falls below this (e.g. 0.01), at most --spp samples.
        #[arg(long, value_name = "RELMSE")]
        target_error: Option<f64>,
        /// Time between progress lines when stderr is not a terminal (30s,
        /// 1m; plain numbers are seconds; at least 0.1 s).
        #[arg(long, value_name = "DURATION", value_parser = parse_duration, default_value = "5")]
        log_every: std::time::Duration,
        /// Rewrite NAME.preview.png (atomically) this often while rendering,
        /// after the pass under way (10s, 1m; plain numbers are seconds); it
        /// goes when the render's files are written.
        #[arg(long, value_name = "DURATION", value_parser = parse_duration)]
        preview_every: Option<std::time::Duration>,
        /// Stream the image to the tev HDR viewer at HOST:PORT (tev listens
        /// on 127.0.0.1:14158 by default) after every pass.
        #[arg(long, value_name = "HOST:PORT")]
        display: Option<String>,
        /// Spend the samples (--spp on average per pixel) where a pilot
        /// (the first sixteenth, part of the image) finds the relative error
        /// high; unbiased, as a pixel's count depends on its neighbours'
        /// pilot samples, never its own. Overrides film.sampling; where the
        /// scene asks for it, a part of a
        /// render (--samples, --tile) or an error target, which say so.
        #[arg(long, conflicts_with_all = ["samples", "uniform"])]
        adaptive: bool,
        /// Take the same samples in every pixel (overrides film.sampling).
        #[arg(long)]
        uniform: bool,
        /// Advance the path tracer's samples as a stream of paths, their
        /// rays traced together: `auto` where the scene's tree is larger
        /// than 16 MiB (a tree that fits the caches gains nothing). The
        /// image is the same, bit for bit.
        #[arg(long, value_enum, default_value = "auto")]
        stream: Streams,
        /// Advance the path tracer's samples as packets of paths, shaded
        /// together: `auto` where the scene needs only what the packet core
        /// models (diffuse surfaces, no media). `never` renders one path at
        /// a time. The image is the same in distribution, not bit for bit.
        #[arg(long, value_enum, default_value = "auto")]
        packets: Packets,
        /// Hide the progress bar.
        #[arg(short, long)]
        quiet: bool,
    },
    /// Merge partial renders (spectral EXRs from `render --samples/--tile`)
    /// into one image: OUT.spectral.exr, OUT.exr and OUT.png.
    ///
    /// Parts must come from the same scene, seed, resolution and spectral
    /// layout, and no two may hold the same sample of the same pixel.
    Merge {
        /// The partial renders (NAME.spectral.exr files).
        #[arg(required = true)]
        parts: Vec<PathBuf>,
        /// Output path without extension.
        #[arg(short, long, value_name = "PATH")]
        output: PathBuf,
        /// Exposure of the PNG in stops.
        #[arg(
            long,
            value_name = "STOPS",
            allow_hyphen_values = true,
            default_value_t = 0.0
        )]
        exposure: f32,
    },
    /// Speed against error: render a ladder of sample counts, time each
    /// (scene loading excluded) and measure its relative MSE against a
    /// high-sample reference (rendered once, cached). Writes DIR/prism.csv
    /// and each rung's EXR; tools/bench.py adds FLIP, Mitsuba 3 and a plot.
    ///
    /// Example: prism bench scenes/cornell-box.toml --threads 2
    Bench {
        /// The scene file (TOML).
        scene: PathBuf,
        /// Sample counts to render, comma-separated.
        #[arg(long, value_name = "N,N,…", value_delimiter = ',', default_values_t = [1u32, 2, 4, 8, 16, 32, 64, 128])]
        spp: Vec<u32>,
        /// Samples per pixel of the reference render.
        #[arg(long, value_name = "N", default_value_t = 4096)]
        reference_spp: u32,
        /// A reference RGB EXR to use instead of rendering one.
        #[arg(long, value_name = "EXR")]
        reference: Option<PathBuf>,
        /// Image size as WIDTHxHEIGHT (overrides film.resolution).
        #[arg(long, value_name = "WxH", value_parser = parse_resolution)]
        resolution: Option<(u32, u32)>,
        /// Worker threads (default: all cores).
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
        /// Where the CSV, the rungs' images and the cached reference go.
        #[arg(short, long, value_name = "DIR", default_value = "bench")]
        out: PathBuf,
        /// Integrators, comma-separated (override integrator.type): each
        /// runs the ladder on the one loaded scene (the first renders the
        /// reference), its CSV OUT/prism-NAME.csv.
        #[arg(long, value_enum, value_delimiter = ',')]
        integrator: Vec<IntegratorKind>,
        /// Continuations per camera sample from its first surface that is
        /// not a Dirac one, for the path tracers (overrides integrator.split;
        /// the reference is rendered with it too).
        #[arg(long, value_name = "N")]
        split: Option<u32>,
        /// Adaptive sampling in every rung (not the reference): each
        /// rung's samples per pixel on average, spread where a pilot of its
        /// first samples finds the relative error high. Rungs sample as
        /// `prism render` does by default (film.sampling).
        #[arg(long, conflicts_with = "uniform")]
        adaptive: bool,
        /// The same samples in every pixel of every rung.
        #[arg(long)]
        uniform: bool,
    },
    /// Describe an OpenEXR file: size, channels, spectral layout, statistics.
    Info {
        /// The file (a spectral EXR of prism's or anyone's, or a plain RGB EXR).
        file: PathBuf,
    },
    /// The colorimetry of a spectrum, without a scene: XYZ, xy, u'v', CCT
    /// and Duv, luminance; or, with --under, a reflectance's XYZ and CIELAB.
    #[command(after_long_help = SPECTRUM_EXAMPLES)]
    Spectrum {
        /// A built-in illuminant ("D65", "LED-B3"), a spectrum file, or a
        /// scene file's form ('{ daylight = 5500 }', '{ blackbody = 2856 }').
        spectrum: String,
        /// The value column of a multi-column file: a header name or a
        /// position from 1.
        #[arg(long, value_name = "NAME_OR_N")]
        column: Option<String>,
        /// Treat the spectrum as a reflectance seen under this illuminant
        /// (the same forms).
        #[arg(long, value_name = "ILLUMINANT")]
        under: Option<String>,
        /// The observer of XYZ, xy and u'v' (CCT and Duv always use CIE 1931).
        #[arg(long, default_value = "cie1931-2", value_name = "OBSERVER")]
        observer: String,
    },
}

const SPECTRUM_EXAMPLES: &str = "Examples:
  prism spectrum D65
  prism spectrum '{ daylight = 5500 }'
  prism spectrum lamps.csv --column 3
  prism spectrum spectra/colorchecker/13_blue.csv --under D50 --observer cie1964-10";

/// `--adaptive` or `--uniform` (clap refuses both); None: the default.
fn sampling_flag(adaptive: bool, uniform: bool) -> Option<Sampling> {
    match (adaptive, uniform) {
        (true, _) => Some(Sampling::Adaptive),
        (_, true) => Some(Sampling::Uniform),
        _ => None,
    }
}

fn parse_samples(s: &str) -> Result<std::ops::Range<u32>, String> {
    prism::merge::parse_sample_range(s)
        .ok_or_else(|| format!("expected START..END with START < END, found `{s}`"))
}

fn parse_tile(s: &str) -> Result<[u32; 4], String> {
    prism::merge::parse_region(s)
        .ok_or_else(|| format!("expected X0,Y0,X1,Y1 with X0 < X1 and Y0 < Y1, found `{s}`"))
}

fn parse_resolution(s: &str) -> Result<(u32, u32), String> {
    let parsed = s
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)));
    match parsed {
        Some((w, h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => Err(format!(
            "expected WIDTHxHEIGHT with positive numbers, found `{s}`"
        )),
    }
}

fn parse_range(s: &str) -> Result<[f32; 2], String> {
    let parts: Vec<&str> = s.split(',').collect();
    match parts[..] {
        [a, b] => match (a.trim().parse::<f32>(), b.trim().parse::<f32>()) {
            (Ok(a), Ok(b)) => Ok([a, b]),
            _ => Err(format!("expected two numbers MIN,MAX, found `{s}`")),
        },
        _ => Err(format!("expected MIN,MAX, found `{s}`")),
    }
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum TonemapArg {
    Clamp,
    Reinhard,
    Filmic,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum GamutArg {
    Clip,
    Map,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum StrategyArg {
    Mis,
    Nee,
    Bsdf,
}

impl From<TonemapArg> for Tonemap {
    fn from(t: TonemapArg) -> Self {
        match t {
            TonemapArg::Clamp => Tonemap::Clamp,
            TonemapArg::Reinhard => Tonemap::Reinhard,
            TonemapArg::Filmic => Tonemap::Filmic,
        }
    }
}

impl From<GamutArg> for Gamut {
    fn from(g: GamutArg) -> Self {
        match g {
            GamutArg::Clip => Gamut::Clip,
            GamutArg::Map => Gamut::Map,
        }
    }
}

impl From<StrategyArg> for Strategy {
    fn from(s: StrategyArg) -> Self {
        match s {
            StrategyArg::Mis => Strategy::Mis,
            StrategyArg::Nee => Strategy::Nee,
            StrategyArg::Bsdf => Strategy::Bsdf,
        }
    }
}

/// Interrupts that Ctrl-C (and SIGTERM) set: the first stops after the
/// pass under way, a second exits without writing, any while writing waits.
fn interrupts_on_ctrl_c() -> Result<std::sync::Arc<Interrupts>> {
    let interrupts = Interrupts::new();
    let handler = interrupts.clone();
    ctrlc::set_handler(move || match handler.on_signal() {
        Reaction::Stop => eprintln!(
            "\ninterrupted: finishing the samples under way, then writing (Ctrl-C again to abort)"
        ),
        Reaction::Exit => {
            eprintln!("\ninterrupted again: exiting without writing");
            std::process::exit(130);
        }
        Reaction::Wait => eprintln!(
            "\ninterrupted while writing: the files are finished first, so that they replace the old ones together"
        ),
    })
    .context("cannot install the Ctrl-C handler")?;
    Ok(interrupts)
}

/// The longest duration accepted: a year. Deadlines are instants plus a
/// duration, and the clock's instants overflow far below `Duration::MAX`.
const MAX_DURATION_SECONDS: f64 = 366.0 * 86_400.0;

/// "90s", "5m", "1.5h" or plain seconds, up to a year.
fn parse_duration(s: &str) -> Result<std::time::Duration, String> {
    let s = s.trim();
    let (number, unit) = match s.find(|c: char| c.is_ascii_alphabetic()) {
        Some(i) => s.split_at(i),
        None => (s, "s"),
    };
    let seconds = match unit {
        "s" => 1.0,
        "m" | "min" => 60.0,
        "h" => 3600.0,
        _ => return Err(format!("unknown unit {unit:?}: use s, m or h")),
    };
    let v: f64 = number
        .trim()
        .parse()
        .map_err(|_| format!("{s:?} is not a duration such as 90s, 5m or 1.5h"))?;
    if !(v > 0.0 && v.is_finite()) {
        return Err("the duration must be positive".into());
    }
    if v * seconds > MAX_DURATION_SECONDS {
        return Err(format!(
            "{s:?} is longer than a year, the longest duration prism takes"
        ));
    }
    Ok(std::time::Duration::from_secs_f64(v * seconds))
}

/// `PRISM_BASELINE=1` runs the baseline x86-64 build embedded in this one,
/// as a CPU without AVX2 does: to compare the two on one machine.
fn run_baseline_if_asked() -> Result<(), String> {
    use std::env::VarError;
    match std::env::var("PRISM_BASELINE").as_deref() {
        Err(VarError::NotPresent) | Ok("0") => Ok(()),
        Err(VarError::NotUnicode(v)) => Err(format!("PRISM_BASELINE={v:?} is neither 0 nor 1")),
        Ok("1") if prism::cpu::IS_BASELINE_BUILD => Ok(()),
        Ok("1") if prism::cpu::BASELINE_EMBEDDED => Err(format!(
            "PRISM_BASELINE=1: the baseline build did not start: {}",
            prism::cpu::exec_baseline()
        )),
        Ok("1") => Err(
            "PRISM_BASELINE=1: this build of prism carries no baseline build \
             (only release builds for x86-64 Linux with glibc do)"
                .into(),
        ),
        Ok(other) => Err(format!("PRISM_BASELINE={other:?} is neither 0 nor 1")),
    }
}

/// `PRISM_AVX512=0` keeps the ray packets to AVX2's eight lanes on a CPU
/// with AVX-512: to compare the two on one machine.
fn limit_packets_if_asked() -> Result<(), String> {
    match std::env::var_os("PRISM_AVX512") {
        Some(v) if v == "0" => prism::geometry::bvh::keep_packets_to_avx2(),
        Some(v) if v != "1" => return Err(format!("PRISM_AVX512={v:?} is neither 0 nor 1")),
        _ => {}
    }
    Ok(())
}

fn main() -> ExitCode {
    // First, before code that may use instructions this CPU lacks.
    prism::cpu::refuse_if_missing();
    if let Err(e) = run_baseline_if_asked().and_then(|()| limit_packets_if_asked()) {
        eprintln!("error: {e}");
        return ExitCode::from(1);
    }
    prism::memory::share_allocator_arenas();
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(1)
        }
    }
}

fn run(cli: Cli) -> Result<ExitCode> {
    if let Some(bytes) = cli.max_memory {
        prism::memory::set_limit(bytes);
    }
    match cli.command {
        Command::Render {
            scene,
            output,
            resolution,
            spp,
            samples,
            tile,
            threads,
            seed,
            exposure,
            tonemap,
            gamut,
            integrator,
            strategy,
            split,
            spectral_range,
            spectral_buckets,
            no_spectral,
            quiet,
            time,
            target_error,
            log_every,
            preview_every,
            display,
            adaptive,
            uniform,
            stream,
            packets,
        } => {
            let overrides = Overrides {
                resolution,
                spectral_range,
                spectral_buckets,
                no_spectral,
                exposure,
                tonemap: tonemap.map(Into::into),
                gamut: gamut.map(Into::into),
                integrator,
                strategy: strategy.map(Into::into),
                split,
            };
            let job = RenderJob {
                scene,
                output,
                overrides,
                spp,
                samples,
                tile,
                threads,
                seed,
                progress: !quiet,
                interrupts: interrupts_on_ctrl_c()?,
                time_budget: time,
                target_error,
                log_every: log_every.max(std::time::Duration::from_millis(100)),
                preview_every,
                display,
                sampling: sampling_flag(adaptive, uniform),
                streams: stream,
                packets,
            };
            // 130: interrupted (Ctrl-C), as a shell reports it.
            let interrupted = render_files(&job)?.interrupted;
            Ok(ExitCode::from(if interrupted { 130 } else { 0 }))
        }
        Command::Merge {
            parts,
            output,
            exposure,
        } => {
            merge_files(&MergeJob {
                parts,
                output,
                exposure,
            })?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Bench {
            scene,
            spp,
            reference_spp,
            reference,
            resolution,
            threads,
            out,
            integrator,
            split,
            adaptive,
            uniform,
        } => {
            let opts = prism::bench::BenchOptions {
                ladder: spp,
                reference_spp,
                reference,
                threads,
                out_dir: out,
                integrators: integrator,
                split,
                sampling: sampling_flag(adaptive, uniform),
            };
            prism::bench::run(&scene, resolution, &opts)?;
            Ok(ExitCode::SUCCESS)
        }
        Command::Info { file } => {
            print!("{}", describe(&file)?);
            Ok(ExitCode::SUCCESS)
        }
        Command::Spectrum {
            spectrum,
            column,
            under,
            observer,
        } => spectrum_command(&spectrum, column.as_deref(), under.as_deref(), &observer),
    }
}

/// `prism spectrum`.
fn spectrum_command(
    spectrum: &str,
    column: Option<&str>,
    under: Option<&str>,
    observer: &str,
) -> Result<ExitCode> {
    let observer = prism::spectrum::cie::Observer::from_name(observer).ok_or_else(|| {
        anyhow::anyhow!(
            "--observer {observer}: one of cie1931-2, cie1964-10, cie2015-2, cie2015-10"
        )
    })?;
    let query = SpectrumQuery {
        spectrum,
        column,
        under,
        observer,
    };
    print!("{}", describe_spectrum(&query)?);
    Ok(ExitCode::SUCCESS)
}
