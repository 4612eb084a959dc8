//! The PNG: display-referred output. The film's XYZ becomes linear RGB of
//! the display (sRGB or Display P3, both D65 with the sRGB transfer
//! function), is exposed, tone mapped (a view transform), brought into the
//! display's gamut, encoded and quantised to 8 or 16 bits, and tagged with
//! a cICP chunk (and sRGB's own chunk for sRGB) so viewers show it right.
//!
//! Gamut mapping (`film.gamut = "map"`) is CSS Color 4's: keep OKLab
//! lightness and hue, reduce chroma by bisection until clipping what is
//! left moves the colour by less than a just-noticeable ΔE_OK of 0.02. A
//! rainbow's spectral colours, far outside sRGB, keep their hue instead of
//! drifting towards the primaries as per-channel clipping makes them.

use std::io::BufWriter;
use std::path::Path;

use anyhow::{Context, Result};
use glam::{DMat3, Mat3, Vec3};

use super::colour::{rgb_to_xyz, ColourSpace};
use super::output::{write_atomically, Tonemap};
use super::FilmSettings;
use crate::spectrum::cie::srgb_encode;

/// The display the PNG is for (`film.display`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
pub enum Display {
    #[default]
    #[serde(rename = "srgb")]
    Srgb,
    #[serde(rename = "display-p3")]
    DisplayP3,
}

impl Display {
    pub fn name(self) -> &'static str {
        match self {
            Display::Srgb => "srgb",
            Display::DisplayP3 => "display-p3",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        [Display::Srgb, Display::DisplayP3]
            .into_iter()
            .find(|d| d.name() == name)
    }

    /// Its linear RGB space.
    pub fn space(self) -> ColourSpace {
        match self {
            Display::Srgb => ColourSpace::SrgbLinear,
            Display::DisplayP3 => ColourSpace::DisplayP3Linear,
        }
    }

    /// The ICC profile of the PNG's iCCP chunk, for displays other than
    /// sRGB (which has a chunk of its own).
    pub fn icc_profile(self) -> Option<Vec<u8>> {
        match self {
            Display::Srgb => None,
            Display::DisplayP3 => Some(super::icc::srgb_curve_profile(
                "Display P3 (prism)",
                ColourSpace::DisplayP3Linear.chromaticities(),
            )),
        }
    }

    /// cICP code points (ITU-T H.273): colour primaries (1: BT.709, 12:
    /// SMPTE EG 432-1, P3 with D65), transfer 13 (sRGB), RGB, full range.
    pub fn cicp(self) -> [u8; 4] {
        let primaries = match self {
            Display::Srgb => 1,
            Display::DisplayP3 => 12,
        };
        [primaries, 13, 0, 1]
    }
}

/// How a render spreads its samples over the pixels (`film.sampling`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Sampling {
    /// Where a pilot finds the relative error high (`drive::adaptive`).
    Adaptive,
    /// The same samples in every pixel.
    Uniform,
}

/// How out-of-gamut display colours are brought in (`film.gamut`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Gamut {
    /// Clip each channel to [0, 1].
    #[default]
    Clip,
    /// CSS Color 4 gamut mapping: chroma reduction in OKLCh.
    Map,
}

/// Everything about the PNG.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DisplaySettings {
    pub display: Display,
    /// 8 or 16.
    pub bits: u8,
    pub gamut: Gamut,
    pub exposure: f32,
    pub tonemap: Tonemap,
}

impl Default for DisplaySettings {
    fn default() -> Self {
        Self {
            display: Display::Srgb,
            bits: 8,
            gamut: Gamut::Clip,
            exposure: 0.0,
            tonemap: Tonemap::Clamp,
        }
    }
}

/// Display-linear RGB → display values in [0, 1] (before the transfer
/// function): exposure, view transform, gamut.
pub fn to_display(c: Vec3, settings: &DisplaySettings, oklab: &Oklab) -> Vec3 {
    let c = c * settings.exposure.exp2();
    let c = match settings.tonemap {
        Tonemap::Clamp => c,
        // Per channel on the positive part; negative (out-of-gamut) parts
        // are left to the gamut step.
        Tonemap::Reinhard => {
            Vec3::from_array(
                c.to_array()
                    .map(|v| if v > 0.0 { v / (1.0 + v) } else { v }),
            )
        }
        Tonemap::Filmic => filmic(c, oklab),
    };
    match settings.gamut {
        Gamut::Clip => c.clamp(Vec3::ZERO, Vec3::ONE),
        Gamut::Map => oklab.map_into_gamut(c),
    }
}

/// A filmic view transform that holds hue: the colour is scaled so that
/// its largest channel follows a logistic curve in stops around middle grey
/// (0.18 → 0.18 on the display; +6.5 stops → 99 % white; −10 stops →
/// black), which keeps its chromaticity; then, as that curve nears white,
/// it is moved towards white in OKLab at constant hue (lightness up, chroma
/// down), so highlights roll off and desaturate smoothly instead of
/// clipping to a primary. Hue changes only in the gamut step after it
/// (none with `gamut = "map"` for colours inside the spectral locus).
pub fn filmic(c: Vec3, oklab: &Oklab) -> Vec3 {
    // Logistic width (stops) and centre (stops above grey): grey maps to
    // sRGB-encoded 0.4614 (linear 0.18) and grey + 6.5 stops to 0.99.
    const WIDTH: f32 = 1.366;
    const CENTRE: f32 = 0.2185;
    // Where on the encoded curve the path to white starts.
    const SHOULDER: f32 = 0.75;
    let peak = c.max_element();
    if !(peak > 0.0) {
        return Vec3::ZERO;
    }
    let stops = (peak / 0.18).log2();
    let encoded = 1.0 / (1.0 + (-(stops - CENTRE) / WIDTH).exp());
    let scaled = c * (crate::spectrum::cie::srgb_decode(encoded) / peak);
    let towards_white = ((encoded - SHOULDER) / (1.0 - SHOULDER))
        .clamp(0.0, 1.0)
        .powi(2);
    if towards_white == 0.0 {
        return scaled;
    }
    let lab = oklab.from_rgb(scaled);
    let lightness = lab.x + (1.0 - lab.x) * towards_white;
    let chroma = 1.0 - towards_white;
    oklab.to_rgb(Vec3::new(lightness, lab.y * chroma, lab.z * chroma))
}

/// OKLab for one display's linear RGB (Ottosson 2020; CSS Color 4's
/// matrices from D65 XYZ).
#[derive(Clone, Copy, Debug)]
pub struct Oklab {
    rgb_to_lms: Mat3,
    lms_to_rgb: Mat3,
    lms_to_lab: Mat3,
    lab_to_lms: Mat3,
}

const XYZ_TO_LMS: DMat3 = DMat3::from_cols_array(&[
    0.819_022_437_996_703,
    0.032_983_653_932_388_5,
    0.048_177_189_359_624_2,
    0.361_906_260_052_890_4,
    0.929_286_861_586_343_4,
    0.264_239_531_752_730_8,
    -0.128_873_781_520_987_9,
    0.036_144_666_350_642_4,
    0.633_547_828_469_430_9,
]);

const LMS_TO_LAB: DMat3 = DMat3::from_cols_array(&[
    0.210_454_268_309_314,
    1.977_998_532_431_168_4,
    0.025_904_042_465_547_8,
    0.793_617_774_702_305_4,
    -2.428_592_242_048_58,
    0.782_771_712_457_529_6,
    -0.004_072_043_011_619_3,
    0.450_593_709_617_411,
    -0.808_675_766_031_012_7,
]);

impl Oklab {
    pub fn for_display(display: Display) -> Self {
        let m = XYZ_TO_LMS * rgb_to_xyz(display.space().chromaticities());
        Self {
            rgb_to_lms: m.as_mat3(),
            lms_to_rgb: m.inverse().as_mat3(),
            lms_to_lab: LMS_TO_LAB.as_mat3(),
            lab_to_lms: LMS_TO_LAB.inverse().as_mat3(),
        }
    }

    /// Linear RGB → (L, a, b).
    pub fn from_rgb(&self, c: Vec3) -> Vec3 {
        let lms = self.rgb_to_lms * c;
        self.lms_to_lab * Vec3::from_array(lms.to_array().map(f32::cbrt))
    }

    /// (L, a, b) → linear RGB.
    pub fn to_rgb(&self, lab: Vec3) -> Vec3 {
        let lms = self.lab_to_lms * lab;
        self.lms_to_rgb * Vec3::from_array(lms.to_array().map(|v| v * v * v))
    }

    /// CSS Color 4's gamut mapping of linear RGB into [0, 1]³.
    pub fn map_into_gamut(&self, c: Vec3) -> Vec3 {
        const JND: f32 = 0.02;
        const EPSILON: f32 = 1e-4;
        let in_gamut = |c: Vec3| c.min_element() >= 0.0 && c.max_element() <= 1.0;
        if in_gamut(c) {
            return c;
        }
        let lab = self.from_rgb(c);
        if lab.x >= 1.0 {
            return Vec3::ONE;
        }
        if lab.x <= 0.0 {
            return Vec3::ZERO;
        }
        let chroma = (lab.y * lab.y + lab.z * lab.z).sqrt();
        let with_chroma = |c: f32| {
            let s = if chroma > 0.0 { c / chroma } else { 0.0 };
            Vec3::new(lab.x, lab.y * s, lab.z * s)
        };
        let clip = |c: Vec3| c.clamp(Vec3::ZERO, Vec3::ONE);
        let delta = |a: Vec3, b: Vec3| (a - b).length();
        let mut clipped = clip(c);
        if delta(self.from_rgb(clipped), lab) < JND {
            return clipped;
        }
        let (mut lo, mut hi, mut lo_in_gamut) = (0.0f32, chroma, true);
        while hi - lo > EPSILON {
            let mid = 0.5 * (lo + hi);
            let current = with_chroma(mid);
            let rgb = self.to_rgb(current);
            if lo_in_gamut && in_gamut(rgb) {
                lo = mid;
                continue;
            }
            clipped = clip(rgb);
            let e = delta(self.from_rgb(clipped), current);
            if e < JND {
                if JND - e < EPSILON {
                    break;
                }
                lo_in_gamut = false;
                lo = mid;
            } else {
                hi = mid;
            }
        }
        clipped
    }
}

/// Writes display-linear pixels (`transform` applied by the caller) as a
/// tagged PNG.
pub fn write_png(
    rgb: &[Vec3],
    width: u32,
    height: u32,
    path: &Path,
    settings: &DisplaySettings,
) -> Result<()> {
    let oklab = Oklab::for_display(settings.display);
    let max = if settings.bits == 16 { 65535.0 } else { 255.0 };
    let samples: Vec<u16> = rgb
        .iter()
        .flat_map(|&c| {
            let d = to_display(c, settings, &oklab);
            [d.x, d.y, d.z].map(|v| (srgb_encode(v.clamp(0.0, 1.0)) * max + 0.5) as u16)
        })
        .collect();
    let bytes: Vec<u8> = if settings.bits == 16 {
        samples.iter().flat_map(|v| v.to_be_bytes()).collect()
    } else {
        samples.iter().map(|&v| v as u8).collect()
    };
    write_atomically(path, |tmp| {
        let file = std::fs::File::create(tmp)
            .with_context(|| format!("cannot create {}", tmp.display()))?;
        let mut info = png::Info::with_size(width, height);
        info.color_type = png::ColorType::Rgb;
        info.bit_depth = if settings.bits == 16 {
            png::BitDepth::Sixteen
        } else {
            png::BitDepth::Eight
        };
        // For viewers that do not read cICP: sRGB's own chunk, or an ICC
        // profile of the display (without one they would assume sRGB).
        info.icc_profile = settings.display.icc_profile().map(Into::into);
        let mut encoder = png::Encoder::with_info(BufWriter::new(file), info)
            .with_context(|| format!("cannot write {}", tmp.display()))?;
        if settings.display == Display::Srgb {
            encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        }
        let mut writer = encoder
            .write_header()
            .with_context(|| format!("cannot write {}", tmp.display()))?;
        writer
            .write_chunk(png::chunk::cICP, &settings.display.cicp())
            .and_then(|_| writer.write_image_data(&bytes))
            .and_then(|_| writer.finish())
            .with_context(|| format!("cannot write {}", tmp.display()))
    })
}

/// Attributes of a spectral EXR that say how `prism merge` makes the PNG
/// from its R, G, B channels (absent in older files: sRGB, clipped, 8 bits).
pub const ATTR_DISPLAY: &str = "prismDisplay";
pub const ATTR_RGB_TO_DISPLAY: &str = "prismRgbToDisplay";
pub const ATTR_GAMUT: &str = "prismGamut";
pub const ATTR_PNG_BITS: &str = "prismPngBits";

/// The film's EXR RGB → the display's linear RGB.
pub fn rgb_to_display(film: &FilmSettings) -> Mat3 {
    film.display_colour.matrix() * film.colour.matrix().inverse()
}

/// A matrix as nine numbers, row by row.
pub fn matrix_text(m: Mat3) -> String {
    let rows = m.transpose().to_cols_array();
    rows.iter()
        .map(|v| format!("{v:e}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The inverse of [`matrix_text`].
pub fn parse_matrix(text: &str) -> Option<Mat3> {
    let v: Vec<f32> = text
        .split_whitespace()
        .map(|t| t.parse().ok())
        .collect::<Option<_>>()?;
    let rows: [f32; 9] = v.try_into().ok()?;
    let m = Mat3::from_cols_array(&rows).transpose();
    m.is_finite().then_some(m)
}

/// How a spectral EXR's R, G, B become the PNG: the matrix to the display's
/// linear RGB and the display settings, from its attributes.
pub fn from_attributes(
    attributes: &std::collections::BTreeMap<String, String>,
    exposure: f32,
) -> Result<(Mat3, DisplaySettings)> {
    let bad = |k: &str| anyhow::anyhow!("bad `{k}` attribute");
    let matrix = match attributes.get(ATTR_RGB_TO_DISPLAY) {
        Some(t) => parse_matrix(t).ok_or_else(|| bad(ATTR_RGB_TO_DISPLAY))?,
        None => Mat3::IDENTITY,
    };
    let display = match attributes.get(ATTR_DISPLAY) {
        Some(t) => Display::from_name(t).ok_or_else(|| bad(ATTR_DISPLAY))?,
        None => Display::Srgb,
    };
    let gamut = match attributes.get(ATTR_GAMUT).map(String::as_str) {
        None | Some("clip") => Gamut::Clip,
        Some("map") => Gamut::Map,
        Some(_) => return Err(bad(ATTR_GAMUT)),
    };
    let bits = match attributes.get(ATTR_PNG_BITS).map(String::as_str) {
        None | Some("8") => 8,
        Some("16") => 16,
        Some(_) => return Err(bad(ATTR_PNG_BITS)),
    };
    Ok((
        matrix,
        DisplaySettings {
            display,
            bits,
            gamut,
            exposure,
            tonemap: Tonemap::Clamp,
        },
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn oklab_round_trips_and_white_is_l_1() {
        let ok = Oklab::for_display(Display::Srgb);
        let white = ok.from_rgb(Vec3::ONE);
        assert!((white - Vec3::X).length() < 1e-3, "{white}");
        for c in [Vec3::new(0.2, 0.5, 0.9), Vec3::new(1.2, -0.1, 0.3)] {
            assert!((ok.to_rgb(ok.from_rgb(c)) - c).length() < 1e-4);
        }
    }

    #[test]
    fn mapped_colours_are_in_gamut_with_their_hue() {
        for display in [Display::Srgb, Display::DisplayP3] {
            let ok = Oklab::for_display(display);
            let mut rng = crate::sampler::Sampler::new(3, 1);
            for _ in 0..2000 {
                let (u, v) = rng.next_2d();
                let w = rng.next_f32();
                let c = Vec3::new(u * 1.6 - 0.3, v * 1.6 - 0.3, w * 1.6 - 0.3);
                let m = ok.map_into_gamut(c);
                assert!(
                    m.min_element() >= 0.0 && m.max_element() <= 1.0,
                    "{c} → {m}"
                );
                let (a, b) = (ok.from_rgb(c), ok.from_rgb(m));
                if a.x > 0.05 && a.x < 0.95 && (a.y * a.y + a.z * a.z).sqrt() > 0.05 {
                    // The result is within JND of a colour with the input's L
                    // and hue: its (a, b) lies within 0.02 of the input's hue
                    // line.
                    let hue = Vec3::new(0.0, a.y, a.z).normalize();
                    let off_line =
                        Vec3::new(0.0, b.y, b.z) - hue * Vec3::new(0.0, b.y, b.z).dot(hue);
                    assert!(
                        off_line.length() < 0.021,
                        "{c} → {m}: {}",
                        off_line.length()
                    );
                }
            }
        }
    }

    /// OKLab hue of saturated colours and spectral lines over 11 stops of
    /// exposure, against the colour's own (where the result has chroma to
    /// speak of). The filmic curve before this change drifted −5° (blue),
    /// +24° (orange), −8.5° (red), +48° (450 nm), −17° (520 nm) and +44°
    /// (600 nm); Reinhard per channel drifts as much.
    #[test]
    fn filmic_holds_hue() {
        use crate::spectrum::cie;
        let ok = Oklab::for_display(Display::Srgb);
        let hue = |c: Vec3| {
            let l = ok.from_rgb(c);
            l.z.atan2(l.y).to_degrees()
        };
        let line = |nm: f32| {
            let rgb = cie::xyz_to_linear_srgb(cie::cmf(nm));
            rgb / rgb.max_element()
        };
        let colours = [
            (Vec3::new(0.05, 0.1, 1.0), true),
            (Vec3::new(1.0, 0.45, 0.05), true),
            (Vec3::new(1.0, 0.05, 0.05), true),
            (line(450.0), false),
            (line(520.0), false),
            (line(600.0), false),
        ];
        for (c, in_gamut) in colours {
            for gamut in [Gamut::Clip, Gamut::Map] {
                // Lines outside the display's gamut keep hue only when mapped.
                if !in_gamut && gamut == Gamut::Clip {
                    continue;
                }
                let settings = DisplaySettings {
                    tonemap: Tonemap::Filmic,
                    gamut,
                    ..Default::default()
                };
                for k in -12..=32 {
                    let out = to_display(c * (k as f32 * 0.25).exp2(), &settings, &ok);
                    let lab = ok.from_rgb(out);
                    if lab.y.hypot(lab.z) < 0.02 {
                        continue;
                    }
                    let d = (hue(out) - hue(c) + 540.0) % 360.0 - 180.0;
                    let limit = if in_gamut { 3.0 } else { 6.0 };
                    assert!(
                        d.abs() < limit,
                        "{c} x 2^{}: hue {d:+.1}° ({gamut:?})",
                        k as f32 / 4.0
                    );
                }
            }
        }
    }

    #[test]
    fn filmic_keeps_grey_rolls_off_and_desaturates_highlights() {
        let ok = Oklab::for_display(Display::Srgb);
        let filmic = |c: Vec3| filmic(c, &ok);
        let g = filmic(Vec3::splat(0.18));
        assert!((g - Vec3::splat(0.18)).abs().max_element() < 2e-3, "{g}");
        let bright = filmic(Vec3::splat(100.0));
        assert!(
            bright.min_element() > 0.97 && bright.max_element() <= 1.0,
            "{bright}"
        );
        // A saturated red: strong at moderate exposure, whiter when far over.
        let sat = |c: Vec3| (c.max_element() - c.min_element()) / c.max_element();
        let red = Vec3::new(1.0, 0.05, 0.05);
        assert!(sat(filmic(red * 64.0)) < 0.5 * sat(filmic(red * 0.5)));
        // Monotonic in exposure.
        let mut last = 0.0;
        for k in -20..20 {
            let y = filmic(Vec3::splat(0.18 * (k as f32 * 0.5).exp2())).y;
            assert!(y >= last);
            last = y;
        }
    }
}
