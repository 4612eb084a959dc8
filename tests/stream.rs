//! The path tracer's stream of paths (`drive::stream`: camera samples
//! advanced together, their closest-hit and shadow rays traced as streams)
//! gives the image that one sample at a time gives, bit for bit: every
//! pixel's sums, ray counts, spectral buckets and AOVs, on scenes that
//! take each of the walk's branches (dispersion, splitting, media,
//! spheres, fluorescence, environment maps, adaptive counts, AOVs).

use crate::common::repo_scene;
use prism::film::Film;
use prism::render::{render, Packets, RenderOptions, Streams};

fn film(scene: &str, film: &str, integrator: &str, streams: Streams) -> Film {
    let loaded = repo_scene(scene, film, integrator);
    let options = RenderOptions {
        threads: Some(2),
        streams,
        // Both one path at a time or as a stream, not as packets.
        packets: Packets::Never,
        ..loaded.settings.options()
    };
    render(&loaded.scene, &loaded.settings, &options).unwrap().0
}

fn assert_identical(scene: &str, film_toml: &str, integrator: &str) {
    let a = film(scene, film_toml, integrator, Streams::Never);
    let b = film(scene, film_toml, integrator, Streams::Always);
    assert!(a.total_samples() > 0, "{scene}: nothing rendered");
    for y in 0..a.height {
        for x in 0..a.width {
            let (p, q) = (a.sums(x, y), b.sums(x, y));
            let what = format!("{scene} ({integrator}) pixel ({x}, {y})");
            assert_eq!(p.xyz, q.xyz, "{what}: XYZ sums");
            assert_eq!(p.y_squared, q.y_squared, "{what}: Y² sums");
            assert_eq!((p.samples, p.rays), (q.samples, q.rays), "{what}: counts");
            assert_eq!(a.spectrum(x, y), b.spectrum(x, y), "{what}: buckets");
            assert_eq!(a.aov(x, y), b.aov(x, y), "{what}: AOVs");
        }
    }
}

const FILM: &str = "resolution = [40, 30]\nspp = 6";

#[test]
fn cornell_box_adaptive_with_aovs_and_split() {
    let film = format!("{FILM}\nsampling = \"adaptive\"\naovs = [\"albedo\", \"depth\"]");
    assert_identical("scenes/cornell-box.toml", &film, "max_depth = 16");
    assert_identical("scenes/cornell-box.toml", FILM, "split = 3");
}

#[test]
fn dispersion_spheres_and_environment_maps() {
    // Dispersive glass splits into one path per wavelength mid-stream.
    assert_identical("scenes/gltf-spheres.toml", FILM, "type = \"path\"");
    assert_identical("scenes/metals-studio.toml", FILM, "type = \"path\"");
    assert_identical("scenes/colorchecker.toml", FILM, "type = \"path\"");
}

#[test]
fn media_textures_and_fluorescence() {
    // Haze: shadow rays through a medium are traced at once, not deferred.
    assert_identical("scenes/haze.toml", FILM, "type = \"path\"");
    assert_identical("scenes/textured-obj.toml", FILM, "type = \"path\"");
    assert_identical("scenes/fluorescence.toml", FILM, "type = \"path\"");
}
