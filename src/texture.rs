//! Image textures: decoded once at load, shared by every material that uses
//! them, looked up with bilinear (or nearest) filtering and a wrap mode.
//!
//! Colour textures are sRGB-decoded and every texel is upsampled to a
//! reflectance spectrum at load (Jakob–Hanika coefficients per texel), so a
//! lookup blends four spectra: filtering happens on spectra, as it should,
//! not on RGB that is upsampled afterwards. Data textures (roughness,
//! metalness, normals) stay linear numbers.

use std::sync::Arc;

use glam::{Vec2, Vec3, Vec4};

use crate::memory;
use crate::spectrum::cie::srgb_decode;
use crate::spectrum::rgb2spec::{self, normalised_wavelengths, SigmoidPolynomial};
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// What to do with texture coordinates outside [0, 1].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Wrap {
    Repeat,
    Clamp,
    Mirror,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Filter {
    Bilinear,
    Nearest,
}

/// How the texel values are to be read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Encoding {
    /// sRGB-encoded colour, used as a reflectance (upsampled per texel).
    SrgbColour,
    /// Linear numbers (metalness, roughness, normal vectors).
    Linear,
    /// The alpha channel alone (1 where the image has none): glTF coverage.
    Alpha,
    /// The alpha channel, or the grey level of an image without one: an
    /// MTL `map_d` matte.
    Matte,
}

#[derive(Clone, Debug, PartialEq)]
enum Texels {
    /// Per texel: sigmoid coefficients c0, c1, c2 and the scale.
    Spectral(Vec<[f32; 4]>),
    /// Per texel: RGBA as linear numbers.
    Linear(Vec<Vec4>),
    /// Per texel: one number (coverage).
    Scalar(Vec<f32>),
}

/// A decoded image with its sampling state.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    width: u32,
    height: u32,
    texels: Texels,
    pub wrap: [Wrap; 2],
    pub filter: Filter,
    /// Mean linear RGB over the image (for light power estimates).
    mean_rgb: Vec3,
}

impl Texture {
    /// Decodes an image file's bytes (PNG, JPEG, …; the format is guessed
    /// from the content), within the memory budget.
    pub fn decode(bytes: &[u8], encoding: Encoding) -> Result<Texture, String> {
        let held = match encoding {
            Encoding::SrgbColour | Encoding::Linear => 16,
            Encoding::Alpha | Encoding::Matte => 4,
        };
        // The RGBA float copy below is 16 bytes a texel.
        let image = decode_image(bytes, 16, held)?;
        let (width, height) = (image.width(), image.height());
        // Values scaled to [0, 1] per channel, no colour conversion yet.
        let mut rgba = image.to_rgba32f().into_raw();
        if encoding == Encoding::Matte && !image.color().has_alpha() {
            for p in rgba.chunks_exact_mut(4) {
                p[3] = (p[0] + p[1] + p[2]) / 3.0;
            }
        }
        drop(image);
        Ok(Self::from_rgba(width, height, &rgba, encoding))
    }

    /// Builds a texture from RGBA values in [0, 1], row by row from the top
    /// (texture coordinate v = 0 is the top row, as in glTF and images).
    pub fn from_rgba(width: u32, height: u32, rgba: &[f32], encoding: Encoding) -> Texture {
        // In usize: a 32768² texture's 4 channels overflow u32.
        assert_eq!(rgba.len(), width as usize * height as usize * 4);
        let pixels = rgba.chunks_exact(4).map(Vec4::from_slice);
        let (texels, mean_rgb) = match encoding {
            Encoding::SrgbColour => {
                let mut sum = Vec3::ZERO;
                let coeffs = pixels
                    .map(|p| {
                        let rgb = Vec3::new(srgb_decode(p.x), srgb_decode(p.y), srgb_decode(p.z));
                        sum += rgb;
                        let (s, scale) = rgb2spec::albedo(rgb);
                        [s.c[0], s.c[1], s.c[2], scale]
                    })
                    .collect();
                (Texels::Spectral(coeffs), sum)
            }
            Encoding::Linear => {
                let values: Vec<Vec4> = pixels.collect();
                let sum = values.iter().map(|v| v.truncate()).sum();
                (Texels::Linear(values), sum)
            }
            Encoding::Alpha | Encoding::Matte => {
                let values: Vec<f32> = pixels.map(|p| p.w).collect();
                let sum = Vec3::splat(values.iter().sum());
                (Texels::Scalar(values), sum)
            }
        };
        Texture {
            width,
            height,
            texels,
            wrap: [Wrap::Repeat; 2],
            filter: Filter::Bilinear,
            mean_rgb: mean_rgb / (width as f64 * height as f64) as f32,
        }
    }

    pub fn mean_rgb(&self) -> Vec3 {
        self.mean_rgb
    }

    /// The texels around `uv` and their bilinear weights.
    fn footprint(&self, uv: Vec2) -> [(usize, f32); 4] {
        let (w, h) = (self.width as i64, self.height as i64);
        // Texel centres sit at half-integers.
        // Beyond ±2²⁴ texels single precision has no fraction left; the
        // bound keeps the integer arithmetic in range, and a NaN from a
        // broken transform reads texel 0 instead of poisoning the path.
        let bound = |v: f32| {
            if v.is_finite() {
                v.clamp(-16_777_216.0, 16_777_216.0)
            } else {
                0.0
            }
        };
        let x = bound(uv.x * w as f32 - 0.5);
        let y = bound(uv.y * h as f32 - 0.5);
        if self.filter == Filter::Nearest {
            let i = wrap(x.round() as i64, w, self.wrap[0]);
            let j = wrap(y.round() as i64, h, self.wrap[1]);
            return [((j * w + i) as usize, 1.0), (0, 0.0), (0, 0.0), (0, 0.0)];
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (i0, j0) = (x0 as i64, y0 as i64);
        let (i0, i1) = wrap_pair(i0, w, self.wrap[0]);
        let (j0, j1) = wrap_pair(j0, h, self.wrap[1]);
        let at = |i: i64, j: i64| (j * w + i) as usize;
        [
            (at(i0, j0), (1.0 - fx) * (1.0 - fy)),
            (at(i1, j0), fx * (1.0 - fy)),
            (at(i0, j1), (1.0 - fx) * fy),
            (at(i1, j1), fx * fy),
        ]
    }

    /// The reflectance at `uv` for the path's wavelengths (colour textures),
    /// or the red channel as a constant spectrum (data textures).
    pub fn spectrum(&self, uv: Vec2, wl: &SampledWavelengths) -> SampledSpectrum {
        let texels = match &self.texels {
            Texels::Spectral(t) => t,
            Texels::Linear(_) | Texels::Scalar(_) => {
                return SampledSpectrum::splat(self.linear(uv).x)
            }
        };
        let t = normalised_wavelengths(wl.lambda);
        let mut s = SampledSpectrum::ZERO;
        for (index, weight) in self.footprint(uv) {
            if weight == 0.0 {
                continue;
            }
            let [c0, c1, c2, scale] = texels[index];
            s += SigmoidPolynomial { c: [c0, c1, c2] }.at(t) * (weight * scale);
        }
        s
    }

    /// The filtered RGBA value at `uv` (data textures), or the texel colour
    /// as linear RGB with alpha 1 would be meaningless for colour textures:
    /// those return their mean spectrum value in every channel.
    pub fn linear(&self, uv: Vec2) -> Vec4 {
        match &self.texels {
            Texels::Linear(t) => self
                .footprint(uv)
                .iter()
                .map(|&(i, w)| t[i] * w)
                .fold(Vec4::ZERO, |a, b| a + b),
            Texels::Scalar(t) => Vec4::splat(
                self.footprint(uv)
                    .iter()
                    .map(|&(i, w)| t[i] * w)
                    .sum::<f32>(),
            ),
            Texels::Spectral(_) => Vec4::splat(self.mean_rgb.element_sum() / 3.0),
        }
    }
}

/// Texels i and i + 1 wrapped: under Repeat from one division, not two
/// (a 64-bit division is the slowest instruction of a texture lookup).
fn wrap_pair(i: i64, n: i64, mode: Wrap) -> (i64, i64) {
    if mode == Wrap::Repeat {
        let first = i.rem_euclid(n);
        let next = if first + 1 == n { 0 } else { first + 1 };
        return (first, next);
    }
    (wrap(i, n, mode), wrap(i + 1, n, mode))
}

/// Texel index `i` wrapped into [0, n).
fn wrap(i: i64, n: i64, mode: Wrap) -> i64 {
    match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Mirror => {
            let period = i.rem_euclid(2 * n);
            if period < n {
                period
            } else {
                2 * n - 1 - period
            }
        }
    }
}

/// A texture as a material uses it: which texture, and the affine map from
/// the mesh's texture coordinates to the texture's (KHR_texture_transform).
#[derive(Clone, Debug, PartialEq)]
pub struct TextureRef {
    pub texture: Arc<Texture>,
    /// uv' = [m0 m1 m2; m3 m4 m5] · (u, v, 1).
    pub transform: Option<[f32; 6]>,
}

impl TextureRef {
    pub fn new(texture: Arc<Texture>) -> Self {
        Self {
            texture,
            transform: None,
        }
    }

    pub fn uv(&self, uv: Vec2) -> Vec2 {
        match self.transform {
            None => uv,
            Some(m) => Vec2::new(
                m[0] * uv.x + m[1] * uv.y + m[2],
                m[3] * uv.x + m[4] * uv.y + m[5],
            ),
        }
    }

    pub fn spectrum(&self, uv: Vec2, wl: &SampledWavelengths) -> SampledSpectrum {
        self.texture.spectrum(self.uv(uv), wl)
    }

    pub fn linear(&self, uv: Vec2) -> Vec4 {
        self.texture.linear(self.uv(uv))
    }
}

/// Decodes an image (format guessed from the content: PNG, JPEG, Radiance
/// HDR, BMP, or else TGA) after checking its
/// declared size against the memory budget: the decoder's buffer (counted
/// three times over for JPEG, whose progressive decoder keeps its
/// coefficients), `scratch` bytes a texel that the caller uses
/// briefly, and `held` bytes a texel that it keeps. A 64 KB file declaring
/// 23000×23000 texels is refused here, before anything is allocated.
pub fn decode_image(bytes: &[u8], scratch: u64, held: u64) -> Result<image::DynamicImage, String> {
    use image::ImageDecoder;
    let cannot = |e: image::ImageError| format!("cannot decode: {e}");
    let mut reader = image::ImageReader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| format!("cannot decode: {e}"))?;
    if reader.format().is_none() {
        // TGA has no signature: bytes that no signature matches are tried
        // as TGA (whose header check refuses most else).
        reader.set_format(image::ImageFormat::Tga);
    }
    // A progressive JPEG's decoder keeps working copies (its coefficients)
    // beside the image: its buffer counts three times over.
    let copies = if reader.format() == Some(image::ImageFormat::Jpeg) {
        3
    } else {
        1
    };
    let mut limits = image::Limits::no_limits();
    limits.max_alloc = Some(memory::limit().0);
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(cannot)?;
    let (width, height) = decoder.dimensions();
    if width == 0 || height == 0 {
        return Err("the image is empty".into());
    }
    let texels = width as u64 * height as u64;
    let what = format!("the decoded image ({width}x{height} texels)");
    let decoded = decoder.total_bytes();
    memory::check(
        &what,
        decoded
            .saturating_mul(copies)
            .saturating_add(texels.saturating_mul(scratch + held)),
    )?;
    memory::hold(&what, texels * held)?;
    // A decoder that panics on a forged file (an allocation the image
    // crate does not expect to fail) is an error naming the file, not the
    // end of the process.
    without_panicking(|| image::DynamicImage::from_decoder(decoder))
        .map_err(|e| format!("cannot decode: the decoder failed ({e})"))?
        .map_err(cannot)
}

/// Runs `f`, turning a panic into an error (with the panic's message, and
/// without printing it: the caller reports it).
pub fn without_panicking<T>(f: impl FnOnce() -> T) -> Result<T, String> {
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    std::panic::set_hook(hook);
    result.map_err(|payload| {
        payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic".into())
    })
}

/// Whether JPEG bytes stop before their end-of-image marker: a truncated
/// file, which the decoder fills in silently. Entropy-coded data never
/// holds FF D9 (a data FF is followed by 00), so the marker must follow
/// the last start-of-scan; an EXIF thumbnail's own marker comes before it.
pub fn jpeg_is_truncated(bytes: &[u8]) -> bool {
    if !bytes.starts_with(&[0xFF, 0xD8]) {
        return false;
    }
    let last_scan = bytes.windows(2).rposition(|w| w == [0xFF, 0xDA]);
    match last_scan {
        Some(at) => !bytes[at..].windows(2).any(|w| w == [0xFF, 0xD9]),
        None => true,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wl() -> SampledWavelengths {
        SampledWavelengths::sample_visible(0.3)
    }

    #[test]
    fn wrap_modes() {
        assert_eq!(wrap(-1, 4, Wrap::Repeat), 3);
        assert_eq!(wrap(5, 4, Wrap::Repeat), 1);
        assert_eq!(wrap(-1, 4, Wrap::Clamp), 0);
        assert_eq!(wrap(9, 4, Wrap::Clamp), 3);
        assert_eq!(wrap(4, 4, Wrap::Mirror), 3);
        assert_eq!(wrap(-1, 4, Wrap::Mirror), 0);
        assert_eq!(wrap(8, 4, Wrap::Mirror), 0);
    }

    #[test]
    fn wrapped_pairs_are_the_two_wrapped_texels() {
        for mode in [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror] {
            for n in [1, 2, 5] {
                for i in -12..12 {
                    let pair = wrap_pair(i, n, mode);
                    assert_eq!(
                        pair,
                        (wrap(i, n, mode), wrap(i + 1, n, mode)),
                        "{mode:?} {n} {i}"
                    );
                }
            }
        }
    }

    #[test]
    fn bilinear_blends_neighbouring_texels() {
        // Two texels side by side: 0 and 1.
        let rgba = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        let mut t = Texture::from_rgba(2, 1, &rgba, Encoding::Linear);
        t.wrap = [Wrap::Clamp; 2];
        assert_eq!(t.linear(Vec2::new(0.25, 0.5)).x, 0.0);
        assert_eq!(t.linear(Vec2::new(0.75, 0.5)).x, 1.0);
        assert!((t.linear(Vec2::new(0.5, 0.5)).x - 0.5).abs() < 1e-6);
        assert!((t.linear(Vec2::new(0.375, 0.5)).x - 0.25).abs() < 1e-6);
        t.filter = Filter::Nearest;
        assert_eq!(t.linear(Vec2::new(0.45, 0.5)).x, 0.0);
        assert_eq!(t.linear(Vec2::new(0.55, 0.5)).x, 1.0);
    }

    #[test]
    fn extreme_coordinates_read_a_texel() {
        // Far out, infinite or NaN coordinates (from broken files or
        // transforms) give a finite texel, never an integer overflow.
        let rgba = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 1.0];
        for wrap in [Wrap::Repeat, Wrap::Clamp, Wrap::Mirror] {
            for filter in [Filter::Bilinear, Filter::Nearest] {
                let mut t = Texture::from_rgba(2, 1, &rgba, Encoding::Linear);
                t.wrap = [wrap; 2];
                t.filter = filter;
                for v in [
                    1e30,
                    -1e30,
                    f32::INFINITY,
                    f32::NEG_INFINITY,
                    f32::NAN,
                    9.2e18,
                ] {
                    let x = t.linear(Vec2::new(v, -v)).x;
                    assert!((0.0..=1.0).contains(&x), "{v} {wrap:?} {filter:?}: {x}");
                }
            }
        }
    }

    #[test]
    fn colour_texels_are_srgb_decoded_reflectances() {
        // sRGB 0.5 grey is linear 0.214: the spectrum must be flat at that value.
        let t = Texture::from_rgba(1, 1, &[0.5, 0.5, 0.5, 1.0], Encoding::SrgbColour);
        let s = t.spectrum(Vec2::new(0.3, 0.9), &wl());
        for v in s.to_array() {
            assert!((v - srgb_decode(0.5)).abs() < 0.01, "{v}");
        }
        // A red texel reflects long wavelengths more than short ones.
        let red = Texture::from_rgba(1, 1, &[1.0, 0.0, 0.0, 1.0], Encoding::SrgbColour);
        let mut w = wl();
        w.lambda = Vec4::new(450.0, 500.0, 620.0, 680.0);
        let s = red.spectrum(Vec2::ZERO, &w);
        assert!(s.x < 0.1 && s.w > 0.8, "{s:?}");
    }

    #[test]
    fn texture_transform_maps_coordinates() {
        let t = Arc::new(Texture::from_rgba(1, 1, &[1.0; 4], Encoding::Linear));
        let r = TextureRef {
            texture: t,
            transform: Some([2.0, 0.0, 0.5, 0.0, 3.0, 0.25]),
        };
        assert_eq!(r.uv(Vec2::new(1.0, 1.0)), Vec2::new(2.5, 3.25));
    }
}
