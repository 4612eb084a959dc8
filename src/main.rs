//! The `prism` command line.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use clap::{Parser, Subcommand};

use prism::film::{output, spectral_exr};
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
    /// Render a TOML scene to OpenEXR (linear sRGB), PNG (sRGB, tone mapped)
    /// and spectral OpenEXR (Fichet 2021 layout, NAME.spectral.exr).
    ///
    /// Example: prism render scenes/cornell-box.toml --spp 256
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
        /// Direct-lighting strategy (overrides integrator.strategy).
        #[arg(long, value_enum)]
        strategy: Option<StrategyArg>,
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
    },
    /// Describe an OpenEXR file: size, channels, spectral layout, statistics.
    Info {
        /// The file (a spectral EXR of prism's or anyone's, or a plain RGB EXR).
        file: PathBuf,
    },
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

/// A byte count for people: KiB, MiB or GiB.
fn human_bytes(bytes: usize) -> String {
    let b = bytes as f64;
    if b < (1 << 20) as f64 {
        format!("{:.1} KiB", b / 1024.0)
    } else if b < (1 << 30) as f64 {
        format!("{:.1} MiB", b / (1 << 20) as f64)
    } else {
        format!("{:.2} GiB", b / (1 << 30) as f64)
    }
}

/// `stem` + "." + `ext`, keeping any dots already in the stem (`out.part3`).
fn suffixed(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
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
            resolution,
            spp,
            samples,
            tile,
            threads,
            seed,
            exposure,
            tonemap,
            strategy,
            spectral_range,
            spectral_buckets,
            no_spectral,
            quiet,
        } => {
            let load_start = std::time::Instant::now();
            let mut scene = scene::load(&scene_path)?;
            for w in &scene.warnings {
                eprintln!("warning: {w}");
            }
            if let Some(s) = strategy {
                scene.settings.strategy = match s {
                    StrategyArg::Mis => Strategy::Mis,
                    StrategyArg::Nee => Strategy::Nee,
                    StrategyArg::Bsdf => Strategy::Bsdf,
                };
            }
            if let Some((w, h)) = resolution {
                scene.settings.width = w;
                scene.settings.height = h;
                scene.camera = scene.camera.clone().with_resolution(w, h);
            }
            if let Some(r) = spectral_range {
                scene.settings.spectral_range = r;
            }
            if let Some(n) = spectral_buckets {
                scene.settings.spectral_buckets = n;
            }
            scene::check_spectral_layout(
                scene.settings.spectral_range,
                scene.settings.spectral_buckets,
            )
            .map_err(|e| anyhow::anyhow!("`--{}", e.replace('_', "-")))?;
            scene::check_film_size(
                scene.settings.width,
                scene.settings.height,
                scene.settings.spectral_buckets,
            )
            .map_err(|e| anyhow::anyhow!(e))?;
            if no_spectral {
                if samples.is_some() || tile.is_some() {
                    bail!("--samples and --tile write a partial spectral EXR for `prism merge`: drop --no-spectral");
                }
                scene.settings.spectral_output = false;
            }
            if let Some(t) = tile {
                if t[2] > scene.settings.width || t[3] > scene.settings.height {
                    bail!(
                        "--tile {},{},{},{} reaches outside the {}x{} image",
                        t[0],
                        t[1],
                        t[2],
                        t[3],
                        scene.settings.width,
                        scene.settings.height
                    );
                }
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
                "loaded {} in {:.2} s: {} triangles ({} degenerate dropped), BVH {} nodes ({}), {} emissive triangles, {}x{}",
                scene_path.display(),
                load_start.elapsed().as_secs_f64(),
                scene.triangle_count(),
                scene.degenerate_triangles,
                scene.bvh().node_count(),
                human_bytes(scene.bvh().size_bytes()),
                scene.lights.len(),
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
            let sample_range = samples
                .clone()
                .unwrap_or(0..spp.unwrap_or(scene.settings.spp));
            let region = tile.unwrap_or([0, 0, scene.settings.width, scene.settings.height]);
            let options = RenderOptions {
                spp,
                samples,
                region: Some(region),
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
            if stats.stack_overflows > 0 {
                eprintln!(
                    "warning: {} times a path was inside more than {} nested dielectrics; the extra media were ignored",
                    stats.stack_overflows,
                    prism::integrator::ior_stack::CAPACITY
                );
            }
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
            let exr = suffixed(&stem, "exr");
            let png = suffixed(&stem, "png");
            output::write_exr(&film, &exr)?;
            output::write_png(&film, &png, exposure, tonemap)?;
            eprintln!("wrote {} and {}", exr.display(), png.display());
            if scene.settings.spectral_output {
                let spectral = suffixed(&stem, "spectral.exr");
                let seed = seed.unwrap_or(scene.settings.seed);
                let scene_bytes = std::fs::read(&scene_path).unwrap_or_default();
                let mut extra = vec![
                    ("prismScene", scene_path.display().to_string()),
                    (
                        prism::merge::ATTR_SCENE_HASH,
                        prism::merge::scene_hash(&scene_bytes),
                    ),
                    (prism::merge::ATTR_SEED, seed.to_string()),
                    (
                        prism::merge::ATTR_SAMPLES,
                        format!("{}..{}", sample_range.start, sample_range.end),
                    ),
                    (
                        prism::merge::ATTR_REGION,
                        region.map(|v| v.to_string()).join(","),
                    ),
                ];
                if stats.interrupted {
                    extra.push(("prismInterrupted", "true".into()));
                }
                spectral_exr::write(&film, &spectral, &extra)?;
                eprintln!("wrote {}", spectral.display());
            }
            Ok(if stats.interrupted {
                ExitCode::from(130)
            } else {
                ExitCode::SUCCESS
            })
        }
        Command::Merge {
            parts,
            output,
            exposure,
        } => {
            let images = parts
                .iter()
                .map(|p| Ok((p.clone(), spectral_exr::read(p)?)))
                .collect::<Result<Vec<_>>>()?;
            for (p, img) in &images {
                if img.attributes.contains_key("prismInterrupted") {
                    eprintln!("warning: {} is an interrupted render: it holds fewer samples than its range", p.display());
                }
            }
            let merged = prism::merge::merge(&images)?;
            let stem = output_stem(Path::new(""), Some(output));
            check_writable(&stem)?;
            let spectral = suffixed(&stem, "spectral.exr");
            spectral_exr::write_image(&merged, &spectral)?;
            let rgb: Vec<glam::Vec3> = (0..merged.width * merged.height)
                .map(|i| {
                    glam::Vec3::new(
                        merged.other["R"][i],
                        merged.other["G"][i],
                        merged.other["B"][i],
                    )
                })
                .collect();
            let (w, h) = (merged.width as u32, merged.height as u32);
            let (exr, png) = (suffixed(&stem, "exr"), suffixed(&stem, "png"));
            output::write_rgb_exr(&rgb, w, h, &exr)?;
            output::write_rgb_png(&rgb, w, h, &png, exposure, Tonemap::Clamp)?;
            eprintln!(
                "merged {} parts (samples {}): wrote {}, {} and {}",
                parts.len(),
                merged.attributes[prism::merge::ATTR_SAMPLES],
                spectral.display(),
                exr.display(),
                png.display()
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Bench {
            scene: scene_path,
            spp,
            reference_spp,
            reference,
            resolution,
            threads,
            out,
        } => {
            if spp.is_empty() || spp.contains(&0) || reference_spp == 0 {
                bail!("sample counts must be at least 1");
            }
            if threads == Some(0) {
                bail!("--threads must be at least 1");
            }
            let load_start = std::time::Instant::now();
            let mut scene = scene::load(&scene_path)?;
            let load = load_start.elapsed();
            for w in &scene.warnings {
                eprintln!("warning: {w}");
            }
            if let Some((w, h)) = resolution {
                scene::check_film_size(w, h, scene.settings.spectral_buckets)
                    .map_err(|e| anyhow::anyhow!(e))?;
                scene.settings.width = w;
                scene.settings.height = h;
                scene.camera = scene.camera.clone().with_resolution(w, h);
            }
            std::fs::create_dir_all(&out)
                .with_context(|| format!("cannot create {}", out.display()))?;
            let bytes = std::fs::read(&scene_path)?;
            let opts = prism::bench::BenchOptions {
                ladder: spp,
                reference_spp,
                reference,
                threads,
                out_dir: out.clone(),
                scene_hash: prism::merge::scene_hash(&bytes),
            };
            eprintln!(
                "loaded {} in {:.3} s ({} triangles)",
                scene_path.display(),
                load.as_secs_f64(),
                scene.triangle_count()
            );
            let (_, reference) = prism::bench::reference(&scene, &opts)?;
            let rungs = prism::bench::run_ladder(&scene, &reference, &opts)?;
            let csv = out.join("prism.csv");
            prism::bench::write_csv(&csv, &scene_path.display().to_string(), load, &rungs)?;
            eprintln!("wrote {}", csv.display());
            Ok(ExitCode::SUCCESS)
        }
        Command::Info { file } => {
            print!("{}", describe(&file)?);
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// The report of `prism info`.
fn describe(file: &Path) -> Result<String> {
    use std::fmt::Write;
    let img = spectral_exr::read(file)?;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{}: {} x {} pixels",
        file.display(),
        img.width,
        img.height
    );
    for (k, v) in &img.attributes {
        let _ = writeln!(out, "  {k} = {v}");
    }
    let stats = |values: &[f32]| {
        let finite: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
        let mean = finite.iter().map(|&v| v as f64).sum::<f64>() / finite.len().max(1) as f64;
        let min = finite.iter().copied().fold(f32::INFINITY, f32::min);
        let max = finite.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        (min, max, mean, values.len() - finite.len())
    };
    if img.wavelengths.is_empty() {
        let _ = writeln!(out, "no spectral channels");
    } else {
        let n = img.wavelengths.len();
        let (first, last) = (img.wavelengths[0], img.wavelengths[n - 1]);
        let spacing = if n > 1 {
            (last - first) / (n - 1) as f64
        } else {
            0.0
        };
        let _ = writeln!(
            out,
            "spectral (emissive S0): {n} channels, centres {first:.3}-{last:.3} nm, spacing {spacing:.3} nm"
        );
        let _ = writeln!(
            out,
            "  {:>12}  {:>12}  {:>12}  {:>12}",
            "nm", "min", "mean", "max"
        );
        let mut bad = 0;
        for (lambda, plane) in img.wavelengths.iter().zip(&img.spectral) {
            let (min, max, mean, non_finite) = stats(plane);
            bad += non_finite;
            let _ = writeln!(
                out,
                "  {lambda:>12.3}  {min:>12.6}  {mean:>12.6}  {max:>12.6}"
            );
        }
        let _ = writeln!(out, "  non-finite spectral values: {bad}");
    }
    for (name, plane) in &img.other {
        let (min, max, mean, non_finite) = stats(plane);
        let _ = writeln!(
            out,
            "channel {name}: min {min:.6}, mean {mean:.6}, max {max:.6}, non-finite {non_finite}"
        );
    }
    Ok(out)
}
