//! A tile of the film being rendered by one task, and the band of film
//! rows a finished tile adds itself to.

use glam::Vec3;

use super::{AovSample, AovSums, PixelSums, SpectralLayout};
use crate::spectrum::cie::{ColourMatching, Observer};
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// Tiles sum their spectra densely up to this many buckets per sample a
/// pixel takes in the pass (Cornell 256², 16 spp, 2 threads: 40 buckets
/// dense 6% faster than entries even at one sample a pass; 4096 buckets
/// dense 55% slower at up to 16).
const DENSE_BUCKETS_PER_SAMPLE: u64 = 64;

fn dense_spectrum(buckets: u32, samples: u32) -> bool {
    buckets as u64 <= DENSE_BUCKETS_PER_SAMPLE * samples as u64
}

/// Bytes of spectral sums a tile holds per pixel for `samples` samples a
/// pixel: its dense buckets, or up to four entries of 12 bytes a sample.
pub fn tile_spectrum_bytes(buckets: u32, samples: u32) -> u64 {
    if buckets == 0 {
        0
    } else if dense_spectrum(buckets, samples) {
        4 * buckets as u64
    } else {
        48 * samples as u64
    }
}

/// A rectangle of the film being rendered by one task.
pub struct FilmTile {
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub pixels: Vec<PixelSums>,
    /// Dense spectral sums of the tile's pixels, `layout.count` buckets a
    /// pixel, where there are few buckets for the samples (`sparse`
    /// otherwise; neither when the film keeps no spectrum). 16 × 16 pixels
    /// × 40 buckets is 40 KiB: a sample adds in cache and the film takes
    /// the tile in one sweep, where a list of entries replayed into the
    /// film cost 8% of a render's CPU time.
    pub buckets: Vec<f32>,
    /// Spectral contributions (pixel in the tile, bucket, radiance per nm)
    /// in sample order, where buckets are many for the samples a pass
    /// takes (4096 buckets: 4 MiB a tile to clear and sweep for a few
    /// samples a pixel).
    pub sparse: Vec<(u32, u32, f32)>,
    /// Contributions to any pixel of the film (splats), by film pixel
    /// index, in the order they were made: XYZ, and spectral entries
    /// (pixel, bucket, radiance per nm).
    pub splat_xyz: Vec<(u32, Vec3)>,
    pub splat_spectral: Vec<(u32, u32, f32)>,
    /// Splats dropped because they were not finite.
    pub non_finite_splats: u64,
    film_width: u32,
    layout: SpectralLayout,
    cmfs: &'static ColourMatching,
    /// AOV sums per pixel of the tile (empty when none is traced).
    pub aovs: Vec<AovSums>,
}

impl FilmTile {
    /// A `width` × `height` tile at (x0, y0) of a film `film_width` wide.
    pub fn new(
        x0: u32,
        y0: u32,
        width: u32,
        height: u32,
        film_width: u32,
        layout: SpectralLayout,
    ) -> Self {
        let n = (width * height) as usize;
        Self {
            x0,
            y0,
            width,
            pixels: vec![PixelSums::default(); n],
            buckets: Vec::new(),
            sparse: Vec::new(),
            splat_xyz: Vec::new(),
            splat_spectral: Vec::new(),
            non_finite_splats: 0,
            film_width,
            layout,
            cmfs: Observer::Cie1931.cmfs(),
            aovs: Vec::new(),
        }
    }

    /// The same tile recording AOVs too.
    pub fn with_aovs(self) -> Self {
        let n = self.pixels.len();
        Self {
            aovs: vec![[0.0; 7]; n],
            ..self
        }
    }

    /// The same tile for `samples` samples a pixel: its spectral sums
    /// dense where the buckets are at most `DENSE_BUCKETS_PER_SAMPLE` per
    /// sample, else (and in a tile made without this) a list of entries.
    pub fn for_samples(self, samples: u32) -> Self {
        let count = self.layout.count;
        if count == 0 || !dense_spectrum(count, samples) {
            return self;
        }
        Self {
            buckets: vec![0.0; self.pixels.len() * count as usize],
            ..self
        }
    }

    /// Adds one sample's AOVs to the pixel at film position (x, y).
    pub fn add_aov(&mut self, x: u32, y: u32, a: &AovSample) {
        let i = ((y - self.y0) * self.width + (x - self.x0)) as usize;
        let v = [
            a.albedo.x, a.albedo.y, a.albedo.z, a.normal.x, a.normal.y, a.normal.z, a.depth,
        ];
        for (sum, v) in self.aovs[i].iter_mut().zip(v) {
            if v.is_finite() {
                *sum += v as f64;
            }
        }
    }

    /// The same tile integrating XYZ with `observer`.
    pub fn with_observer(self, observer: Observer) -> Self {
        Self {
            cmfs: observer.cmfs(),
            ..self
        }
    }

    /// Adds radiance `l` to the film pixel (x, y), which may lie outside
    /// the tile, without counting a sample there: the pixel's value is its
    /// sums over its own sample count, so a splatting integrator's splats
    /// are already divided by nothing else.
    pub fn add_splat(&mut self, x: u32, y: u32, l: SampledSpectrum, wl: &SampledWavelengths) {
        if !l.is_finite() {
            self.non_finite_splats += 1;
            return;
        }
        if l == SampledSpectrum::ZERO {
            return;
        }
        let i = y * self.film_width + x;
        self.splat_xyz.push((i, self.cmfs.sampled_to_xyz(l, wl)));
        let entries = self.layout.contributions(l, wl).map(|(b, v)| (i, b, v));
        self.splat_spectral.extend(entries);
    }

    /// Adds one sample's radiance to the pixel at film position (x, y).
    /// Terminated wavelengths (pdf 0) contribute nothing.
    pub fn add_sample(&mut self, x: u32, y: u32, l: SampledSpectrum, wl: &SampledWavelengths) {
        let i = ((y - self.y0) * self.width + (x - self.x0)) as usize;
        if l == SampledSpectrum::ZERO {
            self.pixels[i].samples += 1;
            return;
        }
        let xyz = self.cmfs.sampled_to_xyz(l, wl).as_dvec3();
        let px = &mut self.pixels[i];
        px.xyz += xyz;
        px.y_squared += xyz.y * xyz.y;
        px.samples += 1;
        let n = self.layout.count as usize;
        if !self.buckets.is_empty() {
            let buckets = &mut self.buckets[i * n..][..n];
            for (b, v) in self.layout.contributions(l, wl) {
                buckets[b as usize] += v;
            }
        } else if n > 0 {
            let entries = self
                .layout
                .contributions(l, wl)
                .map(|(b, v)| (i as u32, b, v));
            self.sparse.extend(entries);
        }
    }

    /// Counts the rays traced for the pixel's samples.
    pub fn add_rays(&mut self, x: u32, y: u32, rays: u64) {
        let i = ((y - self.y0) * self.width + (x - self.x0)) as usize;
        self.pixels[i].rays += rays;
    }

    /// Counts a sample that was dropped (non-finite): it adds zero.
    pub fn add_empty_sample(&mut self, x: u32, y: u32) {
        let i = ((y - self.y0) * self.width + (x - self.x0)) as usize;
        self.pixels[i].samples += 1;
    }
}

/// Whole rows of a film, borrowed: what one tile's pixels add to.
pub struct FilmBand<'a> {
    pub(super) y0: u32,
    pub(super) width: u32,
    pub(super) count: u32,
    pub(super) pixels: &'a mut [PixelSums],
    pub(super) buckets: &'a mut [f32],
    pub(super) aovs: &'a mut [AovSums],
}

impl FilmBand<'_> {
    /// Adds a tile's pixel sums, AOVs and spectral sums; its splats are the
    /// film's to add.
    pub fn add_tile(&mut self, tile: &FilmTile) {
        let index = |i: u32| {
            ((tile.y0 - self.y0 + i / tile.width) * self.width + tile.x0 + i % tile.width) as usize
        };
        for (i, b) in tile.pixels.iter().enumerate() {
            let a = &mut self.pixels[index(i as u32)];
            a.xyz += b.xyz;
            a.y_squared += b.y_squared;
            a.samples += b.samples;
            a.rays += b.rays;
        }
        if !self.aovs.is_empty() {
            for (i, b) in tile.aovs.iter().enumerate() {
                let a = &mut self.aovs[index(i as u32)];
                for (s, v) in a.iter_mut().zip(b) {
                    *s += v;
                }
            }
        }
        let n = self.count as usize;
        for &(i, bucket, v) in &tile.sparse {
            self.buckets[index(i) * n + bucket as usize] += v;
        }
        if n > 0 {
            for (row, sums) in tile
                .buckets
                .chunks_exact(tile.width as usize * n)
                .enumerate()
            {
                let start = index(row as u32 * tile.width) * n;
                for (a, b) in self.buckets[start..][..sums.len()].iter_mut().zip(sums) {
                    *a += b;
                }
            }
        }
    }
}
