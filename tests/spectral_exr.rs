//! The spectral OpenEXR round trip: what the film holds is what a reader
//! gets back, channels ordered by wavelength (never by name).

use crate::common;

use exr::prelude::*;
use prism::film::spectral_exr::{self, channel_name};
use prism::render::render;

#[test]
fn write_then_read_gives_identical_channels_and_attributes() {
    let scene = common::repo_scene(
        "scenes/cornell-box.toml",
        "resolution = [20, 12]\nspp = 4\nspectral_range = [400, 700]\nspectral_buckets = 30",
        "",
    );
    let (film, _) = render(&scene.scene, &scene.settings, &scene.settings.options()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("round.spectral.exr");
    spectral_exr::write(
        &film,
        &prism::film::ColourTransform::default(),
        &path,
        &[("prismSeed", "7".into())],
    )
    .unwrap();
    let img = spectral_exr::read(&path).unwrap();
    assert_eq!((img.width, img.height), (20, 12));
    assert_eq!(img.attributes["spectralLayoutVersion"], "1.0");
    assert_eq!(img.attributes["emissiveUnits"], "W.m^-2.sr^-1");
    assert_eq!(img.attributes["prismSeed"], "7");
    assert_eq!(img.wavelengths.len(), 30);
    for (b, lambda) in img.wavelengths.iter().enumerate() {
        assert!((lambda - (405.0 + 10.0 * b as f64)).abs() < 1e-9);
        assert_eq!(img.names[b], channel_name(*lambda));
    }
    let rgb = film.linear_srgb();
    for y in 0..12u32 {
        for x in 0..20u32 {
            let i = (y * 20 + x) as usize;
            let spectrum = film.spectrum(x, y);
            for (plane, value) in img.spectral.iter().zip(&spectrum) {
                assert_eq!(plane[i].to_bits(), value.to_bits());
            }
            assert_eq!(img.other["R"][i], rgb[i].x);
            assert_eq!(img.other["G"][i], rgb[i].y);
            assert_eq!(img.other["B"][i], rgb[i].z);
        }
    }
    assert!(
        img.spectral.iter().flatten().any(|&v| v > 0.0),
        "the render is black"
    );
}

#[test]
fn channels_are_ordered_by_wavelength_not_by_name() {
    // By name "S0.1,0um" (1000 nm) sorts before "S0.900nm"; a frequency
    // channel (499.65 nm ≈ 600 THz) sorts among them by wavelength too.
    let names = ["S0.900nm", "S0.1,0um", "S0.600THz", "S0.950,5nm"];
    let channels: Vec<AnyChannel<FlatSamples>> = names
        .iter()
        .enumerate()
        .map(|(k, n)| AnyChannel::new(*n, FlatSamples::F32(vec![k as f32; 4])))
        .collect();
    let layer = Layer::new(
        (2, 2),
        LayerAttributes::default(),
        Encoding::UNCOMPRESSED,
        AnyChannels::sort(channels.into_iter().collect()),
    );
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("order.exr");
    Image::from_layer(layer).write().to_file(&path).unwrap();
    let img = spectral_exr::read(&path).unwrap();
    assert_eq!(
        img.names,
        vec!["S0.600THz", "S0.900nm", "S0.950,5nm", "S0.1,0um"]
    );
    assert!((img.wavelengths[0] - 499.654).abs() < 1e-3);
    assert_eq!(img.spectral[3][0], 1.0);
    assert_eq!(img.spectral[0][0], 2.0);
}

/// The exr crate writes custom attributes in hash-map order; prism sorts
/// them, so the same film gives the same bytes, every time.
#[test]
fn the_same_film_gives_the_same_bytes() {
    let scene = common::repo_scene(
        "scenes/cornell-box.toml",
        "resolution = [8, 6]\nspp = 2",
        "",
    );
    let (film, _) = render(&scene.scene, &scene.settings, &scene.settings.options()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let names: Vec<String> = (0..12).map(|i| format!("prismNote{i}")).collect();
    let attributes: Vec<(&str, String)> = names.iter().map(|n| (n.as_str(), n.clone())).collect();
    let colour = prism::film::ColourTransform::default();
    let mut files = Vec::new();
    for k in 0..4 {
        let path = dir.path().join(format!("{k}.spectral.exr"));
        spectral_exr::write(&film, &colour, &path, &attributes).unwrap();
        files.push(std::fs::read(&path).unwrap());
    }
    assert!(files.windows(2).all(|w| w[0] == w[1]));
    let img = spectral_exr::read(&dir.path().join("0.spectral.exr")).unwrap();
    for n in &names {
        assert_eq!(&img.attributes[n], n);
    }
}
