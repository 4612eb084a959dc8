//! Splitting: a path tracer's camera sample that continues from its first
//! surface along several BSDF samples converges to the same image as one
//! that does not — also where the first surface is dispersive glass and
//! some branches keep only their hero wavelength — and has less noise per
//! sample.

use crate::common;

use common::agree::{assert_scenes_agree, cornell_box, GLASS_METAL_SHADING};
use common::{region_mean, render_film};
use prism::load::Loaded;

fn with_split(text: &str, split: u32) -> Loaded {
    common::scene(&format!(
        "{text}\n[integrator]\ntype = \"path\"\nsplit = {split}\n"
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
fn splitting_lowers_the_noise_per_sample() {
    // Most of the Cornell Box's noise is indirect light, which the four
    // branches average: below the light (whose edge pixels' noise is the
    // pixel's footprint, which splitting leaves alone) the variance per
    // camera sample falls to about a third.
    let text = cornell_box().replace("spp = 16", "spp = 64");
    let plain = region_mean(&render_film(&with_split(&text, 1), 2), 0, 8, 32, 32);
    let split = region_mean(&render_film(&with_split(&text, 4), 2), 0, 8, 32, 32);
    let ratio = split.1 / plain.1;
    eprintln!("variance of the image mean, split 4 over plain: {ratio:.3}");
    assert!(ratio < 0.5, "split {split:?}, plain {plain:?}");
    assert!(
        common::z_score(plain, split) < 4.5,
        "{plain:?} vs {split:?}"
    );
}
