//! The Hosek–Wilkie sky and sun (`[environment] sky = {...}`): radiance of
//! the sky and of the limb-darkened solar disc against an independent
//! implementation (Mitsuba 3's `sunsky`, values in
//! tests/data/sky_reference.csv, written by tools/sky_reference.py), the
//! sun's irradiance against the table Mitsuba ships, a floor's brightness
//! under sun and sky against its quadrature, and every integrator against
//! that.

use crate::common;

use std::f64::consts::PI;
use std::sync::Arc;

use glam::{Vec3, Vec4};
use prism::film::Film;
use prism::light::{Sky, SkyModel, Sun, SKY_BANDS, SUN_DIAMETER_DEGREES};
use prism::render::{render, RenderOptions};
use prism::spectrum::cie;
use prism::spectrum::SampledWavelengths;

struct Row {
    kind: String,
    turbidity: f32,
    albedo: f32,
    sun: Vec3,
    view: Vec3,
    nm: f32,
    value: f64,
}

/// Mitsuba's +z up turned to prism's +y up (a reflection: angles, which
/// are all the model depends on, are kept).
fn y_up(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, z, y)
}

fn reference() -> Vec<Row> {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/sky_reference.csv"
    ))
    .unwrap();
    text.lines()
        .filter(|l| !l.starts_with('#') && !l.starts_with("kind"))
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let n = |i: usize| f[i].parse::<f64>().unwrap();
            Row {
                kind: f[0].to_string(),
                turbidity: n(1) as f32,
                albedo: n(2) as f32,
                sun: y_up(n(3) as f32, n(4) as f32, n(5) as f32),
                view: y_up(n(6) as f32, n(7) as f32, n(8) as f32),
                nm: n(9) as f32,
                value: n(10),
            }
        })
        .collect()
}

fn model(row: &Row) -> Arc<SkyModel> {
    Arc::new(SkyModel::new(
        row.sun.y.asin(),
        row.turbidity,
        [row.albedo; SKY_BANDS],
    ))
}

fn at(nm: f32) -> SampledWavelengths {
    SampledWavelengths {
        lambda: Vec4::splat(nm),
        pdf: Vec4::ONE,
    }
}

/// Both evaluate the same formula in single precision: they agree to a
/// few parts in 10⁵ (exp(B / (cos θ + 0.01)) near the horizon amplifies
/// rounding most).
#[test]
fn sky_radiance_matches_mitsuba() {
    let rows: Vec<Row> = reference()
        .into_iter()
        .filter(|r| r.kind == "sky")
        .collect();
    assert!(rows.len() > 2000);
    let mut worst = 0.0f64;
    let mut sky: Option<(Vec3, f32, f32, Sky)> = None;
    for r in &rows {
        if sky
            .as_ref()
            .is_none_or(|(s, t, a, _)| (*s, *t, *a) != (r.sun, r.turbidity, r.albedo))
        {
            sky = Some((r.sun, r.turbidity, r.albedo, Sky::new(model(r), r.sun, 1.0)));
        }
        let light = &sky.as_ref().unwrap().3;
        let got = light.radiance(r.view, &at(r.nm))[0] as f64;
        let rel = (got - r.value).abs() / r.value;
        worst = worst.max(rel);
        assert!(
            rel < 2e-4,
            "sky at {} nm, turbidity {}, albedo {}, sun {}, view {}: {got} vs Mitsuba's {}",
            r.nm,
            r.turbidity,
            r.albedo,
            r.sun,
            r.view,
            r.value
        );
    }
    eprintln!(
        "sky: {} values, worst relative difference {worst:.1e}",
        rows.len()
    );
}

/// The solar radiance function with limb darkening, at the disc's centre,
/// halfway out and near its rim: the model's polynomials are evaluated in
/// double precision here and single precision in Mitsuba, and cos ψ near
/// the rim magnifies the direction's rounding (1e-3 there).
#[test]
fn sun_radiance_matches_mitsuba() {
    let rows: Vec<Row> = reference()
        .into_iter()
        .filter(|r| r.kind == "sun")
        .collect();
    assert!(rows.len() > 900);
    let mut worst = 0.0f64;
    for r in &rows {
        let sun = Sun::new(model(r), r.sun, SUN_DIAMETER_DEGREES, 1.0);
        let got = sun.radiance(r.view, &at(r.nm))[0] as f64;
        let rel = (got - r.value).abs() / r.value.max(1e-3);
        worst = worst.max(rel);
        assert!(
            rel < 1e-3,
            "sun at {} nm, turbidity {}, sun {}, view {}: {got} vs Mitsuba's {}",
            r.nm,
            r.turbidity,
            r.sun,
            r.view,
            r.value
        );
    }
    eprintln!(
        "sun: {} values, worst relative difference {worst:.1e}",
        rows.len()
    );
}

/// Mitsuba's table of the sun's irradiance (its own integration of the
/// model) against ours: within 0.6 %. Both sides integrate the same
/// radiance (checked above to 1e-3); the table sits 0.3–0.4 % below a
/// fine quadrature of Mitsuba's own radiance too.
#[test]
fn sun_irradiance_matches_the_published_table() {
    let rows: Vec<Row> = reference()
        .into_iter()
        .filter(|r| r.kind == "sun_irradiance")
        .collect();
    assert_eq!(rows.len(), 150);
    let mut worst = 0.0f64;
    for r in &rows {
        let sun = Sun::new(model(r), r.sun, SUN_DIAMETER_DEGREES, 1.0);
        let band = ((r.nm - 320.0) / 40.0).round() as usize;
        let got = sun.band_irradiance(band);
        let rel = (got - r.value).abs() / r.value.max(1e-6);
        worst = worst.max(rel);
        assert!(
            rel < 6e-3 || (got - r.value).abs() < 1e-5,
            "sun irradiance at {} nm, turbidity {}, elevation {:.0}°: {got} vs the table's {}",
            r.nm,
            r.turbidity,
            r.sun.y.asin().to_degrees(),
            r.value
        );
    }
    eprintln!("sun irradiance: worst relative difference {worst:.1e}");
}

const SUN_ELEVATION: f32 = 35.0;
const SUN_AZIMUTH: f32 = 40.0;
const ALBEDO: f64 = 0.5;

/// The `[environment]` of the rendering tests, with `extra` keys for the sky.
fn sky_table(extra: &str) -> String {
    format!(
        "[environment]\nsky = {{ sun_elevation = {SUN_ELEVATION}, sun_azimuth = {SUN_AZIMUTH}, turbidity = 4, ground_albedo = 0.2{extra} }}\n"
    )
}

fn sun_direction() -> Vec3 {
    let (e, a) = (SUN_ELEVATION.to_radians(), SUN_AZIMUTH.to_radians());
    Vec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos())
}

/// Luminance (Y, normalised as the film's) of a light's radiance towards
/// `w`, by the 1 nm sum over 360–830 nm.
fn luminance(radiance: impl Fn(&SampledWavelengths) -> Vec4) -> f64 {
    let (mut sum, mut norm) = (0.0f64, 0.0f64);
    for nm in (360..=830).step_by(4) {
        let lambdas = Vec4::from_array(std::array::from_fn(|k| (nm + k) as f32));
        let l = radiance(&SampledWavelengths {
            lambda: lambdas,
            pdf: Vec4::ONE,
        });
        for k in 0..4 {
            if nm + k <= 830 {
                let y = cie::cmf(lambdas[k]).y as f64;
                sum += l[k] as f64 * y;
                norm += y;
            }
        }
    }
    sum / norm
}

/// Luminance irradiance on a floor facing +y: the sky by a midpoint rule
/// over the hemisphere, the sun by rings over its disc (in sin²γ, where
/// limb darkening is smooth).
fn floor_irradiance() -> f64 {
    let sun_dir = sun_direction();
    let e = SUN_ELEVATION.to_radians();
    let m = Arc::new(SkyModel::new(e, 4.0, [0.2; SKY_BANDS]));
    let sky = Sky::new(m.clone(), sun_dir, 1.0);
    let sun = Sun::new(m, sun_dir, SUN_DIAMETER_DEGREES, 1.0);
    let (n_t, n_p) = (64, 128);
    let mut sky_e = 0.0;
    for i in 0..n_t {
        let theta = (i as f64 + 0.5) / n_t as f64 * PI / 2.0;
        for j in 0..n_p {
            let phi = (j as f64 + 0.5) / n_p as f64 * 2.0 * PI;
            let w = Vec3::new(
                (theta.sin() * phi.cos()) as f32,
                theta.cos() as f32,
                (theta.sin() * phi.sin()) as f32,
            );
            let d_omega = theta.sin() * (PI / 2.0 / n_t as f64) * (2.0 * PI / n_p as f64);
            sky_e += luminance(|wl| sky.radiance(w, wl)) * theta.cos() * d_omega;
        }
    }
    let alpha = (0.5 * SUN_DIAMETER_DEGREES as f64).to_radians();
    let frame = prism::geometry::Frame::from_normal(sun_dir);
    let (rings, spokes) = (48, 12);
    let mut sun_e = 0.0;
    for i in 0..rings {
        // s = sin²γ / sin²α uniform: dω = π sin²α ds / cos γ per ring.
        let s = (i as f64 + 0.5) / rings as f64;
        let gamma = (s.sqrt() * alpha.sin()).asin();
        for k in 0..spokes {
            let phi = 2.0 * PI * (k as f64 + 0.5) / spokes as f64;
            let local = Vec3::new(
                (gamma.sin() * phi.cos()) as f32,
                (gamma.sin() * phi.sin()) as f32,
                gamma.cos() as f32,
            );
            let w = frame.to_world(local).normalize();
            let d_omega = PI * alpha.sin().powi(2) / (rings * spokes) as f64 / gamma.cos();
            sun_e += luminance(|wl| sun.radiance(w, wl)) * w.y as f64 * d_omega;
        }
    }
    sky_e + sun_e
}

/// A camera straight above a grey floor under sun and sky (nothing else,
/// so it sees the whole sky; small, so that light paths find the camera):
/// every pixel is ρ/π × the floor's irradiance. Image means over independent
/// runs give the error bar (photons and splats correlate pixels).
fn floor_mean(integrator: &str, spp: u32, runs: u64) -> (f64, f64) {
    let scene = common::scene(&format!(
        "[camera]\nposition = [0, 3, 0]\nlook_at = [0, 0, 0.001]\nfov = 30\n\
         [film]\nresolution = [16, 16]\nspp = {spp}\n\
         [integrator]\n{integrator}\nmax_depth = 1\n\
         [materials.floor]\ntype = \"diffuse\"\nreflectance = {ALBEDO}\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-2, 0, -2], [-2, 0, 2], [2, 0, 2], [2, 0, -2]]\nmaterial = \"floor\"\n\
         {}",
        sky_table("")
    ));
    let means: Vec<f64> = (1..=runs)
        .map(|seed| {
            let options = RenderOptions {
                seed,
                threads: Some(2),
                ..RenderOptions::with_spp(&scene.settings.film, spp)
            };
            let (film, stats) = render(&scene.scene, &scene.settings, &options).unwrap();
            assert_eq!(stats.non_finite, 0);
            image_mean(&film)
        })
        .collect();
    let n = runs as f64;
    let mean = means.iter().sum::<f64>() / n;
    let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

fn image_mean(film: &Film) -> f64 {
    common::region_mean(film, 0, 0, film.width, film.height).0
}

/// Every integrator lights the floor as the quadrature says: next-event
/// estimation of sun and sky with MIS (path), light paths from both (light
/// tracer, bdpt) and photons (sppm: the floor is evenly lit, so its
/// density estimate has no blur bias). Within 5 standard errors (t with
/// 7 degrees of freedom: p ≈ 1.6e-3) plus the quadrature's 0.2 %.
#[test]
fn a_floor_under_sun_and_sky_is_lit_as_the_quadrature_says_by_every_integrator() {
    let expected = ALBEDO / PI * floor_irradiance();
    for (integrator, spp) in [
        ("type = \"path\"", 16),
        ("type = \"path\"\nstrategy = \"nee\"", 16),
        ("type = \"light\"", 16),
        ("type = \"bdpt\"", 16),
        ("type = \"sppm\"\nradius = 0.05\nphotons = 20000", 4),
    ] {
        let (mean, se) = floor_mean(integrator, spp, 8);
        eprintln!(
            "{}: {mean:.5} ± {se:.5}, expected {expected:.5}",
            integrator.replace('\n', " ")
        );
        assert!(
            (mean - expected).abs() < 5.0 * se + 2e-3 * expected,
            "{integrator}: {mean} ± {se}, expected {expected}"
        );
    }
}

/// Spheres on a floor: the strategies agree (diffuse and rough gold; the
/// sun is made 3° wide so that BSDF sampling alone finds it often enough
/// to compare), and bdpt agrees with the path tracer with rough glass
/// added (its caustics need the spread of independent runs for errors).
#[test]
fn strategies_and_bdpt_agree_under_sun_and_sky() {
    let body = format!(
        "[camera]\nposition = [0, 1.5, -4]\nlook_at = [0, 0.6, 0]\nfov = 40\n\
         [film]\nresolution = [32, 24]\nspp = 16\n\
         [materials.m]\ntype = \"diffuse\"\nreflectance = 0.7\n\
         [materials.gold]\ntype = \"conductor\"\nmetal = \"Au\"\nroughness = 0.3\n\
         [materials.glass]\ntype = \"dielectric\"\nior = 1.5\nroughness = 0.2\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]\nmaterial = \"m\"\n\
         [[shape]]\ntype = \"sphere\"\ncenter = [-0.8, 0.5, 0]\nradius = 0.5\nmaterial = \"glass\"\n\
         [[shape]]\ntype = \"sphere\"\ncenter = [0.4, 0.5, 0.3]\nradius = 0.5\nmaterial = \"gold\"\n\
         {}",
        sky_table(", sun_aperture = 3")
    );
    let films: Vec<_> = ["mis", "nee", "bsdf"]
        .iter()
        .map(|s| {
            common::render_film(
                &common::scene(&format!(
                    "{}\n[integrator]\nstrategy = \"{s}\"\n",
                    body.replace("spp = 16", "spp = 256")
                        .replace("material = \"glass\"", "material = \"m\"")
                )),
                2,
            )
        })
        .collect();
    common::assert_blocks_agree(&films[0], &films[1], 5.0, "mis against nee");
    common::assert_blocks_agree(&films[0], &films[2], 5.0, "mis against bsdf");
    common::agree::assert_integrators_agree(&body, "bdpt", "bdpt under sun and sky");
}

#[test]
fn bad_skies_are_clear_errors() {
    let error = |sky: &str| match prism::load::load_str(
        &format!("[camera]\nposition = [0, 1, -5]\nlook_at = [0, 0, 0]\n[environment]\n{sky}"),
        std::path::Path::new("."),
    ) {
        Ok(_) => panic!("expected an error for {sky}"),
        Err(e) => e.to_string(),
    };
    let e = error("sky = { sun_elevation = -5 }");
    assert!(
        e.contains("sky.sun_elevation") && e.contains("above the horizon"),
        "{e}"
    );
    let e = error("sky = { sun_elevation = 20, turbidity = 12 }");
    assert!(e.contains("sky.turbidity") && e.contains("[1, 10]"), "{e}");
    let e = error("sky = { sun_elevation = 20, ground_albedo = 1.5 }");
    assert!(e.contains("ground_albedo") && e.contains("[0, 1]"), "{e}");
    let e = error("sky = { sun_elevation = 20, sun_aperture = 0 }");
    assert!(e.contains("sun_aperture"), "{e}");
    let e = error("sky = { sun_elevation = 20 }\nrotate = 30");
    assert!(e.contains("sun_azimuth"), "{e}");
    let e = error("sky = { sun_elevation = 20 }\nradiance = 1");
    assert!(e.contains("one of `radiance`"), "{e}");
    let e = error("sky = { sun_elevation = 20, sun_elevaton = 3 }");
    assert!(e.contains("sun_elevaton"), "{e}");
    let e = error("sky = { sun_elevation = nan }");
    assert!(e.contains("sun_elevation"), "{e}");
}
