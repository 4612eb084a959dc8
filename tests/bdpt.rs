//! Bidirectional path tracing against the path tracer (the same image
//! within error bars) on the Cornell Box, glass, metal, shading normals,
//! delta lights and a lamp inside nested frosted glass; against closed
//! forms (a white furnace, a mirror's caustic from a point light, which
//! the path tracer cannot find at all); and the same image for any number
//! of threads.

mod common;

use common::agree::{
    assert_integrators_agree, assert_scenes_agree, block_estimates, cornell_box, tilted_floor_obj,
    DELTA_LIGHTS, GLASS_METAL_SHADING, TILTED_FLOOR,
};
use glam::DVec3;

#[test]
fn bdpt_matches_the_path_tracer_on_the_cornell_box() {
    assert_integrators_agree(&cornell_box(), "bdpt", "Cornell Box");
}

#[test]
fn bdpt_matches_the_path_tracer_through_glass_metal_and_shading_normals() {
    assert_integrators_agree(
        GLASS_METAL_SHADING,
        "bdpt",
        "glass, metal and shading normals",
    );
}

#[test]
fn bdpt_applies_the_shading_normal_correction() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("floor.obj"), tilted_floor_obj()).unwrap();
    let load = |kind: &str| {
        prism::scene::load_str(
            &format!("{TILTED_FLOOR}\n[integrator]\ntype = \"{kind}\"\n"),
            dir.path(),
        )
        .unwrap()
    };
    assert_scenes_agree(&load("path"), &load("bdpt"), "tilted shading normals");
}

#[test]
fn bdpt_matches_the_path_tracer_under_delta_lights() {
    assert_integrators_agree(DELTA_LIGHTS, "bdpt", "point, spot and directional lights");
}

/// A lamp inside a frosted water sphere inside a frosted glass sphere, a
/// smooth glass sphere (specular chains on the camera side), under a
/// constant sky (camera rays that escape). Light subpaths start inside two
/// media: they must carry both on their IOR stack, so that leaving the
/// water is an interface water → glass, not water → air; and they carry
/// importance, so crossing the rough interfaces must not scale by 1/η'²
/// as radiance does (the lamp's light is 1.5² = 2.25 times too dim or too
/// bright otherwise).
#[test]
fn bdpt_matches_the_path_tracer_for_a_lamp_inside_nested_frosted_glass() {
    let text = r#"
[camera]
position = [0, 1.4, -4]
look_at = [0, 0.8, 0]
fov = 45
[film]
resolution = [32, 24]
spp = 16
[materials.floor]
type = "diffuse"
reflectance = 0.6
[materials.frosted]
type = "dielectric"
ior = 1.5
roughness = 0.25
[materials.water]
type = "dielectric"
ior = 1.33
roughness = 0.25
[materials.clear]
type = "dielectric"
ior = 1.5
[[shape]]
type = "quad"
vertices = [[-4, 0, -4], [-4, 0, 4], [4, 0, 4], [4, 0, -4]]
material = "floor"
[[shape]]
type = "sphere"
center = [-0.5, 1, 0]
radius = 0.9
material = "frosted"
[[shape]]
type = "sphere"
center = [-0.5, 1, 0]
radius = 0.55
material = "water"
[[shape]]
type = "quad"
vertices = [[-0.7, 0.8, -0.2], [-0.3, 0.8, -0.2], [-0.3, 0.8, 0.2], [-0.7, 0.8, 0.2]]
emission = 40
two_sided = true
[[shape]]
type = "sphere"
center = [1.3, 0.5, -0.6]
radius = 0.5
material = "clear"
[environment]
radiance = 0.05
"#;
    assert_integrators_agree(text, "bdpt", "lamp inside nested frosted glass");
}

/// The white furnace (tests/furnace.rs) for bdpt: inside a closed diffuse
/// sphere of albedo ρ whose walls all emit Le, radiance is Le/(1 − ρ).
#[test]
fn bdpt_white_furnace() {
    let (albedo, emission) = (0.7, 0.3);
    let s = common::scene(&format!(
        "[camera]\nposition = [0.1, -0.2, 0.05]\nlook_at = [0, 0, 1]\nfov = 100\n\
         [film]\nresolution = [8, 8]\n\
         [integrator]\ntype = \"bdpt\"\nmax_depth = 100000\n\
         [materials.wall]\ntype = \"diffuse\"\nreflectance = {albedo}\n\
         [[shape]]\ntype = \"sphere\"\nradius = 1\nsegments = 24\nsmooth = false\n\
         flip_normals = true\nmaterial = \"wall\"\nemission = {emission}\n"
    ));
    let blocks = block_estimates(&s, 32, 16);
    let (m, var) = blocks[0];
    let expected = emission / (1.0 - albedo);
    eprintln!("bdpt furnace: {m} ± {}, expected {expected}", var.sqrt());
    assert!(
        (m - expected).abs() < 5.0 * var.sqrt(),
        "bdpt furnace: {m} ± {}, expected {expected}",
        var.sqrt()
    );
    assert!(
        var.sqrt() < 0.01 * expected,
        "error bar too wide to test anything"
    );
}

/// Fresnel reflectance of a conductor of complex index η + ik at incidence
/// cos θ (exact, for unpolarised light), computed here independently of
/// prism's own.
fn conductor_reflectance(cos: f64, eta: f64, k: f64) -> f64 {
    // n² − sin²θ = a + ib, with n = η + ik; s and p amplitudes from its root.
    let sin2 = 1.0 - cos * cos;
    let (a, b) = (eta * eta - k * k - sin2, 2.0 * eta * k);
    let modulus = (a * a + b * b).sqrt();
    let (u, v) = (((modulus + a) / 2.0).sqrt(), ((modulus - a) / 2.0).sqrt());
    let rs = ((cos - u).powi(2) + v * v) / ((cos + u).powi(2) + v * v);
    // r_p = (n² cos − w) / (n² cos + w), w = u + iv, n² = (a + sin²) + ib.
    let (n2r, n2i) = (a + sin2, b);
    let (pr, pi) = (n2r * cos - u, n2i * cos - v);
    let (qr, qi) = (n2r * cos + u, n2i * cos + v);
    let rp = (pr * pr + pi * pi) / (qr * qr + qi * qi);
    0.5 * (rs + rp)
}

/// A caustic with a closed form: a point light of intensity I at height 1
/// over a Lambertian floor of albedo ρ, under a horizontal mirror (a smooth
/// conductor) at height 2. The floor receives the light directly and from
/// its mirror image at height 3, attenuated by the mirror's Fresnel
/// reflectance: E = I·1/r₁³ + R(3/r₂)·I·3/r₂³, and has radiance ρE/π.
/// With max_depth 2 nothing else reaches the camera. The path tracer never
/// finds the mirrored light (a point seen in a mirror); bdpt finds it by
/// light tracing and must match the closed form.
#[test]
fn bdpt_and_light_tracing_match_a_mirror_caustic() {
    let (rho, intensity, eta, k) = (0.5, 10.0, 0.2, 3.0);
    let text = |kind: &str| {
        format!(
            "[camera]\nposition = [0, 1.8, -3]\nlook_at = [0, 0, 1]\nfov = 30\n\
             [film]\nresolution = [32, 24]\n\
             [integrator]\ntype = \"{kind}\"\nmax_depth = 2\n\
             [materials.floor]\ntype = \"diffuse\"\nreflectance = {rho}\n\
             [materials.mirror]\ntype = \"conductor\"\neta = {eta}\nk = {k}\n\
             [[shape]]\ntype = \"quad\"\nvertices = [[-20, 0, -20], [-20, 0, 20], [20, 0, 20], [20, 0, -20]]\nmaterial = \"floor\"\n\
             [[shape]]\ntype = \"quad\"\nvertices = [[-8, 2, -8], [8, 2, -8], [8, 2, 8], [-8, 2, 8]]\nmaterial = \"mirror\"\n\
             [[light]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = {intensity}\n"
        )
    };
    let radiance = |p: DVec3| {
        let direct = 1.0 / (p - DVec3::Y).length().powi(3);
        let r2 = (p - 3.0 * DVec3::Y).length();
        let mirrored = conductor_reflectance(3.0 / r2, eta, k) * 3.0 / r2.powi(3);
        rho / std::f64::consts::PI * intensity * (direct + mirrored)
    };
    // The closed form averaged over each 8 × 8 block (16 points a pixel:
    // the box filter), where every point sees the floor.
    let probe = common::scene(&text("bdpt"));
    let (w, h) = (32u32, 24u32);
    let mut expected = Vec::new();
    for y0 in (0..h).step_by(8) {
        for x0 in (0..w).step_by(8) {
            let (mut sum, mut n) = (0.0, 0.0);
            for y in y0..y0 + 8 {
                for x in x0..x0 + 8 {
                    for (i, j) in (0..4).flat_map(|i| (0..4).map(move |j| (i, j))) {
                        let r = probe.camera.generate_ray(
                            x as f32 + (i as f32 + 0.5) / 4.0,
                            y as f32 + (j as f32 + 0.5) / 4.0,
                        );
                        let t = -r.origin.y / r.dir.y;
                        assert!(t > 0.0, "every pixel sees the floor");
                        sum += radiance((r.origin + r.dir * t).as_dvec3());
                        n += 1.0;
                    }
                }
            }
            expected.push(sum / n);
        }
    }
    // The mirror's share is large enough to matter.
    let centre = DVec3::new(0.0, 0.0, 1.0);
    let r2 = (centre - 3.0 * DVec3::Y).length();
    let share = conductor_reflectance(3.0 / r2, eta, k) * 3.0
        / r2.powi(3)
        / (1.0 / (centre - DVec3::Y).length().powi(3));
    assert!(share > 0.1, "mirrored / direct = {share}");

    for kind in ["bdpt", "light"] {
        let s = common::scene(&text(kind));
        let blocks = block_estimates(&s, 64, 16);
        let mut worst = 0.0f64;
        for (i, ((m, var), e)) in blocks.iter().zip(&expected).enumerate() {
            let sd = var.sqrt();
            let z = (m - e).abs() / sd;
            worst = worst.max(z);
            assert!(
                z < 5.0,
                "{kind}, block {i}: {m} ± {sd}, closed form {e} ({z:.1}σ)"
            );
            assert!(sd < 0.02 * e, "{kind}, block {i}: error bar too wide");
        }
        eprintln!("{kind}: mirror caustic within {worst:.2}σ of the closed form");
    }
}

#[test]
fn bdpt_splats_are_the_same_for_any_thread_count() {
    common::agree::assert_thread_count_invariant("bdpt");
}
