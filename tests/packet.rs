//! The path tracer's packet core (`integrator::path_packet`: a tile's
//! samples advanced eight paths at a time, their rays walked through a
//! small tree together) renders what one path at a time renders:
//! block by block within 5σ on the Cornell Box, the colorchecker, a
//! diffuse scene with every kind of light the core meets (area, point,
//! environment, an emitting sphere) and spheres, the metals (mirrors and
//! rough), glTF's metallic-roughness layers and fluorescence, with paths
//! reused between pixels (`reuse`) where the scene or the test asks; the
//! same image for any thread count; and only the scenes it models go to
//! it.

use crate::common::{assert_blocks_agree_reused, repo_scene, scene};
use prism::film::Film;
use prism::integrator::Integrator;
use prism::load::Loaded;
use prism::render::{render, Packets, RenderOptions};

fn film(loaded: &Loaded, packets: Packets, seed: u64, threads: usize) -> Film {
    let options = RenderOptions {
        threads: Some(threads),
        seed,
        packets,
        ..loaded.settings.options()
    };
    let (film, stats) = render(&loaded.scene, &loaded.settings, &options).unwrap();
    assert_eq!(stats.non_finite, 0);
    film
}

fn packets_model(loaded: &Loaded) -> bool {
    match &loaded.settings.integrator {
        Integrator::Path(tracer) => tracer.models_in_packets(&loaded.scene),
        _ => false,
    }
}

/// Independent renders (different seeds) with and without packets agree
/// block by block within 5σ of their error bars (which allow for the
/// pixels of a 2 × 2 block sharing paths where the packets `reuse` them).
fn assert_agree(loaded: &Loaded, what: &str) {
    assert!(
        packets_model(loaded),
        "{what}: the packet core should model it"
    );
    let packets = film(loaded, Packets::Auto, 1, 2);
    let one_at_a_time = film(loaded, Packets::Never, 2, 2);
    assert!(packets.total_samples() > 0);
    assert_blocks_agree_reused(&packets, &one_at_a_time, 5.0, what);
}

#[test]
fn the_cornell_box_agrees_with_one_path_at_a_time() {
    let loaded = repo_scene(
        "scenes/cornell-box.toml",
        "resolution = [48, 48]\nspp = 256",
        "max_depth = 16",
    );
    assert_agree(&loaded, "Cornell Box");
}

#[test]
fn the_colorchecker_agrees_with_one_path_at_a_time() {
    // The other shipped scene of diffuse surfaces alone (an emitting
    // sphere around it, direct light only).
    let loaded = repo_scene(
        "scenes/colorchecker.toml",
        "resolution = [60, 40]\nspp = 256",
        "max_depth = 1",
    );
    assert_agree(&loaded, "colorchecker");
}

const LIGHTS_AND_SPHERES: &str = r#"
[camera]
position = [0, 1.5, -5]
look_at = [0, 0.5, 0]
fov = 45

[film]
resolution = [48, 40]
spp = 256

[integrator]
type = "path"
max_depth = 8

[materials.white]
type = "diffuse"
reflectance = 0.7

[materials.red]
type = "diffuse"
reflectance = { rgb = [0.8, 0.2, 0.1] }

[[shape]]
type = "quad"
vertices = [[-3, 0, -3], [-3, 0, 3], [3, 0, 3], [3, 0, -3]]
material = "white"

[[shape]]
type = "quad"
vertices = [[-3, 0, 2], [-3, 3, 2], [3, 3, 2], [3, 0, 2]]
material = "red"

[[shape]]
type = "sphere"
center = [0.6, 0.6, 0.3]
radius = 0.6
material = "white"

[[shape]]
type = "sphere"
center = [-1.2, 1.6, 0.5]
radius = 0.15
emission = "D65"
material = "white"

[[shape]]
type = "quad"
vertices = [[-0.5, 2.9, -0.5], [0.5, 2.9, -0.5], [0.5, 2.9, 0.5], [-0.5, 2.9, 0.5]]
emission = "A"
material = "white"

[[light]]
type = "point"
position = [1.5, 1.2, -1]
intensity = 2

[environment]
radiance = 0.2
"#;

#[test]
fn point_area_sphere_and_environment_lights_agree() {
    let loaded = scene(LIGHTS_AND_SPHERES);
    assert_agree(&loaded, "diffuse scene, four kinds of light");
}

#[test]
fn packets_give_the_same_image_for_any_thread_count() {
    let loaded = scene(LIGHTS_AND_SPHERES);
    let (a, b) = (
        film(&loaded, Packets::Auto, 3, 1),
        film(&loaded, Packets::Auto, 3, 2),
    );
    for y in 0..a.height {
        for x in 0..a.width {
            let (p, q) = (a.sums(x, y), b.sums(x, y));
            assert_eq!(p.xyz, q.xyz, "pixel ({x}, {y})");
            assert_eq!((p.samples, p.rays), (q.samples, q.rays), "pixel ({x}, {y})");
        }
    }
}

#[test]
fn metals_agree_with_one_path_at_a_time() {
    // Mirrors (Dirac lobes: no light sample, emission found counted whole)
    // and rough metals (GGX: light samples weighed by MIS) under a large
    // area light, by the general BSDF.
    let loaded = repo_scene(
        "scenes/metals.toml",
        "resolution = [64, 36]\nspp = 256",
        "max_depth = 8",
    );
    assert_agree(&loaded, "metals");
}

#[test]
fn reused_paths_agree_with_one_path_at_a_time() {
    // `reuse` on where the scene leaves it off (not every surface is
    // diffuse): first surfaces and second vertices of metal, which the
    // groups must not share, among diffuse ones, which they do.
    let loaded = repo_scene(
        "scenes/metals.toml",
        "resolution = [64, 36]\nspp = 256",
        "max_depth = 8\nreuse = true",
    );
    assert_agree(&loaded, "metals, paths reused");
}

#[test]
fn reuse_is_on_where_every_surface_is_diffuse() {
    let cornell = repo_scene("scenes/cornell-box.toml", "spp = 1", "max_depth = 16");
    let metals = repo_scene("scenes/metals.toml", "spp = 1", "max_depth = 8");
    let reuses = |loaded: &Loaded| match &loaded.settings.integrator {
        Integrator::Path(tracer) => tracer.reuses_paths(&loaded.scene),
        _ => false,
    };
    assert!(reuses(&cornell));
    assert!(!reuses(&metals));
}

#[test]
fn gltf_metallic_roughness_agrees_with_one_path_at_a_time() {
    // glTF's layered BRDF (iridescence, specular, sheen, clearcoat) on
    // single-sided surfaces, under an environment map.
    let loaded = repo_scene(
        "scenes/gltf-layers.toml",
        "resolution = [64, 30]\nspp = 256",
        "max_depth = 8",
    );
    assert_agree(&loaded, "gltf-layers");
}

#[test]
fn fluorescence_agrees_with_one_path_at_a_time() {
    // Paper and a highlighter under near-UV and white light: a path moves
    // to the wavelengths where light was absorbed, and the film gets those
    // the camera saw.
    let loaded = repo_scene(
        "scenes/fluorescence.toml",
        "resolution = [96, 40]\nspp = 256",
        "max_depth = 6",
    );
    assert_agree(&loaded, "fluorescence");
}

/// A floor lit only by the green glow of a highlighter card under a
/// near-UV lamp. A floor path samples the lamp at the visible wavelengths
/// it sees (nothing there), then meets the card and moves to the
/// wavelengths that excite it: the lamp must be looked up again there.
const UV_GLOW: &str = r#"
[camera]
position = [0, 1.2, -3]
look_at = [0, 0.2, 0.5]
fov = 40

[film]
resolution = [48, 32]
spp = 256

[integrator]
type = "path"
max_depth = 4

[spectra]
near_uv = [[375, 0], [385, 0.5], [395, 1], [405, 0.5], [415, 0]]

[materials.floor]
type = "diffuse"
reflectance = 0.8

[materials.highlighter]
type = "fluorescent"
reflectance = [[360, 0.08], [480, 0.06], [500, 0.3], [520, 0.8], [830, 0.9]]
excitation = [[380, 0.3], [420, 0.6], [460, 0.85], [490, 0.8], [510, 0.2], [520, 0]]
emission = [[490, 0], [510, 0.6], [525, 1], [550, 0.6], [600, 0.1], [620, 0]]
quantum_yield = 0.9

[[shape]]
type = "quad"
vertices = [[-2, 0, -2], [-2, 0, 2], [2, 0, 2], [2, 0, -2]]
material = "floor"

[[shape]]   # the card, standing on the floor, facing the camera
type = "quad"
vertices = [[-0.6, 0, 0.8], [-0.6, 0.8, 0.8], [0.6, 0.8, 0.8], [0.6, 0, 0.8]]
material = "highlighter"

[[shape]]   # the lamp, above the card and in front of it, facing down
type = "quad"
vertices = [[-0.5, 1.5, 0], [0.5, 1.5, 0], [0.5, 1.5, 0.6], [-0.5, 1.5, 0.6]]
material = "floor"
emission = "near_uv"
emission_scale = 20
"#;

#[test]
fn light_found_after_fluorescence_is_looked_up_at_the_new_wavelengths() {
    assert_agree(&scene(UV_GLOW), "floor lit by fluorescence");
}

#[test]
fn only_scenes_the_core_models_go_to_it() {
    let film = "resolution = [16, 16]\nspp = 1";
    let cornell = |integrator: &str| repo_scene("scenes/cornell-box.toml", film, integrator);
    assert!(packets_model(&cornell("max_depth = 16")));
    for reflecting_only in [
        "scenes/metals.toml",
        "scenes/metals-studio.toml",
        "scenes/fluorescence.toml",
    ] {
        let loaded = repo_scene(reflecting_only, film, "type = \"path\"");
        assert!(packets_model(&loaded), "{reflecting_only}");
    }
    // Splitting, glass and media take the one-path walk.
    assert!(!packets_model(&cornell("split = 2")));
    for glass_or_media in [
        "scenes/glass-of-water.toml",
        "scenes/haze.toml",
        "scenes/sunset.toml",
        "scenes/gltf-spheres.toml",
    ] {
        let loaded = repo_scene(glass_or_media, film, "type = \"path\"");
        assert!(!packets_model(&loaded), "{glass_or_media}");
    }
}
