//! Hero-wavelength sampling: each camera path carries four wavelengths, one
//! drawn by importance sampling toward the visible and three rotations of it.

use glam::Vec4;

use super::{LAMBDA_MAX, LAMBDA_MIN};

/// Number of wavelengths carried by each path.
pub const N_WAVELENGTHS: usize = 4;

/// Values of a spectral quantity at the path's four wavelengths.
pub type SampledSpectrum = Vec4;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampledWavelengths {
    /// Wavelengths in nanometres; lane 0 is the hero.
    pub lambda: Vec4,
    /// Probability density of each wavelength (per nm). Zero marks a
    /// wavelength that was terminated and must not reach the film.
    pub pdf: Vec4,
}

impl SampledWavelengths {
    /// Samples four wavelengths over [360, 830] nm with density proportional
    /// to 1/cosh²(0.0072 (λ − 538)), a smooth fit of the visual response.
    /// The three secondaries are the hero's stratified rotations.
    pub fn sample_visible(u: f32) -> Self {
        let mut lambda = [0.0; N_WAVELENGTHS];
        let mut pdf = [0.0; N_WAVELENGTHS];
        for i in 0..N_WAVELENGTHS {
            let mut up = u + i as f32 / N_WAVELENGTHS as f32;
            if up >= 1.0 {
                up -= 1.0;
            }
            // λ = 538 − atanh(y)/0.0072, so the density 1/cosh²(0.0072 (λ − 538))
            // is (1 − y²): no cosh, and one logarithm for the atanh.
            let y = 0.856_910_6 - 1.827_502 * up;
            lambda[i] = (538.0 - 138.888_89 * 0.5 * ((1.0 + y) / (1.0 - y)).ln())
                .clamp(LAMBDA_MIN, LAMBDA_MAX);
            pdf[i] = 0.003_939_804 * (1.0 - y * y);
        }
        Self {
            lambda: Vec4::from_array(lambda),
            pdf: Vec4::from_array(pdf),
        }
    }

    /// Keeps only the hero wavelength (for paths through a dispersive
    /// interface, which the secondaries cannot follow).
    pub fn terminate_secondary(&mut self) {
        if self.secondary_terminated() {
            return;
        }
        self.pdf = Vec4::new(self.pdf.x / N_WAVELENGTHS as f32, 0.0, 0.0, 0.0);
    }

    pub fn secondary_terminated(&self) -> bool {
        self.pdf.y == 0.0 && self.pdf.z == 0.0 && self.pdf.w == 0.0
    }
}

/// Inverse CDF of the visible-wavelength density on [360, 830] nm.
pub fn sample_visible_wavelength(u: f32) -> f32 {
    538.0 - 138.888_89 * (0.856_910_6 - 1.827_502 * u).atanh()
}

/// Density (per nm) of [`sample_visible_wavelength`].
pub fn visible_wavelength_pdf(lambda: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    let c = (0.0072 * (lambda - 538.0)).cosh();
    0.003_939_804 / (c * c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn visible_pdf_integrates_to_one_and_matches_sampling() {
        let n = 47_000;
        let step = (LAMBDA_MAX - LAMBDA_MIN) / n as f32;
        let integral: f32 = (0..n)
            .map(|i| visible_wavelength_pdf(LAMBDA_MIN + (i as f32 + 0.5) * step) * step)
            .sum();
        assert!((integral - 1.0).abs() < 1e-3, "integral {integral}");
        assert!((sample_visible_wavelength(0.0) - LAMBDA_MIN).abs() < 0.1);
        assert!((sample_visible_wavelength(1.0) - LAMBDA_MAX).abs() < 0.1);
        // The CDF evaluated by quadrature at the sampled λ recovers u.
        for &u in &[0.1f32, 0.37, 0.5, 0.81] {
            let l = sample_visible_wavelength(u);
            let m = 4000;
            let h = (l - LAMBDA_MIN) / m as f32;
            let cdf: f32 = (0..m)
                .map(|i| visible_wavelength_pdf(LAMBDA_MIN + (i as f32 + 0.5) * h) * h)
                .sum();
            assert!((cdf - u).abs() < 2e-3, "u {u} cdf {cdf}");
        }
    }

    #[test]
    fn sampled_wavelengths_and_densities_match_the_closed_forms() {
        for k in 0..1000 {
            let wl = SampledWavelengths::sample_visible(k as f32 / 1000.0);
            for i in 0..N_WAVELENGTHS {
                let (l, p) = (wl.lambda[i], wl.pdf[i]);
                let mut u = k as f32 / 1000.0 + i as f32 / 4.0;
                if u >= 1.0 {
                    u -= 1.0;
                }
                assert!((l - sample_visible_wavelength(u)).abs() < 0.05, "{l}");
                assert!(
                    (p - visible_wavelength_pdf(l)).abs() < 1e-4 * p,
                    "{p} at {l}"
                );
            }
        }
    }

    #[test]
    fn terminating_secondaries_keeps_the_estimate_unbiased() {
        let mut wl = SampledWavelengths::sample_visible(0.3);
        let hero_pdf = wl.pdf.x;
        wl.terminate_secondary();
        assert_eq!(wl.pdf.x, hero_pdf / 4.0);
        assert!(wl.secondary_terminated());
        wl.terminate_secondary();
        assert_eq!(wl.pdf.x, hero_pdf / 4.0);
    }
}
