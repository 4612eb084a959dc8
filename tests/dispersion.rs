//! Dispersion is physical: a ray through an N-SF11 prism is deviated by the
//! angle Snell's law and the Sellmeier equation give, and a rendered
//! spectrum through the prism runs from red (least deviated) to violet.

use crate::common;

use glam::{Vec3, Vec4};
use prism::geometry::offset::offset_ray_origin;
use prism::geometry::Ray;
use prism::material::{Ior, ShadingGeometry, TransportMode};
use prism::render::render;
use prism::spectrum::SampledWavelengths;

/// Traces one ray at wavelength `lambda` through the prism scene's
/// refractions (always taking the transmitted branch) and returns the
/// exit direction.
fn trace(scene: &prism::scene::Scene, origin: Vec3, dir: Vec3, lambda: f32) -> Vec3 {
    let mut ray = Ray::new(origin, dir);
    let mut wl = SampledWavelengths {
        lambda: Vec4::splat(lambda),
        pdf: Vec4::ONE,
    };
    for _ in 0..2 {
        let hit = scene.intersect(&ray).expect("the ray meets the prism");
        let material = &scene.materials[hit.material as usize];
        let n = material.ior().unwrap().eval(lambda);
        let geom = ShadingGeometry {
            ng: hit.ng,
            ns: hit.ns,
            wo: -ray.dir,
        };
        let bsdf = material.bsdf(&geom, glam::Vec2::ZERO, &mut wl, Vec4::splat(n));
        // uc just below 1 picks refraction (Fresnel reflectance < 1).
        let smp = bsdf
            .sample(geom.wo, 0.999_999, (0.5, 0.5), TransportMode::Radiance)
            .expect("refraction, not total internal reflection");
        ray = Ray::new(offset_ray_origin(hit.p, hit.p_err, hit.ng, smp.wi), smp.wi);
    }
    ray.dir
}

#[test]
fn prism_deviation_matches_snell_and_sellmeier() {
    let scene = common::scene(
        r#"
        [camera]
        position = [0, 0.4, -5]
        look_at = [0, 0.4, 0]

        [materials.sf11]
        type = "dielectric"
        ior = "N-SF11"

        [[shape]]
        type = "obj"
        file = "scenes/meshes/prism.obj"
        material = "sf11"
        "#,
    );
    let sf11 = Ior::preset("N-SF11").unwrap();
    let apex = 60f64.to_radians();
    // The left face's outward normal is (−cos 30°, sin 30°); the ray meets
    // it at θ1 = 65° from the normal, travelling 35° above horizontal (at
    // smaller angles N-SF11 reflects totally at the second face).
    let theta1 = 65f64.to_radians();
    let dir = Vec3::new(35f32.to_radians().cos(), 35f32.to_radians().sin(), 0.0);
    let on_face = Vec3::new(-0.25, 0.433, 0.0);
    let origin = on_face - 2.0 * dir;
    let mut deviations = Vec::new();
    for lambda in [450.0f32, 550.0, 650.0] {
        let out = trace(&scene.scene, origin, dir, lambda);
        let traced = (dir.dot(out) as f64).clamp(-1.0, 1.0).acos();
        let n = sf11.eval(lambda) as f64;
        let theta2 = (theta1.sin() / n).asin();
        let theta4 = (n * (apex - theta2).sin()).asin();
        let analytic = theta1 + theta4 - apex;
        assert!(
            (traced - analytic).abs() < 2e-4,
            "{lambda} nm: traced {:.5}°, Snell {:.5}°",
            traced.to_degrees(),
            analytic.to_degrees()
        );
        // The ray leaves downwards (bent towards the base).
        assert!(out.y < dir.y);
        deviations.push(traced);
    }
    // Red is deviated least.
    assert!(
        deviations[2] < deviations[1] && deviations[1] < deviations[0],
        "{deviations:?}"
    );
}

#[test]
fn rendered_spectrum_runs_red_to_violet() {
    // A spectroscope: the camera looks through the prism at a thin white
    // slit (a D65 emitter strip). Each image column sees the slit at the
    // wavelengths that the prism deviates onto it.
    // The camera looks along the 35° ray of the test above; the slit sits
    // 6 units beyond the prism where 550 nm leaves it (32.2° below horizontal).
    let s = common::scene(
        r#"
        [camera]
        position = [-2.707, -1.288, 0]
        look_at = [-0.25, 0.433, 0]
        fov = 12

        [film]
        resolution = [8, 96]
        spp = 64
        max_depth = 4
        spectral_range = [400, 700]
        spectral_buckets = 30

        [materials.sf11]
        type = "dielectric"
        ior = "N-SF11"

        [[shape]]
        type = "obj"
        file = "scenes/meshes/prism.obj"
        material = "sf11"

        [[shape]]   # the slit: 0.06 wide, across the beam
        type = "quad"
        vertices = [[5.314, -2.785, -3], [5.314, -2.785, 3], [5.346, -2.734, 3], [5.346, -2.734, -3]]
        emission = "E"
        two_sided = true
        "#,
    );
    let (film, _) = render(&s.scene, &s.settings, &s.settings.options()).unwrap();
    // Mean wavelength seen by each row that sees the slit.
    let mut centroids = Vec::new();
    for y in 0..96 {
        let (mut w, mut total) = (0.0, 0.0);
        for x in 0..8 {
            for (b, v) in film.spectrum(x, y).iter().enumerate() {
                w += *v as f64 * film.layout.centre(b as u32) as f64;
                total += *v as f64;
            }
        }
        if total > 0.0 {
            centroids.push((y, w / total));
        }
    }
    assert!(
        centroids.len() >= 10,
        "the slit is hardly visible: {centroids:?}"
    );
    let (first, last) = (centroids.first().unwrap().1, centroids.last().unwrap().1);
    assert!(
        (first - last).abs() > 100.0,
        "no spectrum spread: {centroids:?}"
    );
    // Rows are ordered by deviation, so wavelength is monotonic down the image.
    let increasing = first < last;
    for pair in centroids.windows(2) {
        let step = pair[1].1 - pair[0].1;
        assert!(
            if increasing {
                step > -15.0
            } else {
                step < 15.0
            },
            "{centroids:?}"
        );
    }
}
