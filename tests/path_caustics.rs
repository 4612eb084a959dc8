//! Path tracing with caustics from photons (`path_caustics`): consistent,
//! not unbiased. Against the closed form of a point light's caustic in a
//! mirror, blurred over the photon radius (the direct light is the path
//! tracer's, exact); against the path tracer where photons are aimed at
//! glass and metal from an area light and from a sky; and the same image
//! for any number of threads.

use crate::common;

use common::caustic;
use common::region_mean;

/// A rough glass sphere and a rough metal one on a floor, under a panel
/// light and a uniform sky: caustics that the path tracer also converges
/// on, with photons aimed at the spheres from both lights.
const SPHERES: &str = r#"
[camera]
position = [0, 2.5, -5]
look_at = [0, 0.5, 0]
fov = 40
[film]
resolution = [32, 24]
[environment]
radiance = "D65"
scale = 0.3
[materials.floor]
type = "diffuse"
reflectance = 0.7
[materials.glass]
type = "dielectric"
ior = 1.5
roughness = 0.3
[materials.metal]
type = "conductor"
metal = "Au"
roughness = 0.3
[[shape]]
type = "quad"
vertices = [[-10, 0, -10], [-10, 0, 10], [10, 0, 10], [10, 0, -10]]
material = "floor"
[[shape]]
type = "sphere"
center = [-0.7, 0.6, 0]
radius = 0.6
material = "glass"
[[shape]]
type = "sphere"
center = [0.8, 0.5, 0.3]
radius = 0.5
material = "metal"
[[shape]]
type = "quad"
vertices = [[-1, 4, 1], [1, 4, 1], [1, 4, 3], [-1, 4, 3]]
emission = "D65"
emission_scale = 5
"#;

fn render(scene: &prism::load::Loaded, iterations: u32) -> prism::film::Film {
    let options = prism::render::RenderOptions {
        threads: Some(2),
        ..prism::render::RenderOptions::with_spp(&scene.settings.film, iterations)
    };
    let (film, stats) = prism::render::render(&scene.scene, &scene.settings, &options).unwrap();
    assert_eq!(stats.non_finite, 0);
    film
}

/// The mirror's caustic of a point light (no camera path can find it)
/// comes from the photons, blurred over their fixed radius; the direct
/// light from light sampling. Every 8 × 8 block within 5σ of that closed
/// form, with error bars narrow enough to mean something.
#[test]
fn path_caustics_measures_the_mirror_caustic_blurred_by_its_radius() {
    let r = 0.5;
    let s = caustic::scene(
        "path_caustics",
        &format!("radius = {r}\nalpha = 1\nphotons = 20000"),
        false,
        2,
    );
    let film = render(&s, 256);
    let expected = caustic::expected_pixels(&s.scene, false, false, r);
    let (w, h) = (s.settings.film.width, s.settings.film.height);
    let mut worst = 0.0f64;
    for y0 in (0..h).step_by(8) {
        for x0 in (0..w).step_by(8) {
            let (mut m, mut v, mut e, mut n) = (0.0, 0.0, 0.0, 0.0);
            for y in y0..(y0 + 8).min(h) {
                for x in x0..(x0 + 8).min(w) {
                    if let Some(ex) = expected[(y * w + x) as usize] {
                        let (pm, pv) = region_mean(&film, x, y, x + 1, y + 1);
                        (m, v, e, n) = (m + pm, v + pv, e + ex, n + 1.0);
                    }
                }
            }
            if n < 8.0 {
                continue;
            }
            let (m, sd, e) = (m / n, (v / (n * n)).sqrt(), e / n);
            assert!(sd < 0.01 * m, "error bar too wide to test anything");
            let z = (m - e).abs() / sd;
            worst = worst.max(z);
            assert!(z < 5.0, "block ({x0}, {y0}): {m} against {e} ± {sd}");
        }
    }
    eprintln!("mirror caustic: worst block {worst:.2}σ from the blurred closed form");
}

/// Against the path tracer, 16 runs each, every block within 5σ: the light
/// through the glass and off the metal that camera paths leave to photons
/// is all there, aimed from the panel (cones towards the spheres) and from
/// the sky (a disc facing the spheres), and none is counted twice.
#[test]
fn path_caustics_agrees_with_the_path_tracer() {
    common::agree::assert_integrators_agree(SPHERES, "path_caustics", "path_caustics");
}

/// The same sums in every pixel on 1 and 3 threads (photon maps included).
#[test]
fn path_caustics_is_the_same_for_any_thread_count() {
    let s = common::scene(&format!(
        "{SPHERES}\n[integrator]\ntype = \"path_caustics\"\n"
    ));
    let one = common::render_film(&s, 1);
    let three = common::render_film(&s, 3);
    for y in 0..24 {
        for x in 0..32 {
            assert_eq!(one.sums(x, y), three.sums(x, y), "pixel ({x}, {y})");
        }
    }
}

/// The default photon count follows what the pilots measure: photon paths
/// get at least an eighth of the camera samples' rays, and more where
/// photons carry the image. The mirror's caustic of a point light, which
/// only photons find, owes them more of its camera samples' mean square
/// than caustics on a floor lit mostly by a panel and a sky, and gets the
/// larger share of rays. The pilots take fixed streams: a second
/// integrator measures the same.
#[test]
fn default_photon_count_follows_what_photons_cost_and_carry() {
    use prism::integrator::{Integrator, PhotonBudget};
    let size = "resolution = [640, 480]";
    let floor = common::scene(&format!(
        "{}\n[integrator]\ntype = \"path_caustics\"\n",
        SPHERES.replace("resolution = [32, 24]", size)
    ));
    let mirror_text =
        caustic::text("path_caustics", "", false, 2).replace("resolution = [32, 24]", size);
    let mirror = common::scene(&mirror_text);
    let budget = |s: &prism::load::Loaded| -> PhotonBudget {
        match &s.settings.integrator {
            Integrator::PathCaustics(p) => p.photon_budget(&s.scene),
            other => panic!("path_caustics, not {}", other.name()),
        }
    };
    // Photon rays against camera rays, over the whole image.
    let share = |b: &PhotonBudget| {
        b.per_iteration as f64 * b.rays_per_photon / (640.0 * 480.0 * b.rays_per_camera_sample)
    };
    let (on_floor, in_mirror) = (budget(&floor), budget(&mirror));
    eprintln!(
        "floor {on_floor:?} {:.3}; mirror {in_mirror:?} {:.3}",
        share(&on_floor),
        share(&in_mirror)
    );
    for b in [&on_floor, &in_mirror] {
        assert!(
            b.rays_per_photon > 0.0 && b.rays_per_camera_sample > 0.0,
            "{b:?}"
        );
        assert!(share(b) > 0.124, "photons get at least an eighth: {b:?}");
    }
    assert!(
        in_mirror.photon_moment_share > 2.0 * on_floor.photon_moment_share,
        "the mirror's caustic owes photons more: {in_mirror:?} against {on_floor:?}"
    );
    assert!(share(&in_mirror) > 1.5 * share(&on_floor));
    let again = budget(&common::scene(&mirror_text));
    assert_eq!(again.per_iteration, in_mirror.per_iteration);
    assert_eq!(
        again.photon_moment_share.to_bits(),
        in_mirror.photon_moment_share.to_bits()
    );
}
