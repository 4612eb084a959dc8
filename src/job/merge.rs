//! `prism merge`: partial renders into one image and its files.

use std::path::{Path, PathBuf};

use anyhow::Result;

use super::{check_writable, output_stem, suffixed};
use crate::film::output::write_rgb_exr_in;
use crate::film::spectral_exr::ATTR_COLOUR_SPACE;
use crate::film::{display, spectral_exr, ColourSpace};
use crate::merge::{merge, ATTR_SAMPLES};

pub struct MergeJob {
    /// The partial renders (NAME.spectral.exr files).
    pub parts: Vec<PathBuf>,
    /// Output path without extension.
    pub output: PathBuf,
    /// Exposure of the PNG in stops.
    pub exposure: f32,
}

/// Merges the parts and writes OUT.spectral.exr, OUT.exr and OUT.png; the
/// report goes to stderr.
pub fn merge_files(job: &MergeJob) -> Result<()> {
    if !job.exposure.is_finite() {
        anyhow::bail!("--exposure must be a finite number of stops");
    }
    // Every part is held at once: each is checked with those read before it.
    let (images, _) = crate::memory::tallying(None, || {
        job.parts
            .iter()
            .map(|p| {
                let img = spectral_exr::read(p)?;
                crate::memory::hold(&p.display().to_string(), img.bytes())
                    .map_err(anyhow::Error::msg)?;
                Ok((p.clone(), img))
            })
            .collect::<Result<Vec<_>>>()
    });
    let images = images?;
    // The merged image is one more of the size of the largest part.
    let sizes = images.iter().map(|(_, img)| img.bytes());
    crate::memory::check(
        &format!("merging {} parts", images.len()),
        sizes.clone().sum::<u64>() + sizes.max().unwrap_or(0),
    )
    .map_err(anyhow::Error::msg)?;
    for (p, img) in &images {
        if img.attributes.contains_key(super::ATTR_INTERRUPTED) {
            eprintln!(
                "warning: {} is an interrupted render: it holds fewer samples than its range",
                p.display()
            );
        }
    }
    let merged = merge(&images)?;
    let stem = output_stem(Path::new(""), Some(job.output.clone()));
    check_writable(&stem)?;
    let spectral = suffixed(&stem, "spectral.exr");
    // merge() refuses parts without R, G and B.
    let (r, g, b) = (&merged.other["R"], &merged.other["G"], &merged.other["B"]);
    let rgb: Vec<glam::Vec3> = (0..merged.width * merged.height)
        .map(|i| glam::Vec3::new(r[i], g[i], b[i]))
        .collect();
    let (w, h) = (merged.width as u32, merged.height as u32);
    let (exr, png) = (suffixed(&stem, "exr"), suffixed(&stem, "png"));
    let space = match merged.attributes.get(ATTR_COLOUR_SPACE) {
        Some(name) => Some(
            ColourSpace::from_name(name)
                .ok_or_else(|| anyhow::anyhow!("unknown `{ATTR_COLOUR_SPACE}` {name:?}"))?,
        ),
        None => Some(ColourSpace::SrgbLinear),
    };
    let (to_display, settings) = display::from_attributes(&merged.attributes, job.exposure)?;
    let uncovered = merged.other[spectral_exr::SAMPLE_COUNT]
        .iter()
        .filter(|&&c| c == 0.0)
        .count();
    let samples = merged.attributes[ATTR_SAMPLES].clone();
    // NAME.exr says of its colour what the parts' spectral files say.
    let colour_attributes: Vec<(&str, String)> = [
        spectral_exr::ATTR_COLOUR_SPACE,
        spectral_exr::ATTR_OBSERVER,
        spectral_exr::ATTR_WHITE_BALANCE,
        spectral_exr::ATTR_XYZ_TO_RGB,
    ]
    .into_iter()
    .filter_map(|k| merged.attributes.get(k).map(|v| (k, v.clone())))
    .collect();
    // The three files replace the old ones together, or none does. The
    // merged image goes into its file without a copy of its planes.
    crate::film::output::as_one_set(|| {
        spectral_exr::write_image(merged, &spectral)?;
        write_rgb_exr_in(&rgb, w, h, space, &colour_attributes, &exr)?;
        let display_rgb: Vec<glam::Vec3> = rgb.iter().map(|&c| to_display * c).collect();
        display::write_png(&display_rgb, w, h, &png, &settings)
    })?;
    if uncovered > 0 {
        eprintln!(
            "warning: {uncovered} of {} pixels are in no part: they are black",
            w as u64 * h as u64
        );
    }
    eprintln!(
        "merged {} part{} (samples {}): wrote {}, {} and {}",
        job.parts.len(),
        if job.parts.len() == 1 { "" } else { "s" },
        samples,
        spectral.display(),
        exr.display(),
        png.display()
    );
    Ok(())
}
