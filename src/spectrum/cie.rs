//! CIE 1931 2° colorimetry and the standard illuminants, from tables that
//! `tools/gen_tables.py` generates with colour-science and that are embedded
//! at compile time.

use std::sync::OnceLock;

use glam::{Mat3, Vec3};

use super::csv;
use super::{SampledSpectrum, SampledWavelengths, Spectrum, TabulatedSpectrum};

/// First wavelength of the embedded colour-matching-function table (nm).
pub const CMF_START: usize = 360;
/// Last wavelength of the embedded colour-matching-function table (nm).
pub const CMF_END: usize = 830;

const CMF_CSV: &str = include_str!("../../spectra/cie_1931_2deg.csv");

/// The CIE 1931 2° observer at 1 nm steps, 360..=830 nm.
pub struct ColourMatching {
    pub xyz: Vec<Vec3>,
    /// Σ ȳ over the 1 nm table; dividing by it makes a constant radiance of 1 have Y = 1.
    pub y_integral: f32,
}

pub fn cmfs() -> &'static ColourMatching {
    static CMFS: OnceLock<ColourMatching> = OnceLock::new();
    CMFS.get_or_init(|| {
        let table = csv::parse(CMF_CSV).expect("embedded CMF table is valid");
        assert_eq!(table.wavelengths.len(), CMF_END - CMF_START + 1);
        let xyz: Vec<Vec3> = (0..table.wavelengths.len())
            .map(|i| {
                Vec3::new(
                    table.columns[0][i],
                    table.columns[1][i],
                    table.columns[2][i],
                )
            })
            .collect();
        let y_integral = xyz.iter().map(|v| v.y as f64).sum::<f64>() as f32;
        ColourMatching { xyz, y_integral }
    })
}

/// x̄ȳz̄ at a wavelength, linearly interpolated; zero outside 360–830 nm.
pub fn cmf(lambda: f32) -> Vec3 {
    let t = lambda - CMF_START as f32;
    if !(0.0..=(CMF_END - CMF_START) as f32).contains(&t) {
        return Vec3::ZERO;
    }
    let table = &cmfs().xyz;
    let i = (t as usize).min(table.len() - 2);
    let f = t - i as f32;
    table[i] * (1.0 - f) + table[i + 1] * f
}

/// Monte Carlo estimate of the XYZ of a spectrum known at sampled wavelengths:
/// the average over wavelengths of x̄ȳz̄(λ)·L(λ)/pdf(λ), normalised so that a
/// constant spectrum of 1 has Y = 1. Terminated wavelengths (pdf 0) are skipped.
pub fn sampled_to_xyz(l: SampledSpectrum, wl: &SampledWavelengths) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for i in 0..4 {
        let pdf = wl.pdf[i];
        if pdf > 0.0 {
            sum += cmf(wl.lambda[i]) * (l[i] / pdf);
        }
    }
    sum / (4.0 * cmfs().y_integral)
}

/// XYZ of a spectrum by the 1 nm Riemann sum over 360–830 nm, with the same
/// normalisation as [`sampled_to_xyz`].
pub fn spectrum_to_xyz(s: &Spectrum) -> Vec3 {
    let c = cmfs();
    let sum: glam::DVec3 = c
        .xyz
        .iter()
        .enumerate()
        .map(|(i, bar)| bar.as_dvec3() * s.eval((CMF_START + i) as f32) as f64)
        .sum();
    (sum / c.y_integral as f64).as_vec3()
}

/// Linear sRGB (Rec. 709 primaries, D65 white) from XYZ, with the rounded
/// matrix of IEC 61966-2-1 that colour-science also uses.
pub fn xyz_to_linear_srgb(xyz: Vec3) -> Vec3 {
    XYZ_TO_SRGB * xyz
}

/// IEC 61966-2-1 XYZ → linear sRGB, column-major for glam.
pub const XYZ_TO_SRGB: Mat3 = Mat3::from_cols_array(&[
    3.2406, -0.9689, 0.0557, //
    -1.5372, 1.8758, -0.2040, //
    -0.4986, 0.0415, 1.0570,
]);

/// The sRGB transfer function (linear → encoded), for 8-bit output.
pub fn srgb_encode(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// The sRGB transfer function inverse (encoded → linear), for colour textures.
pub fn srgb_decode(v: f32) -> f32 {
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// Standard illuminants prism knows by name, with their relative spectral
/// power as tabulated by the CIE. `E` is the equal-energy illuminant.
pub const ILLUMINANT_NAMES: [&str; 7] = ["D65", "D50", "A", "E", "FL2", "FL7", "FL11"];

/// A named CIE illuminant as tabulated (relative units, not normalised).
pub fn illuminant(name: &str) -> Option<&'static TabulatedSpectrum> {
    static TABLES: OnceLock<Vec<(&'static str, TabulatedSpectrum)>> = OnceLock::new();
    let tables = TABLES.get_or_init(|| {
        let sources: [(&str, &str); 7] = [
            ("D65", include_str!("../../spectra/cie_d65.csv")),
            ("D50", include_str!("../../spectra/cie_d50.csv")),
            ("A", include_str!("../../spectra/cie_a.csv")),
            ("E", "300,1\n830,1\n"),
            ("FL2", include_str!("../../spectra/cie_fl2.csv")),
            ("FL7", include_str!("../../spectra/cie_fl7.csv")),
            ("FL11", include_str!("../../spectra/cie_fl11.csv")),
        ];
        sources
            .iter()
            .map(|(name, text)| {
                let t = csv::parse(text).expect("embedded illuminant table is valid");
                (
                    *name,
                    TabulatedSpectrum::new(t.wavelengths, t.columns[0].clone()),
                )
            })
            .collect()
    });
    tables.iter().find(|(n, _)| *n == name).map(|(_, t)| t)
}

/// The D65 illuminant, as the white of sRGB.
pub fn d65() -> &'static TabulatedSpectrum {
    illuminant("D65").expect("D65 is embedded")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn y_integral_matches_colour_science() {
        assert!((cmfs().y_integral as f64 - 106.856_917).abs() < 1e-3);
    }

    #[test]
    fn d65_white_reflector_has_the_d65_white_point_and_srgb_white() {
        let d65 = Spectrum::Table(d65().clone());
        let xyz = spectrum_to_xyz(&d65);
        let xyz = xyz / xyz.y;
        assert!(
            (xyz - Vec3::new(0.95047, 1.0, 1.08883)).abs().max_element() < 2e-4,
            "{xyz}"
        );
        let rgb = xyz_to_linear_srgb(xyz);
        assert!((rgb - Vec3::ONE).abs().max_element() < 1e-3, "{rgb}");
    }

    #[test]
    fn srgb_transfer_round_trips() {
        for i in 0..=100 {
            let v = i as f32 / 100.0;
            assert!((srgb_decode(srgb_encode(v)) - v).abs() < 1e-5);
        }
    }
}
