//! Point, spot and directional lights against their closed forms: a
//! Lambertian floor of albedo ρ lit by a point of intensity I at distance d
//! and angle θ has radiance ρ/π · I cos θ / d²; under a directional light of
//! irradiance E, ρ/π · E cos θ. A spot light is the point light inside its
//! inner cone, nothing outside its outer cone, and smoothstep in between.

use crate::common;

use std::path::Path;

use glam::{DVec3, Vec3};
use prism::light::LightSource;
use prism::load::Loaded;
use prism::spectrum::SampledWavelengths;

const FLOOR: &str = "[camera]\nposition = [0, 5, -5]\nlook_at = [0, 0, 0]\n\
    [integrator]\nmax_depth = 1\n\
    [materials.floor]\ntype = \"diffuse\"\nreflectance = 0.5\n\
    [[shape]]\ntype = \"quad\"\nvertices = [[-20, 0, -20], [-20, 0, 20], [20, 0, 20], [20, 0, -20]]\nmaterial = \"floor\"\n";

fn assert_close(got: (f64, f64), expected: f64, what: &str) {
    // 5 standard errors of the wavelength noise, plus 1e-4 relative for
    // single-precision rounding.
    let tol = 5.0 * got.1 + 1e-4 * expected.abs() + 1e-9;
    assert!(
        (got.0 - expected).abs() <= tol,
        "{what}: {} ± {}, expected {expected}",
        got.0,
        got.1
    );
}

fn scene(lights: &str) -> Loaded {
    common::scene(&format!("{FLOOR}{lights}"))
}

#[test]
fn point_light_irradiance_follows_the_inverse_square_law() {
    let light = DVec3::new(0.5, 2.0, -0.3);
    let s = scene("[[light]]\ntype = \"point\"\nposition = [0.5, 2, -0.3]\nintensity = 10\n");
    for target in [
        [0.0, 0.0, 0.0],
        [1.5, 0.0, 0.7],
        [-3.0, 0.0, 2.0],
        [0.5, 0.0, -0.3],
    ] {
        let t = DVec3::from(target);
        let d = light - t;
        let expected = 0.5 / std::f64::consts::PI * 10.0 * (d.y / d.length()) / d.length_squared();
        assert_close(
            common::floor_luminance(&s, t.as_vec3()),
            expected,
            &format!("point at {t}"),
        );
    }
}

#[test]
fn spot_light_is_a_point_light_inside_its_cone_and_dark_outside() {
    // Straight down from 2 m: the inner cone (20°) reaches 0.73 m, the
    // outer (30°) 1.15 m.
    let s = scene(
        "[[light]]\ntype = \"spot\"\nposition = [0, 2, 0]\nlook_at = [0, 0, 0]\n\
         intensity = 10\ncone_angle = 30\nfalloff_start = 20\n",
    );
    let point = |x: f64| {
        let d = DVec3::new(0.0, 2.0, 0.0) - DVec3::new(x, 0.0, 0.0);
        0.5 / std::f64::consts::PI * 10.0 * (d.y / d.length()) / d.length_squared()
    };
    for x in [0.0, 0.4, 0.7] {
        assert_close(
            common::floor_luminance(&s, Vec3::new(x as f32, 0.0, 0.0)),
            point(x),
            "inside",
        );
    }
    for x in [1.2, 3.0] {
        let (m, _) = common::floor_luminance(&s, Vec3::new(x as f32, 0.0, 0.0));
        assert_eq!(m, 0.0, "outside the cone at x = {x}");
    }
    // In the falloff band: smoothstep of the cosine.
    let x = 0.95f64;
    let cos = 2.0 / (4.0 + x * x).sqrt();
    let (lo, hi) = (30f64.to_radians().cos(), 20f64.to_radians().cos());
    let t = (cos - lo) / (hi - lo);
    let expected = point(x) * t * t * (3.0 - 2.0 * t);
    assert_close(
        common::floor_luminance(&s, Vec3::new(x as f32, 0.0, 0.0)),
        expected,
        "falloff",
    );
}

#[test]
fn directional_light_gives_irradiance_times_cosine() {
    let s = scene("[[light]]\ntype = \"directional\"\ndirection = [1, -2, 0.5]\nirradiance = 3\n");
    let cos = 2.0 / (1.0f64 + 4.0 + 0.25).sqrt();
    let expected = 0.5 / std::f64::consts::PI * 3.0 * cos;
    for target in [[0.0, 0.0, 0.0], [4.0, 0.0, -3.0]] {
        assert_close(
            common::floor_luminance(&s, Vec3::from(target)),
            expected,
            "directional",
        );
    }
}

#[test]
fn power_is_intensity_over_the_solid_angle() {
    let wl = SampledWavelengths::sample_visible(0.4);
    let li = |lights: &str| {
        let s = scene(lights);
        s.scene
            .lights
            .get(0)
            .sample_li(Vec3::ZERO, (0.5, 0.5), &wl)
            .unwrap()
            .li
    };
    let by_intensity = li("[[light]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = 10\n");
    let by_power = li(&format!(
        "[[light]]\ntype = \"point\"\nposition = [0, 2, 0]\npower = {}\n",
        40.0 * std::f64::consts::PI
    ));
    assert!((by_intensity - by_power).abs().max_element() < 1e-5 * by_intensity.x);
}

#[test]
fn bad_lights_are_clear_errors() {
    let error = |lights: &str| match prism::load::load_str(
        &format!("{FLOOR}{lights}"),
        Path::new(env!("CARGO_MANIFEST_DIR")),
    ) {
        Ok(_) => panic!("expected an error for {lights}"),
        Err(e) => e.to_string(),
    };
    let e = error("[[light]]\ntype = \"spot\"\nposition = [0, 2, 0]\nintensity = 1\n");
    assert!(e.contains("light[0]") && e.contains("look_at"), "{e}");
    let e = error("[[light]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = 1\npower = 2\n");
    assert!(e.contains("either `intensity` or `power`"), "{e}");
    let e = error("[[light]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = 1\ndirection = [0, -1, 0]\n");
    assert!(
        e.contains("light[0].direction") && e.contains("does not apply"),
        "{e}"
    );
    let e = error("[[light]]\ntype = \"spot\"\nposition = [0, 2, 0]\nlook_at = [0, 0, 0]\nintensity = 1\ncone_angle = 0\n");
    assert!(e.contains("cone_angle"), "{e}");
    let e = error("[[light]]\ntype = \"directional\"\ndirection = [0, 0, 0]\nirradiance = 1\n");
    assert!(e.contains("must not be zero"), "{e}");
    let e = error("[[light]]\ntype = \"lamp\"\n");
    assert!(e.contains("unknown variant `lamp`"), "{e}");
}
