//! Output colour: the film's XYZ (under its observer) as RGB of an output
//! colour space. Primaries and whites are the spaces' own; where the
//! space's white is not the render's, the Bradford transform adapts
//! (as colour-science's `XYZ_to_RGB` with `chromatic_adaptation_transform
//! = "Bradford"` does).
//!
//! The render's white is D65, as a display's is: the XYZ of the tabulated
//! D65 spectrum under the film's observer, so that D65 renders neutral
//! under every observer (under CIE 1931 that is (x, y) = (0.31272,
//! 0.32903), which the spaces' rounded (0.3127, 0.3290) misses by 3e-5: a
//! Bradford step of that size takes it there). A white balance replaces it
//! by the XYZ of its illuminant: that illuminant renders neutral, as in a
//! camera.

use glam::{DMat3, DVec2, DVec3, Mat3, Vec3};

use crate::spectrum::cct::xy;
use crate::spectrum::cie::{self, Observer};
use crate::spectrum::Spectrum;

/// The RGB space of the EXR outputs (`film.colour_space`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
pub enum ColourSpace {
    /// Rec. 709 primaries, D65 (IEC 61966-2-1), linear.
    #[default]
    #[serde(rename = "srgb-linear")]
    SrgbLinear,
    /// ITU-R BT.2020 primaries, D65, linear.
    #[serde(rename = "rec2020-linear")]
    Rec2020Linear,
    /// Display P3 (DCI-P3 primaries, D65), linear.
    #[serde(rename = "display-p3-linear")]
    DisplayP3Linear,
    /// ACEScg: AP1 primaries, the ACES white (≈ D60).
    #[serde(rename = "acescg")]
    AcesCg,
    /// ACES2065-1: AP0 primaries, the ACES white.
    #[serde(rename = "aces2065-1")]
    Aces2065_1,
    /// CIE XYZ itself (under the film's observer).
    #[serde(rename = "xyz")]
    Xyz,
}

/// Chromaticities of a space's red, green and blue primaries and white,
/// as OpenEXR's `chromaticities` attribute holds them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chromaticities {
    pub red: DVec2,
    pub green: DVec2,
    pub blue: DVec2,
    pub white: DVec2,
}

const D65: DVec2 = DVec2::new(0.3127, 0.3290);
const ACES_WHITE: DVec2 = DVec2::new(0.32168, 0.33767);
const E: DVec2 = DVec2::new(1.0 / 3.0, 1.0 / 3.0);

const fn chroma(p: [f64; 8]) -> Chromaticities {
    Chromaticities {
        red: DVec2::new(p[0], p[1]),
        green: DVec2::new(p[2], p[3]),
        blue: DVec2::new(p[4], p[5]),
        white: DVec2::new(p[6], p[7]),
    }
}

impl ColourSpace {
    pub const ALL: [ColourSpace; 6] = [
        ColourSpace::SrgbLinear,
        ColourSpace::Rec2020Linear,
        ColourSpace::DisplayP3Linear,
        ColourSpace::AcesCg,
        ColourSpace::Aces2065_1,
        ColourSpace::Xyz,
    ];

    /// The name scene files use.
    pub fn name(self) -> &'static str {
        match self {
            ColourSpace::SrgbLinear => "srgb-linear",
            ColourSpace::Rec2020Linear => "rec2020-linear",
            ColourSpace::DisplayP3Linear => "display-p3-linear",
            ColourSpace::AcesCg => "acescg",
            ColourSpace::Aces2065_1 => "aces2065-1",
            ColourSpace::Xyz => "xyz",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|s| s.name() == name)
    }

    /// Primaries and white; for XYZ, OpenEXR's convention for XYZ images
    /// (primaries at the XYZ axes, white E).
    pub fn chromaticities(self) -> Chromaticities {
        match self {
            ColourSpace::SrgbLinear => chroma([0.64, 0.33, 0.30, 0.60, 0.15, 0.06, D65.x, D65.y]),
            ColourSpace::Rec2020Linear => {
                chroma([0.708, 0.292, 0.170, 0.797, 0.131, 0.046, D65.x, D65.y])
            }
            ColourSpace::DisplayP3Linear => {
                chroma([0.680, 0.320, 0.265, 0.690, 0.150, 0.060, D65.x, D65.y])
            }
            ColourSpace::AcesCg => chroma([
                0.713,
                0.293,
                0.165,
                0.830,
                0.128,
                0.044,
                ACES_WHITE.x,
                ACES_WHITE.y,
            ]),
            ColourSpace::Aces2065_1 => chroma([
                0.7347,
                0.2653,
                0.0,
                1.0,
                0.0001,
                -0.0770,
                ACES_WHITE.x,
                ACES_WHITE.y,
            ]),
            ColourSpace::Xyz => chroma([1.0, 0.0, 0.0, 1.0, 0.0, 0.0, E.x, E.y]),
        }
    }

    /// XYZ (adapted to the space's white) → RGB, derived from the primaries
    /// and white (for sRGB too, rather than IEC 61966-2-1's 4-digit
    /// rounding, which maps D65 to RGB 2.6e-4 off neutral).
    fn xyz_to_rgb(self) -> DMat3 {
        match self {
            ColourSpace::Xyz => DMat3::IDENTITY,
            other => rgb_to_xyz(other.chromaticities()).inverse(),
        }
    }
}

/// XYZ of chromaticity `xy` with Y = 1.
pub fn xy_to_xyz(xy: DVec2) -> DVec3 {
    DVec3::new(xy.x / xy.y, 1.0, (1.0 - xy.x - xy.y) / xy.y)
}

/// The normalised primary matrix: RGB → XYZ, with RGB (1, 1, 1) → the
/// white (Y = 1).
pub fn rgb_to_xyz(c: Chromaticities) -> DMat3 {
    let primaries = DMat3::from_cols(xy_to_xyz(c.red), xy_to_xyz(c.green), xy_to_xyz(c.blue));
    let scale = primaries.inverse() * xy_to_xyz(c.white);
    primaries * DMat3::from_diagonal(scale)
}

/// The Bradford cone response matrix (Lam 1985).
const BRADFORD: DMat3 = DMat3::from_cols_array(&[
    0.8951, -0.7502, 0.0389, //
    0.2664, 1.7135, -0.0685, //
    -0.1614, 0.0367, 1.0296,
]);

/// Bradford adaptation of XYZ seen under white `from` to white `to`.
pub fn bradford(from: DVec3, to: DVec3) -> DMat3 {
    let (a, b) = (BRADFORD * from, BRADFORD * to);
    BRADFORD.inverse() * DMat3::from_diagonal(b / a) * BRADFORD
}

/// The matrix that turns the film's XYZ into output RGB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ColourTransform {
    pub space: ColourSpace,
    pub observer: Observer,
    xyz_to_rgb: Mat3,
}

impl ColourTransform {
    /// XYZ under `observer` → `space`, adapted from the render's white: D65,
    /// or the XYZ of the white balance's illuminant `white_balance`.
    pub fn new(space: ColourSpace, observer: Observer, white_balance: Option<&Spectrum>) -> Self {
        let source = match white_balance {
            Some(s) => Some(observer.cmfs().spectrum_to_xyz(s).as_dvec3()),
            None => render_white(observer),
        };
        let destination = match space {
            // Raw XYZ, unless a white balance asks for its white at E.
            ColourSpace::Xyz => white_balance.map(|_| xy_to_xyz(E)),
            _ => Some(xy_to_xyz(space.chromaticities().white)),
        };
        let adapt = match (source, destination) {
            (Some(from), Some(to)) => bradford(from / from.y, to),
            _ => DMat3::IDENTITY,
        };
        Self {
            space,
            observer,
            xyz_to_rgb: (space.xyz_to_rgb() * adapt).as_mat3(),
        }
    }

    /// The same transform with its output multiplied by `k` (absolute
    /// photometric units: 683 lm/W × Σ ȳ makes Y luminance in cd/m²).
    pub fn scaled(self, k: f32) -> Self {
        Self {
            xyz_to_rgb: self.xyz_to_rgb * k,
            ..self
        }
    }

    /// Linear RGB of XYZ.
    #[inline]
    pub fn rgb(&self, xyz: Vec3) -> Vec3 {
        self.xyz_to_rgb * xyz
    }

    /// The matrix, row-major (for the EXR header and tests).
    pub fn matrix(&self) -> Mat3 {
        self.xyz_to_rgb
    }
}

/// OpenEXR's `adoptedNeutral` of a file in `space`: the chromaticity, as
/// the file's own chromaticities make its pixels, that the render white
/// (D65, or the white balance's illuminant) became. In an RGB space that
/// is the space's white, where the render white was adapted to; in raw
/// XYZ, the render white itself (D65 under `observer`), or E after a
/// white balance.
pub fn adopted_neutral(space: ColourSpace, observer: Observer, white_balanced: bool) -> DVec2 {
    match (space, white_balanced) {
        (ColourSpace::Xyz, false) => xy(render_white(observer).unwrap_or(DVec3::ONE)),
        _ => space.chromaticities().white,
    }
}

impl Default for ColourTransform {
    fn default() -> Self {
        Self::new(ColourSpace::SrgbLinear, Observer::Cie1931, None)
    }
}

/// The render's white without a white balance: the D65 spectrum under
/// `observer`.
fn render_white(observer: Observer) -> Option<DVec3> {
    let d65 = Spectrum::Table(cie::d65().clone());
    Some(observer.cmfs().spectrum_to_xyz(&d65).as_dvec3())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn primary_matrices_match_the_published_ones() {
        // ITU-R BT.2020 and ACES (S-2014-004) RGB → XYZ, as published.
        let m = rgb_to_xyz(ColourSpace::Rec2020Linear.chromaticities());
        let rec2020 = DMat3::from_cols_array(&[
            0.636958, 0.262700, 0.0, 0.144617, 0.677998, 0.028073, 0.168881, 0.059302, 1.060985,
        ]);
        assert!(m.abs_diff_eq(rec2020, 2e-6), "{m}");
        let m = rgb_to_xyz(ColourSpace::Aces2065_1.chromaticities());
        let ap0 = DMat3::from_cols_array(&[
            0.952_552_395_9,
            0.343_966_449_8,
            0.0,
            0.0,
            0.728_166_096_6,
            0.0,
            0.000_093_678_6,
            -0.072_132_546_4,
            1.008_825_184_4,
        ]);
        assert!(m.abs_diff_eq(ap0, 1e-9), "{m}");
    }

    #[test]
    fn the_render_white_is_neutral_in_every_space_and_observer() {
        let d65 = Spectrum::Table(cie::d65().clone());
        for observer in Observer::ALL {
            let xyz = observer.cmfs().spectrum_to_xyz(&d65);
            for space in ColourSpace::ALL {
                if space == ColourSpace::Xyz {
                    continue;
                }
                let t = ColourTransform::new(space, observer, None);
                let rgb = t.rgb(xyz / xyz.y);
                assert!(
                    (rgb - Vec3::splat(rgb.y)).abs().max_element() < 1e-5,
                    "{space:?} {observer:?}: {rgb}"
                );
            }
        }
    }

    /// The adopted neutral is where the render white lands: RGB (1, 1, 1)
    /// seen through the space's chromaticities, or the white itself in XYZ.
    #[test]
    fn the_adopted_neutral_is_where_the_render_white_lands() {
        let a = Spectrum::Table(cie::illuminant("A").unwrap().clone());
        for observer in Observer::ALL {
            for space in ColourSpace::ALL {
                for balance in [None, Some(&a)] {
                    let t = ColourTransform::new(space, observer, balance);
                    let white = match balance {
                        Some(s) => observer.cmfs().spectrum_to_xyz(s).as_dvec3(),
                        None => render_white(observer).unwrap(),
                    };
                    let rgb = t.matrix().as_dmat3() * white;
                    let xyz = match space {
                        ColourSpace::Xyz => rgb,
                        _ => rgb_to_xyz(space.chromaticities()) * rgb,
                    };
                    let neutral = adopted_neutral(space, observer, balance.is_some());
                    assert!(
                        (xy(xyz) - neutral).abs().max_element() < 1e-5,
                        "{space:?} {observer:?}: {} {neutral}",
                        xy(xyz)
                    );
                }
            }
        }
    }

    #[test]
    fn a_white_balance_makes_its_illuminant_neutral() {
        let a = Spectrum::Table(cie::illuminant("A").unwrap().clone());
        let planck = Spectrum::Blackbody {
            kelvin: 3200.0,
            scale: 1.0,
        };
        for observer in Observer::ALL {
            for space in ColourSpace::ALL {
                for s in [&a, &planck] {
                    let t = ColourTransform::new(space, observer, Some(s));
                    let rgb = t.rgb(observer.cmfs().spectrum_to_xyz(s));
                    let spread = rgb.max_element() - rgb.min_element();
                    assert!(
                        spread < 1e-4 * rgb.max_element(),
                        "{space:?} {observer:?}: {rgb}"
                    );
                }
            }
        }
        // Without one, illuminant A is warm.
        let rgb = ColourTransform::default().rgb(cie::spectrum_to_xyz(&a));
        assert!(rgb.x > 1.5 * rgb.z, "{rgb}");
    }

    #[test]
    fn srgb_under_cie_1931_is_the_derived_matrix_adapted_from_tabulated_d65() {
        let t = ColourTransform::default();
        let d65 = cie::spectrum_to_xyz(&Spectrum::Table(cie::d65().clone())).as_dvec3();
        let adapted = cie::XYZ_TO_SRGB.as_dmat3() * bradford(d65 / d65.y, xy_to_xyz(D65));
        assert!(
            t.matrix().abs_diff_eq(adapted.as_mat3(), 1e-6),
            "{}",
            t.matrix()
        );
        // A step of 3e-5 in chromaticity: the derived matrix to 5e-4.
        assert!(t.matrix().abs_diff_eq(cie::XYZ_TO_SRGB, 5e-4));
        // Within IEC 61966-2-1's rounding of it.
        let iec = Mat3::from_cols_array(&[
            3.2406, -0.9689, 0.0557, -1.5372, 1.8758, -0.2040, -0.4986, 0.0415, 1.0570,
        ]);
        assert!(t.matrix().abs_diff_eq(iec, 5e-4));
        let xyz = ColourTransform::new(ColourSpace::Xyz, Observer::Cie1931, None);
        assert_eq!(xyz.matrix(), Mat3::IDENTITY);
    }
}
