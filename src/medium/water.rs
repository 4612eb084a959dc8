//! The absorption coefficient of pure liquid water (1/m), Segelstein
//! (1981) via refractiveindex.info (CC0): `spectra/water_absorption.csv`,
//! written by `tools/extract_water.py`. The scene files' `"water"`.

use std::sync::OnceLock;

use crate::spectrum::{csv, TabulatedSpectrum};

/// The name scene files use for it.
pub const NAME: &str = "water";

pub fn absorption() -> &'static TabulatedSpectrum {
    static TABLE: OnceLock<TabulatedSpectrum> = OnceLock::new();
    TABLE.get_or_init(|| {
        let t = csv::parse(include_str!("../../spectra/water_absorption.csv"))
            .expect("the built-in water table parses");
        TabulatedSpectrum::new(t.wavelengths, t.columns[0].clone())
    })
}

#[cfg(test)]
mod tests {
    #[test]
    fn water_is_blue_clear_and_red_absorbing() {
        let a = super::absorption();
        // Segelstein's values: about 0.02/m in the blue-green window, 0.3/m at 620 nm.
        assert!(a.eval(475.0) < 0.025 && a.eval(475.0) > 0.01);
        assert!((a.eval(620.0) - 0.28).abs() < 0.03);
        assert!(a.eval(700.0) > 0.5);
    }
}
