//! Exact spheres against their closed forms, beside the tessellated
//! spheres they replace: the irradiance a spherical lamp casts, and the
//! area of a sphere's silhouette.

use crate::common;

use prism::render::{render, RenderOptions};

/// A diffuse floor (albedo ρ) under a spherical lamp of radiance `L`,
/// radius r = 0.5, its centre at height h = 3 above the origin: the floor's radiance
/// there is ρ/π · π L (r/h)² = ρ L (r/h)² (the lamp wholly above the
/// horizon). Returns the path tracer's estimate and its standard error.
fn floor_under_lamp(lamp: &str) -> (f64, f64) {
    let s = common::scene(&format!(
        r#"
        [camera]
        position = [0, 5, -5]
        look_at = [0, 0, 0]
        [integrator]
        max_depth = 1
        [materials.floor]
        type = "diffuse"
        reflectance = 0.5
        [[shape]]
        type = "quad"
        vertices = [[-50, 0, -50], [-50, 0, 50], [50, 0, 50], [50, 0, -50]]
        material = "floor"
        [[shape]]
        type = "sphere"
        center = [0, 3, 0]
        radius = 0.5
        emission = 3
        {lamp}
        "#
    ));
    common::floor_luminance(&s, glam::Vec3::ZERO)
}

#[test]
fn a_spherical_lamp_lights_a_floor_as_its_closed_form_says() {
    // Y of a flat emission of 3 is 3 (prism's flat spectra have Y = value).
    let expected = 0.5 * 3.0 * (0.5f64 / 3.0).powi(2);
    let (exact, se) = floor_under_lamp("");
    assert!(
        (exact - expected).abs() < 5.0 * se + 1e-4 * expected,
        "exact sphere: {exact} ± {se}, expected {expected}"
    );
    let (coarse, se_coarse) = floor_under_lamp("tessellate = true\nsegments = 16");
    let (fine, se_fine) = floor_under_lamp("tessellate = true\nsegments = 256");
    eprintln!(
        "irradiance: expected {expected:.6}; exact {exact:.6} ± {se:.1e}; \
         16 segments {coarse:.6} ± {se_coarse:.1e}; 256 segments {fine:.6} ± {se_fine:.1e}"
    );
    // Sampled by the solid angle it subtends, the exact lamp is seen by
    // every light sample at its own density; a tessellated one is sampled
    // by area, triangle by triangle (measured: 50× the standard error).
    assert!(se < se_fine / 10.0, "{se} vs {se_fine}");
}

/// The image's mean luminance times its area: an orthographic view of a
/// sphere of radiance 1 on black sees its silhouette, π r².
fn silhouette_area(sphere: &str) -> (f64, f64) {
    let s = common::scene(&format!(
        r#"
        [camera]
        type = "orthographic"
        position = [0, 0, -5]
        look_at = [0, 0, 0]
        width = 2.5
        [film]
        resolution = [64, 64]
        spp = 64
        [integrator]
        max_depth = 1
        [[shape]]
        type = "sphere"
        radius = 1
        emission = 1
        {sphere}
        "#
    ));
    let options = RenderOptions {
        threads: Some(2),
        ..s.settings.options()
    };
    let (film, _) = render(&s.scene, &s.settings, &options).unwrap();
    let (mean, var) = common::region_mean(&film, 0, 0, 64, 64);
    (mean * 2.5 * 2.5, var.sqrt() * 2.5 * 2.5)
}

#[test]
fn a_spheres_silhouette_has_its_area() {
    let expected = std::f64::consts::PI;
    let (exact, se) = silhouette_area("");
    assert!(
        (exact - expected).abs() < 4.0 * se + 1e-3,
        "exact sphere: {exact} ± {se}, expected {expected}"
    );
    let (coarse, se_coarse) = silhouette_area("tessellate = true\nsegments = 16");
    eprintln!(
        "silhouette: expected {expected:.5}; exact {exact:.5} ± {se:.1e}; 16 segments {coarse:.5} ± {se_coarse:.1e}"
    );
    assert!(coarse < expected - 4.0 * se_coarse);
}
