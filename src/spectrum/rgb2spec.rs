//! RGB → spectrum upsampling after Jakob & Hanika 2019, "A Low-Dimensional
//! Function Space for Efficient Spectral Upsampling": a reflectance is
//! `sigmoid(c0 t² + c1 t + c2)` with t = (λ − 360)/470, and the three
//! coefficients for any sRGB colour come from a table fitted offline by
//! `tools/fit_rgb2spec.rs` (committed as `spectra/rgb2spec_srgb.bin`).

use std::sync::OnceLock;

use glam::{Vec3, Vec4};

use super::{LAMBDA_MAX, LAMBDA_MIN};

/// `sigmoid(c0 t² + c1 t + c2)` over normalised wavelength t ∈ [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SigmoidPolynomial {
    pub c: [f32; 3],
}

impl SigmoidPolynomial {
    pub fn eval(&self, lambda: f32) -> f32 {
        let t = normalised_wavelength(lambda);
        sigmoid((self.c[0] * t + self.c[1]) * t + self.c[2])
    }

    /// At a path's four wavelengths, in SIMD: lane for lane the arithmetic
    /// of `eval`, so the values are the same to the bit.
    pub fn sample(&self, lambda: Vec4) -> Vec4 {
        self.at(normalised_wavelengths(lambda))
    }

    /// At four normalised wavelengths (`normalised_wavelengths`), for
    /// callers that evaluate many polynomials at the same wavelengths.
    pub fn at(&self, t: Vec4) -> Vec4 {
        let [c0, c1, c2] = self.c.map(Vec4::splat);
        sigmoids((c0 * t + c1) * t + c2)
    }
}

/// Maps [360, 830] nm to [0, 1], the variable the polynomial is fitted in.
pub fn normalised_wavelength(lambda: f32) -> f32 {
    (lambda - LAMBDA_MIN) / (LAMBDA_MAX - LAMBDA_MIN)
}

/// `normalised_wavelength` in each lane.
pub fn normalised_wavelengths(lambda: Vec4) -> Vec4 {
    (lambda - Vec4::splat(LAMBDA_MIN)) / (LAMBDA_MAX - LAMBDA_MIN)
}

/// `sigmoid` in each lane, in SIMD (the hot form: textures and RGB lights
/// evaluate it at every hit and every light sample).
pub fn sigmoids(x: Vec4) -> Vec4 {
    // glam 0.29 has no Vec4::sqrt; LLVM's SLP pass makes the lanes one sqrtps.
    let root = Vec4::from_array((1.0 + x * x).to_array().map(f32::sqrt));
    let finite = 0.5 + x / (2.0 * root);
    // ±∞ would give ∞/∞: their limits instead.
    let limit = Vec4::select(x.cmpgt(Vec4::ZERO), Vec4::ONE, Vec4::ZERO);
    Vec4::select(x.abs().cmpeq(Vec4::INFINITY), limit, finite)
}

/// The smooth map of ℝ onto (0, 1) used by the paper: ½ + x / (2√(1 + x²)).
pub fn sigmoid(x: f32) -> f32 {
    if x.is_infinite() {
        return if x > 0.0 { 1.0 } else { 0.0 };
    }
    0.5 + x / (2.0 * (1.0 + x * x).sqrt())
}

/// Identifies the binary table format written by the fitting tool.
pub const TABLE_MAGIC: &[u8; 8] = b"PRGB2SP1";

/// Coefficients over a res³ grid for each of the three "largest component"
/// cases: `data[((l·res + k)·res + j)·res + i]` holds the fit for
/// rgb[l] = scale[k], rgb[l+1] = i/(res−1)·scale[k], rgb[l+2] = j/(res−1)·scale[k].
pub struct Rgb2SpecTable {
    pub res: usize,
    pub scale: Vec<f32>,
    pub data: Vec<[f32; 3]>,
}

impl Rgb2SpecTable {
    /// Parses the fitting tool's output (little-endian): magic, res (u32),
    /// res scale values, then 3·res³ coefficient triples.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, String> {
        if bytes.len() < 12 || &bytes[..8] != TABLE_MAGIC {
            return Err("not an rgb2spec table (bad magic)".into());
        }
        let res = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
        let floats: Vec<f32> = bytes[12..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect();
        if res < 2 || floats.len() != res + 3 * res * res * res * 3 {
            return Err(format!(
                "rgb2spec table of resolution {res} has the wrong size"
            ));
        }
        let scale = floats[..res].to_vec();
        let data = floats[res..]
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        Ok(Self { res, scale, data })
    }

    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = TABLE_MAGIC.to_vec();
        out.extend((self.res as u32).to_le_bytes());
        for v in self.scale.iter().chain(self.data.iter().flatten()) {
            out.extend(v.to_le_bytes());
        }
        out
    }

    /// The sigmoid polynomial whose reflectance has (approximately) this
    /// linear sRGB colour under D65. Components are clamped to [0, 1].
    pub fn lookup(&self, rgb: Vec3) -> SigmoidPolynomial {
        let rgb = rgb.clamp(Vec3::ZERO, Vec3::ONE);
        if rgb.x == rgb.y && rgb.y == rgb.z {
            // Grey: a constant, exactly representable. 0 and 1 are the
            // sigmoid's limits at ∓∞.
            let v = rgb.x;
            let c2 = if v <= 0.0 {
                f32::NEG_INFINITY
            } else if v >= 1.0 {
                f32::INFINITY
            } else {
                (v - 0.5) / (v * (1.0 - v)).sqrt()
            };
            return SigmoidPolynomial { c: [0.0, 0.0, c2] };
        }
        let c = rgb.to_array();
        let l = if c[0] >= c[1] && c[0] >= c[2] {
            0
        } else if c[1] >= c[2] {
            1
        } else {
            2
        };
        let z = c[l];
        let last = (self.res - 1) as f32;
        let x = c[(l + 1) % 3] / z * last;
        let y = c[(l + 2) % 3] / z * last;
        let xi = (x as usize).min(self.res - 2);
        let yi = (y as usize).min(self.res - 2);
        let zi = self
            .scale
            .partition_point(|&s| s <= z)
            .clamp(1, self.res - 1)
            - 1;
        let (dx, dy) = (x - xi as f32, y - yi as f32);
        let dz = (z - self.scale[zi]) / (self.scale[zi + 1] - self.scale[zi]);
        let mut out = [0.0f32; 3];
        for (dk, wz) in [(0, 1.0 - dz), (1, dz)] {
            for (dj, wy) in [(0, 1.0 - dy), (1, dy)] {
                for (di, wx) in [(0, 1.0 - dx), (1, dx)] {
                    let idx = ((l * self.res + zi + dk) * self.res + yi + dj) * self.res + xi + di;
                    let w = wx * wy * wz;
                    for (o, v) in out.iter_mut().zip(self.data[idx]) {
                        *o += w * v;
                    }
                }
            }
        }
        SigmoidPolynomial { c: out }
    }
}

const SRGB_TABLE: &[u8] = include_bytes!("../../spectra/rgb2spec_srgb.bin");

/// The committed sRGB table.
pub fn srgb_table() -> &'static Rgb2SpecTable {
    static TABLE: OnceLock<Rgb2SpecTable> = OnceLock::new();
    TABLE.get_or_init(|| {
        Rgb2SpecTable::from_bytes(SRGB_TABLE)
            .expect("spectra/rgb2spec_srgb.bin is valid; regenerate it with tools/fit_rgb2spec.rs")
    })
}

/// Brightness below which reflectances are fitted at this brightness and
/// scaled down: a sigmoid's tails decay slowly, so dark saturated colours
/// are reached far better as a scaled brighter spectrum.
const DARK_LIMIT: f32 = 0.5;

/// A reflectance spectrum (within [0, 1]) for a linear sRGB albedo:
/// `scale · sigmoid(λ)`. Components are clamped to [0, 1].
pub fn albedo(rgb: Vec3) -> (SigmoidPolynomial, f32) {
    let rgb = rgb.clamp(Vec3::ZERO, Vec3::ONE);
    let m = rgb.max_element();
    if m > 0.0 && m < DARK_LIMIT {
        let scale = m / DARK_LIMIT;
        (srgb_table().lookup(rgb / scale), scale)
    } else {
        (srgb_table().lookup(rgb), 1.0)
    }
}

/// An unbounded spectrum for a linear sRGB value of any magnitude: a
/// sigmoid fitted to rgb / (2·max) and the scale 2·max that undoes it.
pub fn unbounded(rgb: Vec3) -> (SigmoidPolynomial, f32) {
    let m = rgb.max_element().max(0.0);
    if m == 0.0 {
        return (srgb_table().lookup(Vec3::ZERO), 0.0);
    }
    let scale = 2.0 * m;
    (srgb_table().lookup(rgb / scale), scale)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::cie;

    /// The linear sRGB of a reflectance under D65, normalised to the white.
    fn reflectance_rgb(s: &SigmoidPolynomial) -> Vec3 {
        let c = cie::cmfs();
        let d65 = cie::d65();
        let (mut xyz, mut white) = (glam::DVec3::ZERO, 0.0f64);
        for (i, bar) in c.xyz.iter().enumerate() {
            let l = (cie::CMF_START + i) as f32;
            let e = d65.eval(l) as f64;
            xyz += bar.as_dvec3() * e * s.eval(l) as f64;
            white += bar.y as f64 * e;
        }
        cie::xyz_to_linear_srgb((xyz / white).as_vec3())
    }

    #[test]
    fn sigmoid_limits() {
        assert_eq!(sigmoid(0.0), 0.5);
        assert_eq!(sigmoid(f32::INFINITY), 1.0);
        assert_eq!(sigmoid(f32::NEG_INFINITY), 0.0);
        assert!(sigmoid(1e30) <= 1.0 && sigmoid(-1e30) >= 0.0);
    }

    #[test]
    fn simd_forms_match_the_scalar_ones_to_the_bit() {
        let xs = [
            0.0,
            -0.0,
            1e-30,
            0.3,
            -2.5,
            17.0,
            1e19,
            -1e30,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for x in xs.chunks(4) {
            let mut lanes = [0.0; 4];
            lanes[..x.len()].copy_from_slice(x);
            let simd = sigmoids(Vec4::from_array(lanes)).to_array();
            for (v, x) in simd.iter().zip(lanes) {
                assert_eq!(v.to_bits(), sigmoid(x).to_bits(), "sigmoid({x})");
            }
        }
        let poly = SigmoidPolynomial {
            c: [-31.2, 27.5, -4.1],
        };
        let lambda = Vec4::new(360.0, 451.7, 600.25, 830.0);
        let simd = poly.sample(lambda).to_array();
        for (v, l) in simd.iter().zip(lambda.to_array()) {
            assert_eq!(v.to_bits(), poly.eval(l).to_bits(), "λ = {l}");
        }
    }

    #[test]
    fn table_round_trips_through_bytes() {
        let t = srgb_table();
        let back = Rgb2SpecTable::from_bytes(&t.to_bytes()).unwrap();
        assert_eq!(back.res, t.res);
        assert_eq!(back.data, t.data);
        assert!(Rgb2SpecTable::from_bytes(b"garbage!").is_err());
    }

    fn worst_error(steps: &[f32]) -> f32 {
        let mut worst = 0.0f32;
        for &r in steps {
            for &g in steps {
                for &b in steps {
                    let rgb = Vec3::new(r, g, b);
                    let (s, scale) = albedo(rgb);
                    let got = reflectance_rgb(&s) * scale;
                    worst = worst.max((got - rgb).abs().max_element());
                }
            }
        }
        worst
    }

    #[test]
    fn upsampled_reflectances_reproduce_their_rgb() {
        // Inside the cube the error is the table's interpolation error.
        let inner = worst_error(&[0.05, 0.1, 0.25, 0.5, 0.75, 0.9]);
        assert!(inner < 3e-3, "worst sRGB error {inner}");
        // Dark saturated colours, reached as scaled brighter spectra.
        let dark = worst_error(&[0.0, 0.005, 0.02, 0.1]);
        assert!(dark < 1e-3, "worst sRGB error of dark colours {dark}");
        // At the cube's bright saturated edges no smooth reflectance matches
        // exactly (a sigmoid reaches 0 and 1 only at infinity and the fit
        // bounds its coefficients): the error stays below 2%.
        let edges = worst_error(&[0.0, 0.02, 0.5, 0.98, 1.0]);
        assert!(edges < 2e-2, "worst sRGB error at the edges {edges}");
        // Greys are exact constants.
        let (grey, scale) = albedo(Vec3::splat(0.3));
        assert!(
            (grey.eval(400.0) * scale - 0.3).abs() < 1e-6
                && (grey.eval(700.0) * scale - 0.3).abs() < 1e-6
        );
        // Every upsampled spectrum is a valid reflectance.
        let (s, _) = albedo(Vec3::new(1.0, 0.0, 0.0));
        assert!((360..=830).all(|l| (0.0..=1.0).contains(&s.eval(l as f32))));
    }

    #[test]
    fn unbounded_spectra_scale_back() {
        let (s, scale) = unbounded(Vec3::new(4.0, 2.0, 1.0));
        assert_eq!(scale, 8.0);
        let rgb = reflectance_rgb(&s) * scale;
        assert!(
            (rgb - Vec3::new(4.0, 2.0, 1.0)).abs().max_element() < 0.03,
            "{rgb}"
        );
    }
}
