//! What a render will hold at its peak, estimated before the first sample
//! and checked against the memory budget.

use super::RenderSettings;
use crate::drive::RenderOptions;
use crate::film::film_bytes;
use crate::scene::Scene;

/// What a render will hold at its peak, in bytes, by part: estimated from
/// the sizes of what it allocates and checked against the memory budget
/// before the first sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MemoryEstimate {
    /// The peak of loading: images, meshes and the BVH build (before the
    /// film exists).
    pub loading: u64,
    /// Geometry, BVH, lights and decoded images.
    pub scene: u64,
    /// The film's sums (and an adaptive render's pilot film).
    pub film: u64,
    /// Tiles of one batch with a pass's samples in them, and the photon
    /// map: held while rendering.
    pub passes: u64,
    /// The images being encoded: held while writing, once the passes are
    /// done.
    pub writing: u64,
}

impl MemoryEstimate {
    pub fn total(&self) -> u64 {
        PROCESS_BYTES + self.loading.max(self.rendering())
    }

    /// What rendering and writing add to the loaded scene, at their peak.
    pub fn rendering(&self) -> u64 {
        self.scene + self.film + self.passes.max(self.writing)
    }
}

/// The process itself: code, tables, threads (measured: 40 MiB peak for a
/// 256² Cornell Box).
const PROCESS_BYTES: u64 = 48 << 20;

/// The memory `scene` rendered with `settings` and `options` will hold at
/// its peak; `loading` is what loading it held at its peak.
pub fn memory_estimate(
    scene: &Scene,
    settings: &RenderSettings,
    options: &RenderOptions,
    loading: u64,
) -> MemoryEstimate {
    let f = &settings.film;
    let pixels = f.width as u64 * f.height as u64;
    let buckets = f.kept_layout().count;
    let (film, writing) = film_bytes(pixels, buckets, f.spectral_output, f.aovs.traced());
    let (planes, passes) = settings
        .integrator
        .as_integrate()
        .loop_memory(scene, f, options);
    MemoryEstimate {
        loading,
        scene: scene.memory_bytes(),
        film: film + planes,
        passes,
        writing,
    }
}
