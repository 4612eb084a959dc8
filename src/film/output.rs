//! Writing the film: linear sRGB OpenEXR (float) and sRGB-encoded 8-bit PNG.
//! Files are written under a temporary name and renamed into place, so a
//! reader never sees half a file.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use glam::Vec3;

use super::Film;
use crate::scene::Tonemap;
use crate::spectrum::cie::srgb_encode;

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
    let rgb = film.linear_srgb();
    let w = film.width as usize;
    write_atomically(path, |tmp| {
        exr::prelude::write_rgb_file(tmp, w, film.height as usize, |x, y| {
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
    let bytes: Vec<u8> = film
        .linear_srgb()
        .into_iter()
        .flat_map(|c| {
            let t = tonemap(c, exposure, op);
            [t.x, t.y, t.z].map(|v| (srgb_encode(v) * 255.0 + 0.5).clamp(0.0, 255.0) as u8)
        })
        .collect();
    write_atomically(path, |tmp| {
        image::save_buffer(tmp, &bytes, film.width, film.height, image::ColorType::Rgb8)
            .with_context(|| format!("cannot write {}", tmp.display()))
    })
}
