//! White furnace: inside a closed diffuse enclosure of albedo ρ whose walls
//! all emit Le, radiance is Le/(1 − ρ) everywhere (the Neumann series of the
//! rendering equation). Any lost or invented energy shows up here.

mod common;

use common::{render_film, scene};
use prism::scene::Scene;

/// The furnace: a closed sphere of albedo `albedo` emitting `emission`
/// inwards, the camera inside; `extra` adds TOML (materials, shapes).
fn furnace_scene(albedo: f64, emission: f64, strategy: &str, extra: &str) -> Scene {
    scene(&format!(
        r#"
        [camera]
        position = [0.1, -0.2, 0.05]
        look_at = [0, 0, 1]
        fov = 100

        [film]
        resolution = [8, 8]
        spp = 256
        max_depth = 100000

        [integrator]
        strategy = "{strategy}"

        [materials.wall]
        type = "diffuse"
        reflectance = {albedo}

        [[shape]]
        type = "sphere"
        radius = 1
        segments = 24
        smooth = false
        flip_normals = true
        material = "wall"
        emission = {emission}

        {extra}
        "#
    ))
}

fn furnace(albedo: f64, emission: f64, strategy: &str) {
    let s = furnace_scene(albedo, emission, strategy, "");
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
/// is the invisible case. A rough sphere may only lose energy (microfacet
/// single scattering drops what would scatter twice), never gain it.
#[test]
fn furnace_with_dielectric_spheres() {
    for (ior, roughness) in [
        ("1.0", 0.0),
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
        let s = furnace_scene(0.5, 0.25, "mis", &glass);
        let film = render_film(&s, 2);
        let (mut total, mut var) = (0.0, 0.0);
        for y in 0..8 {
            for x in 0..8 {
                let (m, v) = film.luminance_and_variance(x, y);
                if roughness == 0.0 {
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
        if roughness == 0.0 {
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
