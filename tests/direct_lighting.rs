//! Direct lighting with a closed form: a Lambertian floor under an emitting
//! rectangle. The irradiance from a uniform polygonal source is Lambert's
//! formula E = (L/2) Σ θᵢ n·(vᵢ × vᵢ₊₁)/|vᵢ × vᵢ₊₁|, so the floor's radiance
//! is ρ/π · E at every point.

mod common;

use glam::DVec3;
use prism::geometry::Ray;
use prism::sampler::Sampler;
use prism::spectrum::{cie, SampledWavelengths};

const LIGHT: [[f64; 3]; 4] = [
    [-1.0, 1.0, -0.5],
    [1.0, 1.0, -0.5],
    [1.0, 1.0, 0.5],
    [-1.0, 1.0, 0.5],
];

fn lambert_irradiance(p: DVec3, radiance: f64) -> f64 {
    let v: Vec<DVec3> = LIGHT
        .iter()
        .map(|c| (DVec3::from(*c) - p).normalize())
        .collect();
    let mut sum = 0.0;
    for i in 0..4 {
        let (a, b) = (v[i], v[(i + 1) % 4]);
        let theta = a.dot(b).clamp(-1.0, 1.0).acos();
        sum += theta * a.cross(b).normalize().dot(DVec3::Y);
    }
    0.5 * radiance * sum.abs()
}

fn scene(strategy: &str) -> prism::scene::Scene {
    common::scene(&format!(
        r#"
        [camera]
        position = [0, 3, -5]
        look_at = [0, 0, 0]

        [film]
        max_depth = 1

        [integrator]
        strategy = "{strategy}"

        [materials.floor]
        type = "diffuse"
        reflectance = 0.5

        [[shape]]
        type = "quad"
        vertices = [[-50, 0, -50], [-50, 0, 50], [50, 0, 50], [50, 0, -50]]
        material = "floor"

        [[shape]]   # faces down (−y) by its winding
        type = "quad"
        vertices = {LIGHT:?}
        emission = 3.0
        "#
    ))
}

#[test]
fn floor_radiance_matches_lambert_formula() {
    for strategy in ["mis", "nee", "bsdf"] {
        let s = scene(strategy);
        for (i, target) in [
            [0.0, 0.0, 0.0],
            [0.7, 0.0, 0.2],
            [2.5, 0.0, -1.0],
            [-1.5, 0.0, 1.2],
        ]
        .iter()
        .enumerate()
        {
            let target = DVec3::from(*target);
            // Look at the floor point from below the light's plane.
            let origin = DVec3::new(6.0, 0.5, -3.0);
            let dir = (target - origin).normalize().as_vec3();
            // BSDF sampling rarely finds a distant light: it needs more samples.
            let n: u64 = if strategy == "bsdf" { 400_000 } else { 40_000 };
            let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
            for k in 0..n {
                let mut sampler = Sampler::for_sample(11, i as u32, 0, k);
                let mut wl = SampledWavelengths::sample_visible(sampler.next_f32());
                let ray = Ray::new(origin.as_vec3(), dir);
                let l = common::path_radiance(&s, ray, &mut wl, &mut sampler);
                let y = cie::sampled_to_xyz(l, &wl).y as f64;
                sum += y;
                sum_sq += y * y;
            }
            let mean = sum / n as f64;
            let std_err = ((sum_sq / n as f64 - mean * mean) / (n - 1) as f64).sqrt();
            let expected = 0.5 / std::f64::consts::PI * lambert_irradiance(target, 3.0);
            assert!(
                (mean - expected).abs() < 4.5 * std_err,
                "{strategy} at {target}: {mean} ± {std_err}, expected {expected}"
            );
            assert!(
                std_err < 0.02 * expected,
                "{strategy}: error bar too wide at {target}: {mean} ± {std_err}"
            );
        }
    }
}
