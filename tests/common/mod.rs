//! Helpers shared by the rendering tests: load scenes from text, render
//! them, and compare Monte Carlo estimates with their standard errors.
#![allow(dead_code)]

pub mod agree;
pub mod assets;
pub mod caustic;

use std::path::Path;

use prism::film::Film;
use prism::geometry::Ray;
use prism::integrator::{Integrator, PathCounters};
use prism::load::{load_str, Loaded};
use prism::render::{render, RenderOptions};
use prism::sampler::Sampler;

use prism::spectrum::{SampledSpectrum, SampledWavelengths};

/// Every file below `dir`, folders walked.
pub fn files_under(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(files_under(&path));
        } else {
            out.push(path);
        }
    }
    out
}

/// The `backticked` words of a text (a table cell, a message's list).
pub fn ticked(text: &str) -> Vec<String> {
    text.split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

pub fn scene(text: &str) -> Loaded {
    load_str(text, Path::new(env!("CARGO_MANIFEST_DIR"))).unwrap_or_else(|e| panic!("{e}"))
}

/// A scene file of the repository with its [film] and [integrator] entries
/// replaced by `film` and `integrator` (TOML tables as text).
pub fn repo_scene(relative: &str, film: &str, integrator: &str) -> Loaded {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(relative);
    let text = std::fs::read_to_string(&path).unwrap();
    let mut table: toml::Table = toml::from_str(&text).unwrap();
    table.insert(
        "film".into(),
        toml::Value::Table(toml::from_str(film).unwrap()),
    );
    table.insert(
        "integrator".into(),
        toml::Value::Table(toml::from_str(integrator).unwrap()),
    );
    load_str(&toml::to_string(&table).unwrap(), path.parent().unwrap())
        .unwrap_or_else(|e| panic!("{e}"))
}

/// The white furnace: a closed sphere of albedo `albedo` emitting
/// `emission` inwards (so radiance is emission / (1 − albedo) everywhere),
/// the camera inside, 8 × 8 pixels at `spp`; `integrator` adds lines to the
/// `[integrator]` table (unbounded depth), `extra` adds TOML (materials,
/// shapes, a medium).
pub fn furnace_scene(
    albedo: f64,
    emission: f64,
    spp: u32,
    integrator: &str,
    extra: &str,
) -> Loaded {
    scene(&format!(
        r#"
        [camera]
        position = [0.1, -0.2, 0.05]
        look_at = [0, 0, 1]
        fov = 100

        [film]
        resolution = [8, 8]
        spp = {spp}

        [integrator]
        max_depth = 100000
        {integrator}

        [materials.wall]
        type = "diffuse"
        reflectance = {albedo}

        [[shape]]
        type = "sphere"
        radius = 1
        tessellate = true
        segments = 24
        smooth = false
        flip_normals = true
        material = "wall"
        emission = {emission}

        {extra}
        "#
    ))
}

pub fn render_film(loaded: &Loaded, threads: usize) -> Film {
    let (film, stats) = render(
        &loaded.scene,
        &loaded.settings,
        &RenderOptions {
            threads: Some(threads),
            ..loaded.settings.options()
        },
    )
    .unwrap();
    assert_eq!(stats.non_finite, 0, "non-finite samples");
    assert!(!stats.interrupted);
    film
}

/// Radiance along one ray by the scene's path tracer.
pub fn path_radiance(
    loaded: &Loaded,
    ray: Ray,
    wl: &mut SampledWavelengths,
    sampler: &mut Sampler,
) -> SampledSpectrum {
    let scene = &loaded.scene;
    match &loaded.settings.integrator {
        Integrator::Path(p) => p.radiance(scene, ray, wl, sampler, &mut PathCounters::default()),
        other => panic!("a path-traced scene, not {}", other.name()),
    }
}

/// Mean luminance of a floor (or any surface) at `target`, seen from a
/// little above it by the scene's path tracer, and its standard error.
pub fn floor_luminance(s: &Loaded, target: glam::Vec3) -> (f64, f64) {
    let origin = target + glam::Vec3::new(0.3, 2.0, -0.4);
    let n = 4000u64;
    let (mut sum, mut sq) = (0.0, 0.0);
    for k in 0..n {
        let mut sampler = Sampler::for_sample(17, 0, 0, k);
        let mut wl = SampledWavelengths::sample_visible(sampler.next_f32());
        let ray = Ray::new(origin, (target - origin).normalize());
        let l = path_radiance(s, ray, &mut wl, &mut sampler);
        let y = prism::spectrum::cie::sampled_to_xyz(l, &wl).y as f64;
        sum += y;
        sq += y * y;
    }
    let mean = sum / n as f64;
    (
        mean,
        ((sq / n as f64 - mean * mean) / (n - 1) as f64).sqrt(),
    )
}

/// Mean luminance over a pixel rectangle and the variance of that mean.
pub fn region_mean(film: &Film, x0: u32, y0: u32, x1: u32, y1: u32) -> (f64, f64) {
    let (mut sum, mut var) = (0.0, 0.0);
    let n = ((x1 - x0) * (y1 - y0)) as f64;
    for y in y0..y1 {
        for x in x0..x1 {
            let (m, v) = film.luminance_and_variance(x, y);
            sum += m;
            var += v;
        }
    }
    (sum / n, var / (n * n))
}

/// How many standard errors apart two independent estimates are.
pub fn z_score(a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.0 - b.0).abs() / (a.1 + b.1).sqrt()
}

/// Mean luminance over a pixel rectangle and a bound on the variance of
/// that mean for a render whose pixels share paths within aligned 2 × 2
/// blocks (the path tracer's `reuse`), so that a block's pixels are
/// correlated: a block's sum varies by at most the square of the sum of
/// its pixels' standard deviations (Cauchy–Schwarz), up to four times
/// what independent pixels would.
pub fn region_mean_reused(film: &Film, x0: u32, y0: u32, x1: u32, y1: u32) -> (f64, f64) {
    let (mut sum, mut var) = (0.0, 0.0);
    let n = ((x1 - x0) * (y1 - y0)) as f64;
    for by in y0 / 2..y1.div_ceil(2) {
        for bx in x0 / 2..x1.div_ceil(2) {
            let mut sd = 0.0;
            for (x, y) in
                [(0, 0), (1, 0), (0, 1), (1, 1)].map(|(dx, dy)| (2 * bx + dx, 2 * by + dy))
            {
                if (x0..x1).contains(&x) && (y0..y1).contains(&y) {
                    let (m, v) = film.luminance_and_variance(x, y);
                    sum += m;
                    sd += v.sqrt();
                }
            }
            var += sd * sd;
        }
    }
    (sum / n, var / (n * n))
}

/// Asserts that two renders of one scene agree block by block (8 × 8
/// pixels) within `z_max` standard errors of the difference. A block both
/// find exactly the same (black, where nothing is seen) agrees.
pub fn assert_blocks_agree(a: &Film, b: &Film, z_max: f64, what: &str) {
    blocks_agree(a, b, z_max, what, region_mean);
}

/// `assert_blocks_agree` where either render may share paths between
/// neighbouring pixels (`region_mean_reused`'s error bars).
pub fn assert_blocks_agree_reused(a: &Film, b: &Film, z_max: f64, what: &str) {
    blocks_agree(a, b, z_max, what, region_mean_reused);
}

fn blocks_agree(
    a: &Film,
    b: &Film,
    z_max: f64,
    what: &str,
    region: fn(&Film, u32, u32, u32, u32) -> (f64, f64),
) {
    for y0 in (0..a.height).step_by(8) {
        for x0 in (0..a.width).step_by(8) {
            let (x1, y1) = ((x0 + 8).min(a.width), (y0 + 8).min(a.height));
            let (ra, rb) = (region(a, x0, y0, x1, y1), region(b, x0, y0, x1, y1));
            let z = if ra.0 == rb.0 { 0.0 } else { z_score(ra, rb) };
            assert!(
                z < z_max,
                "{what}, block at ({x0}, {y0}): {ra:?} vs {rb:?}: {z:.1}σ"
            );
        }
    }
}

/// An EXR's width and its channels by name (the first layer).
pub fn exr_channels(path: &Path) -> (usize, std::collections::HashMap<String, Vec<f32>>) {
    use exr::prelude::{ReadChannels, ReadLayers};
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let layer = image.layer_data;
    let map = layer
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect();
    (layer.size.width(), map)
}
