//! Spectral OpenEXR in the layout of Fichet, Pacanowski & Wilkie (JCGT 2021,
//! "An OpenEXR Layout for Spectral Images"): one float channel per spectral
//! bucket named `S0.<centre>nm` with a comma as decimal separator (a dot
//! separates EXR layers), the header attributes `spectralLayoutVersion` and
//! `emissiveUnits`, and R, G, B channels as a preview any viewer shows.
//!
//! Values are the mean spectral radiance over each bucket, in the unit of
//! the scene's emission per nm: with emission in W·m⁻²·sr⁻¹·nm⁻¹ a channel
//! holds W·m⁻²·sr⁻¹·nm⁻¹, so `emissiveUnits` reads "W.m^-2.sr^-1" (per nm
//! of the channel's wavelength axis, as the layout defines).

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{bail, Context, Result};
use exr::prelude::*;

use super::output::write_atomically;
use super::Film;

/// A spectral image as read back from a file.
#[derive(Clone, Debug, PartialEq)]
pub struct SpectralImage {
    pub width: usize,
    pub height: usize,
    /// Wavelength of each spectral channel in nm, increasing.
    pub wavelengths: Vec<f64>,
    /// Channel names, in the order of `wavelengths`.
    pub names: Vec<String>,
    /// One row-major plane per spectral channel, in the order of `wavelengths`.
    pub spectral: Vec<Vec<f32>>,
    /// Other channels (R, G, B, ...), by name.
    pub other: BTreeMap<String, Vec<f32>>,
    /// Text attributes of the header, by name.
    pub attributes: BTreeMap<String, String>,
}

/// The channel name of an emissive (S0) bucket centred on `lambda` nm.
pub fn channel_name(lambda: f64) -> String {
    format!("S0.{}nm", format!("{lambda:.6}").replace('.', ","))
}

/// Parses a Fichet channel name `S0.<number><prefix><m|Hz>` (e.g.
/// `S0.550,000000nm`, `S0.0,55um`, `S0.545,077THz`) into nanometres.
/// Returns None for channels that are not emissive spectral channels.
pub fn parse_channel_name(name: &str) -> Option<f64> {
    let quantity = name.strip_prefix("S0.")?;
    let (rest, hertz) = match quantity.strip_suffix("Hz") {
        Some(r) => (r, true),
        None => (quantity.strip_suffix('m')?, false),
    };
    const PREFIXES: [(&str, f64); 20] = [
        ("da", 1e1),
        ("Y", 1e24),
        ("Z", 1e21),
        ("E", 1e18),
        ("P", 1e15),
        ("T", 1e12),
        ("G", 1e9),
        ("M", 1e6),
        ("k", 1e3),
        ("h", 1e2),
        ("d", 1e-1),
        ("c", 1e-2),
        ("m", 1e-3),
        ("u", 1e-6),
        ("n", 1e-9),
        ("p", 1e-12),
        ("f", 1e-15),
        ("a", 1e-18),
        ("z", 1e-21),
        ("y", 1e-24),
    ];
    let (number, multiplier) = PREFIXES
        .iter()
        .find_map(|(p, m)| rest.strip_suffix(p).map(|n| (n, *m)))
        .unwrap_or((rest, 1.0));
    let value: f64 = number.replace(',', ".").parse().ok()?;
    let si = value * multiplier;
    let metres = if hertz { 299_792_458.0 / si } else { si };
    let nm = metres * 1e9;
    (nm.is_finite() && nm > 0.0).then_some(nm)
}

/// Writes the film's spectral buckets and an RGB preview (linear sRGB).
pub fn write(film: &Film, path: &Path, extra: &[(&str, String)]) -> Result<()> {
    let (w, h) = (film.width as usize, film.height as usize);
    let n = film.layout.count as usize;
    let mut planes = vec![vec![0.0f32; w * h]; n];
    for y in 0..film.height {
        for x in 0..film.width {
            let i = y as usize * w + x as usize;
            for (b, v) in film.spectrum(x, y).into_iter().enumerate() {
                planes[b][i] = v;
            }
        }
    }
    let rgb = film.linear_srgb();
    let mut channels: Vec<AnyChannel<FlatSamples>> = planes
        .into_iter()
        .enumerate()
        .map(|(b, plane)| {
            let name = channel_name(film.layout.centre(b as u32) as f64);
            AnyChannel::new(name.as_str(), FlatSamples::F32(plane))
        })
        .collect();
    for (k, name) in ["R", "G", "B"].iter().enumerate() {
        channels.push(AnyChannel::new(
            *name,
            FlatSamples::F32(rgb.iter().map(|c| c[k]).collect()),
        ));
    }
    let mut attributes = LayerAttributes::default();
    let mut text = |k: &str, v: &str| {
        attributes
            .other
            .insert(Text::from(k), AttributeValue::Text(Text::from(v)));
    };
    text("spectralLayoutVersion", "1.0");
    text("emissiveUnits", "W.m^-2.sr^-1");
    for (k, v) in extra {
        text(k, v);
    }
    let layer = Layer::new(
        (w, h),
        attributes,
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(channels.into_iter().collect()),
    );
    let image = Image::from_layer(layer);
    write_atomically(path, |tmp| {
        image
            .write()
            .to_file(tmp)
            .with_context(|| format!("cannot write {}", tmp.display()))
    })
}

/// Reads any single-layer EXR, sorting spectral channels by wavelength
/// (never by name: `S0.1,0um` comes after `S0.900nm`).
pub fn read(path: &Path) -> Result<SpectralImage> {
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .with_context(|| format!("cannot read {} as OpenEXR", path.display()))?;
    let Some(layer) = image.layer_data.first() else {
        bail!("{} has no image layer", path.display());
    };
    if image.layer_data.len() > 1 {
        bail!(
            "{} has {} layers; prism reads single-layer files",
            path.display(),
            image.layer_data.len()
        );
    }
    let mut attributes = BTreeMap::new();
    for (k, v) in image
        .attributes
        .other
        .iter()
        .chain(layer.attributes.other.iter())
    {
        if let AttributeValue::Text(t) = v {
            attributes.insert(k.to_string(), t.to_string());
        }
    }
    let mut spectral: Vec<(f64, String, Vec<f32>)> = Vec::new();
    let mut other = BTreeMap::new();
    for channel in &layer.channel_data.list {
        let name = channel.name.to_string();
        let values: Vec<f32> = channel.sample_data.values_as_f32().collect();
        match parse_channel_name(&name) {
            Some(lambda) => spectral.push((lambda, name, values)),
            None => {
                other.insert(name, values);
            }
        }
    }
    spectral.sort_by(|a, b| a.0.total_cmp(&b.0));
    Ok(SpectralImage {
        width: layer.size.width(),
        height: layer.size.height(),
        wavelengths: spectral.iter().map(|s| s.0).collect(),
        names: spectral.iter().map(|s| s.1.clone()).collect(),
        spectral: spectral.into_iter().map(|s| s.2).collect(),
        other,
        attributes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn channel_names_round_trip() {
        assert_eq!(channel_name(550.0), "S0.550,000000nm");
        assert_eq!(parse_channel_name("S0.550,000000nm"), Some(550.0));
        assert!((parse_channel_name("S0.0,55um").unwrap() - 550.0).abs() < 1e-9);
        assert!((parse_channel_name("S0.545,077196THz").unwrap() - 550.0).abs() < 1e-3);
        assert!((parse_channel_name("S0.5,5e2nm").unwrap() - 550.0).abs() < 1e-9);
        assert_eq!(parse_channel_name("R"), None);
        assert_eq!(parse_channel_name("T.550nm"), None);
        assert_eq!(parse_channel_name("S0.abcnm"), None);
    }
}
