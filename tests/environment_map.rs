//! Environment maps: a map whose light is in one texel against the closed
//! form of that texel's irradiance (and a directional light of the same
//! irradiance); light sampling, BSDF sampling and MIS agree; a rotated map
//! rotates the picture; bidirectional path tracing sees the map as the
//! path tracer does; bad maps are clear errors.

use crate::common;

use std::f64::consts::PI;
use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};
use prism::film::output::write_rgb_exr;
use prism::load::Loaded;

const W: u32 = 64;
const H: u32 = 32;

/// Writes a W × H map, zero but for texel (i, j) of grey radiance `l`.
fn one_texel_map(dir: &Path, i: u32, j: u32, l: f32) -> PathBuf {
    let mut rgb = vec![Vec3::ZERO; (W * H) as usize];
    rgb[(j * W + i) as usize] = Vec3::splat(l);
    let path = dir.join(format!("texel-{i}-{j}.exr"));
    write_rgb_exr(&rgb, W, H, &path).unwrap();
    path
}

/// A smooth sky: bright towards +x and the zenith, coloured.
fn smooth_map(dir: &Path) -> PathBuf {
    let rgb: Vec<Vec3> = (0..H)
        .flat_map(|j| (0..W).map(move |i| (i, j)))
        .map(|(i, j)| {
            let u = (i as f32 + 0.5) / W as f32;
            let v = (j as f32 + 0.5) / H as f32;
            let warm = (1.0 + (2.0 * std::f32::consts::PI * u).sin()) * 0.5;
            Vec3::new(0.3 + 2.0 * warm, 0.4 + warm, 0.6) * (1.2 - v)
        })
        .collect();
    let path = dir.join("smooth.exr");
    write_rgb_exr(&rgb, W, H, &path).unwrap();
    path
}

fn floor_scene(environment: &str) -> Loaded {
    common::scene(&format!(
        "[camera]\nposition = [0, 5, -5]\nlook_at = [0, 0, 0]\n\
         [integrator]\nmax_depth = 1\n\
         [materials.floor]\ntype = \"diffuse\"\nreflectance = 0.5\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-20, 0, -20], [-20, 0, 20], [20, 0, 20], [20, 0, -20]]\nmaterial = \"floor\"\n\
         {environment}"
    ))
}

/// The texel's irradiance on a surface facing +y: L ∫ cos θ dω over the
/// texel = L Δφ (sin²θ₁ − sin²θ₀) / 2.
fn texel_irradiance(j: u32, l: f64) -> f64 {
    let (t0, t1) = (PI * j as f64 / H as f64, PI * (j + 1) as f64 / H as f64);
    l * (2.0 * PI / W as f64) * (t1.sin().powi(2) - t0.sin().powi(2)) / 2.0
}

/// The direction of the texel's centre (the map's convention: the image's
/// centre looks along +z, u grows towards +x, the top row is the zenith).
fn texel_direction(i: u32, j: u32) -> DVec3 {
    let phi = (2.0 * (i as f64 + 0.5) / W as f64 - 1.0) * PI;
    let theta = PI * (j as f64 + 0.5) / H as f64;
    DVec3::new(
        theta.sin() * phi.sin(),
        theta.cos(),
        theta.sin() * phi.cos(),
    )
}

#[test]
fn a_map_with_one_bright_texel_lights_like_that_texel_and_like_a_directional_light() {
    let dir = tempfile::tempdir().unwrap();
    let (i, j, l) = (20, 9, 300.0);
    let map = one_texel_map(dir.path(), i, j, l);
    let s = floor_scene(&format!(
        "[environment]\nfile = {:?}\n",
        map.display().to_string()
    ));
    let e = texel_irradiance(j, l as f64);
    let expected = 0.5 / PI * e;
    let (m, se) = common::floor_luminance(&s, Vec3::ZERO);
    assert!(
        (m - expected).abs() < 5.0 * se + 1e-4 * expected,
        "map: {m} ± {se}, expected {expected}"
    );
    // A directional light along the texel's centre, of the irradiance the
    // texel gives at normal incidence (E / cos θ): the same to within the
    // texel's extent (cos θ varies across it).
    let d = texel_direction(i, j);
    let normal_irradiance = e / d.y;
    let s = floor_scene(&format!(
        "[[light]]\ntype = \"directional\"\ndirection = [{}, {}, {}]\nirradiance = {normal_irradiance}\n",
        -d.x, -d.y, -d.z
    ));
    let (md, sed) = common::floor_luminance(&s, Vec3::ZERO);
    assert!(
        (md - m).abs() < 5.0 * (se + sed) + 2e-3 * m,
        "directional {md} ± {sed} against the map's {m} ± {se}"
    );
}

#[test]
fn light_sampling_bsdf_sampling_and_mis_agree_under_a_map() {
    let dir = tempfile::tempdir().unwrap();
    let map = smooth_map(dir.path());
    let text = |strategy: &str| {
        format!(
            "[camera]\nposition = [0, 1.5, -4]\nlook_at = [0, 0.6, 0]\nfov = 40\n\
             [film]\nresolution = [32, 24]\nspp = 256\n\
             [integrator]\nstrategy = \"{strategy}\"\n\
             [materials.m]\ntype = \"diffuse\"\nreflectance = 0.7\n\
             [materials.gold]\ntype = \"conductor\"\nmetal = \"Au\"\nroughness = 0.3\n\
             [[shape]]\ntype = \"quad\"\nvertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]\nmaterial = \"m\"\n\
             [[shape]]\ntype = \"sphere\"\ncenter = [-0.7, 0.6, 0]\nradius = 0.6\nmaterial = \"m\"\n\
             [[shape]]\ntype = \"sphere\"\ncenter = [0.7, 0.6, 0]\nradius = 0.6\nmaterial = \"gold\"\n\
             [environment]\nfile = {:?}\nrotate = 30\n",
            map.display().to_string()
        )
    };
    let films: Vec<_> = ["mis", "nee", "bsdf"]
        .iter()
        .map(|s| common::render_film(&common::scene(&text(s)), 2))
        .collect();
    common::assert_blocks_agree(&films[0], &films[1], 5.0, "mis against nee");
    common::assert_blocks_agree(&films[0], &films[2], 5.0, "mis against bsdf");
}

#[test]
fn a_rotated_map_rotates_the_picture() {
    // Turning the map by 90° about +y is the same as moving its bright
    // texel a quarter of the way round: the pictures agree; unturned, the
    // picture differs.
    let dir = tempfile::tempdir().unwrap();
    let scene = |map: &Path, rotate: f32| {
        common::scene(&format!(
            "[camera]\nposition = [0, 2, -4]\nlook_at = [0, 0.5, 0]\nfov = 40\n\
             [film]\nresolution = [32, 24]\nspp = 64\n\
             [materials.m]\ntype = \"diffuse\"\nreflectance = 0.7\n\
             [[shape]]\ntype = \"quad\"\nvertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]\nmaterial = \"m\"\n\
             [[shape]]\ntype = \"sphere\"\ncenter = [0, 0.6, 0]\nradius = 0.6\nmaterial = \"m\"\n\
             [environment]\nfile = {:?}\nrotate = {rotate}\n",
            map.display().to_string()
        ))
    };
    let a = one_texel_map(dir.path(), 8, 10, 200.0);
    let b = one_texel_map(dir.path(), 8 + W / 4, 10, 200.0);
    let turned = common::render_film(&scene(&a, 90.0), 2);
    let moved = common::render_film(&scene(&b, 0.0), 2);
    let unturned = common::render_film(&scene(&a, 0.0), 2);
    common::assert_blocks_agree(&turned, &moved, 5.0, "turned map against moved texel");
    // The sphere's lit side moves: some block differs by far more.
    let mut worst = 0.0f64;
    for y0 in (0..24).step_by(8) {
        for x0 in (0..32).step_by(8) {
            let r = |f| common::region_mean(f, x0, y0, x0 + 8, y0 + 8);
            worst = worst.max(common::z_score(r(&turned), r(&unturned)));
        }
    }
    assert!(worst > 20.0, "rotation changed nothing: {worst:.1}σ");
}

/// Light subpaths that start at the map (importance-sampled directions, a
/// disc over the scene) and camera subpaths that escape to it, weighted
/// against each other: bdpt agrees with the path tracer. (The light tracer
/// cannot see the sky itself, so it is not compared here.)
#[test]
fn bidirectional_path_tracing_sees_the_map_as_the_path_tracer_does() {
    let dir = tempfile::tempdir().unwrap();
    let map = smooth_map(dir.path());
    let text = format!(
        "[camera]\nposition = [0, 1.5, -4]\nlook_at = [0, 0.6, 0]\nfov = 40\n\
         [film]\nresolution = [32, 24]\nspp = 16\n\
         [materials.m]\ntype = \"diffuse\"\nreflectance = 0.7\n\
         [materials.glass]\ntype = \"dielectric\"\nior = 1.5\nroughness = 0.2\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]\nmaterial = \"m\"\n\
         [[shape]]\ntype = \"sphere\"\ncenter = [-0.7, 0.6, 0]\nradius = 0.6\nmaterial = \"m\"\n\
         [[shape]]\ntype = \"sphere\"\ncenter = [0.7, 0.6, 0]\nradius = 0.6\nmaterial = \"glass\"\n\
         [environment]\nfile = {:?}\nrotate = -40\n",
        map.display().to_string()
    );
    common::agree::assert_integrators_agree(&text, "bdpt", "bdpt under a map");
}

#[test]
fn bad_maps_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let error = |environment: String| match prism::load::load_str(
        &format!(
            "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n[environment]\n{environment}"
        ),
        dir.path(),
    ) {
        Ok(_) => panic!("expected an error for {environment}"),
        Err(e) => e.to_string(),
    };
    let mut rgb = vec![Vec3::ONE; 8];
    rgb[5] = Vec3::new(1.0, f32::NAN, 1.0);
    write_rgb_exr(&rgb, 4, 2, &dir.path().join("nan.exr")).unwrap();
    let e = error("file = \"nan.exr\"\n".into());
    assert!(
        e.contains("nan.exr") && e.contains("texel (1, 1)") && e.contains("finite"),
        "{e}"
    );
    rgb[5] = Vec3::new(1.0, -0.5, 1.0);
    write_rgb_exr(&rgb, 4, 2, &dir.path().join("negative.exr")).unwrap();
    let e = error("file = \"negative.exr\"\n".into());
    assert!(
        e.contains("negative.exr") && e.contains("not negative"),
        "{e}"
    );
    std::fs::write(dir.path().join("broken.hdr"), b"#?RADIANCE\nnot really").unwrap();
    let e = error("file = \"broken.hdr\"\n".into());
    assert!(
        e.contains("broken.hdr") && e.contains("cannot decode"),
        "{e}"
    );
    let e = error("file = \"missing.exr\"\n".into());
    assert!(
        e.contains("environment.file") && e.contains("missing.exr"),
        "{e}"
    );
    let e = error("file = \"nan.exr\"\nradiance = 1\n".into());
    assert!(e.contains("one of `radiance`"), "{e}");
    let e = error("radiance = 1\nrotate = 10\n".into());
    assert!(e.contains("environment.rotate"), "{e}");
}
