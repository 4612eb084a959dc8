//! The spectral Hosek–Wilkie sky model: sky-dome radiance (Hosek & Wilkie
//! 2012, "An Analytic Model for Full Spectral Sky-Dome Radiance") and the
//! solar radiance function with limb darkening (Hosek & Wilkie 2013,
//! "Adding a Solar-Radiance Function to the Hosek–Wilkie Skylight Model").
//!
//! The published coefficients (spectra/sky/, with their provenance and the
//! authors' BSD licence) cover 11 bands, 320 to 720 nm in steps of 40;
//! radiance between bands is interpolated linearly, and above 720 nm the
//! 720 nm value is held (the model has no data there; CIE x̄ above 720 nm
//! carries 0.5 % of X). Radiances are in W m⁻² sr⁻¹ nm⁻¹.
//!
//! The sky at a direction with zenith angle θ, at angle γ from the sun:
//!   L = (1 + A e^{B/(cos θ + 0.01)}) (C + D e^{Eγ} + F cos²γ + G χ(H, γ) + I √cos θ) L_M,
//!   χ(H, γ) = (1 + cos²γ) / (1 + H² − 2H cos γ)^{3/2},
//! where A..I and L_M are quintic Bézier curves in (sun elevation / 90°)^{1/3},
//! interpolated linearly in turbidity (1 to 10) and ground albedo (0 to 1).

use std::f64::consts::FRAC_PI_2;
use std::sync::OnceLock;

/// Spectral bands of the model.
pub const BANDS: usize = 11;
/// Wavelength of band 0, and the step between bands (nm).
const FIRST_BAND: f32 = 320.0;
const BAND_STEP: f32 = 40.0;
const TURBIDITIES: usize = 10;
const ALBEDOS: usize = 2;
const CONTROL_POINTS: usize = 6;
const SKY_PARAMS: usize = 9;
const SUN_SEGMENTS: usize = 45;
const SUN_POWERS: usize = 4;
const LIMB_POWERS: usize = 6;

/// Angular diameter of the sun the model was fitted for (degrees).
pub const SUN_DIAMETER_DEGREES: f32 = 0.5358;

/// The coefficients as published, in the layout of spectra/sky/README.md.
struct Dataset {
    /// [turbidity][albedo][control point][band][parameter]
    sky_params: Vec<f64>,
    /// [turbidity][albedo][control point][band]
    sky_radiance: Vec<f64>,
    /// [turbidity][segment][band][power]
    sun_radiance: Vec<f64>,
    /// [band][power]
    limb_darkening: Vec<f64>,
}

fn dataset() -> &'static Dataset {
    static DATA: OnceLock<Dataset> = OnceLock::new();
    DATA.get_or_init(|| {
        let bytes: &[u8] = include_bytes!("../../spectra/sky/hosek_wilkie_2012.bin");
        let (magic, mut rest) = bytes.split_at(8);
        assert_eq!(
            magic, b"HW2012s\0",
            "spectra/sky/hosek_wilkie_2012.bin: bad magic"
        );
        let mut take = |count: usize| -> Vec<f64> {
            let (head, tail) = rest.split_at(8 * count);
            rest = tail;
            head.chunks_exact(8)
                .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")))
                .collect()
        };
        let data = Dataset {
            sky_params: take(TURBIDITIES * ALBEDOS * CONTROL_POINTS * BANDS * SKY_PARAMS),
            sky_radiance: take(TURBIDITIES * ALBEDOS * CONTROL_POINTS * BANDS),
            sun_radiance: take(TURBIDITIES * SUN_SEGMENTS * BANDS * SUN_POWERS),
            limb_darkening: take(BANDS * LIMB_POWERS),
        };
        assert!(
            rest.is_empty(),
            "spectra/sky/hosek_wilkie_2012.bin: trailing bytes"
        );
        data
    })
}

/// Band index i and weight f of band i + 1 for `lambda` (nm): bands i and
/// i + 1 bracket it; held at the ends.
#[inline]
fn band_position(lambda: f32) -> (usize, f32) {
    let t = ((lambda - FIRST_BAND) / BAND_STEP).clamp(0.0, (BANDS - 1) as f32);
    let i = (t as usize).min(BANDS - 2);
    (i, t - i as f32)
}

/// Wavelength of band `b` (nm).
pub fn band_wavelength(b: usize) -> f32 {
    FIRST_BAND + BAND_STEP * b as f32
}

/// Linear interpolation weights (turbidity level, weight) for turbidity
/// `t` in [1, 10].
fn turbidity_weights(t: f32) -> [(usize, f64); 2] {
    let t = t.clamp(1.0, TURBIDITIES as f32) as f64;
    let low = ((t - 1.0).floor() as usize).min(TURBIDITIES - 2);
    let f = t - 1.0 - low as f64;
    [(low, 1.0 - f), (low + 1, f)]
}

/// The sky (and sun) for one sun elevation, turbidity and ground albedo.
#[derive(Clone, Debug)]
pub struct SkyModel {
    /// Per band: the parameters (A B C D E F G I H, the published order)
    /// and the radiance scale L_M.
    bands: [[f32; SKY_PARAMS + 1]; BANDS],
    /// Per sun segment and band: the solar radiance polynomial's
    /// coefficients in increasing powers, interpolated in turbidity.
    sun: Vec<[f64; SUN_POWERS]>,
}

impl SkyModel {
    /// `sun_elevation` in radians, in [0, π/2]; `turbidity` in [1, 10];
    /// `albedo` per band, in [0, 1].
    pub fn new(sun_elevation: f32, turbidity: f32, albedo: [f32; BANDS]) -> Self {
        let data = dataset();
        // Bézier weights of the six control points.
        let x = (sun_elevation.clamp(0.0, std::f32::consts::FRAC_PI_2) as f64 / FRAC_PI_2).cbrt();
        let binomial = [1.0, 5.0, 10.0, 10.0, 5.0, 1.0];
        let bezier: [f64; CONTROL_POINTS] = std::array::from_fn(|k| {
            binomial[k] * x.powi(k as i32) * (1.0 - x).powi((CONTROL_POINTS - 1 - k) as i32)
        });
        let turbidity = turbidity_weights(turbidity);
        let mut bands = [[0.0f32; SKY_PARAMS + 1]; BANDS];
        for (b, band) in bands.iter_mut().enumerate() {
            let a = albedo[b].clamp(0.0, 1.0) as f64;
            let mut acc = [0.0f64; SKY_PARAMS + 1];
            for &(t, wt) in &turbidity {
                for (alb, wa) in [(0, 1.0 - a), (1, a)] {
                    for (c, &wc) in bezier.iter().enumerate() {
                        let w = wt * wa * wc;
                        let cell = (t * ALBEDOS + alb) * CONTROL_POINTS + c;
                        let params =
                            &data.sky_params[(cell * BANDS + b) * SKY_PARAMS..][..SKY_PARAMS];
                        for (p, v) in params.iter().enumerate() {
                            acc[p] += w * v;
                        }
                        acc[SKY_PARAMS] += w * data.sky_radiance[cell * BANDS + b];
                    }
                }
            }
            *band = acc.map(|v| v as f32);
        }
        let mut sun = vec![[0.0f64; SUN_POWERS]; SUN_SEGMENTS * BANDS];
        for &(t, wt) in &turbidity {
            for (k, coefficients) in sun.iter_mut().enumerate() {
                let at = &data.sun_radiance[(t * SUN_SEGMENTS * BANDS + k) * SUN_POWERS..];
                for (c, v) in coefficients.iter_mut().zip(at) {
                    *c += wt * v;
                }
            }
        }
        Self { bands, sun }
    }

    /// Sky radiance of band `b` towards `view`.
    #[inline]
    pub fn sky_band(&self, b: usize, view: &SkyView) -> f32 {
        // Stored in the published order: A B C D E F G I H.
        let [a, bb, c, d, e, f, g, i, h, radiance] = self.bands[b];
        let q = (1.0 + h * h - 2.0 * h * view.cos_gamma).max(f32::MIN_POSITIVE);
        let chi = view.one_plus_cos2_gamma / (q * q.sqrt());
        let c1 = 1.0 + a * (bb * view.horizon).exp();
        let c2 = c
            + d * (e * view.gamma).exp()
            + f * view.cos2_gamma
            + g * chi
            + i * view.sqrt_cos_theta;
        c1 * c2 * radiance
    }

    /// Sky radiance at wavelength `lambda` (nm) towards `view`.
    #[inline]
    pub fn sky(&self, lambda: f32, view: &SkyView) -> f32 {
        let (b, f) = band_position(lambda);
        let low = self.sky_band(b, view);
        if f == 0.0 {
            return low;
        }
        let high = self.sky_band(b + 1, view);
        low + f * (high - low)
    }

    /// Solar radiance of band `b` at the sun's centre, seen at `elevation`
    /// (radians, ≥ 0) above the horizon, before limb darkening.
    #[inline]
    pub fn sun_band(&self, b: usize, elevation: f64) -> f64 {
        let (segment, x) = sun_segment(elevation);
        self.sun_polynomial(segment, x, b)
    }

    #[inline]
    fn sun_polynomial(&self, segment: usize, x: f64, b: usize) -> f64 {
        let c = &self.sun[segment * BANDS + b];
        ((c[3] * x + c[2]) * x + c[1]) * x + c[0]
    }

    /// Limb darkening of band `b` where the line of sight meets the solar
    /// disc at cos ψ = `cos_psi` from its normal (1 at the centre, 0 at the rim).
    #[inline]
    pub fn limb_darkening(b: usize, cos_psi: f64) -> f64 {
        let c = &dataset().limb_darkening[b * LIMB_POWERS..][..LIMB_POWERS];
        c.iter().rev().fold(0.0, |acc, &v| acc * cos_psi + v)
    }

    /// Solar radiance at wavelengths `lambdas` (nm), seen at `elevation`
    /// (radians) where cos ψ = `cos_psi`: radiance and limb darkening each
    /// interpolated between bands, as the model defines it.
    #[inline]
    pub fn sun<const N: usize>(&self, lambdas: [f32; N], elevation: f64, cos_psi: f64) -> [f64; N] {
        let (segment, x) = sun_segment(elevation);
        let limb = &dataset().limb_darkening;
        lambdas.map(|lambda| {
            let (b, f) = band_position(lambda);
            let f = f as f64;
            let lerp = |low: f64, high: f64| low + f * (high - low);
            let radiance = lerp(
                self.sun_polynomial(segment, x, b),
                self.sun_polynomial(segment, x, b + 1),
            );
            let (lo, hi) = (&limb[b * LIMB_POWERS..], &limb[(b + 1) * LIMB_POWERS..]);
            let darkening = (0..LIMB_POWERS)
                .rev()
                .fold(0.0, |acc, j| acc * cos_psi + lerp(lo[j], hi[j]));
            radiance * darkening
        })
    }
}

/// The sun's polynomial segment for `elevation` (radians) and the offset
/// into it: segments are uniform in (elevation / 90°)^{1/3}.
#[inline]
fn sun_segment(elevation: f64) -> (usize, f64) {
    let t = (2.0 * elevation.max(0.0) / std::f64::consts::PI).cbrt();
    let segment = ((t * SUN_SEGMENTS as f64) as usize).min(SUN_SEGMENTS - 1);
    let start = FRAC_PI_2 * (segment as f64 / SUN_SEGMENTS as f64).powi(3);
    (segment, elevation - start)
}

/// What the sky's radiance needs of a view direction, shared by its bands.
#[derive(Clone, Copy, Debug)]
pub struct SkyView {
    cos_gamma: f32,
    cos2_gamma: f32,
    one_plus_cos2_gamma: f32,
    gamma: f32,
    /// 1 / (cos θ + 0.01), the horizon term's argument.
    horizon: f32,
    sqrt_cos_theta: f32,
}

impl SkyView {
    /// A view with cos θ = `cos_theta` (≥ 0) from the zenith, at cos γ =
    /// `cos_gamma` from the sun.
    #[inline]
    pub fn new(cos_theta: f32, cos_gamma: f32) -> Self {
        let cos_gamma = cos_gamma.clamp(-1.0, 1.0);
        let cos2_gamma = cos_gamma * cos_gamma;
        Self {
            cos_gamma,
            cos2_gamma,
            one_plus_cos2_gamma: 1.0 + cos2_gamma,
            gamma: cos_gamma.acos(),
            horizon: 1.0 / (cos_theta.max(0.0) + 0.01),
            sqrt_cos_theta: cos_theta.max(0.0).sqrt(),
        }
    }
}

/// Weights w_b with Σ_b w_b R_b = ∫ R(λ) s(λ) dλ / ∫ s(λ) dλ over 360–830 nm
/// for a spectrum R interpolated between bands as the model does: `s` = ȳ
/// gives luminance, `s` = 1 the spectral mean.
pub fn band_weights(s: impl Fn(f32) -> f32) -> [f64; BANDS] {
    let mut w = [0.0f64; BANDS];
    let mut total = 0.0f64;
    for nm in crate::spectrum::LAMBDA_MIN as usize..=crate::spectrum::LAMBDA_MAX as usize {
        let lambda = nm as f32;
        let weight = s(lambda) as f64;
        let (b, f) = band_position(lambda);
        w[b] += (1.0 - f as f64) * weight;
        w[b + 1] += f as f64 * weight;
        total += weight;
    }
    w.map(|v| v / total)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dataset_parses_and_has_its_published_first_values() {
        let d = dataset();
        // dataset320, turbidity 1, albedo 0, first control point: A, B.
        assert_eq!(d.sky_params[0], -13.41049);
        assert_eq!(d.sky_params[1], -3.742293);
        // Limb darkening at the disc centre (cos ψ = 1) is the sum of the
        // coefficients, near 1 for every band.
        for b in 0..BANDS {
            let centre = SkyModel::limb_darkening(b, 1.0);
            assert!((0.9..1.1).contains(&centre), "band {b}: {centre}");
            assert!(SkyModel::limb_darkening(b, 0.0) < 0.5 * centre);
        }
    }

    #[test]
    fn bands_interpolate_and_hold_at_the_ends() {
        assert_eq!(band_position(320.0), (0, 0.0));
        assert_eq!(band_position(360.0), (1, 0.0));
        let (b, f) = band_position(500.0);
        assert_eq!(b, 4);
        assert!((f - 0.5).abs() < 1e-6);
        assert_eq!(band_position(720.0), (9, 1.0));
        assert_eq!(band_position(830.0), (9, 1.0));
        let m = SkyModel::new(0.5, 3.0, [0.3; BANDS]);
        let view = SkyView::new(0.6, 0.9f32.cos());
        let at = |l| m.sky(l, &view);
        let mid = 0.5 * (m.sky_band(4, &view) + m.sky_band(5, &view));
        assert!((at(500.0) - mid).abs() <= 1e-6 * mid);
        assert_eq!(at(800.0), m.sky_band(10, &view));
    }

    #[test]
    fn band_weights_integrate_constants_exactly() {
        let mean = band_weights(|_| 1.0);
        assert!((mean.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        // Nothing of 360–830 nm falls on the 320 nm band.
        assert_eq!(mean[0], 0.0);
        let luminance = band_weights(|l| crate::spectrum::cie::cmf(l).y);
        assert!((luminance.iter().sum::<f64>() - 1.0).abs() < 1e-12);
        // ȳ peaks at 555 nm: the 520, 560 and 600 nm bands carry 83 %.
        assert!(luminance[5] + luminance[6] + luminance[7] > 0.8);
        assert!(luminance[6] > luminance[5] && luminance[6] > luminance[7]);
    }
}
