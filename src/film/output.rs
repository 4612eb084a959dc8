//! Writing the film: RGB OpenEXR (float, in the film's colour space,
//! tagged with its chromaticities) and the display PNG (`display`). Files
//! are written under a temporary name and renamed into place, so a reader
//! never sees half a file.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use glam::Vec3;

use super::colour::ColourSpace;
use super::display::{self, DisplaySettings};
use super::{AovSet, Film, FilmSettings};
use crate::spectrum::cie::Observer;

/// The view transform of the PNG: how linear radiance becomes display
/// values.
#[derive(Clone, Copy, Debug, Default, serde::Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Tonemap {
    /// None: values above 1 are left to the gamut step (clipped or mapped).
    #[default]
    Clamp,
    /// x / (1 + x) per channel: keeps highlights, compresses everything.
    Reinhard,
    /// A logistic roll-off in stops of the largest channel, then a path to
    /// white in OKLab at constant hue: highlights roll off and desaturate
    /// smoothly without hue shifts ([`display::filmic`]).
    Filmic,
}

thread_local! {
    /// Inside `as_one_set`: files written but not yet moved into place.
    static STAGED: std::cell::RefCell<Option<Vec<(PathBuf, PathBuf)>>> =
        const { std::cell::RefCell::new(None) };
    /// Inside `as_one_set`: files of an earlier set that this one does not
    /// replace, to go when it is in place.
    static RETIRED: std::cell::RefCell<Vec<PathBuf>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Inside `as_one_set`: `path`, if it exists, belongs to the set being
/// replaced but not to the new one (a spectral EXR under `--no-spectral`):
/// it goes when the new set is in place, and stays if the set fails.
pub fn retire_in_set(path: &Path) {
    if path.is_file() {
        RETIRED.with(|r| r.borrow_mut().push(path.to_path_buf()));
    }
}

/// Writes `path` through a temporary sibling and a rename (deferred to the
/// end of `as_one_set` when inside one).
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = temp_name(path);
    if let Err(e) = write(&tmp) {
        let _ = std::fs::remove_file(&tmp);
        return Err(e);
    }
    let staged = STAGED.with(|s| {
        s.borrow_mut()
            .as_mut()
            .map(|files| files.push((tmp.clone(), path.to_path_buf())))
            .is_some()
    });
    if staged {
        return Ok(());
    }
    std::fs::rename(&tmp, path).with_context(|| {
        let _ = std::fs::remove_file(&tmp);
        format!("cannot move {} into place", tmp.display())
    })
}

/// Runs `write`, which writes several files, so that they replace the
/// files of those names together: every file is written under its
/// temporary name first, and only when all are written are they moved into
/// place. A failure (a full disk, a name taken by a folder) leaves the
/// files that were there before, all of them, and no temporary ones.
pub fn as_one_set(write: impl FnOnce() -> Result<()>) -> Result<()> {
    STAGED.with(|s| *s.borrow_mut() = Some(Vec::new()));
    RETIRED.with(|r| r.borrow_mut().clear());
    let result = write();
    let files = STAGED.with(|s| s.borrow_mut().take()).unwrap_or_default();
    let retired = RETIRED.with(|r| std::mem::take(&mut *r.borrow_mut()));
    let discard = |files: &[(PathBuf, PathBuf)]| {
        for (tmp, _) in files {
            let _ = std::fs::remove_file(tmp);
        }
    };
    if let Err(e) = result {
        discard(&files);
        return Err(e);
    }
    // Two commands writing the same names take turns: each moves its
    // whole set while holding the folder's lock, so the sets never mix.
    let _turn = files.first().and_then(|(_, path)| lock_folder(path));
    // A name that cannot take its file fails before anything moves.
    if let Some((_, taken)) = files.iter().find(|(_, path)| path.is_dir()) {
        discard(&files);
        anyhow::bail!("cannot write {}: a folder has that name", taken.display());
    }
    // The earlier set's files that the new one lacks step aside first, so
    // that no moment shows them beside the new files.
    let mut aside = Vec::new();
    for path in &retired {
        let tmp = temp_name(path).with_extension("retired");
        if std::fs::rename(path, &tmp).is_ok() {
            aside.push((tmp, path));
        }
    }
    for (i, (tmp, path)) in files.iter().enumerate() {
        if let Err(e) = std::fs::rename(tmp, path) {
            discard(&files[i..]);
            for (tmp, path) in &aside {
                let _ = std::fs::rename(tmp, path);
            }
            return Err(e).with_context(|| format!("cannot move {} into place", tmp.display()));
        }
    }
    for (tmp, _) in &aside {
        let _ = std::fs::remove_file(tmp);
    }
    Ok(())
}

/// An exclusive lock on the folder that holds `path` (flock on the
/// folder itself: no lock file is left behind), held until the returned
/// handle is dropped. None where the file system has no such locks: the
/// set is then moved without one.
fn lock_folder(path: &Path) -> Option<std::fs::File> {
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let handle = std::fs::File::open(folder).ok()?;
    handle.lock().ok()?;
    Some(handle)
}

fn temp_name(path: &Path) -> PathBuf {
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    let ext = path.extension().unwrap_or_default().to_string_lossy();
    // Keep the extension last: the image writers pick the format by it.
    path.with_file_name(format!(".{stem}.partial-{}.{ext}", std::process::id()))
}

/// The film as NAME.exr: RGB in the film's colour space, and the AOVs its
/// settings ask for as further channels (`albedo.R/G/B` in the same space,
/// `normal.X/Y/Z`, `depth.Z`, `sampleCount.Y`).
pub fn write_film_exr(film: &Film, settings: &FilmSettings, path: &Path) -> Result<()> {
    let aovs = settings.aovs;
    let attributes = colour_attributes(settings);
    if aovs == AovSet::default() {
        let rgb = film.rgb(&settings.colour);
        let space = Some(settings.colour.space);
        return write_rgb_exr_in(&rgb, film.width, film.height, space, &attributes, path);
    }
    use exr::prelude::*;
    let (w, h) = (film.width as usize, film.height as usize);
    let pixels = || (0..film.height).flat_map(|y| (0..film.width).map(move |x| (x, y)));
    let rgb = film.rgb(&settings.colour);
    let mut planes: Vec<(&str, Vec<f32>)> = vec![
        ("R", rgb.iter().map(|c| c.x).collect()),
        ("G", rgb.iter().map(|c| c.y).collect()),
        ("B", rgb.iter().map(|c| c.z).collect()),
    ];
    let aov: Vec<(Vec3, Vec3, f32)> = pixels()
        .map(|(x, y)| film.aov(x, y).unwrap_or_default())
        .collect();
    if aovs.albedo {
        let albedo: Vec<Vec3> = aov.iter().map(|a| settings.colour.rgb(a.0)).collect();
        planes.push(("albedo.R", albedo.iter().map(|c| c.x).collect()));
        planes.push(("albedo.G", albedo.iter().map(|c| c.y).collect()));
        planes.push(("albedo.B", albedo.iter().map(|c| c.z).collect()));
    }
    if aovs.normal {
        planes.push(("normal.X", aov.iter().map(|a| a.1.x).collect()));
        planes.push(("normal.Y", aov.iter().map(|a| a.1.y).collect()));
        planes.push(("normal.Z", aov.iter().map(|a| a.1.z).collect()));
    }
    if aovs.depth {
        planes.push(("depth.Z", aov.iter().map(|a| a.2).collect()));
    }
    if aovs.sample_count {
        let counts = pixels()
            .map(|(x, y)| film.sums(x, y).samples as f32)
            .collect();
        planes.push(("sampleCount.Y", counts));
    }
    let channels: Vec<AnyChannel<FlatSamples>> = planes
        .into_iter()
        .map(|(name, plane)| AnyChannel::new(name, FlatSamples::F32(plane)))
        .collect();
    let mut header = LayerAttributes::default();
    set_header_attributes(
        &mut header,
        attributes.iter().map(|(k, v)| (*k, v.as_str())),
    );
    let layer = Layer::new(
        (w, h),
        header,
        exr_encoding(),
        AnyChannels::sort(channels.into_iter().collect()),
    );
    let mut image = Image::from_layer(layer);
    image.attributes.chromaticities = Some(exr_chromaticities(settings.colour.space));
    write_atomically(path, |tmp| {
        image
            .write()
            .to_file(tmp)
            .with_context(|| format!("cannot write {}", tmp.display()))?;
        super::spectral_exr::sort_header_attributes(tmp)
    })
}

/// Row-major linear sRGB pixels as a float32 RGB OpenEXR.
pub fn write_rgb_exr(rgb: &[Vec3], width: u32, height: u32, path: &Path) -> Result<()> {
    write_rgb_exr_in(rgb, width, height, None, &[], path)
}

/// OpenEXR's `chromaticities` attribute for a colour space.
pub fn exr_chromaticities(space: ColourSpace) -> exr::meta::attribute::Chromaticities {
    let c = space.chromaticities();
    let v = |p: glam::DVec2| exr::math::Vec2(p.x as f32, p.y as f32);
    exr::meta::attribute::Chromaticities {
        red: v(c.red),
        green: v(c.green),
        blue: v(c.blue),
        white: v(c.white),
    }
}

/// How prism's EXRs are encoded: RLE in 64² tiles (quick, lossless), and
/// the tiles in increasing order. The exr crate compresses tiles in
/// parallel and, without an order, writes them as they finish: the same
/// image would give different bytes from run to run.
pub fn exr_encoding() -> exr::prelude::Encoding {
    exr::prelude::Encoding {
        line_order: exr::prelude::LineOrder::Increasing,
        ..exr::prelude::Encoding::FAST_LOSSLESS
    }
}

/// Puts text `attributes` in an EXR header (non-ASCII characters, say of a
/// file name, become '?'), and OpenEXR's `adoptedNeutral` where they name
/// the colour space, observer and white balance (`colour_attributes`).
pub fn set_header_attributes<'a>(
    header: &mut exr::meta::header::LayerAttributes,
    attributes: impl IntoIterator<Item = (&'a str, &'a str)> + Clone,
) {
    use super::spectral_exr::{ATTR_COLOUR_SPACE, ATTR_OBSERVER, ATTR_WHITE_BALANCE};
    use exr::meta::attribute::{AttributeValue, Text};
    let get = |key: &str| {
        attributes
            .clone()
            .into_iter()
            .find(|a| a.0 == key)
            .map(|a| a.1)
    };
    let space = get(ATTR_COLOUR_SPACE).and_then(ColourSpace::from_name);
    let observer = get(ATTR_OBSERVER).and_then(Observer::from_name);
    if let (Some(space), Some(observer), Some(balance)) = (space, observer, get(ATTR_WHITE_BALANCE))
    {
        let xy = super::colour::adopted_neutral(space, observer, balance != "none");
        header.adopted_neutral = Some(exr::math::Vec2(xy.x as f32, xy.y as f32));
    }
    let text = |s: &str| {
        Text::from(
            s.chars()
                .map(|c| if c.is_ascii() { c } else { '?' })
                .collect::<String>()
                .as_str(),
        )
    };
    for (k, v) in attributes {
        header.other.insert(text(k), AttributeValue::Text(text(v)));
    }
}

/// What NAME.exr says of its colour: the space of its R, G, B, the
/// observer, the white balance and the XYZ → RGB matrix (the spectral
/// EXR's `render` attributes say the same).
pub fn colour_attributes(settings: &FilmSettings) -> Vec<(&'static str, String)> {
    use super::spectral_exr::*;
    vec![
        (ATTR_COLOUR_SPACE, settings.colour.space.name().to_string()),
        (ATTR_OBSERVER, settings.observer.name().to_string()),
        (
            ATTR_WHITE_BALANCE,
            settings
                .white_balance
                .clone()
                .unwrap_or_else(|| "none".into()),
        ),
        (
            ATTR_XYZ_TO_RGB,
            super::display::matrix_text(settings.colour.matrix()),
        ),
    ]
}

/// Row-major RGB pixels as a float32 RGB OpenEXR, tagged with `space`'s
/// chromaticities where given, and text `attributes`.
pub fn write_rgb_exr_in(
    rgb: &[Vec3],
    width: u32,
    height: u32,
    space: Option<ColourSpace>,
    attributes: &[(&str, String)],
    path: &Path,
) -> Result<()> {
    use exr::prelude::*;
    let (w, h) = (width as usize, height as usize);
    let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let c = rgb[p.y() * w + p.x()];
        (c.x, c.y, c.z)
    });
    let mut image = Image::from_encoded_channels((w, h), exr_encoding(), channels);
    image.attributes.chromaticities = space.map(exr_chromaticities);
    set_header_attributes(
        &mut image.layer_data.attributes,
        attributes.iter().map(|(k, v)| (*k, v.as_str())),
    );
    write_atomically(path, |tmp| {
        image
            .write()
            .to_file(tmp)
            .with_context(|| format!("cannot write {}", tmp.display()))?;
        super::spectral_exr::sort_header_attributes(tmp)
    })
}

/// The film as the display PNG of `settings`.
pub fn write_png(film: &Film, settings: &FilmSettings, path: &Path) -> Result<()> {
    display::write_png(
        &film.rgb(&settings.display_colour),
        film.width,
        film.height,
        path,
        &settings.display_settings(),
    )
}

/// Row-major linear sRGB pixels as an sRGB PNG (8-bit, clipped) after
/// `exposure` stops and `tonemap`.
pub fn write_rgb_png(
    rgb: &[Vec3],
    width: u32,
    height: u32,
    path: &Path,
    exposure: f32,
    tonemap: Tonemap,
) -> Result<()> {
    let settings = DisplaySettings {
        exposure,
        tonemap,
        ..DisplaySettings::default()
    };
    display::write_png(rgb, width, height, path, &settings)
}

/// Reads a linear RGB OpenEXR (the first layer's R, G, B).
pub fn read_rgb_exr(path: &Path) -> Result<(u32, u32, Vec<Vec3>)> {
    use exr::prelude::*;
    // 12 bytes of ours a pixel, counted per channel (three or four).
    super::spectral_exr::check_declared_size(path, 4)?;
    let image = read_first_rgba_layer_from_file(
        path,
        |resolution, _| {
            (
                resolution.width(),
                vec![Vec3::ZERO; resolution.width() * resolution.height()],
            )
        },
        |(width, pixels), position, (r, g, b, _a): (f32, f32, f32, f32)| {
            pixels[position.y() * *width + position.x()] = Vec3::new(r, g, b);
        },
    )
    .with_context(|| format!("cannot read {}", path.display()))?;
    let size = image.layer_data.size;
    Ok((
        size.width() as u32,
        size.height() as u32,
        image.layer_data.channel_data.pixels.1,
    ))
}
