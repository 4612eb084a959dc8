//! Spectral distributions: functions of wavelength that materials and lights
//! are made of, evaluated at a path's sampled wavelengths.

use super::rgb2spec::SigmoidPolynomial;
use super::{SampledSpectrum, SampledWavelengths};

/// A piecewise-linear spectrum through measured points. Outside its range it
/// is zero, as in pbrt-v4 and Mitsuba 3: extend a table if you mean otherwise.
#[derive(Clone, Debug, PartialEq)]
pub struct TabulatedSpectrum {
    lambdas: Vec<f32>,
    values: Vec<f32>,
    /// For each whole nanometre from LAMBDA_MIN: the segment that starts at
    /// or before it, so a lookup starts there instead of bisecting (empty
    /// for tables with the dense copy below, which bisect only to build it).
    segment_at_nm: Vec<u32>,
    /// When every knot lies on a whole nanometre (measured data usually
    /// does): for each nanometre from the first knot to the one before the
    /// last, the values there and a nanometre on, so a lookup is one
    /// subtraction and one load — and exactly the same piecewise-linear
    /// function.
    dense: Option<Vec<[f32; 2]>>,
}

impl TabulatedSpectrum {
    /// `lambdas` must be strictly increasing (the CSV reader and the scene
    /// loader check this for user input) and as long as `values`.
    pub fn new(lambdas: Vec<f32>, values: Vec<f32>) -> Self {
        assert_eq!(lambdas.len(), values.len());
        assert!(lambdas.len() >= 2 && lambdas.windows(2).all(|w| w[0] < w[1]));
        let integral = lambdas.iter().all(|l| l.fract() == 0.0)
            && lambdas[lambdas.len() - 1] - lambdas[0] <= 100_000.0;
        // Only tables without the dense copy look up segments.
        let segment_at_nm = if integral {
            Vec::new()
        } else {
            (0..=(super::LAMBDA_MAX - super::LAMBDA_MIN) as u32)
                .map(|nm| {
                    let lambda = super::LAMBDA_MIN + nm as f32;
                    (lambdas
                        .partition_point(|&x| x <= lambda)
                        .clamp(1, lambdas.len() - 1)
                        - 1) as u32
                })
                .collect()
        };
        let mut table = Self {
            lambdas,
            values,
            segment_at_nm,
            dense: None,
        };
        if integral {
            let (first, last) = (table.lambdas[0], table.lambdas[table.lambdas.len() - 1]);
            let values: Vec<f32> = (0..=(last - first) as u32)
                .map(|nm| table.eval_sparse(first + nm as f32))
                .collect();
            table.dense = Some(values.windows(2).map(|w| [w[0], w[1]]).collect());
        }
        table
    }

    pub fn eval(&self, lambda: f32) -> f32 {
        if self.dense.is_none() {
            return self.eval_sparse(lambda);
        }
        // One dense lookup, the SIMD one (the same value in every lane).
        self.sample(glam::Vec4::splat(lambda))[0]
    }

    /// The table at four wavelengths at once (the dense case in SIMD).
    pub fn sample(&self, lambda: glam::Vec4) -> SampledSpectrum {
        let Some(dense) = &self.dense else {
            return SampledSpectrum::from_array(lambda.to_array().map(|l| self.eval_sparse(l)));
        };
        let x = lambda - glam::Vec4::splat(self.lambdas[0]);
        let last = dense.len() as f32;
        let inside = x.cmpge(glam::Vec4::ZERO) & x.cmple(glam::Vec4::splat(last));
        let xc = x.clamp(glam::Vec4::ZERO, glam::Vec4::splat(last));
        // Truncation is the floor here (xc ≥ 0), in SIMD; the last knot
        // takes the last segment at t = 1.
        let i = truncate(xc).min(glam::IVec4::splat(dense.len() as i32 - 1));
        let t = xc - i.as_vec4();
        let segments = i.to_array().map(|i| dense[i as usize]);
        let v0 = glam::Vec4::from_array(segments.map(|s| s[0]));
        let v1 = glam::Vec4::from_array(segments.map(|s| s[1]));
        let v = v0 + t * (v1 - v0);
        glam::Vec4::select(inside, v, glam::Vec4::ZERO)
    }

    fn eval_sparse(&self, lambda: f32) -> f32 {
        let l = &self.lambdas;
        if !(lambda >= l[0] && lambda <= l[l.len() - 1]) {
            return 0.0;
        }
        let nm = lambda - super::LAMBDA_MIN;
        let mut i = if nm >= 0.0 && (nm as usize) < self.segment_at_nm.len() {
            // Exact: walk on from the segment of the whole nanometre below.
            let mut i = self.segment_at_nm[nm as usize] as usize;
            while i + 2 < l.len() && l[i + 1] <= lambda {
                i += 1;
            }
            i
        } else {
            l.partition_point(|&x| x <= lambda).clamp(1, l.len() - 1) - 1
        };
        i = i.min(l.len() - 2);
        let t = (lambda - l[i]) / (l[i + 1] - l[i]);
        self.values[i] + t * (self.values[i + 1] - self.values[i])
    }

    pub fn scaled(mut self, s: f32) -> Self {
        self.values.iter_mut().for_each(|v| *v *= s);
        // The dense copy is the same function: it scales with the knots.
        if let Some(dense) = &mut self.dense {
            dense.iter_mut().flatten().for_each(|v| *v *= s);
        }
        self
    }

    pub fn values(&self) -> &[f32] {
        &self.values
    }
}

/// An RGB colour turned into a smooth spectrum (Jakob & Hanika 2019):
/// `scale · sigmoid(polynomial(λ)) · illuminant(λ)`.
#[derive(Clone, Debug, PartialEq)]
pub struct RgbSpectrum {
    pub sigmoid: SigmoidPolynomial,
    /// 1 for reflectances; 2·max(rgb) for unbounded values.
    pub scale: f32,
    /// For emission: the white of the colour space (D65 for sRGB).
    pub illuminant: Option<TabulatedSpectrum>,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    Constant(f32),
    Table(TabulatedSpectrum),
    /// Planck's law in W·m⁻²·sr⁻¹·nm⁻¹, times `scale`.
    Blackbody {
        kelvin: f32,
        scale: f32,
    },
    Rgb(RgbSpectrum),
}

impl Spectrum {
    /// A reflectance for a linear sRGB albedo (components clamped to [0, 1]).
    pub fn rgb_reflectance(rgb: glam::Vec3) -> Spectrum {
        let (sigmoid, scale) = super::rgb2spec::albedo(rgb);
        Spectrum::Rgb(RgbSpectrum {
            sigmoid,
            scale,
            illuminant: None,
        })
    }

    /// A smooth spectrum of any magnitude through an RGB value (no
    /// illuminant): optical constants given as colours.
    pub fn rgb_unbounded(rgb: glam::Vec3) -> Spectrum {
        let (sigmoid, scale) = super::rgb2spec::unbounded(rgb.max(glam::Vec3::ZERO));
        Spectrum::Rgb(RgbSpectrum {
            sigmoid,
            scale,
            illuminant: None,
        })
    }

    /// An emitted radiance for a linear sRGB value of any magnitude,
    /// relative to the sRGB white (D65), normalised so that rgb (1, 1, 1)
    /// has luminance 1.
    pub fn rgb_emission(rgb: glam::Vec3) -> Spectrum {
        let (sigmoid, scale) = super::rgb2spec::unbounded(rgb.max(glam::Vec3::ZERO));
        let d65 = super::cie::d65();
        let y = super::cie::spectrum_to_xyz(&Spectrum::Table(d65.clone())).y;
        Spectrum::Rgb(RgbSpectrum {
            sigmoid,
            scale: scale / y,
            illuminant: Some(d65.clone()),
        })
    }

    pub fn eval(&self, lambda: f32) -> f32 {
        match self {
            Spectrum::Constant(c) => *c,
            Spectrum::Table(t) => t.eval(lambda),
            Spectrum::Blackbody { kelvin, scale } => scale * planck(lambda, *kelvin),
            Spectrum::Rgb(rgb) => {
                let mut v = rgb.scale * rgb.sigmoid.eval(lambda);
                if let Some(illum) = &rgb.illuminant {
                    v *= illum.eval(lambda);
                }
                v
            }
        }
    }

    /// The spectrum at each of the path's wavelengths.
    pub fn sample(&self, wl: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Spectrum::Constant(c) => SampledSpectrum::splat(*c),
            Spectrum::Table(t) => t.sample(wl.lambda),
            Spectrum::Rgb(rgb) => {
                let v = rgb.scale * rgb.sigmoid.sample(wl.lambda);
                match &rgb.illuminant {
                    Some(illum) => v * illum.sample(wl.lambda),
                    None => v,
                }
            }
            Spectrum::Blackbody { .. } => SampledSpectrum::new(
                self.eval(wl.lambda.x),
                self.eval(wl.lambda.y),
                self.eval(wl.lambda.z),
                self.eval(wl.lambda.w),
            ),
        }
    }

    /// The same spectrum multiplied by `s`.
    pub fn scaled(self, s: f32) -> Spectrum {
        match self {
            Spectrum::Constant(c) => Spectrum::Constant(c * s),
            Spectrum::Table(t) => Spectrum::Table(t.scaled(s)),
            Spectrum::Blackbody { kelvin, scale } => Spectrum::Blackbody {
                kelvin,
                scale: scale * s,
            },
            Spectrum::Rgb(mut rgb) => {
                rgb.scale *= s;
                Spectrum::Rgb(rgb)
            }
        }
    }

    /// Mean value over [min, max] nm by a 1 nm midpoint rule.
    pub fn average(&self, min: f32, max: f32) -> f32 {
        let n = ((max - min).ceil() as usize).max(1);
        let h = (max - min) / n as f32;
        let sum: f64 = (0..n)
            .map(|i| self.eval(min + (i as f32 + 0.5) * h) as f64)
            .sum();
        (sum / n as f64) as f32
    }
}

/// Planck's law: spectral radiance of a blackbody at `kelvin`, in
/// W·m⁻²·sr⁻¹·nm⁻¹, at wavelength `lambda_nm`.
pub fn planck(lambda_nm: f32, kelvin: f32) -> f32 {
    if kelvin <= 0.0 {
        return 0.0;
    }
    const C: f64 = 299_792_458.0;
    const H: f64 = 6.626_070_15e-34;
    const KB: f64 = 1.380_649e-23;
    let l = lambda_nm as f64 * 1e-9;
    let radiance_per_m =
        2.0 * H * C * C / (l.powi(5) * ((H * C / (l * KB * kelvin as f64)).exp() - 1.0));
    (radiance_per_m * 1e-9) as f32
}

/// Each lane truncated towards zero, for lanes in i32's range: one SIMD
/// conversion (glam's `as_ivec4` converts lane by lane, saturating, which
/// was 1.5% of a Cornell Box's instructions).
#[inline(always)]
pub(super) fn truncate(v: glam::Vec4) -> glam::IVec4 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{__m128i, _mm_cvttps_epi32};
        // SAFETY: SSE2 is part of x86-64; the conversion reads no memory.
        let lanes = unsafe { std::mem::transmute::<__m128i, [i32; 4]>(_mm_cvttps_epi32(v.into())) };
        glam::IVec4::from_array(lanes)
    }
    #[cfg(not(target_arch = "x86_64"))]
    v.as_ivec4()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dense_tables_are_the_same_function() {
        // Knots on whole nanometres, 4 nm apart, as measured data comes.
        let lambdas: Vec<f32> = (0..60).map(|i| 400.0 + 4.0 * i as f32).collect();
        let values: Vec<f32> = (0..60).map(|i| ((i * 7919) % 101) as f32 / 100.0).collect();
        let t = TabulatedSpectrum::new(lambdas.clone(), values.clone());
        assert!(t.dense.is_some());
        // Scaling scales every lookup path alike.
        let doubled = t.clone().scaled(2.0);
        for lambda in [401.3f32, 517.0, 600.9] {
            assert_eq!(doubled.eval(lambda), 2.0 * t.eval(lambda));
            assert_eq!(
                doubled.sample(glam::Vec4::splat(lambda)).x,
                2.0 * t.eval(lambda)
            );
        }
        for k in 0..30_000 {
            let lambda = 390.0 + k as f32 * 0.0087;
            let four = t.sample(glam::Vec4::new(lambda, lambda + 1.3, lambda - 7.1, 300.0));
            assert_eq!(four.x, t.eval(lambda));
            assert_eq!(four.y, t.eval(lambda + 1.3));
            assert_eq!(four.z, t.eval(lambda - 7.1));
            assert_eq!(four.w, 0.0);
            let i = lambdas
                .partition_point(|&x| x <= lambda)
                .clamp(1, lambdas.len() - 1)
                - 1;
            let expected = if lambda < 400.0 || lambda > lambdas[59] {
                0.0
            } else {
                let u = (lambda - lambdas[i]) / (lambdas[i + 1] - lambdas[i]);
                values[i] + u * (values[i + 1] - values[i])
            };
            assert!((t.eval(lambda) - expected).abs() < 1e-6, "at {lambda}");
        }
    }

    #[test]
    fn table_lookup_equals_bisection() {
        // Irregular spacing: several points within one nanometre, gaps of
        // many, a range starting below and ending above the rendered one.
        let lambdas = vec![
            300.0, 361.2, 361.5, 361.9, 400.0, 400.25, 455.0, 455.5, 700.0, 829.9, 900.0,
        ];
        let values: Vec<f32> = (0..lambdas.len()).map(|i| (i * i) as f32 * 0.3).collect();
        let t = TabulatedSpectrum::new(lambdas.clone(), values.clone());
        let bisect = |lambda: f32| {
            if !(lambda >= lambdas[0] && lambda <= lambdas[lambdas.len() - 1]) {
                return 0.0;
            }
            let i = lambdas
                .partition_point(|&x| x <= lambda)
                .clamp(1, lambdas.len() - 1)
                - 1;
            let u = (lambda - lambdas[i]) / (lambdas[i + 1] - lambdas[i]);
            values[i] + u * (values[i + 1] - values[i])
        };
        for k in 0..20_000 {
            let lambda = 280.0 + k as f32 * 0.0317;
            assert_eq!(t.eval(lambda), bisect(lambda), "at {lambda}");
        }
    }

    #[test]
    fn table_interpolates_and_is_zero_outside() {
        let t = TabulatedSpectrum::new(vec![400.0, 500.0, 600.0], vec![0.0, 8.0, 16.0]);
        assert_eq!(t.eval(450.0), 4.0);
        assert_eq!(t.eval(400.0), 0.0);
        assert_eq!(t.eval(600.0), 16.0);
        assert_eq!(t.eval(550.0), 12.0);
        assert_eq!(t.eval(399.0), 0.0);
        assert_eq!(t.eval(601.0), 0.0);
        assert_eq!(t.eval(f32::NAN), 0.0);
    }

    #[test]
    fn planck_peak_follows_wien() {
        // Wien's displacement: λ_max = 2.897771955e6 nm·K / T.
        let t = 5000.0;
        let peak = (300..=1000)
            .map(|l| (l, planck(l as f32, t)))
            .max_by(|a, b| a.1.partial_cmp(&b.1).unwrap())
            .unwrap()
            .0;
        assert!((peak as f32 - 2.897_772e6 / t).abs() <= 1.0, "peak {peak}");
        // Absolute value at 500 nm, 5000 K: 1.2107e13 W m^-3 sr^-1 → per nm.
        let v = planck(500.0, 5000.0);
        assert!((v / 1.2107e4 - 1.0).abs() < 1e-3, "{v}");
    }
}
