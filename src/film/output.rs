//! Writing the film: RGB OpenEXR (float, in the film's colour space,
//! tagged with its chromaticities) and the display PNG (`display`). Files
//! are written under a temporary name and renamed into place, so a reader
//! never sees half a file.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use glam::Vec3;

use super::colour::{ColourSpace, ColourTransform};
use super::display::{self, DisplaySettings};
use super::{Film, FilmSettings};

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
    /// An AgX-like curve: a logistic in stops per channel in an inset
    /// space; highlights roll off and desaturate smoothly
    /// ([`display::filmic`]).
    Filmic,
}

/// Writes `path` through a temporary sibling and a rename.
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let tmp = temp_name(path);
    let result = write(&tmp).and_then(|_| {
        std::fs::rename(&tmp, path)
            .with_context(|| format!("cannot move {} into place", tmp.display()))
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

fn temp_name(path: &Path) -> PathBuf {
    let stem = path.file_stem().unwrap_or_default().to_string_lossy();
    let ext = path.extension().unwrap_or_default().to_string_lossy();
    // Keep the extension last: the image writers pick the format by it.
    path.with_file_name(format!(".{stem}.partial-{}.{ext}", std::process::id()))
}

/// The film's RGB (in `colour`'s space) as a float32 RGB OpenEXR tagged
/// with the space's chromaticities.
pub fn write_exr(film: &Film, colour: &ColourTransform, path: &Path) -> Result<()> {
    write_rgb_exr_in(
        &film.rgb(colour),
        film.width,
        film.height,
        Some(colour.space),
        path,
    )
}

/// Row-major linear sRGB pixels as a float32 RGB OpenEXR.
pub fn write_rgb_exr(rgb: &[Vec3], width: u32, height: u32, path: &Path) -> Result<()> {
    write_rgb_exr_in(rgb, width, height, None, path)
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

/// Row-major RGB pixels as a float32 RGB OpenEXR, tagged with `space`'s
/// chromaticities where given.
pub fn write_rgb_exr_in(
    rgb: &[Vec3],
    width: u32,
    height: u32,
    space: Option<ColourSpace>,
    path: &Path,
) -> Result<()> {
    use exr::prelude::*;
    let (w, h) = (width as usize, height as usize);
    let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
        let c = rgb[p.y() * w + p.x()];
        (c.x, c.y, c.z)
    });
    let mut image = Image::from_channels((w, h), channels);
    image.attributes.chromaticities = space.map(exr_chromaticities);
    write_atomically(path, |tmp| {
        image
            .write()
            .to_file(tmp)
            .with_context(|| format!("cannot write {}", tmp.display()))
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
