//! The film: per-pixel sums of the XYZ estimate (and of Y², for error
//! estimates) plus spectral buckets, each pixel with its own sample count so
//! an interrupted render is still an unbiased image.

pub mod colour;
pub mod convergence;
pub mod display;
mod icc;
pub mod output;
pub mod spectral_exr;
mod tile;

pub use tile::{tile_spectrum_bytes, FilmBand, FilmTile};

pub use colour::{ColourSpace, ColourTransform};
pub use display::{Display, DisplaySettings, Gamut, Sampling};
pub use output::Tonemap;

use glam::{DVec3, Vec3};

use crate::spectrum::cie::Observer;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// What the scene file says about the image: its size, the sampling
/// defaults of a render (`RenderOptions::new` takes them), the spectral
/// buckets and how the PNG is made.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmSettings {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel of a render that does not choose its own.
    pub spp: u32,
    /// Seed of a render that does not choose its own.
    pub seed: u64,
    /// How a render spreads its samples, where the scene says; None:
    /// uniformly (`RenderSettings::adaptive`).
    pub sampling: Option<Sampling>,
    pub layout: SpectralLayout,
    /// Write NAME.spectral.exr next to the RGB files.
    pub spectral_output: bool,
    /// Exposure of the PNG in stops (the EXR stays radiometric).
    pub exposure: f32,
    pub tonemap: Tonemap,
    /// The observer whose colour-matching functions the film integrates.
    pub observer: Observer,
    /// The film's XYZ → the EXRs' RGB (colour space, white balance).
    pub colour: ColourTransform,
    /// The film's XYZ → the display's linear RGB, for the PNG.
    pub display_colour: ColourTransform,
    pub display: Display,
    /// Bits per PNG sample: 8 or 16.
    pub png_bits: u8,
    pub gamut: Gamut,
    /// Extra outputs of NAME.exr.
    pub aovs: AovSet,
    /// The white balance as the scene names it (an illuminant, or a
    /// temperature in kelvin), for the files' headers; None without one.
    pub white_balance: Option<String>,
}

/// Which arbitrary output variables NAME.exr carries (`film.aovs`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AovSet {
    pub albedo: bool,
    pub normal: bool,
    pub depth: bool,
    pub sample_count: bool,
}

impl AovSet {
    /// The names `film.aovs` takes.
    pub const NAMES: [&'static str; 4] = ["albedo", "normal", "depth", "sample_count"];

    /// Whether a first-hit ray must be traced per sample.
    pub fn traced(&self) -> bool {
        self.albedo || self.normal || self.depth
    }

    /// Adds the AOV `name`; false for an unknown name.
    pub fn add(&mut self, name: &str) -> bool {
        match name {
            "albedo" => self.albedo = true,
            "normal" => self.normal = true,
            "depth" => self.depth = true,
            "sample_count" => self.sample_count = true,
            _ => return false,
        }
        true
    }
}

/// Per-pixel sums of the traced AOVs: albedo XYZ, normal, depth.
pub type AovSums = [f64; 7];

impl FilmSettings {
    /// A film of `width` × `height` with every other setting at its default.
    pub fn new(width: u32, height: u32) -> Self {
        Self {
            width,
            height,
            spp: 64,
            seed: 0,
            sampling: None,
            layout: SpectralLayout {
                min: 380.0,
                max: 780.0,
                count: 40,
            },
            spectral_output: true,
            exposure: 0.0,
            tonemap: Tonemap::Clamp,
            observer: Observer::Cie1931,
            colour: ColourTransform::default(),
            display_colour: ColourTransform::default(),
            display: Display::Srgb,
            png_bits: 8,
            gamut: Gamut::Clip,
            aovs: AovSet::default(),
            white_balance: None,
        }
    }

    /// How the PNG is made.
    pub fn display_settings(&self) -> DisplaySettings {
        DisplaySettings {
            display: self.display,
            bits: self.png_bits,
            gamut: self.gamut,
            exposure: self.exposure,
            tonemap: self.tonemap,
        }
    }

    /// The buckets a render keeps: the layout where the spectral EXR is
    /// written, none otherwise (summing them costs memory traffic, and a
    /// 40-bucket 512² film 40 MiB).
    pub fn kept_layout(&self) -> SpectralLayout {
        if self.spectral_output {
            self.layout
        } else {
            self.layout.without_buckets()
        }
    }
}

/// Equal-width wavelength buckets over [min, max] nm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpectralLayout {
    pub min: f32,
    pub max: f32,
    pub count: u32,
}

impl SpectralLayout {
    pub fn width(&self) -> f32 {
        (self.max - self.min) / self.count as f32
    }

    /// Centre wavelength of bucket `i`.
    pub fn centre(&self, i: u32) -> f32 {
        self.min + (i as f32 + 0.5) * self.width()
    }

    /// The same range with no buckets: a film that keeps no spectrum (its
    /// render writes no spectral EXR).
    pub fn without_buckets(self) -> Self {
        Self { count: 0, ..self }
    }

    pub fn bucket(&self, lambda: f32) -> Option<usize> {
        if self.count == 0 || !(lambda >= self.min && lambda < self.max) {
            return None;
        }
        Some((((lambda - self.min) / self.width()) as usize).min(self.count as usize - 1))
    }

    /// One sample's spectral contributions, (bucket, radiance per nm), for
    /// its live wavelengths (terminated ones, pdf 0, contribute nothing).
    fn contributions(
        self,
        l: SampledSpectrum,
        wl: &SampledWavelengths,
    ) -> impl Iterator<Item = (u32, f32)> + '_ {
        let per_nm = 1.0 / (4.0 * self.width());
        (0..4).filter_map(move |k| {
            if !(wl.pdf[k] > 0.0) {
                return None;
            }
            let b = self.bucket(wl.lambda[k])?;
            Some((b as u32, l[k] / wl.pdf[k] * per_nm))
        })
    }
}

/// One sample's arbitrary output variables (AOVs): what its camera ray
/// first met.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AovSample {
    /// XYZ of the albedo under D65 (zero where the ray escapes).
    pub albedo: Vec3,
    /// Unit shading normal facing the ray (zero where it escapes).
    pub normal: Vec3,
    pub depth: f32,
}

/// Running sums for one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelSums {
    pub xyz: DVec3,
    pub y_squared: f64,
    pub samples: u64,
    /// Rays traced for its samples: the cost adaptive sampling weighs.
    pub rays: u64,
}

#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub layout: SpectralLayout,
    pixels: Vec<PixelSums>,
    buckets: Vec<f32>,
    /// AOV sums per pixel (empty when none is traced).
    aovs: Vec<AovSums>,
}

impl Film {
    pub fn new(width: u32, height: u32, layout: SpectralLayout) -> Self {
        let n = (width * height) as usize;
        let mut buckets = vec![0.0; n * layout.count as usize];
        crate::geometry::huge_pages::advise(&mut buckets);
        Self {
            width,
            height,
            layout,
            pixels: vec![PixelSums::default(); n],
            buckets,
            aovs: Vec::new(),
        }
    }

    /// The same film recording AOVs too.
    pub fn with_aovs(self) -> Self {
        let n = self.pixels.len();
        Self {
            aovs: vec![[0.0; 7]; n],
            ..self
        }
    }

    /// Mean AOVs of a pixel (albedo XYZ, unit normal, depth); None when the
    /// film records none.
    pub fn aov(&self, x: u32, y: u32) -> Option<(Vec3, Vec3, f32)> {
        let sums = self.aovs.get((y * self.width + x) as usize)?;
        let n = self.sums(x, y).samples.max(1) as f64;
        let v = sums.map(|s| (s / n) as f32);
        let normal = Vec3::new(v[3], v[4], v[5]).normalize_or_zero();
        Some((Vec3::new(v[0], v[1], v[2]), normal, v[6]))
    }

    /// A film of one spectral bucket whose pixels hold `sums(x, y)` (for
    /// tests of what reads the sums).
    #[cfg(test)]
    pub(crate) fn from_pixel_sums(w: u32, h: u32, sums: impl Fn(u32, u32) -> PixelSums) -> Film {
        let layout = SpectralLayout {
            min: 380.0,
            max: 780.0,
            count: 1,
        };
        let mut tile = FilmTile::new(0, 0, w, h, w, layout);
        for (i, p) in tile.pixels.iter_mut().enumerate() {
            *p = sums(i as u32 % w, i as u32 / w);
        }
        let mut film = Film::new(w, h, layout);
        film.add_tile(&tile);
        film
    }

    pub fn add_tile(&mut self, tile: &FilmTile) {
        let n = self.layout.count as usize;
        // The whole film as one band.
        for band in self.bands(0, self.height) {
            band.into_inner().expect("not shared").add_tile(tile);
        }
        for &(i, xyz) in &tile.splat_xyz {
            self.pixels[i as usize].xyz += xyz.as_dvec3();
        }
        for &(i, bucket, v) in &tile.splat_spectral {
            self.buckets[i as usize * n + bucket as usize] += v;
        }
    }

    /// The rows from `y0` on, in bands of `rows` (the last may be
    /// shorter): tiles of different bands touch different pixels, so
    /// threads can add them at once, each band behind its own lock.
    pub fn bands(&mut self, y0: u32, rows: u32) -> Vec<std::sync::Mutex<FilmBand<'_>>> {
        let (w, n) = (self.width as usize, self.layout.count as usize);
        let start = y0.min(self.height) as usize * w;
        let step = rows.max(1) as usize * w;
        let has_aovs = !self.aovs.is_empty();
        let aov_start = start.min(self.aovs.len());
        let mut aovs = self.aovs[aov_start..].chunks_mut(step);
        // A film without a spectrum has no buckets to share out.
        let mut buckets = self.buckets[start * n..].chunks_mut((step * n).max(1));
        self.pixels[start..]
            .chunks_mut(step)
            .enumerate()
            .map(|(k, pixels)| {
                std::sync::Mutex::new(FilmBand {
                    y0: y0 + (k * rows as usize) as u32,
                    width: self.width,
                    count: self.layout.count,
                    pixels,
                    buckets: if n > 0 {
                        buckets.next().expect("one bucket chunk per band")
                    } else {
                        &mut []
                    },
                    aovs: if has_aovs {
                        aovs.next().expect("one AOV chunk per band")
                    } else {
                        &mut []
                    },
                })
            })
            .collect()
    }

    pub fn sums(&self, x: u32, y: u32) -> &PixelSums {
        &self.pixels[(y * self.width + x) as usize]
    }

    /// Mean XYZ of a pixel (zero if it has no samples).
    pub fn xyz(&self, x: u32, y: u32) -> Vec3 {
        let p = self.sums(x, y);
        if p.samples == 0 {
            return Vec3::ZERO;
        }
        (p.xyz / p.samples as f64).as_vec3()
    }

    /// Linear sRGB (CIE 1931 XYZ, D65) of every pixel, row-major from the
    /// top left.
    pub fn linear_srgb(&self) -> Vec<Vec3> {
        self.rgb(&ColourTransform::default())
    }

    /// RGB of every pixel by `transform`, row-major from the top left.
    pub fn rgb(&self, transform: &ColourTransform) -> Vec<Vec3> {
        (0..self.height)
            .flat_map(|y| (0..self.width).map(move |x| (x, y)))
            .map(|(x, y)| transform.rgb(self.xyz(x, y)))
            .collect()
    }

    /// Mean XYZ of every pixel, row-major from the top left, three floats
    /// a pixel (an H×W×3 array).
    pub fn xyz_image(&self) -> Vec<f32> {
        let mut out = Vec::with_capacity(self.pixels.len() * 3);
        for y in 0..self.height {
            for x in 0..self.width {
                out.extend_from_slice(&self.xyz(x, y).to_array());
            }
        }
        out
    }

    /// Mean spectral radiance (per nm) of every bucket of every pixel,
    /// row-major from the top left, buckets innermost (an H×W×B array).
    pub fn spectral_cube(&self) -> Vec<f32> {
        let n = self.layout.count as usize;
        let mut out = Vec::with_capacity(self.buckets.len());
        for (i, p) in self.pixels.iter().enumerate() {
            let s = p.samples.max(1) as f32;
            out.extend(self.buckets[i * n..(i + 1) * n].iter().map(|v| v / s));
        }
        out
    }

    /// Mean spectral radiance (per nm) of each bucket of a pixel.
    pub fn spectrum(&self, x: u32, y: u32) -> Vec<f32> {
        let n = self.layout.count as usize;
        let i = (y * self.width + x) as usize;
        let s = self.pixels[i].samples.max(1) as f32;
        self.buckets[i * n..(i + 1) * n]
            .iter()
            .map(|v| v / s)
            .collect()
    }

    /// Mean luminance Y of a pixel and the variance of that mean, from the
    /// sample variance of Y.
    pub fn luminance_and_variance(&self, x: u32, y: u32) -> (f64, f64) {
        let p = self.sums(x, y);
        let n = p.samples as f64;
        if n < 2.0 {
            return (p.xyz.y / n.max(1.0), f64::INFINITY);
        }
        let mean = p.xyz.y / n;
        let var = ((p.y_squared / n - mean * mean) * n / (n - 1.0)).max(0.0);
        (mean, var / n)
    }

    /// Estimated relative MSE of the region [x0, x1) × [y0, y1): the mean
    /// over its pixels of the variance of their mean luminance (from the
    /// samples' spread) over (mean² + 0.01), the ε of `prism bench`'s
    /// relMSE. Pixels with fewer than 2 samples count as infinite error.
    pub fn estimated_rel_mse(&self, region: [u32; 4]) -> f64 {
        use rayon::prelude::*;
        let [x0, y0, x1, y1] = region;
        // Rows in parallel, their sums added in row order: the same
        // number for any thread count.
        let rows: Vec<f64> = (y0..y1)
            .into_par_iter()
            .map(|y| {
                (x0..x1)
                    .map(|x| {
                        let (m, var) = self.luminance_and_variance(x, y);
                        var / (m * m + convergence::REL_MSE_EPSILON)
                    })
                    .sum()
            })
            .collect();
        rows.iter().sum::<f64>() / ((x1 - x0) as f64 * (y1 - y0) as f64).max(1.0)
    }

    pub fn total_samples(&self) -> u64 {
        self.pixels.iter().map(|p| p.samples).sum()
    }
}

/// An AOV pixel's sums.
pub const AOV_BYTES: u64 = std::mem::size_of::<AovSums>() as u64;

/// Bytes a film of `pixels` holds with `buckets` spectral sums a pixel
/// (none where no spectral EXR is written), and what writing it adds: the
/// spectral planes (4 bytes a bucket), the sample counts, R, G, B and the
/// PNG's display values (measured: 1.55 GiB peak for 2048², 40 buckets, with a
/// film of 0.85 GiB).
pub fn film_bytes(pixels: u64, buckets: u32, spectral: bool, aovs: bool) -> (u64, u64) {
    let per_pixel = std::mem::size_of::<PixelSums>() as u64
        + 4 * buckets as u64
        + if aovs { AOV_BYTES } else { 0 };
    let writing = if spectral { 4 * buckets as u64 + 4 } else { 0 } + 12 + 12 + 8;
    (
        pixels.saturating_mul(per_pixel),
        pixels.saturating_mul(writing),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buckets_cover_the_range() {
        let l = SpectralLayout {
            min: 380.0,
            max: 780.0,
            count: 40,
        };
        assert_eq!(l.width(), 10.0);
        assert_eq!(l.centre(0), 385.0);
        assert_eq!(l.bucket(380.0), Some(0));
        assert_eq!(l.bucket(779.99), Some(39));
        assert_eq!(l.bucket(780.0), None);
        assert_eq!(l.bucket(379.0), None);
    }

    #[test]
    fn terminated_wavelengths_do_not_reach_the_film() {
        let layout = SpectralLayout {
            min: 360.0,
            max: 830.0,
            count: 47,
        };
        let mut tile = FilmTile::new(0, 0, 1, 1, 1, layout);
        let mut wl = SampledWavelengths::sample_visible(0.4);
        wl.terminate_secondary();
        tile.add_sample(0, 0, SampledSpectrum::ONE, &wl);
        let mut film = Film::new(1, 1, layout);
        film.add_tile(&tile);
        let spectrum = film.spectrum(0, 0);
        assert_eq!(spectrum.iter().filter(|&&v| v != 0.0).count(), 1);
        let b = layout.bucket(wl.lambda.x).unwrap();
        assert!((spectrum[b] - 1.0 / wl.pdf.x / 4.0 / 10.0).abs() < 1e-6);
    }

    /// Tiles land in bands at their place, buckets with their pixels; a
    /// film without buckets has the same colours and no spectrum.
    #[test]
    fn tiles_add_their_pixels_and_buckets_in_place() {
        let layout = SpectralLayout {
            min: 360.0,
            max: 830.0,
            count: 47,
        };
        let (w, h) = (7, 5);
        let sample = |x: u32, y: u32| {
            let wl = SampledWavelengths::sample_visible(((x * 13 + y * 7) % 97) as f32 / 97.0);
            (SampledSpectrum::splat(1.0 + x as f32 + 10.0 * y as f32), wl)
        };
        let render = |layout: SpectralLayout, samples: u32| {
            let mut film = Film::new(w, h, layout);
            let bands = film.bands(0, 2);
            // Tiles of 3 × 2 (the last ones cut), added out of order.
            for (x0, y0) in [
                (3, 2),
                (0, 0),
                (6, 4),
                (0, 2),
                (3, 0),
                (6, 0),
                (0, 4),
                (3, 4),
                (6, 2),
            ] {
                let (tw, th) = (3.min(w - x0), 2.min(h - y0));
                let mut tile = FilmTile::new(x0, y0, tw, th, w, layout).for_samples(samples);
                for y in y0..y0 + th {
                    for x in x0..x0 + tw {
                        let (l, wl) = sample(x, y);
                        tile.add_sample(x, y, l, &wl);
                        tile.add_sample(x, y, l * 0.5, &wl);
                    }
                }
                bands[(y0 / 2) as usize].lock().unwrap().add_tile(&tile);
            }
            drop(bands);
            film
        };
        // Dense sums (47 buckets for 2 samples), entries (47 for none), none.
        let (with, entries) = (render(layout, 2), render(layout, 0));
        assert!(FilmTile::new(0, 0, 1, 1, 1, layout)
            .for_samples(0)
            .buckets
            .is_empty());
        let without = render(layout.without_buckets(), 2);
        for y in 0..h {
            for x in 0..w {
                let (l, wl) = sample(x, y);
                assert_eq!(with.sums(x, y).samples, 2);
                assert_eq!(with.sums(x, y), without.sums(x, y));
                assert!(without.spectrum(x, y).is_empty());
                let mut expected = vec![0.0f32; 47];
                for (b, v) in layout.contributions(l * 1.5, &wl) {
                    expected[b as usize] += v / 2.0;
                }
                for film in [&with, &entries] {
                    let got = film.spectrum(x, y);
                    for (g, e) in got.iter().zip(&expected) {
                        assert!(
                            (g - e).abs() <= 1e-6 * e.abs(),
                            "({x}, {y}): {got:?} {expected:?}"
                        );
                    }
                }
            }
        }
    }
}
