//! The `prism` command line.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};

use prism::film::output;
use prism::render::{render, RenderOptions};
use prism::scene::{self, Strategy, Tonemap};

/// prism: a spectral, physically based path tracer.
#[derive(Parser)]
#[command(version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a TOML scene to OpenEXR (linear sRGB) and PNG (sRGB, tone mapped).
    ///
    /// Example: prism render scenes/cornell-box.toml --spp 256
    Render {
        /// The scene file (TOML).
        scene: PathBuf,
        /// Output path without extension (or with .exr/.png); NAME.exr and
        /// NAME.png are written. Default: next to the scene, named like it.
        #[arg(short, long, value_name = "PATH")]
        output: Option<PathBuf>,
        /// Samples per pixel (overrides the scene's film.spp).
        #[arg(long, value_name = "N")]
        spp: Option<u32>,
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
        /// Direct-lighting strategy (overrides integrator.strategy).
        #[arg(long, value_enum)]
        strategy: Option<StrategyArg>,
        /// Hide the progress bar.
        #[arg(short, long)]
        quiet: bool,
    },
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum TonemapArg {
    Clamp,
    Reinhard,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum StrategyArg {
    Mis,
    Nee,
    Bsdf,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(1)
        }
    }
}

/// Where NAME.exr and NAME.png go: `-o` (extension dropped) or next to the scene.
fn output_stem(scene: &Path, output: Option<PathBuf>) -> PathBuf {
    match output {
        Some(o) => match o.extension().and_then(|e| e.to_str()) {
            Some("exr" | "png") => o.with_extension(""),
            _ => o,
        },
        None => scene.with_extension(""),
    }
}

/// Fails early, before any rendering, if the output folder cannot take files.
fn check_writable(stem: &Path) -> Result<()> {
    let dir = match stem.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        bail!("output folder {} does not exist", dir.display());
    }
    let probe = dir.join(format!(".prism-write-test-{}", std::process::id()));
    std::fs::write(&probe, b"")
        .with_context(|| format!("cannot write to output folder {}", dir.display()))?;
    let _ = std::fs::remove_file(probe);
    Ok(())
}

fn run(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Render {
            scene: scene_path,
            output,
            spp,
            threads,
            seed,
            exposure,
            tonemap,
            strategy,
            quiet,
        } => {
            let load_start = std::time::Instant::now();
            let mut scene = scene::load(&scene_path)?;
            if let Some(s) = strategy {
                scene.settings.strategy = match s {
                    StrategyArg::Mis => Strategy::Mis,
                    StrategyArg::Nee => Strategy::Nee,
                    StrategyArg::Bsdf => Strategy::Bsdf,
                };
            }
            if spp == Some(0) {
                bail!("--spp must be at least 1");
            }
            if threads == Some(0) {
                bail!("--threads must be at least 1");
            }
            let stem = output_stem(&scene_path, output);
            check_writable(&stem)?;
            eprintln!(
                "loaded {} in {:.2} s: {} triangles, {} lights, {}x{}",
                scene_path.display(),
                load_start.elapsed().as_secs_f64(),
                scene.triangle_count(),
                scene.lights.lights.len(),
                scene.settings.width,
                scene.settings.height
            );

            let cancel = Arc::new(AtomicBool::new(false));
            {
                let cancel = cancel.clone();
                ctrlc::set_handler(move || {
                    if cancel.swap(true, Ordering::SeqCst) {
                        eprintln!("\ninterrupted again: exiting without writing");
                        std::process::exit(130);
                    }
                    eprintln!("\ninterrupted: finishing the samples under way, then writing (Ctrl-C again to abort)");
                })
                .context("cannot install the Ctrl-C handler")?;
            }
            let options = RenderOptions {
                spp,
                seed,
                threads,
                progress: !quiet,
                cancel: Some(cancel),
            };
            let (film, stats) = render(&scene, &options);
            let secs = stats.elapsed.as_secs_f64();
            eprintln!(
                "rendered {} samples in {:.2} s: {:.2} M samples/s, {:.2} M rays/s{}",
                stats.samples,
                secs,
                stats.samples as f64 / secs / 1e6,
                stats.rays as f64 / secs / 1e6,
                if stats.non_finite > 0 {
                    format!(", {} non-finite samples dropped", stats.non_finite)
                } else {
                    String::new()
                }
            );
            if stats.interrupted {
                eprintln!(
                    "interrupted: every pixel has at least {} samples",
                    film.min_samples()
                );
            }
            let exposure = exposure.unwrap_or(scene.settings.exposure);
            let tonemap = match tonemap {
                Some(TonemapArg::Clamp) => Tonemap::Clamp,
                Some(TonemapArg::Reinhard) => Tonemap::Reinhard,
                None => scene.settings.tonemap,
            };
            let exr = stem.with_extension("exr");
            let png = stem.with_extension("png");
            output::write_exr(&film, &exr)?;
            output::write_png(&film, &png, exposure, tonemap)?;
            eprintln!("wrote {} and {}", exr.display(), png.display());
            Ok(if stats.interrupted {
                ExitCode::from(130)
            } else {
                ExitCode::SUCCESS
            })
        }
    }
}
