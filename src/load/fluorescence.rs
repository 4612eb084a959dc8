//! Fluorescent materials: a Donaldson matrix from a CSV file, or one made
//! from an excitation spectrum, an emission spectrum and a quantum yield;
//! either way checked to conserve energy before it is used.

use std::path::Path;
use std::sync::Arc;

use super::spectra::Role;
use super::Loader;
use crate::load::format::SceneFile;
use crate::load::spectrum_spec::SpectrumSpec;
use crate::load::SceneError;
use crate::material::Fluorescence;
use crate::spectrum::{csv, Spectrum, LAMBDA_MAX, LAMBDA_MIN};

/// How a fluorescent material's re-emission is given in the scene file.
pub(super) struct FluorescenceSpec<'a> {
    pub donaldson: Option<&'a Path>,
    pub excitation: Option<&'a SpectrumSpec>,
    pub emission: Option<&'a SpectrumSpec>,
    pub quantum_yield: Option<f32>,
}

/// How far a row may exceed 1 (reflected + re-emitted) before it is
/// refused: the rounding of tabulated data.
const ENERGY_SLACK: f32 = 1e-3;

impl Loader {
    /// The matrix of `spec` for the material `key`, whose ordinary
    /// reflectance is `reflectance`.
    pub(super) fn fluorescence(
        &self,
        spec: &FluorescenceSpec,
        reflectance: &Spectrum,
        file: &SceneFile,
        key: &str,
    ) -> Result<Arc<Fluorescence>, SceneError> {
        let triplet = [
            spec.excitation.is_some(),
            spec.emission.is_some(),
            spec.quantum_yield.is_some(),
        ];
        let matrix = match (spec.donaldson, triplet) {
            (Some(path), [false, false, false]) => self.donaldson_file(path, key)?,
            (None, [true, true, true]) => self.triplet_matrix(spec, file, key)?,
            (Some(_), _) => {
                return Err(self.error(format!(
                    "`{key}`: give either `donaldson` or `excitation`, `emission` and `quantum_yield`, not both"
                )))
            }
            (None, _) => {
                let missing: Vec<&str> = ["excitation", "emission", "quantum_yield"]
                    .iter()
                    .zip(triplet)
                    .filter(|(_, given)| !given)
                    .map(|(name, _)| *name)
                    .collect();
                return Err(self.error(format!(
                    "`{key}`: a fluorescent material needs `donaldson` (a matrix file), or `excitation`, `emission` and `quantum_yield`: `{}` missing",
                    missing.join("`, `")
                )));
            }
        };
        let matrix = matrix.ok_or_else(|| {
            self.error(format!(
                "`{key}`: the fluorescence is zero everywhere in {LAMBDA_MIN}-{LAMBDA_MAX} nm: use a diffuse material"
            ))
        })?;
        // Energy: at no exciting wavelength may the surface send back more
        // than arrives, reflected and re-emitted together.
        let [x0, x1] = matrix.excitation_range();
        let worst = (x0 as u32..x1 as u32)
            .map(|x| x as f32 + 0.5)
            .map(|x| (x, reflectance.eval(x).clamp(0.0, 1.0), matrix.row_total(x)))
            .max_by(|a, b| (a.1 + a.2).total_cmp(&(b.1 + b.2)));
        if let Some((x, r, emitted)) = worst.filter(|w| w.1 + w.2 > 1.0 + ENERGY_SLACK) {
            return Err(self.error(format!(
                "`{key}`: at {x} nm it reflects {r:.4} and re-emits {emitted:.4} of the light: more than all of it (the reflectance plus the matrix row's integral over emission must not exceed 1)"
            )));
        }
        Ok(Arc::new(matrix))
    }

    /// A Donaldson matrix CSV: the header names the emission wavelengths
    /// after a first cell that is not a number, each row starts with its
    /// excitation wavelength; values per nm of excitation, interpolated
    /// bilinearly between the rows and columns (zero outside them).
    fn donaldson_file(&self, rel: &Path, key: &str) -> Result<Option<Fluorescence>, SceneError> {
        let key = format!("{key}.donaldson");
        let full = self.input_file(rel, &key)?;
        let fail = |m: String| self.error(format!("`{key}`: {}: {m}", full.display()));
        let text = crate::input::read_to_string(&full).map_err(|e| fail(e.to_string()))?;
        let t = csv::parse(&text).map_err(|e| fail(e.to_string()))?;
        let header = t.header.as_ref().ok_or_else(|| {
            fail(
                "the first row must be a header: a label, then the emission wavelengths in nm"
                    .into(),
            )
        })?;
        let emission: Vec<f32> = header[1..]
            .iter()
            .map(|h| h.parse::<f32>().map_err(|_| h.clone()))
            .collect::<Result<_, _>>()
            .map_err(|h| fail(format!("header: `{h}` is not an emission wavelength in nm")))?;
        if emission.len() != t.columns.len() {
            return Err(fail(format!(
                "the header names {} emission wavelengths and the rows hold {} values",
                emission.len(),
                t.columns.len()
            )));
        }
        if emission.len() < 2 || t.wavelengths.len() < 2 {
            return Err(fail("a matrix needs at least 2 rows and 2 columns".into()));
        }
        if !emission.windows(2).all(|w| w[0] < w[1]) || !(emission[0] > 0.0) {
            return Err(fail(
                "header: the emission wavelengths must be positive and increasing".into(),
            ));
        }
        for (k, column) in t.columns.iter().enumerate() {
            if let Some(i) = column.iter().position(|v| *v < 0.0) {
                return Err(fail(format!(
                    "the value at excitation {} nm, emission {} nm is negative",
                    t.wavelengths[i], emission[k]
                )));
            }
        }
        Ok(Fluorescence::from_density(|x, m| {
            bilinear(&t.wavelengths, &emission, &t.columns, x, m) as f64
        }))
    }

    /// D(λx, λm) = Q a(λx) λx e(λm) / ∫ e(λ) λ dλ for λm ≥ λx: photons
    /// absorbed with probability a, a share Q of them re-emitted with the
    /// emission spectrum's (energy) shape, each with its own energy hc/λm.
    fn triplet_matrix(
        &self,
        spec: &FluorescenceSpec,
        file: &SceneFile,
        key: &str,
    ) -> Result<Option<Fluorescence>, SceneError> {
        let (Some(excitation), Some(emission), Some(q)) =
            (spec.excitation, spec.emission, spec.quantum_yield)
        else {
            unreachable!("the caller checked all three are given");
        };
        if !(0.0..=1.0).contains(&q) {
            return Err(self.error(format!(
                "`{key}.quantum_yield` must lie in [0, 1] (photons out per photon absorbed), found {q}"
            )));
        }
        let a = self.spectrum(
            excitation,
            Role::Reflectance,
            file,
            &format!("{key}.excitation"),
        )?;
        let e = self.spectrum(emission, Role::Unbounded, file, &format!("{key}.emission"))?;
        let photons: f64 = (0..(LAMBDA_MAX - LAMBDA_MIN) as u32)
            .map(|i| LAMBDA_MIN + i as f32 + 0.5)
            .map(|l| e.eval(l) as f64 * l as f64)
            .sum();
        if !(photons > 0.0) {
            return Err(self.error(format!(
                "`{key}.emission` is zero over {LAMBDA_MIN}-{LAMBDA_MAX} nm"
            )));
        }
        Ok(Fluorescence::from_density(|x, m| {
            if m < x {
                return 0.0;
            }
            q as f64 * a.eval(x) as f64 * x as f64 * e.eval(m) as f64 / photons
        }))
    }
}

/// The bilinear interpolation at (x, m) of values on the grid of `rows`
/// (increasing) × `cols` (increasing), `values[col][row]`; zero outside.
fn bilinear(rows: &[f32], cols: &[f32], values: &[Vec<f32>], x: f32, m: f32) -> f32 {
    let (Some((i, s)), Some((k, t))) = (cell(rows, x), cell(cols, m)) else {
        return 0.0;
    };
    let v = |k: usize, i: usize| values[k][i];
    (1.0 - t) * ((1.0 - s) * v(k, i) + s * v(k, i + 1))
        + t * ((1.0 - s) * v(k + 1, i) + s * v(k + 1, i + 1))
}

/// The interval of `grid` holding `x` and where in it (0 to 1).
fn cell(grid: &[f32], x: f32) -> Option<(usize, f32)> {
    if !(x >= grid[0] && x <= grid[grid.len() - 1]) {
        return None;
    }
    let i = (grid.partition_point(|&g| g <= x).max(1) - 1).min(grid.len() - 2);
    Some((i, ((x - grid[i]) / (grid[i + 1] - grid[i])).clamp(0.0, 1.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bilinear_interpolates_inside_and_is_zero_outside() {
        let rows = [400.0, 500.0];
        let cols = [450.0, 550.0, 650.0];
        // values[col][row]
        let values = vec![vec![0.0, 1.0], vec![2.0, 3.0], vec![4.0, 5.0]];
        assert_eq!(bilinear(&rows, &cols, &values, 400.0, 450.0), 0.0);
        assert_eq!(bilinear(&rows, &cols, &values, 500.0, 650.0), 5.0);
        assert!((bilinear(&rows, &cols, &values, 450.0, 500.0) - 1.5).abs() < 1e-6);
        assert!((bilinear(&rows, &cols, &values, 425.0, 600.0) - 3.25).abs() < 1e-6);
        assert_eq!(bilinear(&rows, &cols, &values, 399.0, 500.0), 0.0);
        assert_eq!(bilinear(&rows, &cols, &values, 450.0, 651.0), 0.0);
    }
}
