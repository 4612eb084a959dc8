//! The loops integrators render with. An integrator owns its loop: it is
//! handed a [`RenderJob`] (the scene, the film settings, the options, the
//! progress bar and the stop conditions) and returns the film. Two shared
//! drivers cover the usual schedules:
//! - [`pixels`]: samples of each pixel in tiles, in progressive passes,
//!   with adaptive sampling and error targets (the path tracer, photon
//!   mapping);
//! - [`splats`]: passes of paths that add light to any pixel, their tiles
//!   added in a fixed order (the light tracer, bidirectional paths).
//!
//! An integrator with a schedule of its own (training passes, Markov
//! chains, packets of paths) uses the job's parts directly: [`tile`] for a
//! tile's samples, the job's `stop_reason`, `after_pass` and `finish`.

pub mod adaptive;
pub mod in_order;
mod job;
mod options;
pub mod pixels;
mod progress;
pub mod splats;
pub mod stream;
pub mod tile;

pub use job::{Outcome, RenderJob, TileRect};
pub use options::{Packets, PassHook, RenderError, RenderOptions, RenderStats, Stop, Streams};
pub use progress::ProgressCounts;

use crate::film::{tile_spectrum_bytes, AovSample, FilmSettings, PixelSums, AOV_BYTES};
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// Pixels on a side of the square tiles the drivers render as one job.
pub const TILE_SIZE: u32 = 16;

/// Counts kept per path, summed by the renderer.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathCounters {
    /// Closest-hit and shadow rays traced.
    pub rays: u64,
    /// Media that could not be entered because the IOR stack was full.
    pub stack_overflows: u64,
    /// Photons left on diffuse surfaces (photon mapping).
    pub photons_stored: u64,
}

impl PathCounters {
    pub fn add(&mut self, other: &PathCounters) {
        self.rays += other.rays;
        self.stack_overflows += other.stack_overflows;
        self.photons_stored += other.photons_stored;
    }
}

/// What one sample of a pixel measured, at its wavelengths.
#[derive(Clone, Copy, Debug)]
pub struct PixelSample {
    pub l: SampledSpectrum,
    pub wl: SampledWavelengths,
}

/// Traces the AOVs of a camera sample (`integrator::aov`): the drivers
/// call it beside every sample when the film records AOVs.
pub trait AovTracer: Sync {
    /// The AOVs of a camera ray through film position (`x`, `y`).
    fn first_hit(&self, scene: &Scene, x: f32, y: f32, sampler: &mut Sampler) -> AovSample;
}

/// Samples per pixel of pass `k`: 1, 1, 2, 4, 8, … up to `cap`. The first
/// passes are quick, so a render stopped early soon has a complete image.
pub fn pass_size(k: u32, cap: u32) -> u32 {
    let doubling = if k == 0 { 1 } else { 1u32 << (k - 1).min(16) };
    doubling.clamp(1, cap)
}

/// Samples per pixel in a render's largest pass (passes double up to it):
/// one where each sample index is prepared apart or a time budget should
/// stop soon after a pass, else a sixteenth of the samples, 1 to 16.
pub fn largest_pass(options: &RenderOptions, one_index_a_pass: bool) -> u32 {
    if one_index_a_pass || options.time_budget.is_some() {
        1
    } else {
        (options.samples.len() as u32).div_ceil(16).clamp(1, 16)
    }
}

/// Bytes held by `tiles` tiles in flight for a pass of `pass` samples a
/// pixel, each sample making `splat_bytes` of splats.
pub fn tiles_bytes(
    film: &FilmSettings,
    options: &RenderOptions,
    tiles: u64,
    pass: u32,
    splat_bytes: u64,
) -> u64 {
    let [x0, y0, x1, y1] = options.region;
    let region = (x1.min(film.width).saturating_sub(x0) as u64)
        * (y1.min(film.height).saturating_sub(y0) as u64);
    let batch = region.min(tiles * (TILE_SIZE as u64).pow(2));
    let per_pixel = std::mem::size_of::<PixelSums>() as u64
        + tile_spectrum_bytes(film.kept_layout().count, pass)
        + if film.aovs.traced() { AOV_BYTES } else { 0 }
        + splat_bytes * pass as u64;
    batch * per_pixel
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passes_start_small_and_grow_to_the_cap() {
        let sizes: Vec<u32> = (0..8).map(|k| pass_size(k, 16)).collect();
        assert_eq!(sizes, [1, 1, 2, 4, 8, 16, 16, 16]);
        assert_eq!((0..4).map(|k| pass_size(k, 1)).collect::<Vec<_>>(), [1; 4]);
        assert_eq!(pass_size(40, 4), 4);
    }
}
