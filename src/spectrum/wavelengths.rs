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
        Self::rotations(u, |up| {
            // λ = 538 − atanh(y)/0.0072, so the density 1/cosh²(0.0072 (λ − 538))
            // is (1 − y²): no cosh, and one logarithm for the atanh.
            let y = 0.856_910_6 - 1.827_502 * up;
            let lambda = (538.0 - 138.888_89 * 0.5 * ((1.0 + y) / (1.0 - y)).ln())
                .clamp(LAMBDA_MIN, LAMBDA_MAX);
            (lambda, 0.003_939_804 * (1.0 - y * y))
        })
    }

    /// The hero wavelength at `u` and its three stratified rotations
    /// (`rotated`), each drawn by `draw(u)` = (λ, density).
    #[inline]
    fn rotations(u: f32, draw: impl Fn(f32) -> (f32, f32)) -> Self {
        let drawn = rotated(u).to_array().map(draw);
        Self {
            lambda: Vec4::from_array(drawn.map(|(lambda, _)| lambda)),
            pdf: Vec4::from_array(drawn.map(|(_, pdf)| pdf)),
        }
    }

    /// The same four wavelengths led by lane `k` (lane j of the result is
    /// lane (j + k) mod 4 of these): what a path that follows wavelength
    /// `k` alone from here on carries (`lanes_led_by` turns its spectra).
    pub fn led_by(&self, k: usize) -> Self {
        Self {
            lambda: lanes_led_by(self.lambda, k),
            pdf: lanes_led_by(self.pdf, k),
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

/// A spectrum's lanes led by lane `k`: lane j of the result is lane
/// (j + k) mod 4 of `v` (see [`SampledWavelengths::led_by`]).
#[inline]
pub fn lanes_led_by(v: SampledSpectrum, k: usize) -> SampledSpectrum {
    let a = v.to_array();
    SampledSpectrum::from_array(std::array::from_fn(|j| a[(j + k) % N_WAVELENGTHS]))
}

/// Bins of the weights a [`WavelengthDistribution`] is built from: 1 nm
/// each over [360, 830] nm.
const BINS: usize = (LAMBDA_MAX - LAMBDA_MIN) as usize;
/// Equal-probability segments of a [`WavelengthDistribution`].
const SEGMENTS: usize = 1024;

/// A density over [360, 830] nm that paths draw their wavelengths from:
/// the scene builds one that follows its lights' emission and the film's
/// colour response (see `Scene::wavelengths`), where the fixed visible
/// density would spend samples on wavelengths that carry little light.
///
/// Stored as its quantiles at 1024 equally likely segments, the density
/// constant within each: drawing a wavelength is one lookup and one linear
/// interpolation, with no search.
#[derive(Clone, Debug, PartialEq)]
pub struct WavelengthDistribution {
    /// quantiles[k]: the wavelength below which the probability is k / SEGMENTS.
    quantiles: Vec<f32>,
    /// Density per nm within each segment: 1 / (SEGMENTS × its width).
    density: Vec<f32>,
}

impl WavelengthDistribution {
    /// The distribution proportional to `density` at each 1 nm bin's centre
    /// (constant over the bin).
    pub fn new(density: impl Fn(f32) -> f64) -> Self {
        Self::from_weights(Self::centres().map(density).collect())
    }

    /// The centres of the 1 nm bins, in order.
    pub fn centres() -> impl Iterator<Item = f32> {
        (0..BINS).map(|i| LAMBDA_MIN + i as f32 + 0.5)
    }

    /// The distribution proportional to a weight per 1 nm bin (negative or
    /// non-finite weights count as zero); the visible density where the
    /// weights have no positive, finite sum.
    pub fn from_weights(mut weights: Vec<f64>) -> Self {
        assert_eq!(weights.len(), BINS, "one weight per 1 nm bin");
        for w in &mut weights {
            if !(w.is_finite() && *w > 0.0) {
                *w = 0.0;
            }
        }
        let total: f64 = weights.iter().sum();
        if !(total.is_finite() && total > 0.0) {
            return Self::visible();
        }
        // Invert the piecewise-linear CDF at each k / SEGMENTS, from the
        // start of the first bin with weight to the end of the last.
        let mut quantiles = Vec::with_capacity(SEGMENTS + 1);
        let (mut bin, mut below) = (0, 0.0);
        for k in 0..SEGMENTS {
            let target = k as f64 / SEGMENTS as f64 * total;
            while bin + 1 < BINS && (weights[bin] == 0.0 || below + weights[bin] < target) {
                below += weights[bin];
                bin += 1;
            }
            let t = ((target - below) / weights[bin]).clamp(0.0, 1.0);
            quantiles.push(LAMBDA_MIN + bin as f32 + t as f32);
        }
        let last = weights.iter().rposition(|&w| w > 0.0).unwrap_or(BINS - 1);
        quantiles.push(LAMBDA_MIN + last as f32 + 1.0);
        let density = quantiles
            .windows(2)
            .map(|q| 1.0 / (SEGMENTS as f32 * (q[1] - q[0]).max(1e-6)))
            .collect();
        Self { quantiles, density }
    }

    /// The visible density of [`SampledWavelengths::sample_visible`], tabulated.
    pub fn visible() -> Self {
        Self::new(|l| visible_wavelength_pdf(l) as f64)
    }

    /// One wavelength for `u` in [0, 1), with its density per nm.
    #[inline]
    pub fn sample_one(&self, u: f32) -> (f32, f32) {
        let x = u * SEGMENTS as f32;
        let k = (x as usize).min(SEGMENTS - 1);
        let (q0, q1) = (self.quantiles[k], self.quantiles[k + 1]);
        (q0 + (x - k as f32) * (q1 - q0), self.density[k])
    }

    /// Four wavelengths: the hero for `u` and three stratified rotations of it
    /// (`SampledWavelengths::rotations` with `sample_one`, the four in SIMD
    /// but for the table reads; the same arithmetic lane by lane).
    #[inline]
    pub fn sample(&self, u: f32) -> SampledWavelengths {
        let x = rotated(u) * SEGMENTS as f32;
        // x ≥ 0: truncation is the floor.
        let k = super::spectra::truncate(x).min(glam::IVec4::splat(SEGMENTS as i32 - 1));
        let t = x - k.as_vec4();
        let k = k.to_array().map(|k| k as usize);
        let q0 = Vec4::from_array(k.map(|k| self.quantiles[k]));
        let q1 = Vec4::from_array(k.map(|k| self.quantiles[k + 1]));
        SampledWavelengths {
            lambda: q0 + t * (q1 - q0),
            pdf: Vec4::from_array(k.map(|k| self.density[k])),
        }
    }

    /// Density per nm at `lambda`.
    pub fn pdf(&self, lambda: f32) -> f32 {
        // Quantiles at or below lambda: 0 before the first, SEGMENTS + 1
        // past the last.
        match self.quantiles.partition_point(|&q| q <= lambda) {
            0 => 0.0,
            k if k > SEGMENTS => 0.0,
            k => self.density[k - 1],
        }
    }
}

/// `u` and its stratified rotations: u + 0, 1/4, 1/2, 3/4, each wrapped
/// into [0, 1).
#[inline]
fn rotated(u: f32) -> Vec4 {
    let up = Vec4::splat(u) + Vec4::new(0.0, 0.25, 0.5, 0.75);
    Vec4::select(up.cmpge(Vec4::ONE), up - Vec4::ONE, up)
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

    /// A spiky test density: zero below 400 nm and above 700 nm, a ramp
    /// between, and a narrow line at 589 nm holding a sixth of the mass.
    fn lamp(l: f32) -> f64 {
        let ramp = if (400.0..700.0).contains(&l) {
            (l - 400.0) as f64 / 300.0
        } else {
            0.0
        };
        let line = if (589.0..590.0).contains(&l) {
            0.2 * 150.0
        } else {
            0.0
        };
        ramp + line
    }

    #[test]
    fn distribution_draws_with_the_density_it_reports() {
        for d in [
            WavelengthDistribution::visible(),
            WavelengthDistribution::new(lamp),
        ] {
            // The density integrates to one.
            let n = 470_000;
            let h = (LAMBDA_MAX - LAMBDA_MIN) as f64 / n as f64;
            let integral: f64 = (0..n)
                .map(|i| d.pdf((LAMBDA_MIN as f64 + (i as f64 + 0.5) * h) as f32) as f64 * h)
                .sum();
            assert!((integral - 1.0).abs() < 1e-3, "integral {integral}");
            // Each draw reports the density at the wavelength drawn, and the
            // fraction of draws in each 10 nm band is the density's mass there.
            let draws = 200_000;
            let mut counts = [0u32; 47];
            for k in 0..draws {
                let (l, p) = d.sample_one((k as f32 + 0.5) / draws as f32);
                assert!((LAMBDA_MIN..LAMBDA_MAX).contains(&l), "{l}");
                // (f32 rounding may put a draw at its segment's end into
                // the next one.)
                let near = [d.pdf(l), d.pdf(l - 1e-3), d.pdf(l + 1e-3)];
                assert!(near.contains(&p), "density {p} at {l}: {near:?}");
                counts[((l - LAMBDA_MIN) / 10.0) as usize] += 1;
            }
            for (band, &c) in counts.iter().enumerate() {
                let lo = LAMBDA_MIN + band as f32 * 10.0;
                let mass: f64 = (0..10_000)
                    .map(|i| d.pdf(lo + (i as f32 + 0.5) * 1e-3) as f64 * 1e-3)
                    .sum();
                let got = c as f64 / draws as f64;
                assert!(
                    (got - mass).abs() < 2e-4 + 1e-3 * mass,
                    "band {lo}: {got} vs {mass}"
                );
            }
        }
    }

    #[test]
    fn distribution_follows_its_weights() {
        let d = WavelengthDistribution::new(lamp);
        // Nothing outside the lamp's range; [589, 590] nm holds the line and
        // a little of the ramp: 30.63 of 180 (to within the two segments
        // of 1/1024 that straddle its ends).
        assert_eq!(d.pdf(399.0), 0.0);
        assert_eq!(d.pdf(701.0), 0.0);
        let total = 150.0 + 30.0;
        let line = (0..1000)
            .map(|i| d.pdf(589.0 + (i as f32 + 0.5) / 1000.0) / 1000.0)
            .sum::<f32>();
        assert!((line - 30.63 / total as f32).abs() < 2.0 / 1024.0, "{line}");
        // The ramp: the density at 650 nm is 2.5 times that at 500 nm.
        let ratio = d.pdf(650.5) / d.pdf(500.5);
        assert!((ratio - 2.5).abs() < 0.05, "{ratio}");
        // Weights without mass give the visible density.
        let none = WavelengthDistribution::from_weights(vec![0.0; BINS]);
        assert_eq!(none, WavelengthDistribution::visible());
        let nan = WavelengthDistribution::new(|_| f64::NAN);
        assert_eq!(nan, WavelengthDistribution::visible());
    }

    #[test]
    fn distribution_rotates_the_hero_into_four_strata() {
        let d = WavelengthDistribution::new(lamp);
        for k in 0..1000 {
            let u = k as f32 / 1000.0;
            let wl = d.sample(u);
            for i in 0..N_WAVELENGTHS {
                let up = (u + i as f32 / 4.0) % 1.0;
                assert_eq!((wl.lambda[i], wl.pdf[i]), d.sample_one(up));
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
