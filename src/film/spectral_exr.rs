//! Spectral OpenEXR in the layout of Fichet, Pacanowski & Wilkie (JCGT 2021,
//! "An OpenEXR Layout for Spectral Images"): one float channel per spectral
//! bucket named `S0.<centre>nm` with a comma as decimal separator (a dot
//! separates EXR layers), the header attributes `spectralLayoutVersion` and
//! `emissiveUnits`, and R, G, B channels as a preview any viewer shows (in
//! the film's colour space, tagged by `chromaticities`).
//!
//! Values are the mean spectral radiance over each bucket, in the unit of
//! the scene's emission per nm: with emission in W·m⁻²·sr⁻¹·nm⁻¹ a channel
//! holds W·m⁻²·sr⁻¹·nm⁻¹, so `emissiveUnits` reads "W.m^-2.sr^-1" (per nm
//! of the channel's wavelength axis, as the layout defines).

use std::collections::BTreeMap;
use std::path::Path;

use anyhow::{bail, Context, Result};
use exr::prelude::*;

use super::colour::{ColourSpace, ColourTransform};
use super::output::{exr_chromaticities, write_atomically};
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
    parse_quantity(name.strip_prefix("S0.")?)
}

/// Parses a channel of Fichet's reflective layout, `T.<number><prefix><m|Hz>`
/// (a reflectance or transmittance per wavelength), into nanometres.
pub fn parse_reflective_name(name: &str) -> Option<f64> {
    parse_quantity(name.strip_prefix("T.")?)
}

/// A wavelength or frequency with its SI prefix and unit, in nanometres.
fn parse_quantity(quantity: &str) -> Option<f64> {
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

/// Name of the channel holding each pixel's sample count (prism's own; it
/// lets partial renders be merged exactly).
pub const SAMPLE_COUNT: &str = "sampleCount";

impl SpectralImage {
    /// The bytes its planes hold.
    pub fn bytes(&self) -> u64 {
        let planes = self.spectral.len() + self.other.len();
        (planes * self.width * self.height * 4) as u64
    }

    /// The film as a spectral image: bucket means, the RGB preview (in
    /// `colour`'s space, named by the `prismColourSpace` attribute and the
    /// chromaticities), per-pixel sample counts, and the given text
    /// attributes.
    pub fn from_film(film: &Film, colour: &ColourTransform, attributes: &[(&str, String)]) -> Self {
        let (w, h) = (film.width as usize, film.height as usize);
        let n = film.layout.count as usize;
        let mut spectral = vec![vec![0.0f32; w * h]; n];
        let mut counts = vec![0.0f32; w * h];
        for y in 0..film.height {
            for x in 0..film.width {
                let i = y as usize * w + x as usize;
                for (b, v) in film.spectrum(x, y).into_iter().enumerate() {
                    spectral[b][i] = v;
                }
                counts[i] = film.sums(x, y).samples as f32;
            }
        }
        let rgb = film.rgb(colour);
        let mut other = BTreeMap::new();
        for (k, name) in ["R", "G", "B"].iter().enumerate() {
            other.insert(name.to_string(), rgb.iter().map(|c| c[k]).collect());
        }
        other.insert(SAMPLE_COUNT.to_string(), counts);
        let wavelengths: Vec<f64> = (0..n as u32)
            .map(|b| film.layout.centre(b) as f64)
            .collect();
        let mut attrs = BTreeMap::new();
        attrs.insert("spectralLayoutVersion".to_string(), "1.0".to_string());
        attrs.insert("emissiveUnits".to_string(), "W.m^-2.sr^-1".to_string());
        attrs.insert(
            ATTR_COLOUR_SPACE.to_string(),
            colour.space.name().to_string(),
        );
        for (k, v) in attributes {
            attrs.insert(k.to_string(), v.clone());
        }
        Self {
            width: w,
            height: h,
            names: wavelengths.iter().map(|&l| channel_name(l)).collect(),
            wavelengths,
            spectral,
            other,
            attributes: attrs,
        }
    }
}

/// The colour space of the R, G, B channels (a `film.colour_space` name;
/// linear sRGB where absent).
pub const ATTR_COLOUR_SPACE: &str = "prismColourSpace";
/// The XYZ → RGB matrix (row-major) of the R, G, B channels: the film's
/// colour space and white balance.
pub const ATTR_XYZ_TO_RGB: &str = "prismXyzToRgb";
/// The film's white balance as the scene wrote it ("none" without one).
pub const ATTR_WHITE_BALANCE: &str = "prismWhiteBalance";
/// The observer whose colour-matching functions made XYZ.
pub const ATTR_OBSERVER: &str = "prismObserver";

/// Writes the film's spectral buckets, RGB preview and sample counts.
pub fn write(
    film: &Film,
    colour: &ColourTransform,
    path: &Path,
    attributes: &[(&str, String)],
) -> Result<()> {
    write_image(SpectralImage::from_film(film, colour, attributes), path)
}

/// Writes a spectral image as float32 channels with its text attributes.
/// The planes move into the encoder: a film's worth of memory is not
/// copied once more while writing.
pub fn write_image(img: SpectralImage, path: &Path) -> Result<()> {
    let mut channels: Vec<AnyChannel<FlatSamples>> = img
        .names
        .iter()
        .zip(img.spectral)
        .map(|(name, plane)| AnyChannel::new(name.as_str(), FlatSamples::F32(plane)))
        .collect();
    for (name, plane) in img.other {
        channels.push(AnyChannel::new(name.as_str(), FlatSamples::F32(plane)));
    }
    let mut layer_attributes = LayerAttributes::default();
    super::output::set_header_attributes(
        &mut layer_attributes,
        img.attributes.iter().map(|(k, v)| (k.as_str(), v.as_str())),
    );
    let layer = Layer::new(
        (img.width, img.height),
        layer_attributes,
        super::output::exr_encoding(),
        AnyChannels::sort(channels.into_iter().collect()),
    );
    let mut image = Image::from_layer(layer);
    image.attributes.chromaticities = img
        .attributes
        .get(ATTR_COLOUR_SPACE)
        .and_then(|name| ColourSpace::from_name(name))
        .or(Some(ColourSpace::SrgbLinear))
        .map(exr_chromaticities);
    write_atomically(path, |tmp| {
        image
            .write()
            .to_file(tmp)
            .with_context(|| format!("cannot write {}", tmp.display()))?;
        sort_header_attributes(tmp)
    })
}

/// Rewrites a single-part EXR's header with its attributes sorted by name.
/// The exr crate writes custom attributes in hash-map order, different on
/// every run; sorted, the same image gives the same bytes. The header keeps
/// its size, so the offset table after it stays right.
pub(super) fn sort_header_attributes(path: &Path) -> Result<()> {
    use std::io::{Read, Seek, SeekFrom, Write};
    let cannot = || format!("cannot read back {}", path.display());
    let mut file = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(path)
        .with_context(cannot)?;
    // The header alone (channel list and attributes), not the pixels.
    let mut bytes = Vec::new();
    (&mut file)
        .take(MAX_HEADER_BYTES)
        .read_to_end(&mut bytes)
        .with_context(cannot)?;
    let bad = || anyhow::anyhow!("{}: unexpected EXR header layout", path.display());
    const START: usize = 8; // magic number and version
    let mut at = START;
    let mut attributes: Vec<(&[u8], &[u8])> = Vec::new();
    let field = |at: usize| -> Result<usize> {
        let len = bytes
            .get(at..)
            .ok_or_else(bad)?
            .iter()
            .position(|&b| b == 0)
            .ok_or_else(bad)?;
        Ok(at + len + 1)
    };
    while *bytes.get(at).ok_or_else(bad)? != 0 {
        let name_end = field(at)?;
        let type_end = field(name_end)?;
        let size: [u8; 4] = bytes
            .get(type_end..type_end + 4)
            .ok_or_else(bad)?
            .try_into()
            .expect("four bytes");
        let end = type_end + 4 + u32::from_le_bytes(size) as usize;
        if end > bytes.len() {
            return Err(bad());
        }
        attributes.push((&bytes[at..name_end], &bytes[at..end]));
        at = end;
    }
    attributes.sort_by(|a, b| a.0.cmp(b.0));
    let sorted: Vec<u8> = attributes
        .iter()
        .flat_map(|a| a.1.iter().copied())
        .collect();
    file.seek(SeekFrom::Start(START as u64))
        .and_then(|_| file.write_all(&sorted))
        .with_context(|| format!("cannot write {}", path.display()))
}

/// More header than any file of ours has (4096 channels of 30 bytes, and
/// the attributes).
const MAX_HEADER_BYTES: u64 = 4 << 20;

/// Checks, from its header alone, that reading the EXR at `path` fits the
/// memory budget: each sample as declared plus `scratch` bytes a sample
/// (the caller's own copies). Returns the declared pixel count. A 23 KB
/// file may declare 32768² pixels; it is refused here, before the decoder
/// allocates them. Only regular files are opened (a FIFO would block).
pub fn check_declared_size(path: &Path, scratch: u64) -> Result<u64> {
    crate::input::regular_file_size(path)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .with_context(|| format!("cannot read {} as OpenEXR", path.display()))?;
    let (mut pixels, mut bytes) = (0u64, 0u64);
    for header in &meta.headers {
        // The largest resolution level is all that is read.
        let size = header.layer_size;
        let area = (size.width() as u64).saturating_mul(size.height() as u64);
        let per_pixel: u64 = header
            .channels
            .list
            .iter()
            .map(|c| c.sample_type.bytes_per_sample() as u64 + scratch)
            .sum();
        pixels = pixels.saturating_add(area);
        bytes = bytes.saturating_add(area.saturating_mul(per_pixel));
    }
    let what = format!(
        "{}: its pixels ({pixels} declared, in {} channels)",
        path.display(),
        meta.headers
            .iter()
            .map(|h| h.channels.list.len())
            .sum::<usize>()
    );
    crate::memory::check(&what, bytes).map_err(anyhow::Error::msg)?;
    Ok(pixels)
}

/// Reads any single-layer EXR, sorting spectral channels by wavelength
/// (never by name: `S0.1,0um` comes after `S0.900nm`).
pub fn read(path: &Path) -> Result<SpectralImage> {
    // Each sample is converted to an f32 of ours.
    check_declared_size(path, 4)?;
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
        assert_eq!(parse_reflective_name("T.550nm"), Some(550.0));
        assert!((parse_reflective_name("T.550,5nm").unwrap() - 550.5).abs() < 1e-9);
        assert_eq!(parse_reflective_name("S0.550nm"), None);
        assert_eq!(parse_channel_name("S0.abcnm"), None);
    }
}
