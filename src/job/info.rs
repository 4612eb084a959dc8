//! `prism info`: what an OpenEXR file holds.

use std::path::Path;

use anyhow::Result;

use crate::film::spectral_exr;

/// The report of `prism info`.
pub fn describe(file: &Path) -> Result<String> {
    use std::fmt::Write;
    let img = spectral_exr::read(file)?;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{}: {} x {} pixels",
        file.display(),
        img.width,
        img.height
    );
    for (k, v) in &img.attributes {
        let _ = writeln!(out, "  {k} = {v}");
    }
    let stats = |values: &[f32]| {
        let finite: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
        let mean = finite.iter().map(|&v| v as f64).sum::<f64>() / finite.len().max(1) as f64;
        let min = finite.iter().copied().fold(f32::INFINITY, f32::min);
        let max = finite.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        (min, max, mean, values.len() - finite.len())
    };
    // Emissive channels (S0.), else those of the reflective layout (T.),
    // which stay among the other channels when read.
    let mut reflective: Vec<(f64, &str)> = img
        .other
        .keys()
        .filter_map(|k| spectral_exr::parse_reflective_name(k).map(|l| (l, k.as_str())))
        .collect();
    reflective.sort_by(|a, b| a.0.total_cmp(&b.0));
    let reflective_layout = img.wavelengths.is_empty() && !reflective.is_empty();
    let (layout, wavelengths, planes): (&str, Vec<f64>, Vec<&Vec<f32>>) = if !reflective_layout {
        (
            "emissive S0",
            img.wavelengths.clone(),
            img.spectral.iter().collect(),
        )
    } else {
        (
            "reflective T",
            reflective.iter().map(|r| r.0).collect(),
            reflective.iter().map(|r| &img.other[r.1]).collect(),
        )
    };
    if wavelengths.is_empty() {
        let _ = writeln!(out, "no spectral channels");
    } else {
        let n = wavelengths.len();
        let (first, last) = (wavelengths[0], wavelengths[n - 1]);
        let spacing = if n > 1 {
            (last - first) / (n - 1) as f64
        } else {
            0.0
        };
        let _ = writeln!(
            out,
            "spectral ({layout}): {n} channels, centres {first:.3}-{last:.3} nm, spacing {spacing:.3} nm"
        );
        let _ = writeln!(
            out,
            "  {:>12}  {:>12}  {:>12}  {:>12}",
            "nm", "min", "mean", "max"
        );
        let mut bad = 0;
        for (lambda, plane) in wavelengths.iter().zip(planes) {
            let (min, max, mean, non_finite) = stats(plane);
            bad += non_finite;
            let _ = writeln!(
                out,
                "  {lambda:>12.3}  {min:>12.6}  {mean:>12.6}  {max:>12.6}"
            );
        }
        let _ = writeln!(out, "  non-finite spectral values: {bad}");
    }
    let listed = |name: &str| reflective_layout && reflective.iter().any(|r| r.1 == name);
    for (name, plane) in img.other.iter().filter(|(k, _)| !listed(k)) {
        let (min, max, mean, non_finite) = stats(plane);
        let _ = writeln!(
            out,
            "channel {name}: min {min:.6}, mean {mean:.6}, max {max:.6}, non-finite {non_finite}"
        );
    }
    Ok(out)
}
