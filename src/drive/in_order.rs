//! Samples that end out of order, added to a tile in the order they
//! started. A stream or a packet of paths ends its samples whenever their
//! paths end; adding each one the moment it ends would make the tile's
//! sums depend on path lengths. Added in the order the one-at-a-time loop
//! (`tile`) takes them, the sums are the same for any schedule.

use std::collections::VecDeque;

use super::tile::add_sample;
use super::{PathCounters, PixelSample, RenderJob};
use crate::film::FilmTile;

/// An ended sample waiting for those before it.
struct Ended {
    sample: (u32, u32, u32),
    measured: PixelSample,
    rays: u64,
}

/// The samples started in a tile, from the first not yet added on.
#[derive(Default)]
pub struct InOrder {
    /// From `committed` on, in start order (None: not ended yet).
    ended: VecDeque<Option<Ended>>,
    committed: u64,
    started: u64,
    counters: PathCounters,
    bad: u64,
    taken: u64,
}

impl InOrder {
    /// Notes that a sample starts; its place in the order.
    pub fn start(&mut self) -> u64 {
        self.ended.push_back(None);
        self.started += 1;
        self.started - 1
    }

    /// Sample `order` (pixel and index `sample`) ended with `measured`,
    /// having traced what `counters` count.
    pub fn end(
        &mut self,
        order: u64,
        sample: (u32, u32, u32),
        measured: PixelSample,
        counters: &PathCounters,
    ) {
        self.ended[(order - self.committed) as usize] = Some(Ended {
            sample,
            measured,
            rays: counters.rays,
        });
        self.counters.add(counters);
    }

    /// Adds to `tile` the samples that ended, up to the first that has not.
    pub fn commit(&mut self, job: &RenderJob, tile: &mut FilmTile) {
        while let Some(Some(_)) = self.ended.front() {
            let e = self.ended.pop_front().flatten().expect("checked above");
            self.bad += add_sample(job, tile, e.sample, &e.measured);
            tile.add_rays(e.sample.0, e.sample.1, e.rays);
            self.committed += 1;
            self.taken += 1;
        }
    }

    /// Counts the tile's samples, rays and dropped values into the job,
    /// once every sample has been committed.
    pub fn finish(self, job: &RenderJob, tile: &FilmTile) {
        debug_assert!(self.ended.is_empty(), "every sample committed");
        job.count(
            self.taken,
            &self.counters,
            self.bad + tile.non_finite_splats,
        );
    }
}
