//! Writing the film: linear sRGB OpenEXR (float) and sRGB-encoded 8-bit PNG.
//! Files are written under a temporary name and renamed into place, so a
//! reader never sees half a file.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use glam::Vec3;

use super::Film;
use crate::spectrum::cie::srgb_encode;

/// How linear radiance becomes display values in the PNG.
#[derive(Clone, Copy, Debug, Default, serde::Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Tonemap {
    /// Clip linear values to [0, 1] before sRGB encoding.
    #[default]
    Clamp,
    /// x / (1 + x) per channel: keeps highlights, compresses everything.
    Reinhard,
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

/// Linear sRGB radiance as a float32 RGB OpenEXR.
pub fn write_exr(film: &Film, path: &Path) -> Result<()> {
    write_rgb_exr(&film.linear_srgb(), film.width, film.height, path)
}

/// Row-major linear sRGB pixels as a float32 RGB OpenEXR.
pub fn write_rgb_exr(rgb: &[Vec3], width: u32, height: u32, path: &Path) -> Result<()> {
    let w = width as usize;
    write_atomically(path, |tmp| {
        exr::prelude::write_rgb_file(tmp, w, height as usize, |x, y| {
            let c = rgb[y * w + x];
            (c.x, c.y, c.z)
        })
        .with_context(|| format!("cannot write {}", tmp.display()))
    })
}

/// Maps linear sRGB to display values in [0, 1] (before encoding).
pub fn tonemap(c: Vec3, exposure: f32, op: Tonemap) -> Vec3 {
    let c = (c * exposure.exp2()).max(Vec3::ZERO);
    match op {
        Tonemap::Clamp => c.min(Vec3::ONE),
        Tonemap::Reinhard => c / (Vec3::ONE + c),
    }
}

/// sRGB-encoded 8-bit PNG after exposure (stops) and tone mapping.
pub fn write_png(film: &Film, path: &Path, exposure: f32, op: Tonemap) -> Result<()> {
    write_rgb_png(
        &film.linear_srgb(),
        film.width,
        film.height,
        path,
        exposure,
        op,
    )
}

/// Row-major linear sRGB pixels as an sRGB-encoded 8-bit PNG.
pub fn write_rgb_png(
    rgb: &[Vec3],
    width: u32,
    height: u32,
    path: &Path,
    exposure: f32,
    op: Tonemap,
) -> Result<()> {
    let bytes: Vec<u8> = rgb
        .iter()
        .copied()
        .flat_map(|c| {
            let t = tonemap(c, exposure, op);
            [t.x, t.y, t.z].map(|v| (srgb_encode(v) * 255.0 + 0.5).clamp(0.0, 255.0) as u8)
        })
        .collect();
    write_atomically(path, |tmp| {
        image::save_buffer(tmp, &bytes, width, height, image::ColorType::Rgb8)
            .with_context(|| format!("cannot write {}", tmp.display()))
    })
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
