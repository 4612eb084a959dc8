//! `prism spectrum`: the colorimetry of one spectrum, without a scene: XYZ,
//! xy, u′v′, CCT and Duv, and luminance for a light; for a reflectance
//! under an illuminant, XYZ (the perfect white at Y = 100) and CIELAB.

use std::fmt::Write;
use std::path::Path;

use anyhow::{anyhow, Result};
use glam::DVec3;

use crate::spectrum::cct::{cct_duv, uv_1960, uv_1976, xy};
use crate::spectrum::cie::{self, Observer};
use crate::spectrum::Spectrum;

/// What `prism spectrum` is asked.
pub struct SpectrumQuery<'a> {
    /// A built-in name, a file, or a scene file's spectrum form.
    pub spectrum: &'a str,
    /// The value column of a multi-column file.
    pub column: Option<&'a str>,
    /// The illuminant a reflectance is seen under (None: a light).
    pub under: Option<&'a str>,
    pub observer: Observer,
}

/// The report of `prism spectrum`.
pub fn describe_spectrum(query: &SpectrumQuery) -> Result<String> {
    let cmfs = query.observer.cmfs();
    let mut out = String::new();
    let _ = writeln!(out, "observer: {}", query.observer.name());
    match query.under {
        None => {
            let s = spectrum(query.spectrum, query.column, "emission")?;
            let xyz = cmfs.spectrum_to_xyz(&s).as_dvec3();
            let _ = writeln!(
                out,
                "{}: a light (built-in illuminants and blackbodies scaled to Y = 1 under CIE 1931; files and tables as given)",
                query.spectrum
            );
            chromaticity(&mut out, xyz, true);
            let _ = writeln!(
                out,
                "luminance: {:.6e} cd/m² for spectral radiance in W·m⁻²·sr⁻¹·nm⁻¹ ({} lm/W × ∫ S ȳ dλ, CIE 1931)",
                cie::photometric(&s),
                cie::LUMINOUS_EFFICACY
            );
        }
        Some(illuminant) => {
            let r = spectrum(query.spectrum, query.column, "reflectance")?;
            let e = spectrum(illuminant, None, "emission")?;
            let white = cmfs.spectrum_to_xyz(&e).as_dvec3();
            let product = Spectrum::Table(crate::spectrum::TabulatedSpectrum::new(
                (360..=830).map(|l| l as f32).collect(),
                (360..=830)
                    .map(|l| r.eval(l as f32) * e.eval(l as f32))
                    .collect(),
            ));
            let xyz = cmfs.spectrum_to_xyz(&product).as_dvec3() * (100.0 / white.y);
            let white = white * (100.0 / white.y);
            let _ = writeln!(
                out,
                "{}: a reflectance under {illuminant} (the perfect white has Y = 100)",
                query.spectrum
            );
            chromaticity(&mut out, xyz, false);
            let lab = lab(xyz, white);
            let _ = writeln!(
                out,
                "CIELAB: L* {:.4}  a* {:.4}  b* {:.4} (white: the illuminant)",
                lab.x, lab.y, lab.z
            );
        }
    }
    Ok(out)
}

/// XYZ, xy, u′v′, and for a light CCT with Duv where it has one.
fn chromaticity(out: &mut String, xyz: DVec3, light: bool) {
    let _ = writeln!(out, "XYZ: {:.6} {:.6} {:.6}", xyz.x, xyz.y, xyz.z);
    if !(xyz.x + xyz.y + xyz.z > 0.0) {
        let _ = writeln!(out, "no chromaticity (black)");
        return;
    }
    let c = xy(xyz);
    let p = uv_1976(xyz);
    let _ = writeln!(out, "xy: {:.6} {:.6}", c.x, c.y);
    let _ = writeln!(out, "u'v': {:.6} {:.6}", p.x, p.y);
    if !light {
        return;
    }
    match cct_duv(uv_1960(xyz)) {
        Some((t, duv)) if duv.abs() <= 0.05 => {
            let _ = writeln!(
                out,
                "CCT: {t:.1} K, Duv {duv:+.5} (Ohno 2014, CIE 1960 UCS)"
            );
        }
        _ => {
            let _ = writeln!(out, "CCT: none (farther than Duv 0.05 from the Planckian locus, or outside 1000-100000 K)");
        }
    }
}

/// CIELAB of `xyz` relative to `white`.
fn lab(xyz: DVec3, white: DVec3) -> DVec3 {
    let f = |t: f64| {
        if t > (6.0f64 / 29.0).powi(3) {
            t.cbrt()
        } else {
            t / (3.0 * (6.0f64 / 29.0).powi(2)) + 4.0 / 29.0
        }
    };
    let (fx, fy, fz) = (f(xyz.x / white.x), f(xyz.y / white.y), f(xyz.z / white.z));
    DVec3::new(116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz))
}

/// The spectrum an argument names: a file that exists (with `column`), a
/// scene file's form (`{ daylight = 5500 }`, `[[400, 1], ...]`, `0.5`), or
/// a name.
fn spectrum(arg: &str, column: Option<&str>, role: &str) -> Result<Spectrum> {
    let path = Path::new(arg);
    let value = if path.is_file() {
        let mut t = toml::Table::new();
        t.insert("file".into(), toml::Value::String(arg.into()));
        if let Some(c) = column {
            let v = match c.parse::<i64>() {
                Ok(i) => toml::Value::Integer(i),
                Err(_) => toml::Value::String(c.into()),
            };
            t.insert("column".into(), v);
        }
        toml::Value::Table(t)
    } else {
        if column.is_some() {
            return Err(anyhow!(
                "--column picks a column of a file, and {arg} is not one"
            ));
        }
        match toml::from_str::<toml::Table>(&format!("s = {arg}")) {
            Ok(mut t) => t.remove("s").expect("parsed as s"),
            Err(_) => toml::Value::String(arg.into()),
        }
    };
    crate::load::spectrum(value, role, Path::new(""), arg).map_err(|e| anyhow!("{e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn d65_is_near_6504_k_and_a_white_reflector_is_the_white() {
        let q = SpectrumQuery {
            spectrum: "D65",
            column: None,
            under: None,
            observer: Observer::Cie1931,
        };
        let report = describe_spectrum(&q).unwrap();
        assert!(report.contains("xy: 0.31272"), "{report}");
        assert!(report.contains("CCT: 650"), "{report}");
        let q = SpectrumQuery {
            spectrum: "1",
            under: Some("A"),
            ..q
        };
        let report = describe_spectrum(&q).unwrap();
        assert!(
            report.contains("L* 100.0000  a* 0.0000  b* 0.0000"),
            "{report}"
        );
        let q = SpectrumQuery {
            spectrum: "no-such-lamp",
            under: None,
            ..q
        };
        assert!(describe_spectrum(&q)
            .unwrap_err()
            .to_string()
            .contains("unknown spectrum"));
    }
}
