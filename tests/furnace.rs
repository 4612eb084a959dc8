//! White furnace: inside a closed diffuse enclosure of albedo ρ whose walls
//! all emit Le, radiance is Le/(1 − ρ) everywhere (the Neumann series of the
//! rendering equation). Any lost or invented energy shows up here.

use crate::common;

use common::{furnace_scene, render_film, scene};

/// The `[integrator]` lines choosing the path tracer's `strategy`.
fn strategy_table(strategy: &str) -> String {
    format!("strategy = \"{strategy}\"")
}

fn furnace(albedo: f64, emission: f64, strategy: &str) {
    let s = furnace_scene(albedo, emission, 256, &strategy_table(strategy), "");
    let film = render_film(&s, 2);
    let expected = emission / (1.0 - albedo);
    let (mut total, mut total_var) = (0.0, 0.0);
    for y in 0..8 {
        for x in 0..8 {
            let (m, v) = film.luminance_and_variance(x, y);
            // 5σ per pixel: 64 pixels give a false alarm about once in 3·10⁴ runs.
            assert!(
                (m - expected).abs() < 5.0 * v.sqrt(),
                "{strategy}, ρ = {albedo}: pixel ({x}, {y}) = {m} ± {}, expected {expected}",
                v.sqrt()
            );
            total += m / 64.0;
            total_var += v / (64.0 * 64.0);
        }
    }
    assert!(
        (total - expected).abs() < 4.0 * total_var.sqrt(),
        "{strategy}, ρ = {albedo}: image mean {total} ± {}, expected {expected}",
        total_var.sqrt()
    );
    // The test must be able to fail: the error bars are much tighter than
    // the effect of losing a tenth of the energy per bounce.
    assert!(
        total_var.sqrt() < 0.01 * expected,
        "error bar too wide to test anything"
    );
}

#[test]
fn furnace_half_albedo_all_strategies() {
    for strategy in ["mis", "nee", "bsdf"] {
        furnace(0.5, 0.25, strategy);
    }
}

#[test]
fn furnace_high_albedo_long_paths() {
    furnace(0.9, 0.1, "mis");
}

/// Lossless dielectrics inside the furnace change nothing: seen from
/// outside, a smooth sphere of glass (dispersive or not) shows the same
/// uniform radiance, which tests Fresnel R + T = 1, total internal
/// reflection, the η² radiance bookkeeping and the IOR stack at once. IOR 1
/// is the invisible case, rough or smooth (no microfacet bends light at
/// η = 1). A rough sphere may only lose energy (microfacet
/// single scattering drops what would scatter twice), never gain it.
#[test]
fn furnace_with_dielectric_spheres() {
    for (ior, roughness) in [
        ("1.0", 0.0),
        ("1.0", 0.5),
        ("1.5", 0.0),
        ("1.5", 0.3),
        ("\"N-SF11\"", 0.0),
        ("\"N-SF11\"", 0.3),
    ] {
        let glass = format!(
            r#"
            [materials.glass]
            type = "dielectric"
            ior = {ior}
            roughness = {roughness}

            [[shape]]   # in front of the camera, filling much of the view
            type = "sphere"
            center = [0, 0, 0.5]
            radius = 0.3
            material = "glass"
            "#
        );
        let s = furnace_scene(0.5, 0.25, 256, &strategy_table("mis"), &glass);
        let film = render_film(&s, 2);
        let exact = roughness == 0.0 || ior == "1.0";
        let (mut total, mut var) = (0.0, 0.0);
        for y in 0..8 {
            for x in 0..8 {
                let (m, v) = film.luminance_and_variance(x, y);
                if exact {
                    assert!(
                        (m - 0.5).abs() < 5.0 * v.sqrt(),
                        "ior {ior}: pixel ({x}, {y}) = {m} ± {}",
                        v.sqrt()
                    );
                }
                total += m / 64.0;
                var += v / 4096.0;
            }
        }
        eprintln!("glass sphere ior {ior} roughness {roughness}: image mean {total:.4} ± {:.4} (furnace 0.5)", var.sqrt());
        assert!(var.sqrt() < 0.01, "error bar too wide");
        if exact {
            assert!(
                (total - 0.5).abs() < 4.0 * var.sqrt(),
                "ior {ior}: {total} ± {}",
                var.sqrt()
            );
        } else {
            assert!(
                total < 0.5 + 4.0 * var.sqrt() && total > 0.45,
                "ior {ior} roughness {roughness}: {total} ± {}",
                var.sqrt()
            );
        }
    }
}

/// A diffuse sphere of albedo ρ under a constant environment of radiance L:
/// being convex it sees only the sky, so every point of it has radiance ρL,
/// and the sky seen directly is L. This exercises rays that escape the
/// scene (the environment's `le`, weighted by MIS against its light
/// sampling) for each strategy, and light paths that start at infinity.
#[test]
fn constant_environment_furnace() {
    use prism::render::{render, RenderOptions};
    let (albedo, radiance) = (0.6, 2.0);
    let text = |integrator: &str| {
        format!(
            "[camera]\nposition = [0, 0, -3]\nlook_at = [0, 0, 0]\nfov = 50\n\
             [film]\nresolution = [24, 24]\nspp = 64\n\
             [integrator]\n{integrator}\n\
             [materials.m]\ntype = \"diffuse\"\nreflectance = {albedo}\n\
             [[shape]]\ntype = \"sphere\"\nradius = 1\ntessellate = true\nsegments = 96\nmaterial = \"m\"\n\
             [environment]\nradiance = {radiance}\n"
        )
    };
    let y_sky = prism::spectrum::cie::spectrum_to_xyz(&prism::spectrum::Spectrum::Constant(
        radiance as f32,
    ))
    .y as f64;
    // Pixels whose four corners all see the sphere, or all see the sky.
    let probe = scene(&text("type = \"path\""));
    let inside = |x: u32, y: u32, hit: bool| {
        [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)]
            .iter()
            .all(|(dx, dy)| {
                let r = probe
                    .scene
                    .camera
                    .generate_ray(x as f32 + dx, y as f32 + dy);
                probe.scene.intersect(&r).is_some() == hit
            })
    };
    let sphere: Vec<(u32, u32)> = (0..24)
        .flat_map(|y| (0..24).map(move |x| (x, y)))
        .filter(|&(x, y)| inside(x, y, true))
        .collect();
    let sky: Vec<(u32, u32)> = (0..24)
        .flat_map(|y| (0..24).map(move |x| (x, y)))
        .filter(|&(x, y)| inside(x, y, false))
        .collect();
    assert!(sphere.len() > 100 && sky.len() > 100);
    let mean_of = |film: &prism::film::Film, pixels: &[(u32, u32)]| {
        let (mut m, mut v) = (0.0, 0.0);
        for &(x, y) in pixels {
            let (a, b) = film.luminance_and_variance(x, y);
            m += a;
            v += b;
        }
        let n = pixels.len() as f64;
        (m / n, v / (n * n))
    };
    for strategy in ["mis", "nee", "bsdf"] {
        let s = scene(&text(&format!("strategy = \"{strategy}\"")));
        let film = render_film(&s, 2);
        for (pixels, expected, what) in [(&sphere, albedo * y_sky, "sphere"), (&sky, y_sky, "sky")]
        {
            let (m, v) = mean_of(&film, pixels);
            let z = (m - expected).abs() / v.sqrt().max(1e-12);
            assert!(
                z < 5.0 || (m - expected).abs() < 1e-5 * expected,
                "{strategy}, {what}: {m} ± {}, expected {expected} ({z:.1}σ)",
                v.sqrt()
            );
        }
    }
    // Light paths from the environment reach the sphere alike (the light
    // tracer cannot see the sky itself: no surface to connect from).
    let s = scene(&text("type = \"light\""));
    let runs: Vec<f64> = (1..=8)
        .map(|seed| {
            let options = RenderOptions {
                seed,
                threads: Some(2),
                ..s.settings.options()
            };
            let (film, _) = render(&s.scene, &s.settings, &options).unwrap();
            mean_of(&film, &sphere).0
        })
        .collect();
    let n = runs.len() as f64;
    let m = runs.iter().sum::<f64>() / n;
    let var = runs.iter().map(|r| (r - m) * (r - m)).sum::<f64>() / (n - 1.0) / n;
    let expected = albedo * y_sky;
    assert!(
        (m - expected).abs() < 5.0 * var.sqrt(),
        "light tracer, sphere: {m} ± {}, expected {expected}",
        var.sqrt()
    );
}
