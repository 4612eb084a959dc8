//! Fluorescence: light absorbed at one wavelength and re-emitted, diffusely,
//! at another. A bispectral surface is described by its Donaldson matrix
//! D(λx, λm): the radiance factor it emits at λm per nanometre of exciting
//! light at λx, beside its ordinary reflectance r(λ). Under irradiance E the
//! light leaving it at λm is
//!
//!   r(λm) E(λm) + ∫ D(λx, λm) E(λx) dλx,
//!
//! the total radiance factor of CIE 15 and ASTM E2153.
//!
//! A camera path carries its four wavelengths backwards: at a fluorescent
//! surface each wavelength λm either stays (reflection, with probability
//! r / (r + c)) or becomes an exciting wavelength λx drawn from the matrix's
//! column at λm (c = ∫ D(λx, λm) dλx), so the path's weight at that
//! wavelength is r + c whichever happens, and the light found further on is
//! evaluated where it excites. The four wavelengths decide independently:
//! the directions the path takes do not depend on any of them here, and
//! the densities of wavelength changes are the same whichever wavelength
//! leads, so spectral MIS weights over directions are unchanged. The film
//! still bins each sample at the wavelength the camera saw.
//!
//! The matrix is held as a piecewise-constant density on 1 nm cells (its
//! value at each cell's centre), with each emission cell's running sum over
//! excitation: evaluation, the column totals and sampling all use the same
//! function.

use crate::spectrum::{SampledSpectrum, SampledWavelengths, LAMBDA_MAX, LAMBDA_MIN};

/// A Donaldson matrix on 1 nm cells over its support within
/// [LAMBDA_MIN, LAMBDA_MAX], and optionally the scene's light to guide
/// which exciting wavelengths are drawn.
#[derive(Clone, Debug, PartialEq)]
pub struct Fluorescence {
    /// Start of the first excitation cell (whole nm) and the cell count.
    x0: f32,
    nx: usize,
    /// Start of the first emission cell (whole nm) and the cell count.
    m0: f32,
    nm: usize,
    /// For emission cell k, `cdf[k·(nx+1) + i]` = Σ over excitation cells
    /// below i of D (per nm) × 1 nm; the last entry is the column's total.
    cdf: Vec<f32>,
    /// The same sums of D × E, E being the scene's light at each
    /// excitation cell (`guided_by`): half the exciting wavelengths are
    /// drawn from them, so a narrow lamp is found where it shines. Empty
    /// without a guide.
    lit_cdf: Vec<f32>,
    /// E at each excitation cell (mean 1 over the cells where it shines).
    light: Vec<f32>,
}

/// Share of exciting wavelengths drawn from D × E where a guide is set.
const GUIDED: f32 = 0.5;

/// Cells of 1 nm over the range paths carry.
const CELLS: usize = (LAMBDA_MAX - LAMBDA_MIN) as usize;

impl Fluorescence {
    /// The matrix whose density (per nm of excitation) at excitation `x`
    /// and emission `m` is `density(x, m)`, sampled at cell centres;
    /// None where it is zero everywhere. Negative or non-finite values
    /// count as zero (the loader refuses them first).
    pub fn from_density(density: impl Fn(f32, f32) -> f64) -> Option<Self> {
        let centre = |i: usize| LAMBDA_MIN + i as f32 + 0.5;
        let mut grid = vec![0.0f64; CELLS * CELLS];
        let (mut x_range, mut m_range) = ((CELLS, 0), (CELLS, 0));
        for i in 0..CELLS {
            for k in 0..CELLS {
                let d = density(centre(i), centre(k));
                if d.is_finite() && d > 0.0 {
                    grid[i * CELLS + k] = d;
                    x_range = (x_range.0.min(i), x_range.1.max(i + 1));
                    m_range = (m_range.0.min(k), m_range.1.max(k + 1));
                }
            }
        }
        if x_range.0 >= x_range.1 {
            return None;
        }
        let (nx, nm) = (x_range.1 - x_range.0, m_range.1 - m_range.0);
        let mut cdf = Vec::with_capacity(nm * (nx + 1));
        for k in m_range.0..m_range.1 {
            let mut sum = 0.0f64;
            cdf.push(0.0);
            for i in x_range.0..x_range.1 {
                sum += grid[i * CELLS + k];
                cdf.push(sum as f32);
            }
        }
        Some(Self {
            x0: LAMBDA_MIN + x_range.0 as f32,
            nx,
            m0: LAMBDA_MIN + m_range.0 as f32,
            nm,
            cdf,
            lit_cdf: Vec::new(),
            light: Vec::new(),
        })
    }

    /// The matrix, drawing half its exciting wavelengths in proportion to
    /// D × `light` (per 1 nm cell over [LAMBDA_MIN, LAMBDA_MAX]: the
    /// scene's emission), the other half from D alone so that light from
    /// elsewhere (reflected, or from another fluorescent surface) is still
    /// found. Without light (all zero) it is the matrix unguided.
    pub fn guided_by(&self, light: &[f64]) -> Self {
        let first_x = (self.x0 - LAMBDA_MIN) as usize;
        let cells = &light[first_x..first_x + self.nx];
        let mean = cells.iter().map(|e| e.max(0.0)).sum::<f64>() / self.nx as f64;
        let mut guided = self.clone();
        if !(mean > 0.0 && mean.is_finite()) {
            guided.lit_cdf.clear();
            guided.light.clear();
            return guided;
        }
        guided.light = cells.iter().map(|e| (e.max(0.0) / mean) as f32).collect();
        guided.lit_cdf = Vec::with_capacity(self.cdf.len());
        for k in 0..self.nm {
            let c = &self.cdf[self.sums(k)];
            let mut sum = 0.0f64;
            guided.lit_cdf.push(0.0);
            for i in 0..self.nx {
                sum += (c[i + 1] - c[i]) as f64 * guided.light[i] as f64;
                guided.lit_cdf.push(sum as f32);
            }
        }
        guided
    }

    /// Where emission cell `k`'s running sums lie in `cdf` (and `lit_cdf`).
    #[inline]
    fn sums(&self, k: usize) -> std::ops::Range<usize> {
        k * (self.nx + 1)..(k + 1) * (self.nx + 1)
    }

    /// The emission cell holding `m`, if the matrix has one there.
    #[inline]
    fn cell(&self, m: f32) -> Option<usize> {
        let k = (m - self.m0).floor();
        (k >= 0.0 && (k as usize) < self.nm).then_some(k as usize)
    }

    /// The running sums of the emission cell holding `m`.
    #[inline]
    fn column(&self, m: f32) -> Option<&[f32]> {
        self.cell(m).map(|k| &self.cdf[self.sums(k)])
    }

    /// ∫ D(λx, m) dλx: the radiance factor emitted at `m` under light of
    /// one unit per nm at every wavelength.
    #[inline]
    pub fn column_total(&self, m: f32) -> f32 {
        self.column(m).map_or(0.0, |c| c[self.nx])
    }

    /// D(x, m) per nm of excitation.
    pub fn density(&self, x: f32, m: f32) -> f32 {
        let i = (x - self.x0).floor();
        match self.column(m) {
            Some(c) if i >= 0.0 && (i as usize) < self.nx => c[i as usize + 1] - c[i as usize],
            _ => 0.0,
        }
    }

    /// ∫ D(x, λm) dλm: the share of light at `x` re-emitted (as energy).
    pub fn row_total(&self, x: f32) -> f32 {
        (0..self.nm)
            .map(|k| self.density(x, self.m0 + k as f32 + 0.5))
            .sum()
    }

    /// ∫ D(λx, λm) E(λx) dλx at the centre of each 1 nm cell over
    /// [LAMBDA_MIN, LAMBDA_MAX], for a light `e` given at the same centres:
    /// what the surface re-emits under it.
    pub fn emitted_under(&self, e: &[f64]) -> Vec<f64> {
        let first_x = (self.x0 - LAMBDA_MIN) as usize;
        let first_m = (self.m0 - LAMBDA_MIN) as usize;
        let mut out = vec![0.0; e.len()];
        for k in 0..self.nm {
            let c = &self.cdf[self.sums(k)];
            out[first_m + k] = (0..self.nx)
                .map(|i| (c[i + 1] - c[i]) as f64 * e[first_x + i])
                .sum();
        }
        out
    }

    /// The excitation range the matrix covers, in nm.
    pub fn excitation_range(&self) -> [f32; 2] {
        [self.x0, self.x0 + self.nx as f32]
    }

    /// The emission range the matrix covers, in nm.
    pub fn emission_range(&self) -> [f32; 2] {
        [self.m0, self.m0 + self.nm as f32]
    }

    /// An exciting wavelength for emission at `m`, drawn from `u` in
    /// [0, 1) with density D(·, m) / column_total(m) (`m` itself where
    /// the column is empty).
    #[inline]
    pub fn sample_excitation(&self, m: f32, u: f32) -> f32 {
        match self.column(m) {
            Some(c) => self.invert(c, u).unwrap_or(m),
            None => m,
        }
    }

    /// An exciting wavelength for emission at `m` and its weight, the
    /// density D(·, m) / column_total(m) over the density it was drawn
    /// with: that one where there is no guide, else the mixture with D × E.
    #[inline]
    pub fn sample_excitation_guided(&self, m: f32, u: f32) -> (f32, f32) {
        let (Some(k), false) = (self.cell(m), self.lit_cdf.is_empty()) else {
            return (self.sample_excitation(m, u), 1.0);
        };
        let (c, lit) = (&self.cdf[self.sums(k)], &self.lit_cdf[self.sums(k)]);
        let (total, lit_total) = (c[self.nx], lit[self.nx]);
        if !(lit_total > 0.0 && total > 0.0) {
            return (self.sample_excitation(m, u), 1.0);
        }
        let x = if u < GUIDED {
            self.invert(lit, u / GUIDED)
        } else {
            self.invert(c, (u - GUIDED) / (1.0 - GUIDED))
        };
        let Some(x) = x else {
            return (m, 1.0);
        };
        let i = ((x - self.x0) as usize).min(self.nx - 1);
        // p_D / (g p_DE + (1 − g) p_D), with p_DE / p_D = E c / c_E.
        let ratio = self.light[i] * total / lit_total;
        (x, 1.0 / (GUIDED * ratio + (1.0 - GUIDED)))
    }

    /// The wavelength where the running sums `c` reach `u` of their total.
    #[inline]
    fn invert(&self, c: &[f32], u: f32) -> Option<f32> {
        let total = c[self.nx];
        if !(total > 0.0) {
            return None;
        }
        let target = u * total;
        // The cell i with c[i] <= target < c[i + 1], skipping empty cells.
        let i = (c.partition_point(|&v| v <= target).max(1) - 1).min(self.nx - 1);
        let width = c[i + 1] - c[i];
        let t = if width > 0.0 {
            ((target - c[i]) / width).clamp(0.0, 1.0)
        } else {
            0.5
        };
        Some(self.x0 + i as f32 + t)
    }

    /// The weight of a camera path's bounce off a surface of reflectance
    /// `r` (at the path's wavelengths) that fluoresces with this matrix:
    /// the total radiance factor r + c at each wavelength.
    #[inline]
    pub fn radiance_factor(&self, r: SampledSpectrum, wl: &SampledWavelengths) -> SampledSpectrum {
        r + SampledSpectrum::from_array(wl.lambda.to_array().map(|m| self.column_total(m)))
    }

    /// Moves each of the path's wavelengths back across the bounce: it
    /// stays with probability r / (r + c) and otherwise becomes an
    /// exciting wavelength of the matrix, one number of `u` each. Returns
    /// what the path's throughput is multiplied by: 1 except where a guide
    /// drew the exciting wavelength (`sample_excitation_guided`).
    #[inline]
    pub fn excite(
        &self,
        r: SampledSpectrum,
        wl: &mut SampledWavelengths,
        u: [f32; 4],
    ) -> SampledSpectrum {
        let mut weight = SampledSpectrum::ONE;
        for j in 0..4 {
            if wl.pdf[j] == 0.0 {
                continue;
            }
            let m = wl.lambda[j];
            let c = self.column_total(m);
            let total = r[j] + c;
            if !(total > 0.0 && c > 0.0) {
                continue;
            }
            let t = u[j] * total;
            if t >= r[j] {
                let v = ((t - r[j]) / c).clamp(0.0, 1.0 - f32::EPSILON);
                (wl.lambda[j], weight[j]) = self.sample_excitation_guided(m, v);
            }
        }
        weight
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A highlighter-like matrix: excited around 450 nm, emitting around
    /// 520 nm, 0.4 of the exciting light re-emitted at the peak.
    fn example() -> Fluorescence {
        Fluorescence::from_density(|x, m| {
            let a = (-((x - 450.0) / 25.0).powi(2)).exp();
            let e = (-((m - 520.0) / 20.0).powi(2)).exp() / (20.0 * std::f32::consts::PI.sqrt());
            if m >= x {
                0.4 * (a * e) as f64
            } else {
                0.0
            }
        })
        .unwrap()
    }

    #[test]
    fn totals_are_the_cells_sums() {
        let f = example();
        // Row at the excitation peak: 0.4 of the light, less the part of
        // the emission band below 450 nm (none to speak of).
        assert!(
            (f.row_total(450.5) - 0.4).abs() < 2e-3,
            "{}",
            f.row_total(450.5)
        );
        let m = 520.5;
        let by_cells: f32 = (0..CELLS)
            .map(|i| f.density(LAMBDA_MIN + i as f32 + 0.5, m))
            .sum();
        assert!((f.column_total(m) - by_cells).abs() < 1e-6 * by_cells);
        assert_eq!(f.column_total(300.0), 0.0);
        assert_eq!(f.density(700.0, 520.5), 0.0);
        assert!(Fluorescence::from_density(|_, _| 0.0).is_none());
    }

    #[test]
    fn excitation_is_drawn_with_the_columns_density() {
        let f = example();
        let m = 530.2;
        let total = f.column_total(m) as f64;
        let n = 100_000;
        let mut counts = vec![0u32; CELLS];
        for s in 0..n {
            let x = f.sample_excitation(m, (s as f32 + 0.5) / n as f32);
            assert!(x <= m + 1.0 && x >= f.excitation_range()[0], "{x}");
            counts[(x - LAMBDA_MIN) as usize] += 1;
        }
        for (i, &c) in counts.iter().enumerate() {
            let expected = f.density(LAMBDA_MIN + i as f32 + 0.5, m) as f64 / total;
            let got = c as f64 / n as f64;
            assert!(
                (got - expected).abs() < 2e-4,
                "cell {i}: {got} vs {expected}"
            );
        }
    }

    /// Guided by a narrow lamp, the weighted draws still follow D(·, m):
    /// the histogram of weights per cell is the column's density.
    #[test]
    fn guided_draws_weighted_follow_the_column() {
        let lamp: Vec<f64> = (0..CELLS)
            .map(|i| {
                let l = LAMBDA_MIN + i as f32 + 0.5;
                if (400.0..410.0).contains(&l) {
                    1.0
                } else {
                    0.0
                }
            })
            .collect();
        let f = example().guided_by(&lamp);
        let m = 530.2;
        let total = f.column_total(m) as f64;
        let n = 200_000;
        let mut sums = vec![0.0f64; CELLS];
        let mut in_lamp = 0;
        for s in 0..n {
            let (x, w) = f.sample_excitation_guided(m, (s as f32 + 0.5) / n as f32);
            sums[(x - LAMBDA_MIN) as usize] += w as f64 / n as f64;
            in_lamp += (400.0..410.0).contains(&x) as u32;
        }
        for (i, &got) in sums.iter().enumerate() {
            let expected = f.density(LAMBDA_MIN + i as f32 + 0.5, m) as f64 / total;
            assert!(
                (got - expected).abs() < 2e-4,
                "cell {i}: {got} vs {expected}"
            );
        }
        // More than half the draws land where the lamp shines.
        assert!(in_lamp as f64 > 0.5 * n as f64, "{in_lamp}");
        // No light: the matrix as it was.
        assert_eq!(example().guided_by(&vec![0.0; CELLS]), example());
    }

    #[test]
    fn each_wavelength_is_kept_or_excited_in_proportion() {
        let f = example();
        let r = SampledSpectrum::splat(0.3);
        let m = 520.5;
        let c = f.column_total(m);
        let n = 20_000;
        let mut kept = 0;
        for s in 0..n {
            let u = (s as f32 + 0.5) / n as f32;
            let mut wl = SampledWavelengths {
                lambda: SampledSpectrum::splat(m),
                pdf: SampledSpectrum::ONE,
            };
            assert_eq!(f.excite(r, &mut wl, [u; 4]), SampledSpectrum::ONE);
            if wl.lambda[0] == m {
                kept += 1;
            } else {
                assert!(wl.lambda[0] < m, "excited at {}", wl.lambda[0]);
            }
            assert_eq!(wl.lambda[0], wl.lambda[3]);
        }
        let expected = 0.3 / (0.3 + c);
        assert!(((kept as f32 / n as f32) - expected).abs() < 1e-3);
        // Terminated wavelengths stay where they are.
        let mut wl = SampledWavelengths {
            lambda: SampledSpectrum::splat(m),
            pdf: SampledSpectrum::new(1.0, 0.0, 0.0, 0.0),
        };
        f.excite(r, &mut wl, [0.999; 4]);
        assert!(wl.lambda[0] < m);
        assert_eq!(wl.lambda[1], m);
    }
}
