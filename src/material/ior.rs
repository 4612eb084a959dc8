//! Indices of refraction as functions of wavelength: constant, Cauchy,
//! Sellmeier, Abbe number, or a table; with named glasses.

// Coefficients are kept as published, beyond what f32 holds.
#![allow(clippy::excessive_precision)]

use glam::Vec4;

use crate::spectrum::Spectrum;

/// Fraunhofer d, F and C lines (nm), which define n_d and the Abbe number.
pub const LAMBDA_D: f32 = 587.5618;
pub const LAMBDA_F: f32 = 486.1327;
pub const LAMBDA_C: f32 = 656.2725;

#[derive(Clone, Debug, PartialEq)]
pub enum Ior {
    Constant(f32),
    /// n = a + b/λ², λ in µm.
    Cauchy {
        a: f32,
        b: f32,
    },
    /// n² − 1 = Σ Bᵢλ²/(λ² − Cᵢ), λ in µm, Cᵢ in µm² (up to four terms; unused Bᵢ = 0).
    Sellmeier {
        b: [f32; 4],
        c: [f32; 4],
    },
    Table(Spectrum),
}

/// Sellmeier coefficients of the named glasses (refractiveindex.info, CC0;
/// the table in shared/data/README.md) and water.
pub const PRESETS: [(&str, [f32; 4], [f32; 4]); 6] = [
    (
        "N-BK7",
        [1.039_612_1, 0.231_792_34, 1.010_469_5, 0.0],
        [0.006_000_699, 0.020_017_914, 103.560_65, 0.0],
    ),
    (
        "N-SF11",
        [1.737_597, 0.313_747_35, 1.898_781, 0.0],
        [0.013_188_707, 0.062_306_814, 155.236_29, 0.0],
    ),
    (
        "N-F2",
        [1.397_570_4, 0.159_201_4, 1.268_654_3, 0.0],
        [0.009_959_061, 0.054_693_175, 119.248_35, 0.0],
    ),
    // Malitson 1965: Cᵢ = 0.0684043², 0.1162414², 9.896161².
    (
        "fused silica",
        [0.696_166_3, 0.407_942_6, 0.897_479_4, 0.0],
        [0.004_679_148, 0.013_512_063, 97.934_0, 0.0],
    ),
    // Peter 1923: Cᵢ = 0.175², 0.106².
    (
        "diamond",
        [0.3306, 4.3356, 0.0, 0.0],
        [0.030_625, 0.011_236, 0.0, 0.0],
    ),
    // Daimon & Masumura 2007, 20 °C: n_d = 1.333403.
    (
        "water",
        [0.568_402_76, 0.172_617_74, 0.020_861_896, 0.113_074_87],
        [0.005_101_83, 0.018_211_54, 0.026_207_223, 10.697_927],
    ),
];

impl Ior {
    /// A named glass, or None.
    pub fn preset(name: &str) -> Option<Ior> {
        PRESETS
            .iter()
            .find(|(n, _, _)| n.eq_ignore_ascii_case(name))
            .map(|(_, b, c)| Ior::Sellmeier { b: *b, c: *c })
    }

    /// Cauchy's equation through n_d with Abbe number V_d:
    /// B = (n_d − 1) / (V_d (λF⁻² − λC⁻²)), A = n_d − B/λd².
    pub fn abbe(nd: f32, vd: f32) -> Ior {
        let um = |l: f32| l / 1000.0;
        let b = (nd - 1.0) / (vd * (1.0 / um(LAMBDA_F).powi(2) - 1.0 / um(LAMBDA_C).powi(2)));
        Ior::Cauchy {
            a: nd - b / um(LAMBDA_D).powi(2),
            b,
        }
    }

    pub fn eval(&self, lambda_nm: f32) -> f32 {
        let l = lambda_nm / 1000.0;
        match self {
            Ior::Constant(n) => *n,
            Ior::Cauchy { a, b } => a + b / (l * l),
            Ior::Sellmeier { b, c } => {
                let l2 = l * l;
                let sum: f32 = (0..4)
                    .map(|i| {
                        if b[i] == 0.0 {
                            0.0
                        } else {
                            b[i] * l2 / (l2 - c[i])
                        }
                    })
                    .sum();
                (1.0 + sum).max(0.0).sqrt()
            }
            Ior::Table(s) => s.eval(lambda_nm),
        }
    }

    /// The index at a path's four wavelengths, lane by lane as `eval`
    /// gives it (the same operations in the same order: bit for bit), the
    /// Sellmeier terms of all four at once.
    pub fn eval4(&self, lambda_nm: Vec4) -> Vec4 {
        match self {
            Ior::Sellmeier { b, c } => {
                let l = lambda_nm / 1000.0;
                let l2 = l * l;
                let mut sum = Vec4::ZERO;
                for i in 0..4 {
                    if b[i] != 0.0 {
                        sum += b[i] * l2 / (l2 - c[i]);
                    }
                }
                Vec4::from_array((1.0 + sum).to_array().map(|n2| n2.max(0.0).sqrt()))
            }
            _ => Vec4::from_array(lambda_nm.to_array().map(|l| self.eval(l))),
        }
    }

    /// Whether the index varies with wavelength (then paths disperse).
    pub fn is_dispersive(&self) -> bool {
        match self {
            Ior::Constant(_) => false,
            Ior::Cauchy { b, .. } => *b != 0.0,
            Ior::Sellmeier { .. } => true,
            Ior::Table(s) => !matches!(s, Spectrum::Constant(_)),
        }
    }

    /// Abbe number V_d = (n_d − 1)/(n_F − n_C).
    pub fn abbe_number(&self) -> f32 {
        (self.eval(LAMBDA_D) - 1.0) / (self.eval(LAMBDA_F) - self.eval(LAMBDA_C))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn four_wavelengths_at_once_match_one_at_a_time_bit_for_bit() {
        let lambdas = Vec4::new(361.5, 487.25, 589.3, 829.9);
        let iors = [
            Ior::preset("N-BK7").unwrap(),
            Ior::preset("N-SF11").unwrap(),
            Ior::Cauchy { a: 1.5, b: 0.004 },
            Ior::Constant(1.33),
        ];
        for ior in iors {
            let four = ior.eval4(lambdas).to_array();
            for (k, l) in lambdas.to_array().into_iter().enumerate() {
                assert_eq!(
                    four[k].to_bits(),
                    ior.eval(l).to_bits(),
                    "{ior:?} at {l} nm"
                );
            }
        }
    }

    #[test]
    fn presets_match_their_datasheet_nd_and_abbe_numbers() {
        // (name, n_d, V_d) from ../shared/data/README.md.
        for (name, nd, vd) in [
            ("N-BK7", 1.516800, 64.17),
            ("N-SF11", 1.784720, 25.68),
            ("N-F2", 1.620053, 36.43),
            ("fused silica", 1.458464, 67.82),
            ("diamond", 2.417486, 55.3),
        ] {
            let ior = Ior::preset(name).unwrap();
            assert!(
                (ior.eval(LAMBDA_D) - nd).abs() < 2e-4,
                "{name}: n_d {}",
                ior.eval(LAMBDA_D)
            );
            assert!(
                (ior.abbe_number() - vd).abs() < 0.5,
                "{name}: V_d {}",
                ior.abbe_number()
            );
        }
        let water = Ior::preset("water").unwrap();
        assert!(
            (water.eval(LAMBDA_D) - 1.333403).abs() < 1e-5,
            "water n_d {}",
            water.eval(LAMBDA_D)
        );
    }

    #[test]
    fn abbe_model_reproduces_nd_and_vd() {
        let ior = Ior::abbe(1.5168, 64.17);
        assert!((ior.eval(LAMBDA_D) - 1.5168).abs() < 1e-5);
        assert!((ior.abbe_number() - 64.17).abs() < 0.01);
        assert!(ior.is_dispersive() && !Ior::Constant(1.5).is_dispersive());
    }
}
