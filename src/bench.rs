//! Speed against error: renders a scene at a ladder of sample counts, times
//! each render (wall and CPU, scene loading excluded) and measures its
//! error against a high-sample reference that is rendered once and cached.
//! `prism bench` writes the numbers as CSV; `tools/bench.py` adds FLIP,
//! Mitsuba 3 and the plot.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use glam::Vec3;

use crate::film::output::{read_rgb_exr, write_rgb_exr};
use crate::film::Sampling;
use crate::integrator::{Integrator, IntegratorKind, IntegratorSpec};
use crate::load::Loaded;
use crate::render::{render, RenderOptions, RenderSettings};
use crate::scene::Scene;

pub use crate::film::convergence::REL_MSE_EPSILON;

/// Relative mean squared error of `image` against `reference` (linear RGB),
/// averaged over pixels and channels.
pub fn rel_mse(image: &[Vec3], reference: &[Vec3]) -> f64 {
    assert_eq!(image.len(), reference.len());
    let sum: f64 = image
        .iter()
        .zip(reference)
        .map(|(x, r)| {
            (0..3)
                .map(|c| {
                    let (x, r) = (x[c] as f64, r[c] as f64);
                    (x - r) * (x - r) / (r * r + REL_MSE_EPSILON)
                })
                .sum::<f64>()
        })
        .sum();
    sum / (3 * image.len()) as f64
}

/// CPU time used by this process so far (user + system, all threads).
pub fn process_cpu_time() -> Duration {
    // SAFETY: getrusage only writes the struct it is given.
    let usage = unsafe {
        let mut u = std::mem::zeroed::<libc::rusage>();
        libc::getrusage(libc::RUSAGE_SELF, &mut u);
        u
    };
    let t = |tv: libc::timeval| Duration::new(tv.tv_sec as u64, tv.tv_usec as u32 * 1000);
    t(usage.ru_utime) + t(usage.ru_stime)
}

/// One rung of the ladder.
#[derive(Clone, Debug)]
pub struct Rung {
    pub spp: u32,
    pub wall: Duration,
    pub cpu: Duration,
    pub rel_mse: f64,
    pub image: PathBuf,
}

/// What to run.
pub struct BenchOptions {
    pub ladder: Vec<u32>,
    pub reference_spp: u32,
    /// Use this reference image instead of rendering one.
    pub reference: Option<PathBuf>,
    pub threads: Option<usize>,
    pub out_dir: PathBuf,
    /// Run the ladder with each of these integrators instead of the scene
    /// file's, from one loaded scene (the reference with the first).
    pub integrators: Vec<IntegratorKind>,
    /// The path tracer's splitting instead of the scene file's.
    pub split: Option<u32>,
    /// How the rungs sample; None: as `prism render` would
    /// (`RenderSettings::adaptive`).
    pub sampling: Option<Sampling>,
}

/// The reference image: the given one, a cached render of this scene file
/// at this many samples, or a new render (cached for next time).
pub fn reference(loaded: &Loaded, opts: &BenchOptions) -> Result<(PathBuf, Vec<Vec3>)> {
    let (scene, settings) = (&loaded.scene, &loaded.settings);
    let (width, height) = (settings.film.width, settings.film.height);
    let path = opts.reference.clone().unwrap_or_else(|| {
        opts.out_dir.join(format!(
            "reference-{}-{width}x{height}-{}spp.exr",
            loaded.report.content_hash(),
            opts.reference_spp
        ))
    });
    if path.exists() {
        let (w, h, px) = read_rgb_exr(&path)?;
        if (w, h) != (width, height) {
            bail!(
                "the reference {} is {w}x{h}, the scene renders {width}x{height}",
                path.display(),
            );
        }
        eprintln!("reference: {} (cached)", path.display());
        return Ok((path, px));
    }
    eprintln!(
        "reference: rendering {} spp once (cached as {})",
        opts.reference_spp,
        path.display()
    );
    let (film, _) = render(
        scene,
        settings,
        &RenderOptions {
            // A seed no rung uses: the reference's noise is independent.
            seed: 0x5eed_0000_0000,
            threads: opts.threads,
            progress: true,
            ..RenderOptions::with_spp(&settings.film, opts.reference_spp)
        },
    )?;
    let rgb = film.linear_srgb();
    write_rgb_exr(&rgb, film.width, film.height, &path)?;
    Ok((path, rgb))
}

/// Renders every rung with `settings` and measures it.
pub fn run_ladder(
    scene: &Scene,
    settings: &RenderSettings,
    reference: &[Vec3],
    opts: &BenchOptions,
) -> Result<Vec<Rung>> {
    let mut rungs = Vec::new();
    for (i, &spp) in opts.ladder.iter().enumerate() {
        let (cpu0, wall0) = (process_cpu_time(), Instant::now());
        let (film, stats) = render(
            scene,
            settings,
            &RenderOptions {
                seed: i as u64 + 1,
                threads: opts.threads,
                adaptive: opts
                    .sampling
                    .map_or(settings.adaptive(), |s| s == Sampling::Adaptive),
                ..RenderOptions::with_spp(&settings.film, spp)
            },
        )?;
        let (wall, cpu) = (wall0.elapsed(), process_cpu_time() - cpu0);
        if stats.non_finite > 0 {
            eprintln!(
                "warning: {} non-finite samples at {spp} spp",
                stats.non_finite
            );
        }
        let rgb = film.linear_srgb();
        let image = opts
            .out_dir
            .join(format!("prism-{}-{spp}spp.exr", settings.integrator.name()));
        write_rgb_exr(&rgb, film.width, film.height, &image)?;
        let e = rel_mse(&rgb, reference);
        eprintln!(
            "{spp:>6} spp: {:8.3} s wall, {:8.3} s CPU, relMSE {e:.3e}",
            wall.as_secs_f64(),
            cpu.as_secs_f64()
        );
        rungs.push(Rung {
            spp,
            wall,
            cpu,
            rel_mse: e,
            image,
        });
    }
    Ok(rungs)
}

/// The ladder as CSV: one row per rung.
pub fn write_csv(
    path: &Path,
    scene: &str,
    integrator: &str,
    load: Duration,
    rungs: &[Rung],
) -> Result<()> {
    let mut text =
        String::from("renderer,scene,spp,wall_s,cpu_s,load_s,rel_mse,image,integrator\n");
    for r in rungs {
        text += &format!(
            "prism,{scene},{},{:.6},{:.6},{:.6},{:.6e},{},{integrator}\n",
            r.spp,
            r.wall.as_secs_f64(),
            r.cpu.as_secs_f64(),
            load.as_secs_f64(),
            r.rel_mse,
            r.image.display()
        );
    }
    std::fs::write(path, text).with_context(|| format!("cannot write {}", path.display()))
}

/// `prism bench`: loads the scene once (at `resolution` if given), renders
/// or reads the reference, and runs the ladder with the scene file's
/// integrator (OUT/prism.csv) or with each one asked for (OUT/prism-NAME.csv).
pub fn run(scene_path: &Path, resolution: Option<(u32, u32)>, opts: &BenchOptions) -> Result<()> {
    if opts.ladder.is_empty() || opts.ladder.contains(&0) || opts.reference_spp == 0 {
        bail!("sample counts must be at least 1");
    }
    if opts.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    let load_start = Instant::now();
    let overrides = crate::load::Overrides {
        resolution,
        integrator: opts.integrators.first().copied(),
        split: opts.split,
        // The rungs are measured as RGB, as Mitsuba's are: no spectral
        // buckets to sum.
        no_spectral: true,
        ..Default::default()
    };
    let loaded = crate::load::load_with(scene_path, &overrides)?;
    let load = load_start.elapsed();
    for w in &loaded.report.warnings {
        eprintln!("warning: {w}");
    }
    std::fs::create_dir_all(&opts.out_dir)
        .with_context(|| format!("cannot create {}", opts.out_dir.display()))?;
    eprintln!(
        "loaded {} in {:.3} s ({} triangles)",
        scene_path.display(),
        load.as_secs_f64(),
        loaded.scene.triangle_count()
    );
    let (_, reference) = reference(&loaded, opts)?;
    let mut settings = vec![loaded.settings.clone()];
    for &kind in opts.integrators.iter().skip(1) {
        settings.push(RenderSettings {
            integrator: other_integrator(&loaded.settings.integrator, kind, opts.split)?,
            ..loaded.settings.clone()
        });
    }
    for settings in &settings {
        let rungs = run_ladder(&loaded.scene, settings, &reference, opts)?;
        // The scene's own integrator writes prism.csv (what tools/bench.py
        // reads); one chosen by --integrator, prism-NAME.csv.
        let name = settings.integrator.name();
        let csv = match opts.integrators.is_empty() {
            true => opts.out_dir.join("prism.csv"),
            false => opts.out_dir.join(format!("prism-{name}.csv")),
        };
        write_csv(&csv, &scene_path.display().to_string(), name, load, &rungs)?;
        eprintln!("wrote {}", csv.display());
    }
    Ok(())
}

/// An integrator of `kind` for the scene `loaded` was loaded with: its
/// defaults, with the loaded one's bounce limit (and `split` for the path
/// tracer).
fn other_integrator(
    loaded: &Integrator,
    kind: IntegratorKind,
    split: Option<u32>,
) -> Result<Integrator> {
    let named = |e| anyhow::anyhow!("--integrator {}: {e}", kind.name());
    let mut spec = IntegratorSpec::of(kind);
    spec.set("max_depth", i64::from(loaded.max_depth()))
        .map_err(named)?;
    if let Some(n) = split.filter(|_| kind == IntegratorKind::Path) {
        spec.set("split", i64::from(n)).map_err(named)?;
    }
    Integrator::from_spec(&spec).map_err(named)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rel_mse_of_known_differences() {
        let r = vec![Vec3::ONE; 4];
        assert_eq!(rel_mse(&r, &r), 0.0);
        // 10% too bright everywhere: 0.01 / (1 + ε).
        let x: Vec<Vec3> = r.iter().map(|v| *v * 1.1).collect();
        assert!((rel_mse(&x, &r) - 0.01 / 1.01).abs() < 1e-6);
        // A black reference pixel counts through ε only.
        let z = vec![Vec3::ZERO];
        assert!((rel_mse(&[Vec3::splat(0.1)], &z) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn cpu_time_advances() {
        // Work until the CPU clock moves (its tick may be coarse), within
        // a bound on wall time.
        let (a, start) = (process_cpu_time(), Instant::now());
        let mut x = 0u64;
        while process_cpu_time() <= a {
            for i in 0..1_000_000u64 {
                x = x.wrapping_add(std::hint::black_box(i) * i);
            }
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "no CPU time counted"
            );
        }
        std::hint::black_box(x);
    }
}
