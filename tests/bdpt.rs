//! Bidirectional path tracing against the path tracer (the same image
//! within error bars) on the Cornell Box, glass, metal, shading normals,
//! delta lights and a lamp inside nested frosted glass; against closed
//! forms (a white furnace, a mirror's caustic from a point light, which
//! the path tracer cannot find at all); and the same image for any number
//! of threads.

use crate::common;

use common::agree::{
    assert_integrators_agree, block_estimates, cornell_box, DELTA_LIGHTS, GLASS_METAL_SHADING,
};
use common::caustic;
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
    common::agree::assert_tilted_floor_agrees("bdpt");
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
         [[shape]]\ntype = \"sphere\"\nradius = 1\ntessellate = true\nsegments = 24\nsmooth = false\n\
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

/// The caustic of tests/common/caustic.rs: a point light seen in a mirror
/// lights the floor. With max_depth 2 nothing else reaches the camera. The
/// path tracer never finds the mirrored light (a point seen in a mirror);
/// bdpt finds it by light tracing and must match the closed form.
#[test]
fn bdpt_and_light_tracing_match_a_mirror_caustic() {
    let probe = caustic::scene("bdpt", "", false, 2);
    let pixels = caustic::expected_pixels(&probe.scene, false, false, 0.0);
    let (w, h) = (probe.settings.film.width, probe.settings.film.height);
    let mut expected = Vec::new();
    for y0 in (0..h).step_by(8) {
        for x0 in (0..w).step_by(8) {
            let block: Vec<f64> = (y0..y0 + 8)
                .flat_map(|y| (x0..x0 + 8).map(move |x| (x, y)))
                .map(|(x, y)| pixels[(y * w + x) as usize].expect("every pixel sees the floor"))
                .collect();
            expected.push(block.iter().sum::<f64>() / block.len() as f64);
        }
    }
    // The mirror's share is large enough to matter.
    let centre = DVec3::new(0.0, 0.0, 1.0);
    let direct = caustic::INTENSITY / (centre - DVec3::Y).length().powi(3);
    let share = caustic::irradiance(centre, false) / direct - 1.0;
    assert!(share > 0.1, "mirrored / direct = {share}");

    for kind in ["bdpt", "light"] {
        let s = caustic::scene(kind, "", false, 2);
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

/// The caustic of a smooth glass ball (a ball lens) on the floor under a
/// small light, the ball out of view: light paths through the ball find the
/// caustic at once, camera paths only when a diffuse bounce happens to go
/// through the ball to the light. MIS must give it to the light paths:
/// bdpt's variance there stays near the light tracer's, which sees all of
/// this picture. (Counting a Dirac lobe's density as 1 per area instead of
/// per solid angle, as pbrt does, weights strategies across the ball by the
/// wrong geometry and gives the caustic to the camera paths: still
/// unbiased, but its energy then hides in rare fireflies, and at these
/// sample counts one block reads 0.005 where the light tracer reads 0.25.)
#[test]
fn bdpt_gives_a_ball_lens_caustic_to_light_paths() {
    let text = r#"
[camera]
position = [0, 3, -1.6]
look_at = [0, 0, -1.1]
fov = 14
[film]
resolution = [24, 24]
[materials.floor]
type = "diffuse"
reflectance = 0.7
[materials.glass]
type = "dielectric"
ior = 1.8
[[shape]]
type = "quad"
vertices = [[-8, 0, -8], [-8, 0, 8], [8, 0, 8], [8, 0, -8]]
material = "floor"
[[shape]]
type = "sphere"
center = [0, 0.6, 0]
radius = 0.6
tessellate = true
segments = 64
material = "glass"
[[shape]]
type = "quad"
vertices = [[-0.05, 4.8, 6.35], [0.05, 4.8, 6.35], [0.05, 4.8, 6.45], [-0.05, 4.8, 6.45]]
emission = 12000
two_sided = true
"#;
    let with = |kind: &str| common::scene(&format!("{text}\n[integrator]\ntype = \"{kind}\"\n"));
    let bdpt = block_estimates(&with("bdpt"), 32, 16);
    let light = block_estimates(&with("light"), 32, 16);
    for (b, l) in bdpt.iter().zip(&light) {
        assert!(common::z_score(*b, *l) < 5.0, "bdpt {b:?}, light {l:?}");
    }
    // The brightest block: the caustic.
    let (i, _) = light
        .iter()
        .enumerate()
        .max_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
        .unwrap();
    let ratio = bdpt[i].1 / light[i].1;
    eprintln!(
        "caustic block {i}: bdpt {:?}, light {:?}, variance ratio {ratio:.2}",
        bdpt[i], light[i]
    );
    assert!(
        ratio < 3.0,
        "bdpt's variance is {ratio:.1} times the light tracer's"
    );
}
