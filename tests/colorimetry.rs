//! The film's colorimetry: the XYZ that rendering accumulates from sampled
//! wavelengths converges to the 1 nm Riemann sum of the CIE 1931 CMFs, and
//! D65 white comes out as sRGB white.

use glam::{DVec3, Vec3};
use prism::film::{Film, FilmTile, SpectralLayout};
use prism::sampler::Sampler;
use prism::spectrum::{cie, SampledWavelengths, Spectrum};

#[test]
fn d65_lit_white_reflector_through_the_film() {
    let d65 = Spectrum::Table(cie::d65().clone());
    let exact = cie::spectrum_to_xyz(&d65).as_dvec3();
    let white = exact / exact.y;
    assert!(
        (white - DVec3::new(0.95047, 1.0, 1.08883))
            .abs()
            .max_element()
            < 2e-4,
        "{white}"
    );

    let layout = SpectralLayout {
        min: 380.0,
        max: 780.0,
        count: 40,
    };
    let mut tile = FilmTile::new(0, 0, 1, 1, 1, layout);
    let n = 400_000u64;
    let mut sq = DVec3::ZERO;
    for k in 0..n {
        let mut s = Sampler::for_sample(5, 0, 0, k);
        let wl = SampledWavelengths::sample_visible(s.next_f32());
        let l = d65.sample(&wl);
        let xyz = cie::sampled_to_xyz(l, &wl).as_dvec3();
        sq += xyz * xyz;
        tile.add_sample(0, 0, l, &wl);
    }
    let mut film = Film::new(1, 1, layout);
    film.add_tile(&tile);
    let mean = film.xyz(0, 0).as_dvec3();
    let std_err = ((sq / n as f64 - mean * mean) / (n - 1) as f64)
        .max(DVec3::ZERO)
        .powf(0.5);
    for c in 0..3 {
        assert!(
            (mean[c] - exact[c]).abs() < 4.5 * std_err[c],
            "component {c}: {} ± {}, Riemann sum {}",
            mean[c],
            std_err[c],
            exact[c]
        );
        assert!(std_err[c] < 2e-3 * exact[c], "error bar too wide");
    }
    let rgb = cie::xyz_to_linear_srgb((mean / mean.y).as_vec3());
    assert!((rgb - Vec3::ONE).abs().max_element() < 5e-3, "{rgb}");

    // The spectral buckets hold the mean spectral radiance of each bucket.
    let spectrum = film.spectrum(0, 0);
    for (b, value) in spectrum.iter().enumerate() {
        let (lo, hi) = (
            layout.min + b as f32 * 10.0,
            layout.min + (b + 1) as f32 * 10.0,
        );
        let expected = d65.average(lo, hi);
        assert!(
            (value - expected).abs() < 0.03 * expected,
            "bucket {b} ({lo}–{hi} nm): {value}, expected {expected}"
        );
    }
}
