//! Measured complex indices of refraction of common metals, embedded from
//! `spectra/metals/` (Palik-derived data as shipped by Mitsuba 3 and pbrt-v4).

use crate::spectrum::{csv, Spectrum, TabulatedSpectrum};

pub const NAMES: [&str; 4] = ["Au", "Ag", "Cu", "Al"];

/// n(λ) and k(λ) of a named metal.
pub fn metal(name: &str) -> Option<(Spectrum, Spectrum)> {
    let text = match name {
        "Au" => include_str!("../../spectra/metals/Au.csv"),
        "Ag" => include_str!("../../spectra/metals/Ag.csv"),
        "Cu" => include_str!("../../spectra/metals/Cu.csv"),
        "Al" => include_str!("../../spectra/metals/Al.csv"),
        _ => return None,
    };
    let t = csv::parse(text).expect("embedded metal tables are valid");
    let table = |c: usize| {
        Spectrum::Table(TabulatedSpectrum::new(
            t.wavelengths.clone(),
            t.columns[c].clone(),
        ))
    };
    Some((table(0), table(1)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::fresnel;

    #[test]
    fn normal_incidence_reflectance_at_550_nm() {
        // Spot values of shared/data/README.md.
        for (name, expected) in [("Au", 0.848), ("Ag", 0.960), ("Cu", 0.634), ("Al", 0.921)] {
            let (n, k) = metal(name).unwrap();
            let r = fresnel::conductor(1.0, n.eval(550.0), k.eval(550.0));
            assert!((r - expected).abs() < 2e-3, "{name}: {r}");
        }
    }
}
