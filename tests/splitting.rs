//! Splitting: a path tracer's camera sample that continues from its first
//! surface that is not a Dirac one along several BSDF samples converges to
//! the same image as one that does not — also behind dispersive glass,
//! where each wavelength's path splits on its own, and with caustics from
//! photons — and has less noise per sample.

use crate::common;

use common::agree::{assert_scenes_agree, cornell_box, GLASS_METAL_SHADING};
use common::{region_mean, render_film};
use prism::load::Loaded;

fn with_split(text: &str, split: u32) -> Loaded {
    split_by(text, "path", split)
}

fn split_by(text: &str, kind: &str, split: u32) -> Loaded {
    with_key(text, kind, "split", split)
}

/// `text` rendered by integrator `kind` with `[integrator]` key `key` set
/// to `value`.
fn with_key(text: &str, kind: &str, key: &str, value: impl std::fmt::Display) -> Loaded {
    common::scene(&format!(
        "{text}\n[integrator]\ntype = \"{kind}\"\n{key} = {value}\n"
    ))
}

/// The scene `text` split `n` ways and not at all agree block by block.
fn assert_split_agrees(text: &str, n: u32, what: &str) {
    assert_scenes_agree(&with_split(text, 1), &with_split(text, n), what);
}

#[test]
fn split_paths_agree_with_plain_ones_on_the_cornell_box() {
    assert_split_agrees(&cornell_box(), 4, "Cornell Box, split 4");
}

#[test]
fn split_paths_agree_with_plain_ones_through_dispersive_glass() {
    // Smooth N-SF11: a branch that refracts keeps only its hero wavelength,
    // while its siblings that reflect keep all four.
    let text = GLASS_METAL_SHADING.replace("ior = 1.5\nroughness = 0.3", "ior = \"N-SF11\"");
    assert!(text.contains("N-SF11"));
    assert_split_agrees(&text, 3, "dispersive glass, split 3");
}

#[test]
fn split_paths_with_caustics_from_photons_agree_with_plain_ones() {
    // The photon estimate at the surface where the path splits is counted
    // once, before the branches; each branch leaves out the caustics it
    // would find itself, as the path it continues would.
    let text = GLASS_METAL_SHADING.replace("ior = 1.5\nroughness = 0.3", "ior = \"N-SF11\"");
    assert!(text.contains("N-SF11"));
    let what = "path_caustics, dispersive glass, split 3";
    assert_scenes_agree(
        &split_by(&text, "path_caustics", 1),
        &split_by(&text, "path_caustics", 3),
        what,
    );
}

#[test]
fn splitting_lowers_the_noise_per_sample() {
    // Most of the Cornell Box's noise is indirect light, which the four
    // branches average: below the light (whose edge pixels' noise is the
    // pixel's footprint, which splitting leaves alone) the variance per
    // camera sample falls to about a third.
    let text = cornell_box().replace("spp = 16", "spp = 64");
    // Plain paths not reused between pixels either (`reuse`, which the
    // packet core takes on this scene, lowers the noise another way).
    let plain = with_key(&text, "path", "reuse", false);
    let plain = region_mean(&render_film(&plain, 2), 0, 8, 32, 32);
    let split = region_mean(&render_film(&with_split(&text, 4), 2), 0, 8, 32, 32);
    let ratio = split.1 / plain.1;
    eprintln!("variance of the image mean, split 4 over plain: {ratio:.3}");
    assert!(ratio < 0.5, "split {split:?}, plain {plain:?}");
    assert!(
        common::z_score(plain, split) < 4.5,
        "{plain:?} vs {split:?}"
    );
}

/// The glass and metal scene with smooth N-SF11 glass (it disperses), for
/// integrator `kind`, its camera paths split at dispersion or not.
fn dispersive(kind: &str, split_dispersion: bool) -> Loaded {
    let text = GLASS_METAL_SHADING.replace("ior = 1.5\nroughness = 0.3", "ior = \"N-SF11\"");
    assert!(text.contains("N-SF11"));
    with_key(&text, kind, "split_dispersion", split_dispersion)
}

#[test]
fn paths_split_at_dispersion_agree_with_the_hero_alone() {
    // path_caustics' camera paths that follow one wavelength gather photons
    // led by any of the four (`PhotonMap::gather_matched`, tested there).
    for kind in ["path", "path_caustics"] {
        let what = format!("{kind}, dispersive glass, split at dispersion or not");
        assert_scenes_agree(&dispersive(kind, false), &dispersive(kind, true), &what);
    }
}

/// Per pixel, the variance over `runs` seeds of the colour apart from its
/// brightness (X − Y and Z − Y), summed over the image.
fn chroma_variance(loaded: &Loaded, runs: u64) -> f64 {
    let films = renders(loaded, runs);
    let (w, h) = (loaded.settings.film.width, loaded.settings.film.height);
    let mut total = 0.0;
    for y in 0..h {
        for x in 0..w {
            let chroma: Vec<[f64; 2]> = films
                .iter()
                .map(|f| {
                    let c = f.xyz(x, y).as_dvec3();
                    [c.x - c.y, c.z - c.y]
                })
                .collect();
            for k in 0..2 {
                let n = runs as f64;
                let mean = chroma.iter().map(|c| c[k]).sum::<f64>() / n;
                total += chroma.iter().map(|c| (c[k] - mean).powi(2)).sum::<f64>() / (n - 1.0);
            }
        }
    }
    total
}

#[test]
fn splitting_at_dispersion_lowers_the_colour_noise() {
    // A camera path through the smooth N-SF11 sphere that keeps its hero
    // alone shows one wavelength four times over; split, it shows all four
    // (measured: a fifth of the colour variance; on gem-studio a fifth too).
    let hero = chroma_variance(&dispersive("path", false), 8);
    let split = chroma_variance(&dispersive("path", true), 8);
    eprintln!(
        "colour variance, split at dispersion over the hero alone: {:.3}",
        split / hero
    );
    assert!(split < 0.5 * hero, "split {split}, hero alone {hero}");
}

/// `runs` renders of `loaded` with seeds 1..=runs.
fn renders(loaded: &Loaded, runs: u64) -> Vec<prism::film::Film> {
    (1..=runs)
        .map(|seed| {
            let options = prism::render::RenderOptions {
                seed,
                threads: Some(2),
                ..loaded.settings.options()
            };
            let (film, stats) =
                prism::render::render(&loaded.scene, &loaded.settings, &options).unwrap();
            assert_eq!(stats.non_finite, 0);
            film
        })
        .collect()
}

/// `text` rendered by integrator `kind` with glass met first followed
/// along both lobes (`split_glass`) or along one drawn by Fresnel.
fn split_glass(text: &str, kind: &str, split_glass: bool) -> Loaded {
    with_key(text, kind, "split_glass", split_glass)
}

#[test]
fn glass_followed_along_both_lobes_agrees_with_one_drawn() {
    // Rough glass (both lobes glossy, each weighted by the Fresnel factor
    // at the sampled microfacet) and smooth dispersive glass (the
    // reflection one branch with all four wavelengths, the refraction one
    // per wavelength), for the path tracer and with caustics from photons.
    let dispersive = GLASS_METAL_SHADING.replace("ior = 1.5\nroughness = 0.3", "ior = \"N-SF11\"");
    assert!(dispersive.contains("N-SF11"));
    for (text, glass) in [
        (GLASS_METAL_SHADING, "rough"),
        (dispersive.as_str(), "dispersive"),
    ] {
        for kind in ["path", "path_caustics"] {
            let what = format!("{kind}, {glass} glass, split by lobe or not");
            assert_scenes_agree(
                &split_glass(text, kind, false),
                &split_glass(text, kind, true),
                &what,
            );
        }
    }
}

/// `text` rendered by integrator `kind`, smooth glass past the first
/// surface looked ahead at along both lobes (`look_ahead`) or not.
fn look_ahead(text: &str, kind: &str, look_ahead: bool) -> Loaded {
    with_key(text, kind, "look_ahead", look_ahead)
}

/// A smooth glass ball filling the view under a wide lamp, before a floor
/// and a wall: its facets show the lamp, each seen along one lobe.
const GLASS_BALL_UNDER_A_LAMP: &str = r#"
[camera]
position = [0, 1.5, -4]
look_at = [0, 1.1, 0]
fov = 40
[film]
resolution = [32, 24]
spp = 16
[materials.floor]
type = "diffuse"
reflectance = 0.6
[materials.glass]
type = "dielectric"
ior = 1.5
[[shape]]
type = "quad"
vertices = [[-4, 0, -4], [-4, 0, 4], [4, 0, 4], [4, 0, -4]]
material = "floor"
[[shape]]
type = "quad"
vertices = [[-4, 0, 3], [-4, 4, 3], [4, 4, 3], [4, 0, 3]]
material = "floor"
[[shape]]
type = "quad"
vertices = [[-2, 3.5, -2], [2, 3.5, -2], [2, 3.5, 2], [-2, 3.5, 2]]
emission = 4
[[shape]]
type = "sphere"
center = [0, 1.1, 0]
radius = 1.1
material = "glass"
"#;

#[test]
fn glass_looked_ahead_at_agrees_with_one_lobe_drawn() {
    // Smooth glass under a lamp and a sky (lobes that escape count the
    // sky, lobes that meet the lamp its emission), dispersive glass, glass
    // inside glass (lobes inside an object are not traced ahead), and
    // smooth glass seen through frosted glass, for the path tracer and
    // with caustics from photons.
    let sky = "[environment]\nradiance = 0.4\n";
    let smooth = GLASS_BALL_UNDER_A_LAMP;
    let dispersive = smooth.replace("ior = 1.5", "ior = \"N-SF11\"");
    let nested = format!(
        "{smooth}[materials.core]\ntype = \"dielectric\"\nior = 1.9\npriority = 2\n\
         [[shape]]\ntype = \"sphere\"\ncenter = [0.3, 1.2, 0]\nradius = 0.5\nmaterial = \"core\"\n"
    );
    // Seen through frosted glass first: the smooth ball behind it is
    // looked ahead at too (a path past a surface without a diffuse lobe).
    let frosted = format!(
        "{smooth}[materials.frosted]\ntype = \"dielectric\"\nior = 1.5\nroughness = 0.3\n\
         [[shape]]\ntype = \"sphere\"\ncenter = [0.2, 1.3, -2.2]\nradius = 0.6\nmaterial = \"frosted\"\n"
    );
    assert!(dispersive.contains("N-SF11"));
    for (text, glass) in [
        (format!("{smooth}{sky}"), "smooth"),
        (format!("{dispersive}{sky}"), "dispersive"),
        (nested, "nested"),
        (format!("{frosted}{sky}"), "frosted then smooth"),
    ] {
        for kind in ["path", "path_caustics"] {
            let what = format!("{kind}, {glass} glass, looked ahead at or not");
            assert_scenes_agree(
                &look_ahead(&text, kind, false),
                &look_ahead(&text, kind, true),
                &what,
            );
        }
    }
}
