//! Stochastic progressive photon mapping: consistent, not unbiased. Against
//! closed forms that include its bias (the caustic of a point light in a
//! mirror, blurred over the photon radius, which shrinks to nothing as the
//! iterations go on), seen directly and in a second mirror (visible points
//! found through a specular chain, which no other integrator renders);
//! against the path tracer; and the same image for any number of threads.

use crate::common;

use common::caustic;
use common::region_mean;
use prism::film::Film;
use prism::load::Loaded;

/// Per 8 × 8 block, the mean luminance over the pixels that have an
/// expected value, the variance of that mean and the expected value.
fn blocks(film: &Film, scene: &Loaded, expected: &[Option<f64>]) -> Vec<(f64, f64, f64)> {
    let (w, h) = (scene.settings.film.width, scene.settings.film.height);
    let mut out = Vec::new();
    for y0 in (0..h).step_by(8) {
        for x0 in (0..w).step_by(8) {
            let (mut m, mut v, mut e, mut n) = (0.0, 0.0, 0.0, 0.0);
            for y in y0..(y0 + 8).min(h) {
                for x in x0..(x0 + 8).min(w) {
                    if let Some(ex) = expected[(y * w + x) as usize] {
                        let (pm, pv) = region_mean(film, x, y, x + 1, y + 1);
                        m += pm;
                        v += pv;
                        e += ex;
                        n += 1.0;
                    }
                }
            }
            if n >= 8.0 {
                out.push((m / n, v / (n * n), e / n));
            }
        }
    }
    out
}

/// The blocks' χ² against their expected values, per block: about 1 when
/// they agree, with a standard deviation of √(2/n) over n blocks.
fn chi2_per_block(blocks: &[(f64, f64, f64)]) -> f64 {
    let sum: f64 = blocks.iter().map(|(m, v, e)| (m - e).powi(2) / v).sum();
    sum / blocks.len() as f64
}

/// The largest |z| of the blocks against their expected values.
fn worst_z(blocks: &[(f64, f64, f64)]) -> f64 {
    blocks
        .iter()
        .map(|(m, v, e)| (m - e).abs() / v.sqrt())
        .fold(0.0, f64::max)
}

fn render(scene: &Loaded, iterations: u32) -> Film {
    let options = prism::render::RenderOptions {
        threads: Some(2),
        ..prism::render::RenderOptions::with_spp(&scene.settings.film, iterations)
    };
    let (film, stats) = prism::render::render(&scene.scene, &scene.settings, &options).unwrap();
    assert_eq!(stats.non_finite, 0);
    film
}

/// With a fixed radius (α = 1) photon mapping measures the caustic averaged
/// over the photon disc: it matches that within error bars, and is many
/// error bars off the sharp closed form, so the test sees the bias and
/// knows its size. With the default α the radius shrinks (to 0.35 of the
/// first by iteration 512) and the result matches the closed form at the
/// radius of the iterations' mean square.
#[test]
fn sppm_measures_the_caustic_blurred_by_its_radius() {
    let r = 0.5;
    let s = caustic::scene(
        "sppm",
        &format!("radius = {r}\nalpha = 1\nphotons = 20000"),
        false,
        2,
    );
    let film = render(&s, 256);
    let blurred = blocks(
        &film,
        &s,
        &caustic::expected_pixels(&s.scene, false, false, r),
    );
    let sharp = blocks(
        &film,
        &s,
        &caustic::expected_pixels(&s.scene, false, false, 0.0),
    );
    let zb = worst_z(&blurred);
    // The bias shows over all the blocks together: the sharp form's χ² is
    // far above what agreement gives (1 ± √(2/n) per block).
    let (chi2, n) = (chi2_per_block(&sharp), sharp.len() as f64);
    let chi2_z = (chi2 - 1.0) / (2.0 / n).sqrt();
    eprintln!(
        "fixed radius {r}: {zb:.2}σ from the blurred closed form; χ² per block {chi2:.2} \
         against the sharp one ({chi2_z:.1}σ above agreement, {n} blocks)"
    );
    assert!(zb < 5.0, "{blurred:?}");
    assert!(
        chi2_z > 5.0,
        "the bias of radius {r} should show: χ² {chi2_z:.1}σ"
    );
    for (m, v, _) in &blurred {
        assert!(v.sqrt() < 0.01 * m, "error bar too wide to test anything");
    }

    // The default schedule: r_i = r₁ (i + 1)^(−1/6).
    let s = caustic::scene("sppm", &format!("radius = {r}\nphotons = 20000"), false, 2);
    let iterations = 512u32;
    let mean_square = (0..iterations)
        .map(|i| (r * (i as f64 + 1.0).powf(-1.0 / 6.0)).powi(2))
        .sum::<f64>()
        / iterations as f64;
    let film = render(&s, iterations);
    let shrunk = blocks(
        &film,
        &s,
        &caustic::expected_pixels(&s.scene, false, false, mean_square.sqrt()),
    );
    let z = worst_z(&shrunk);
    eprintln!(
        "α = 2/3, {iterations} iterations: {z:.2}σ from the closed form at radius {:.3}",
        mean_square.sqrt()
    );
    assert!(z < 5.0, "{shrunk:?}");
}

/// The caustic seen in a second, vertical mirror: the camera path reaches
/// the floor through a Dirac reflection, and photons there are gathered as
/// anywhere else.
#[test]
fn sppm_finds_caustics_seen_in_a_mirror() {
    let r = 0.2;
    let s = caustic::scene(
        "sppm",
        &format!("radius = {r}\nalpha = 1\nphotons = 20000"),
        true,
        3,
    );
    let expected = caustic::expected_pixels(&s.scene, true, true, r);
    let seen = expected.iter().filter(|e| e.is_some()).count();
    assert!(seen > 100, "{seen} pixels see the floor in the mirror");
    let film = render(&s, 256);
    let b = blocks(&film, &s, &expected);
    assert!(b.len() >= 3);
    let z = worst_z(&b);
    eprintln!(
        "caustic in a mirror: {z:.2}σ from the closed form over {} blocks",
        b.len()
    );
    assert!(z < 5.0, "{b:?}");
    for (m, v, _) in &b {
        assert!(v.sqrt() < 0.02 * m, "error bar too wide to test anything");
    }
}

#[test]
fn sppm_is_the_same_for_any_thread_count() {
    common::agree::assert_thread_count_invariant("sppm");
}

/// On the Cornell Box (in millimetres), against the path tracer: photon
/// mapping's bias (light leaking around corners, blurred shadows) is many
/// error bars wide at a radius of 80 mm, shrinks as the radius halves, and
/// is lost in the noise at 20 mm. With the default α = 2/3 the radius
/// halves every 64-fold of iterations (r_i = r₁ (i + 1)^(−1/6)), so this is
/// the bias of iterations 0, 63 and 4095 of a render starting at 80 mm.
#[test]
fn sppm_bias_shrinks_with_its_radius_to_the_path_tracer() {
    let text = common::agree::cornell_box();
    let path = common::scene(&format!("{text}\n[integrator]\ntype = \"path\"\n"));
    let reference = render(&path, 1024);
    let mut previous = f64::INFINITY;
    for (radius, z_min, z_max) in [
        (80.0, 5.0, f64::INFINITY),
        (40.0, 0.0, f64::INFINITY),
        (20.0, 0.0, 5.0),
    ] {
        let s = common::scene(&format!(
            "{text}\n[integrator]\ntype = \"sppm\"\nradius = {radius}\nalpha = 1\n"
        ));
        let film = render(&s, 256);
        let (mut worst_z, mut worst_rel) = (0.0f64, 0.0f64);
        for y0 in (0..32).step_by(8) {
            for x0 in (0..32).step_by(8) {
                let a = region_mean(&reference, x0, y0, x0 + 8, y0 + 8);
                let b = region_mean(&film, x0, y0, x0 + 8, y0 + 8);
                worst_z = worst_z.max(common::z_score(a, b));
                worst_rel = worst_rel.max((b.0 / a.0 - 1.0).abs());
            }
        }
        eprintln!(
            "radius {radius} mm: worst block {:.1}% off ({worst_z:.1}σ)",
            100.0 * worst_rel
        );
        assert!(
            worst_z >= z_min && worst_z < z_max,
            "radius {radius}: {worst_z:.1}σ, expected within [{z_min}, {z_max})"
        );
        assert!(worst_rel < previous, "the bias must shrink with the radius");
        previous = worst_rel;
    }
}
