//! Hard cases the renderer must survive. Each scene is small and fast and
//! asserts the failure it targets: light leaks, self-intersection acne,
//! scale dependence, NaN and infinity, stack overflow.

use crate::common;

use common::{assert_blocks_agree, scene};
use glam::Vec3;
use prism::film::Film;
use prism::geometry::Ray;
use prism::load::Loaded;
use prism::render::{render, RenderOptions, RenderStats};
use prism::sampler::Sampler;
use prism::spectrum::{cie, SampledWavelengths};

/// Renders and asserts what must hold for every scene: no non-finite
/// sample, no IOR stack overflow.
fn render_checked(s: &Loaded) -> (Film, RenderStats) {
    let (film, stats) = render(
        &s.scene,
        &s.settings,
        &RenderOptions {
            threads: Some(2),
            ..s.settings.options()
        },
    )
    .unwrap();
    assert_eq!(stats.non_finite, 0, "non-finite samples");
    assert_eq!(stats.stack_overflows, 0, "IOR stack overflows");
    for y in 0..film.height {
        for x in 0..film.width {
            let (m, v) = film.luminance_and_variance(x, y);
            assert!(
                m.is_finite() && v.is_finite() && m >= -1e-6,
                "pixel ({x}, {y}): {m} ± {v}"
            );
        }
    }
    (film, stats)
}

/// The six faces of an axis-aligned box as TOML quads (outward winding).
fn box_quads(lo: [f64; 3], hi: [f64; 3], material: &str, flip: bool) -> String {
    let [a, b, c] = lo;
    let [d, e, f] = hi;
    let faces = [
        [[a, b, c], [a, b, f], [a, e, f], [a, e, c]],
        [[d, b, c], [d, e, c], [d, e, f], [d, b, f]],
        [[a, b, c], [d, b, c], [d, b, f], [a, b, f]],
        [[a, e, c], [a, e, f], [d, e, f], [d, e, c]],
        [[a, b, c], [a, e, c], [d, e, c], [d, b, c]],
        [[a, b, f], [d, b, f], [d, e, f], [a, e, f]],
    ];
    faces
        .iter()
        .map(|q| {
            format!(
                "[[shape]]\ntype = \"quad\"\nvertices = {q:?}\nmaterial = \"{material}\"\nflip_normals = {flip}\n\n"
            )
        })
        .collect()
}

const MATERIALS: &str = r#"
[materials.white]
type = "diffuse"
reflectance = 0.8
"#;

#[test]
fn closed_box_without_light_is_black_not_nan() {
    let s = scene(&format!(
        "[camera]\nposition = [0, 0, 0]\nlook_at = [0, 0, 1]\n[film]\nresolution = [16, 16]\nspp = 16\n{MATERIALS}{}",
        box_quads([-1.0; 3], [1.0; 3], "white", true)
    ));
    let (film, _) = render_checked(&s);
    assert_eq!(film.xyz(8, 8), Vec3::ZERO);
    assert!((0..16).all(|y| (0..16).all(|x| film.xyz(x, y) == Vec3::ZERO)));
}

#[test]
fn thin_shell_does_not_leak_light() {
    // A camera inside a box whose walls are two surfaces 1e-5 apart (of a
    // scene of size 2), with a bright light all around outside: black.
    let gap = 1e-5;
    let s = scene(&format!(
        "[camera]\nposition = [0, 0, 0]\nlook_at = [0.3, 0.2, 1]\nfov = 120\n[film]\nresolution = [16, 16]\nspp = 32\nmax_depth = 8\n{MATERIALS}{}{}\
         [[shape]]\ntype = \"sphere\"\nradius = 5\nflip_normals = true\nemission = 100\n",
        box_quads([-1.0; 3], [1.0; 3], "white", true),
        box_quads([-1.0 - gap; 3], [1.0 + gap; 3], "white", false),
    ));
    let (film, _) = render_checked(&s);
    assert!(
        (0..16).all(|y| (0..16).all(|x| film.xyz(x, y) == Vec3::ZERO)),
        "light leaked through the shell"
    );
}

#[test]
fn camera_inside_a_closed_mesh_sees_no_outside_light() {
    let s = scene(&format!(
        "[camera]\nposition = [0.1, 0.2, 0]\nlook_at = [0, 0, 1]\nfov = 150\n[film]\nresolution = [16, 16]\nspp = 16\n{MATERIALS}\
         [[shape]]\ntype = \"sphere\"\nradius = 1\ntessellate = true\nsegments = 32\nmaterial = \"white\"\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-3, 3, -3], [3, 3, -3], [3, 3, 3], [-3, 3, 3]]\nemission = 50\ntwo_sided = true\n"
    ));
    let (film, _) = render_checked(&s);
    assert!((0..16).all(|y| (0..16).all(|x| film.xyz(x, y) == Vec3::ZERO)));
}

#[test]
fn light_facing_away_lights_nothing() {
    // The quad faces up (+y); the floor below gets nothing, and its back
    // (which the camera below it sees) is black.
    let s = scene(&format!(
        "[camera]\nposition = [0, 1, -4]\nlook_at = [0, 0.5, 0]\n[film]\nresolution = [16, 16]\nspp = 16\n{MATERIALS}\
         [[shape]]\ntype = \"quad\"\nvertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]\nmaterial = \"white\"\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-1, 2, -1], [-1, 2, 1], [1, 2, 1], [1, 2, -1]]\nemission = 10\n"
    ));
    let (film, _) = render_checked(&s);
    // Black up to float rounding: light sampled on the emitter's own plane
    // (from its unlit back) has cos θ of order 1e-8 instead of 0.
    for y in 0..16 {
        for x in 0..16 {
            assert!(
                film.xyz(x, y).abs().max_element() < 1e-9,
                "pixel ({x}, {y}): {}",
                film.xyz(x, y)
            );
        }
    }
}

#[test]
fn coplanar_faces_do_not_shadow_each_other() {
    // A floor modelled twice (once facing down) renders as the floor once.
    let base = format!(
        "[camera]\nposition = [0, 3, -3]\nlook_at = [0, 0, 0]\n[film]\nresolution = [24, 24]\nspp = 64\nmax_depth = 3\n{MATERIALS}\
         [[shape]]\ntype = \"quad\"\nvertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]\nmaterial = \"white\"\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-1, 2, -1], [1, 2, -1], [1, 2, 1], [-1, 2, 1]]\nemission = 10\n"
    );
    let twice = format!(
        "{base}[[shape]]\ntype = \"quad\"\nvertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]\nmaterial = \"white\"\nflip_normals = true\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-2, 0, -2], [-2, 0, 2], [2, 0, 2], [2, 0, -2]]\nmaterial = \"white\"\n"
    );
    let (a, _) = render_checked(&scene(&base));
    let (b, _) = render_checked(&scene(&twice));
    // 9 blocks at 4.5σ: a false alarm about once in 16000 runs.
    assert_blocks_agree(&a, &b, 4.5, "floor modelled twice");
}

#[test]
fn the_same_image_at_every_scale() {
    // The Cornell Box at 1e-4 and 1e5 of its size: the same picture.
    let base = common::repo_scene(
        "scenes/cornell-box.toml",
        "resolution = [24, 24]\nspp = 64",
        "",
    );
    let scaled = |scale: f64| {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
        let mut t: toml::Table = toml::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
        t.insert(
            "film".into(),
            toml::Value::Table(toml::from_str("resolution = [24, 24]\nspp = 64").unwrap()),
        );
        let cam = t["camera"].as_table().unwrap().clone();
        let mut cam = cam;
        for key in ["position", "look_at"] {
            let v: Vec<toml::Value> = cam[key]
                .as_array()
                .unwrap()
                .iter()
                .map(|x| {
                    toml::Value::Float(
                        x.as_float().or(x.as_integer().map(|i| i as f64)).unwrap() * scale,
                    )
                })
                .collect();
            cam.insert(key.into(), toml::Value::Array(v));
        }
        t.insert("camera".into(), toml::Value::Table(cam));
        for shape in t.get_mut("shape").unwrap().as_array_mut().unwrap() {
            let mut tr = toml::Table::new();
            tr.insert("scale".into(), toml::Value::Float(scale));
            shape
                .as_table_mut()
                .unwrap()
                .insert("transform".into(), toml::Value::Table(tr));
        }
        prism::load::load_str(&toml::to_string(&t).unwrap(), path.parent().unwrap()).unwrap()
    };
    let (reference, _) = render_checked(&base);
    for scale in [1e-4, 1e5] {
        let (img, _) = render_checked(&scaled(scale));
        assert_blocks_agree(&reference, &img, 4.5, &format!("scale {scale}"));
    }
}

#[test]
fn grazing_camera_rays_and_degenerate_triangles() {
    let dir = tempfile::tempdir().unwrap();
    // Zero-area (repeated and collinear vertices) and sliver triangles.
    std::fs::write(
        dir.path().join("bad.obj"),
        "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 0 1\nv 1 0 1e-7\nv 0 1e-9 0\nf 1 2 3\nf 1 1 4\nf 1 4 5\nf 1 2 5\nf 1 2 6\n",
    )
    .unwrap();
    let text = format!(
        "[camera]\nposition = [-3, 1e-6, 0.5]\nlook_at = [3, 1e-6, 0.5]\n[film]\nresolution = [16, 16]\nspp = 16\n{MATERIALS}\
         [[shape]]\ntype = \"obj\"\nfile = \"bad.obj\"\nmaterial = \"white\"\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-50, 0, -50], [-50, 0, 50], [50, 0, 50], [50, 0, -50]]\nmaterial = \"white\"\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-1, 3, -1], [1, 3, -1], [1, 3, 1], [-1, 3, 1]]\nemission = 10\n"
    );
    let s = prism::load::load_str(&text, dir.path()).unwrap();
    assert!(
        s.scene.degenerate_triangles >= 2,
        "{} degenerate triangles dropped",
        s.scene.degenerate_triangles
    );
    render_checked(&s);
}

#[test]
fn tiny_bright_light_matches_its_closed_form() {
    // A sphere of radius 1e-3 and radiance 1e7 one unit above a floor of
    // albedo 0.5: irradiance π L r²/d², floor radiance ρ L r² / d² = 5.
    let s = scene(
        "[camera]\nposition = [0, 2, -2]\nlook_at = [0, 0, 0]\n[film]\nmax_depth = 1\n\
         [materials.floor]\ntype = \"diffuse\"\nreflectance = 0.5\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]\nmaterial = \"floor\"\n\
         [[shape]]\ntype = \"sphere\"\ncenter = [0, 1, 0]\nradius = 1e-3\ntessellate = true\nsegments = 256\nemission = 1e7\n",
    );
    let n = 20_000u64;
    let (mut sum, mut sq) = (0.0, 0.0);
    for k in 0..n {
        let mut sampler = Sampler::for_sample(3, 0, 0, k);
        let mut wl = SampledWavelengths::sample_visible(sampler.next_f32());
        let origin = Vec3::new(0.0, 0.5, -1.0);
        let l = common::path_radiance(
            &s,
            Ray::new(origin, (-origin).normalize()),
            &mut wl,
            &mut sampler,
        );
        let y = cie::sampled_to_xyz(l, &wl).y as f64;
        assert!(y.is_finite());
        sum += y;
        sq += y * y;
    }
    let mean = sum / n as f64;
    let se = ((sq / n as f64 - mean * mean) / n as f64).sqrt();
    // The tessellated sphere's silhouette is 0.03% smaller than the disk.
    let expected = 5.0;
    assert!(
        (mean - expected).abs() < 4.0 * se + 2e-3 * expected,
        "{mean} ± {se}, expected {expected}"
    );
}

#[test]
fn glass_extremes_total_internal_reflection_and_roughness() {
    // Glass spheres of IOR 3 (total internal reflection beyond 19.5°), IOR 1,
    // roughness 0 and 1, and a rough conductor, in a lit box.
    let mut text = format!(
        "[camera]\nposition = [0, 1, -4]\nlook_at = [0, 0.5, 0]\n[film]\nresolution = [24, 16]\nspp = 32\nmax_depth = 64\n{MATERIALS}\
         [[shape]]\ntype = \"quad\"\nvertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]\nmaterial = \"white\"\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-2, 4, -2], [2, 4, -2], [2, 4, 2], [-2, 4, 2]]\nemission = 10\n"
    );
    for (i, (ior, roughness)) in [
        (3.0, 0.0),
        (3.0, 1.0),
        (1.0, 0.0),
        (1.0001, 1.0),
        (1.5, 1.0),
    ]
    .iter()
    .enumerate()
    {
        text += &format!(
            "[materials.g{i}]\ntype = \"dielectric\"\nior = {ior}\nroughness = {roughness}\n\
             [[shape]]\ntype = \"sphere\"\ncenter = [{}, 0.5, 0]\nradius = 0.4\nmaterial = \"g{i}\"\n",
            -2.0 + i as f64
        );
    }
    text += "[materials.metal]\ntype = \"conductor\"\nmetal = \"Cu\"\nroughness = 1\n[[shape]]\ntype = \"sphere\"\ncenter = [0, 1.5, 1]\nradius = 0.4\nmaterial = \"metal\"\n";
    let (film, _) = render_checked(&scene(&text));
    assert!(film.xyz(12, 12).y > 0.0);
}

#[test]
fn deep_nesting_overflows_are_counted_not_a_panic() {
    // Ten nested glass spheres: the stack holds eight.
    let mut text = format!(
        "[camera]\nposition = [0, 0, -5]\nlook_at = [0, 0, 0]\n[film]\nresolution = [8, 8]\nspp = 4\nmax_depth = 64\n{MATERIALS}\
         [[shape]]\ntype = \"quad\"\nvertices = [[-5, 5, 5], [5, 5, 5], [5, -5, 5], [-5, -5, 5]]\nemission = 1\ntwo_sided = true\n"
    );
    for i in 0..10 {
        text += &format!(
            "[materials.g{i}]\ntype = \"dielectric\"\nior = 1.2\n[[shape]]\ntype = \"sphere\"\nradius = {}\ntessellate = true\nsegments = 16\nmaterial = \"g{i}\"\n",
            2.0 - 0.15 * i as f64
        );
    }
    let s = scene(&text);
    let (film, stats) = render(
        &s.scene,
        &s.settings,
        &RenderOptions {
            threads: Some(2),
            ..s.settings.options()
        },
    )
    .unwrap();
    assert!(
        stats.stack_overflows > 0,
        "ten nested media must overflow an eight-entry stack"
    );
    assert_eq!(stats.non_finite, 0);
    assert!(film.xyz(4, 4).is_finite());
}
