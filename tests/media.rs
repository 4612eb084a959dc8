//! Participating media against closed forms: Beer–Lambert through a slab,
//! energy conservation of a scattering medium in a furnace, single
//! scattering from a point light, spectral MIS against a hero-only
//! estimate in a chromatic medium, and the integrators against each other.

use crate::common;

use common::agree::assert_integrators_agree;
use common::{path_radiance, render_film, scene};
use glam::{DVec3, Vec3, Vec4};
use prism::geometry::Ray;
use prism::integrator::IntegratorKind;
use prism::sampler::Sampler;
use prism::spectrum::{SampledSpectrum, SampledWavelengths};

/// Six quads bounding the box [min, max], normals outwards, of `material`.
pub(crate) fn box_shapes(min: [f32; 3], max: [f32; 3], material: &str) -> String {
    let [x0, y0, z0] = min;
    let [x1, y1, z1] = max;
    let faces = [
        // -x, +x
        [[x0, y0, z0], [x0, y0, z1], [x0, y1, z1], [x0, y1, z0]],
        [[x1, y0, z0], [x1, y1, z0], [x1, y1, z1], [x1, y0, z1]],
        // -y, +y
        [[x0, y0, z0], [x1, y0, z0], [x1, y0, z1], [x0, y0, z1]],
        [[x0, y1, z0], [x0, y1, z1], [x1, y1, z1], [x1, y1, z0]],
        // -z, +z
        [[x0, y0, z0], [x0, y1, z0], [x1, y1, z0], [x1, y0, z0]],
        [[x0, y0, z1], [x1, y0, z1], [x1, y1, z1], [x0, y1, z1]],
    ];
    faces
        .iter()
        .map(|f| {
            format!(
                "[[shape]]\ntype = \"quad\"\nmaterial = \"{material}\"\nvertices = {:?}\n",
                f.map(|v| v.to_vec()).to_vec()
            )
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// `units`, `materials` and `shapes` (TOML) between a camera at z = −3
/// looking along +z and a white emitter (radiance 1) filling the view at
/// z = 3.
fn in_front_of_a_light(units: f32, materials: &str, shapes: &str) -> prism::load::Loaded {
    scene(&format!(
        r#"
        units = {units}
        [camera]
        position = [0, 0, -3]
        look_at = [0, 0, 0]
        [film]
        resolution = [4, 4]
        [materials.black]
        type = "diffuse"
        reflectance = 0
        {materials}
        {shapes}
        [[shape]]
        type = "quad"
        material = "black"
        emission = 1
        vertices = [[-5, -5, 3], [-5, 5, 3], [5, 5, 3], [5, -5, 3]]
        "#
    ))
}

/// The mean radiance (lanes averaged) along `ray` over `n` samples of
/// seed `seed`, and its standard error.
fn mean_radiance(s: &prism::load::Loaded, ray: Ray, n: u64, seed: u64) -> (f64, f64) {
    let (mut sum, mut sq) = (0.0f64, 0.0f64);
    for k in 0..n {
        let mut sampler = Sampler::for_sample(seed, 0, 0, k);
        let mut wl = SampledWavelengths::sample_visible(sampler.next_f32());
        let v = path_radiance(s, ray, &mut wl, &mut sampler).element_sum() as f64 / 4.0;
        sum += v;
        sq += v * v;
    }
    let mean = sum / n as f64;
    (mean, ((sq / n as f64 - mean * mean) / n as f64).sqrt())
}

/// Wavelengths chosen by hand (density 1, so lanes are plain values).
fn wavelengths(lambda: [f32; 4]) -> SampledWavelengths {
    SampledWavelengths {
        lambda: Vec4::from_array(lambda),
        pdf: Vec4::ONE,
    }
}

#[test]
fn a_slab_transmits_by_beer_lambert_at_every_wavelength() {
    // An index-matched slab 0.5 m thick (units: 1 scene unit = 0.5 m, the
    // slab one unit thick) in front of a white emitter; absorption varies
    // across the spectrum, the camera ray crosses both faces head-on.
    let absorption = [[380.0, 0.2], [500.0, 1.0], [600.0, 2.5], [780.0, 4.0]];
    let s = in_front_of_a_light(
        0.5,
        &format!(
            "[materials.tinted]\ntype = \"interface\"\nmedium = {{ absorption = {absorption:?} }}"
        ),
        &box_shapes([-1.0, -1.0, 0.0], [1.0, 1.0, 1.0], "tinted"),
    );
    let table = |l: f32| {
        let i = absorption.windows(2).position(|w| l <= w[1][0]).unwrap();
        let (a, b) = (absorption[i], absorption[i + 1]);
        a[1] + (b[1] - a[1]) * (l - a[0]) / (b[0] - a[0])
    };
    for lambda in [[400.0, 480.0, 550.0, 700.0], [380.0, 520.0, 610.0, 780.0]] {
        let mut wl = wavelengths(lambda);
        let mut sampler = Sampler::for_sample(1, 0, 0, 0);
        let ray = Ray::new(Vec3::new(0.1, 0.05, -3.0), Vec3::Z);
        let l = path_radiance(&s, ray, &mut wl, &mut sampler);
        for k in 0..4 {
            let expected = (-table(lambda[k]) * 0.5).exp();
            assert!(
                (l[k] - expected).abs() < 1e-4 * expected.max(1e-3),
                "{} nm: {} against exp(-σa d) = {expected}",
                lambda[k],
                l[k]
            );
        }
    }
}

/// A furnace (a closed emitting sphere of albedo 0.5, Le = 0.25, so L =
/// 0.5 everywhere) filled with `medium`: a medium of albedo 1 keeps the
/// uniform radiance field as it is, whatever its density or phase
/// function, and at every wavelength.
fn furnace_with_medium(medium: &str, integrator: &str) {
    let s = common::furnace_scene(0.5, 0.25, 128, integrator, &format!("[medium]\n{medium}"));
    let expected = 0.5;
    let splats = matches!(
        s.settings.integrator.kind(),
        IntegratorKind::Light | IntegratorKind::Bdpt
    );
    let (total, total_var) = if splats {
        // Splats make per-pixel variances meaningless: the spread of the
        // image means of independent runs gives the error bar.
        let blocks = common::agree::block_estimates(&s, 16, 12);
        let n = blocks.len() as f64;
        (
            blocks.iter().map(|b| b.0).sum::<f64>() / n,
            blocks.iter().map(|b| b.1).sum::<f64>() / (n * n),
        )
    } else {
        let film = render_film(&s, 2);
        let (mut total, mut total_var) = (0.0, 0.0);
        for y in 0..8 {
            for x in 0..8 {
                let (m, v) = film.luminance_and_variance(x, y);
                total += m / 64.0;
                total_var += v / (64.0 * 64.0);
            }
        }
        (total, total_var)
    };
    let sigma = total_var.sqrt();
    assert!(
        (total - expected).abs() < 4.0 * sigma,
        "{medium} ({integrator}): image mean {total} ± {sigma}, expected {expected}"
    );
    assert!(
        sigma < 0.01 * expected,
        "error bar {sigma} too wide to test anything"
    );
    eprintln!("{medium} ({integrator}): {total:.5} ± {sigma:.5} (expected {expected})");
}

#[test]
fn a_scattering_medium_of_albedo_one_conserves_energy_in_a_furnace() {
    furnace_with_medium("scattering = 3.0\nphase = { hg = 0.6 }", "type = \"path\"");
    furnace_with_medium(
        "scattering = 1.0\nphase = { hg = -0.3 }",
        "type = \"path\"\nstrategy = \"bsdf\"",
    );
    // Chromatic: σs from 0.3 to 6 per metre across the spectrum.
    furnace_with_medium(
        "scattering = [[380, 0.3], [550, 2.0], [780, 6.0]]",
        "type = \"path\"",
    );
}

/// Single scattering of a point light's intensity I in an infinite medium
/// (σa, σs, isotropic) seen along a ray from the origin along +z: the
/// integral over t of σs e^(−σt t) p I e^(−σt r) / r², r the distance from
/// x(t) to the light (by quadrature in f64).
fn single_scattering(sigma_a: f64, sigma_s: f64, light: DVec3, intensity: f64) -> f64 {
    let st = sigma_a + sigma_s;
    let p = 1.0 / (4.0 * std::f64::consts::PI);
    // Substitute t = −ln(1 − u)/σt: smooth on [0, 1).
    let n = 200_000;
    let mut sum = 0.0;
    for i in 0..n {
        let u = (i as f64 + 0.5) / n as f64;
        let t = -(1.0 - u).ln() / st;
        let x = DVec3::new(0.0, 0.0, t);
        let r = (light - x).length();
        // dt = du / (σt (1 − u)), and e^(−σt t) = 1 − u.
        sum += sigma_s / st * p * intensity * (-st * r).exp() / (r * r) / n as f64;
    }
    sum
}

fn point_light_in_fog(medium: &str) -> prism::load::Loaded {
    scene(&format!(
        r#"
        [camera]
        position = [0, 0, 0]
        look_at = [0, 0, 1]
        [film]
        resolution = [4, 4]
        [integrator]
        max_depth = 1
        [[light]]
        type = "point"
        position = [0.6, 0, 1.5]
        intensity = 2.0
        [medium]
        {medium}
        "#
    ))
}

#[test]
fn a_medium_seen_at_depth_one_matches_the_single_scattering_integral() {
    let s = point_light_in_fog("absorption = 0.3\nscattering = 0.5");
    let expected = single_scattering(0.3, 0.5, DVec3::new(0.6, 0.0, 1.5), 2.0);
    // Grey medium and light: every lane estimates the same number.
    let (mean, sigma) = mean_radiance(&s, Ray::new(Vec3::ZERO, Vec3::Z), 40_000, 5);
    eprintln!("single scattering: {mean:.6} ± {sigma:.6}, closed form {expected:.6}");
    assert!(
        (mean - expected).abs() < 5.0 * sigma,
        "{mean} ± {sigma} against {expected}"
    );
    assert!(sigma < 0.01 * expected);
}

/// Per-wavelength means of the radiance along a ray, in `bins` bins of
/// the visible range: (mean, variance of the mean) per bin. `hero_only`
/// terminates the secondaries at the start: a plain single-wavelength
/// estimator, the reference for spectral MIS.
fn binned_radiance(s: &prism::load::Loaded, ray: Ray, n: u64, hero_only: bool) -> Vec<(f64, f64)> {
    let bins = 6;
    let mut acc = vec![(0.0f64, 0.0f64, 0u64); bins];
    for k in 0..n {
        let mut sampler = Sampler::for_sample(if hero_only { 11 } else { 12 }, 0, 0, k);
        let mut wl = SampledWavelengths::sample_visible(sampler.next_f32());
        if hero_only {
            wl.terminate_secondary();
        }
        let l: SampledSpectrum = path_radiance(s, ray, &mut wl, &mut sampler);
        let lanes = if hero_only { 1 } else { 4 };
        for i in 0..lanes {
            let b = (((wl.lambda[i] - 360.0) / 470.0 * bins as f32) as usize).min(bins - 1);
            let v = l[i] as f64;
            acc[b].0 += v;
            acc[b].1 += v * v;
            acc[b].2 += 1;
        }
    }
    acc.iter()
        .map(|&(s, q, c)| {
            let m = s / c as f64;
            (m, (q / c as f64 - m * m) / c as f64)
        })
        .collect()
}

#[test]
fn spectral_mis_in_a_chromatic_medium_agrees_with_a_single_wavelength_estimate() {
    // A strongly chromatic scattering medium (σs 0.2 → 4 per metre, σa
    // the other way) in a box of fog lit by a grey area light above it:
    // multiple scattering, wavelengths that scatter 20× more than others.
    let text = format!(
        r#"
        [camera]
        position = [0, 0, -3]
        look_at = [0, 0, 0]
        [film]
        resolution = [4, 4]
        [integrator]
        max_depth = 12
        [materials.fog]
        type = "interface"
        medium = {{ scattering = [[380, 0.2], [560, 1.5], [780, 4.0]], absorption = [[380, 0.8], [780, 0.1]], phase = {{ hg = 0.4 }} }}
        [materials.floor]
        type = "diffuse"
        reflectance = 0.6
        {fog}
        [[shape]]
        type = "quad"
        material = "floor"
        vertices = [[-4, -1.01, -4], [-4, -1.01, 4], [4, -1.01, 4], [4, -1.01, -4]]
        [[shape]]
        type = "quad"
        emission = 4
        vertices = [[-0.5, 1.5, -0.5], [0.5, 1.5, -0.5], [0.5, 1.5, 0.5], [-0.5, 1.5, 0.5]]
        "#,
        fog = box_shapes([-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], "fog"),
    );
    let s = scene(&text);
    let ray = Ray::new(
        Vec3::new(0.0, 0.0, -3.0),
        Vec3::new(0.05, -0.1, 1.0).normalize(),
    );
    let mis = binned_radiance(&s, ray, 60_000, false);
    let hero = binned_radiance(&s, ray, 120_000, true);
    let mut worst = 0.0f64;
    for (b, (a, h)) in mis.iter().zip(&hero).enumerate() {
        let z = (a.0 - h.0).abs() / (a.1 + h.1).sqrt();
        worst = worst.max(z);
        assert!(
            z < 5.0,
            "bin {b}: spectral MIS {a:?}, hero only {h:?}: {z:.1}σ"
        );
        assert!(a.0 > 0.0 && a.1.sqrt() < 0.1 * a.0, "bin {b}: {a:?}");
    }
    eprintln!("chromatic medium: per-bin means agree, largest difference {worst:.2}σ");
}

/// A small Cornell-like room: a haze-filled index-matched box, an
/// absorbing glass sphere and an area light: media for every integrator.
fn room_with_media() -> String {
    format!(
        r#"
        [camera]
        position = [0, 0, -3.2]
        look_at = [0, 0, 0]
        fov = 45
        [film]
        resolution = [16, 16]
        [materials.wall]
        type = "diffuse"
        reflectance = 0.6
        [materials.haze]
        type = "interface"
        medium = {{ scattering = 0.6, absorption = 0.1, phase = {{ hg = 0.3 }} }}
        [materials.glass]
        type = "dielectric"
        ior = 1.5
        roughness = 0.3
        medium = {{ attenuation_color = [0.9, 0.4, 0.2], attenuation_distance = 0.5 }}
        {walls}
        {haze}
        [[shape]]
        type = "sphere"
        center = [0.3, -0.55, 0.2]
        radius = 0.4
        material = "glass"
        [[shape]]
        type = "quad"
        emission = 6
        vertices = [[-0.3, 0.99, -0.3], [0.3, 0.99, -0.3], [0.3, 0.99, 0.3], [-0.3, 0.99, 0.3]]
        "#,
        walls = [
            "[[-1, -1, -1], [-1, -1, 1], [1, -1, 1], [1, -1, -1]]",
            "[[-1, 1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1]]",
            "[[-1, -1, 1], [-1, 1, 1], [1, 1, 1], [1, -1, 1]]",
            "[[-1, -1, -1], [-1, 1, -1], [-1, 1, 1], [-1, -1, 1]]",
            "[[1, -1, -1], [1, -1, 1], [1, 1, 1], [1, 1, -1]]",
        ]
        .map(|v| format!("[[shape]]\ntype = \"quad\"\nmaterial = \"wall\"\nvertices = {v}\n"))
        .join("\n"),
        haze = box_shapes([-0.98, -0.98, -0.98], [0.98, 0.3, 0.98], "haze"),
    )
}

#[test]
fn media_agree_between_path_and_bdpt() {
    assert_integrators_agree(&room_with_media(), "bdpt", "haze and tinted glass, bdpt");
}

#[test]
fn media_agree_between_path_and_the_light_tracer() {
    assert_integrators_agree(
        &room_with_media(),
        "light",
        "haze and tinted glass, light tracer",
    );
}

#[test]
fn media_agree_between_path_and_photon_mapping() {
    // Photons cross the haze and the tinted glass and land on the walls; a
    // small radius keeps photon mapping's blur below the error bars.
    let text = room_with_media();
    let path = scene(&format!("{text}\n[integrator]\ntype = \"path\"\n"));
    let sppm = scene(&format!(
        "{text}\n[integrator]\ntype = \"sppm\"\nradius = 0.05\nphotons = 10000\n"
    ));
    common::agree::assert_scenes_agree(&path, &sppm, "haze and tinted glass, photon mapping");
}

#[test]
fn bidirectional_paths_conserve_energy_in_a_furnace_full_of_fog() {
    // The camera and the light subpaths start inside the world medium.
    furnace_with_medium("scattering = 2.0\nphase = { hg = 0.5 }", "type = \"bdpt\"");
}

#[test]
fn absorbing_glass_face_on_matches_fresnel_and_beer_lambert_with_internal_reflections() {
    // A smooth cube of glass (n = 1.5, 0.1 m: units 0.1) absorbing 3 /m,
    // seen face-on in front of a white emitter: the light that gets through
    // is T² a / (1 − R² a²), a = e^(−σ L), summing the reflections between
    // the two faces (the 1/η² going in and η² coming out cancel).
    let s = in_front_of_a_light(
        0.1,
        "[materials.glass]\ntype = \"dielectric\"\nior = 1.5\nmedium = { absorption = 3 }",
        &box_shapes([-0.5, -0.5, -0.5], [0.5, 0.5, 0.5], "glass"),
    );
    let r = ((1.5f64 - 1.0) / 2.5).powi(2);
    let a = (-3.0f64 * 0.1).exp();
    let expected = (1.0 - r).powi(2) * a / (1.0 - r * r * a * a);
    let ray = Ray::new(Vec3::new(0.1, 0.05, -3.0), Vec3::Z);
    let (mean, sigma) = mean_radiance(&s, ray, 20_000, 3);
    eprintln!("absorbing glass face-on: {mean:.5} ± {sigma:.5}, closed form {expected:.5}");
    assert!(
        (mean - expected).abs() < 5.0 * sigma + 1e-6,
        "{mean} ± {sigma} vs {expected}"
    );
    // Beer–Lambert's share is far outside the error bar: the test sees it.
    assert!((expected / a - expected).abs() > 20.0 * sigma);
}
