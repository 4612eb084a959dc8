//! Direct lighting with a closed form: a Lambertian floor under an emitting
//! rectangle. The irradiance from a uniform polygonal source is Lambert's
//! formula E = (L/2) Σ θᵢ n·(vᵢ × vᵢ₊₁)/|vᵢ × vᵢ₊₁|, so the floor's radiance
//! is ρ/π · E at every point.

use crate::common;

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

/// A Lambertian floor under a light (`light`, its `[[shape]]` table), direct
/// light only, found by `strategy`.
fn floor_scene(strategy: &str, light: &str) -> String {
    format!(
        r#"
        [camera]
        position = [0, 3, -5]
        look_at = [0, 0, 0]

        [integrator]
        max_depth = 1
        strategy = "{strategy}"

        [materials.floor]
        type = "diffuse"
        reflectance = 0.5

        [[shape]]
        type = "quad"
        vertices = [[-50, 0, -50], [-50, 0, 50], [50, 0, 50], [50, 0, -50]]
        material = "floor"

        {light}
        "#
    )
}

fn scene(strategy: &str) -> prism::load::Loaded {
    common::scene(&floor_scene(
        strategy,
        &format!(
            "[[shape]]   # faces down (−y) by its winding\ntype = \"quad\"\nvertices = {LIGHT:?}\nemission = 3.0"
        ),
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

/// Mean luminance the path tracer sees at floor point `target` (looked at
/// from below the light's plane) and its standard error.
fn floor_point(s: &prism::load::Loaded, target: DVec3, n: u64, seed: u64) -> (f64, f64) {
    let origin = DVec3::new(6.0, 0.5, -3.0);
    let dir = (target - origin).normalize().as_vec3();
    let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
    for k in 0..n {
        let mut sampler = Sampler::for_sample(seed, 0, 0, k);
        let mut wl = SampledWavelengths::sample_visible(sampler.next_f32());
        let l = common::path_radiance(s, Ray::new(origin.as_vec3(), dir), &mut wl, &mut sampler);
        let y = cie::sampled_to_xyz(l, &wl).y as f64;
        sum += y;
        sum_sq += y * y;
    }
    let mean = sum / n as f64;
    (
        mean,
        ((sum_sq / n as f64 - mean * mean) / (n - 1) as f64).sqrt(),
    )
}

/// Standard errors between two (mean, standard error) estimates.
fn z(a: (f64, f64), b: (f64, f64)) -> f64 {
    (a.0 - b.0).abs() / a.1.hypot(b.1)
}

#[test]
fn cut_out_lights_emit_only_where_they_are_present() {
    // The light is an OBJ card (Ke) of a cut-out material: rays pass where
    // it is absent and find no emission there, so light sampling, which
    // picks points on the whole card, must count none there either, or
    // the strategies disagree.
    let dir = tempfile::tempdir().unwrap();
    // A matte 8 texels wide: black (absent) on the left half.
    image::GrayImage::from_fn(8, 1, |x, _| image::Luma([if x < 4 { 0 } else { 255 }]))
        .save(dir.path().join("matte.png"))
        .unwrap();
    let card = |name: &str, mtl: &str| {
        std::fs::write(
            dir.path().join(format!("{name}.obj")),
            format!(
                "mtllib {name}.mtl\nv -1 1 -0.5\nv 1 1 -0.5\nv 1 1 0.5\nv -1 1 0.5\n\
                 vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl lamp\nf 1/1 2/2 3/3 4/4\n"
            ),
        )
        .unwrap();
        std::fs::write(
            dir.path().join(format!("{name}.mtl")),
            format!("newmtl lamp\nKd 0 0 0\nKe 3 3 3\n{mtl}\n"),
        )
        .unwrap();
    };
    card("solid", "");
    card("veil", "d 0.4");
    card("half", "map_d matte.png");
    let scene = |name: &str, strategy: &str| {
        let path = dir.path().join(format!("{name}-{strategy}.toml"));
        let light = format!("[[shape]]\ntype = \"obj\"\nfile = \"{name}.obj\"");
        std::fs::write(&path, floor_scene(strategy, &light)).unwrap();
        prism::load::load(&path).unwrap_or_else(|e| panic!("{e}"))
    };
    let target = DVec3::new(0.3, 0.0, 0.1);
    let n = |strategy: &str| if strategy == "bsdf" { 400_000 } else { 40_000 };
    let solid = floor_point(&scene("solid", "nee"), target, 40_000, 3);
    for strategy in ["nee", "bsdf", "mis"] {
        // Present with probability 0.4 everywhere: 0.4 of the light.
        let veil = floor_point(&scene("veil", strategy), target, n(strategy), 5);
        let expected = (0.4 * solid.0, 0.4 * solid.1);
        assert!(
            z(veil, expected) < 4.5,
            "{strategy}: a 0.4 veil gives {veil:?}, 0.4 of the solid card {expected:?}"
        );
        assert!(veil.1 < 0.02 * veil.0, "{strategy}: {veil:?}");
    }
    // Half the card absent: light sampling and BSDF sampling agree, on
    // about half of the whole card's light (the right half is nearer).
    let (nee, bsdf) = (
        floor_point(&scene("half", "nee"), target, 40_000, 7),
        floor_point(&scene("half", "bsdf"), target, 400_000, 9),
    );
    assert!(
        z(nee, bsdf) < 4.5,
        "half a card: light sampling {nee:?}, BSDF sampling {bsdf:?}"
    );
    let share = nee.0 / solid.0;
    assert!(
        (0.5..0.75).contains(&share),
        "half a card gives {share} of the whole"
    );
}
