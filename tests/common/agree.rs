//! Two integrators against each other: the same scene rendered by each in
//! 16 independent runs, compared block by block within error bars taken
//! from the runs' spread (splats make per-pixel variances meaningless);
//! and the scenes the comparisons use.

use prism::film::Film;
use prism::load::Loaded;
use prism::render::{render, RenderOptions};

/// `runs` renders with seeds 1..=runs: per 8 × 8 block, the mean luminance
/// over the runs and the variance of that mean (from the runs' spread:
/// splats make per-pixel variances meaningless).
pub fn block_estimates(loaded: &Loaded, spp: u32, runs: u64) -> Vec<(f64, f64)> {
    let films: Vec<Film> = (1..=runs)
        .map(|seed| {
            let options = RenderOptions {
                seed,
                threads: Some(2),
                ..RenderOptions::with_spp(&loaded.settings.film, spp)
            };
            let (film, stats) = render(&loaded.scene, &loaded.settings, &options).unwrap();
            assert_eq!(stats.non_finite, 0);
            film
        })
        .collect();
    let (w, h) = (loaded.settings.film.width, loaded.settings.film.height);
    let mut out = Vec::new();
    for y0 in (0..h).step_by(8) {
        for x0 in (0..w).step_by(8) {
            let means: Vec<f64> = films
                .iter()
                .map(|f| super::region_mean(f, x0, y0, (x0 + 8).min(w), (y0 + 8).min(h)).0)
                .collect();
            let n = means.len() as f64;
            let mean = means.iter().sum::<f64>() / n;
            let var = means.iter().map(|m| (m - mean) * (m - mean)).sum::<f64>() / (n - 1.0);
            out.push((mean, var / n));
        }
    }
    out
}

/// The same scene for both integrators, 16 independent runs each; every
/// block within 5σ. (With 15 degrees of freedom per variance, |t| > 5 has
/// probability 1.6e-4 per block.)
pub fn assert_scenes_agree(path: &Loaded, other: &Loaded, what: &str) {
    let a = block_estimates(path, 16, 16);
    let b = block_estimates(other, 16, 16);
    let mut worst = 0.0f64;
    for (i, (pa, pb)) in a.iter().zip(&b).enumerate() {
        let z = super::z_score(*pa, *pb);
        worst = worst.max(z);
        assert!(
            z < 5.0,
            "{what}, block {i}: path {pa:?}, other {pb:?}: {z:.1}σ"
        );
    }
    eprintln!(
        "{what}: largest block difference {worst:.2}σ over {} blocks",
        a.len()
    );
}

/// `assert_scenes_agree` for a scene file without an `[integrator]` table,
/// rendered by the path tracer and by the integrator `kind`.
pub fn assert_integrators_agree(text_without_integrator: &str, kind: &str, what: &str) {
    let with = |kind: &str| {
        super::scene(&format!(
            "{text_without_integrator}\n[integrator]\ntype = \"{kind}\"\n"
        ))
    };
    assert_scenes_agree(&with("path"), &with(kind), what);
}

pub fn cornell_box() -> String {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cornell-box.toml"
    ))
    .unwrap();
    let mut table: toml::Table = toml::from_str(&text).unwrap();
    table.remove("integrator");
    table.insert(
        "film".into(),
        toml::Value::Table(toml::from_str("resolution = [32, 32]\nspp = 16").unwrap()),
    );
    // Paths relative to the scene's folder.
    toml::to_string(&table)
        .unwrap()
        .replace("\"../spectra/", "\"spectra/")
        .replace("\"cornell/", "\"scenes/cornell/")
}

/// A floor and back wall under a quad light; a rough glass sphere, a rough
/// gold sphere and a diffuse sphere of few facets whose smooth vertex
/// normals differ from the facets' by up to ~15°.
pub const GLASS_METAL_SHADING: &str = r#"
[camera]
position = [0, 1.6, -4.5]
look_at = [0, 0.7, 0]
fov = 45
[film]
resolution = [32, 24]
spp = 16
[materials.floor]
type = "diffuse"
reflectance = 0.6
[materials.glass]
type = "dielectric"
ior = 1.5
roughness = 0.3
[materials.gold]
type = "conductor"
metal = "Au"
roughness = 0.35
[materials.white]
type = "diffuse"
reflectance = 0.8
[[shape]]
type = "quad"
vertices = [[-4, 0, -4], [-4, 0, 4], [4, 0, 4], [4, 0, -4]]
material = "floor"
[[shape]]
type = "quad"
vertices = [[-4, 0, 2], [-4, 4, 2], [4, 4, 2], [4, 0, 2]]
material = "floor"
[[shape]]
type = "quad"
vertices = [[-1, 3, -1], [1, 3, -1], [1, 3, 1], [-1, 3, 1]]
emission = 6
[[shape]]
type = "sphere"
center = [-1.2, 0.6, 0]
radius = 0.6
material = "glass"
[[shape]]
type = "sphere"
center = [0.1, 0.5, 0.4]
radius = 0.5
material = "gold"
[[shape]]
type = "sphere"
center = [1.3, 0.5, -0.3]
radius = 0.5
tessellate = true
segments = 8
material = "white"
"#;

/// A floor whose vertex normals lean 30° off its facets (the OBJ is
/// `tilted_floor_obj`): diffuse reflection uses the shading normal, and
/// light paths see the BSDF's adjoint, which differs from it by Veach's
/// correction.
pub const TILTED_FLOOR: &str = r#"
[camera]
position = [0, 2.5, -3.5]
look_at = [0, 0, 0.5]
fov = 50
[film]
resolution = [32, 24]
spp = 16
[materials.floor]
type = "diffuse"
reflectance = 0.8
[[shape]]
type = "obj"
file = "floor.obj"
material = "floor"
[[shape]]
type = "quad"
vertices = [[-3, 2, 1], [-1, 2, 1], [-1, 2, 3], [-3, 2, 3]]
emission = 4
"#;

/// `TILTED_FLOOR` rendered by the path tracer and by integrator `kind`
/// agree.
pub fn assert_tilted_floor_agrees(kind: &str) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("floor.obj"), tilted_floor_obj()).unwrap();
    let load = |kind: &str| {
        prism::load::load_str(
            &format!("{TILTED_FLOOR}\n[integrator]\ntype = \"{kind}\"\n"),
            dir.path(),
        )
        .unwrap()
    };
    assert_scenes_agree(&load("path"), &load(kind), "tilted shading normals");
}

/// The OBJ of `TILTED_FLOOR`.
fn tilted_floor_obj() -> String {
    let n = (30f32.to_radians().sin(), 30f32.to_radians().cos());
    format!(
        "v -3 0 -3\nv 3 0 -3\nv 3 0 3\nv -3 0 3\nvn {} {} 0\nf 1//1 4//1 3//1 2//1\n",
        n.0, n.1
    )
}

/// Point, spot and directional lights: light paths start at a point, in a
/// cone and on a disc over the scene.
pub const DELTA_LIGHTS: &str = r#"
[camera]
position = [0, 4, -6]
look_at = [0, 0, 0]
fov = 50
[film]
resolution = [32, 24]
spp = 16
[materials.white]
type = "diffuse"
reflectance = 0.7
[[shape]]
type = "quad"
vertices = [[-6, 0, -6], [-6, 0, 6], [6, 0, 6], [6, 0, -6]]
material = "white"
[[shape]]
type = "sphere"
center = [0, 0.8, 0]
radius = 0.8
material = "white"
[[light]]
type = "point"
position = [-2, 3, -1]
intensity = 8
[[light]]
type = "spot"
position = [3, 4, 0]
look_at = [1.5, 0, 1]
intensity = 30
cone_angle = 25
falloff_start = 15
[[light]]
type = "directional"
direction = [1, -2, 1]
irradiance = 0.3
"#;

/// The Cornell Box rendered by integrator `kind` on 1 and 3 threads: every
/// pixel's sums are the same, splats included.
pub fn assert_thread_count_invariant(kind: &str) {
    let s = super::scene(&format!(
        "{}\n[integrator]\ntype = \"{kind}\"\n",
        cornell_box()
    ));
    let one = super::render_film(&s, 1);
    let three = super::render_film(&s, 3);
    for y in 0..32 {
        for x in 0..32 {
            assert_eq!(one.sums(x, y), three.sums(x, y), "pixel ({x}, {y})");
            assert_eq!(one.spectrum(x, y), three.spectrum(x, y), "pixel ({x}, {y})");
        }
    }
    // Splats reached pixels: the image is not empty.
    assert!(one.xyz(16, 16).y > 0.0);
}
