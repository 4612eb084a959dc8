//! Which samples of a tile form the groups that reuse each other's paths
//! (`reuse`), and the groups whose paths have not all ended.

use std::ops::Range;

use super::reuse::{share, Member, GROUP};
use crate::drive::TileRect;
use crate::geometry::Ray;
use crate::integrator::PathTracer;
use crate::material::Material;
use crate::scene::Scene;
use crate::spectrum::SampledWavelengths;

/// Whether the packet core reuses first bounces between the pixels of a
/// 2 × 2 block (`reuse`): as the scene says, else where every surface is
/// diffuse (so every first bounce can be shared: with metal spheres,
/// `metals.toml`, the variance fell 6% for 23% more CPU), where a path
/// takes at least two bounces before Russian roulette may end it and no
/// surface fluoresces (which moves a path's wavelengths from the group's).
pub(super) fn reuses(tracer: &PathTracer, scene: &Scene) -> bool {
    let all_diffuse = || {
        scene
            .materials
            .iter()
            .all(|m| matches!(m, Material::Diffuse { .. }))
    };
    tracer.reuse.unwrap_or_else(all_diffuse)
        && tracer.max_depth >= 2
        && tracer.rr_depth >= 2
        && !scene.materials.iter().any(Material::is_fluorescent)
}

/// The tile's samples, in the groups that reuse each other's paths where
/// `grouped`, else pixel by pixel.
pub(super) fn tile_samples<'a>(
    grouped: bool,
    (x0, y0, w, h): TileRect,
    indices: &'a impl Fn(u32, u32) -> Range<u32>,
) -> Box<dyn Iterator<Item = Grouped> + 'a> {
    if grouped {
        return Box::new(GroupedSamples::new((x0, y0, w, h), indices));
    }
    let samples = (y0..y0 + h)
        .flat_map(move |y| (x0..x0 + w).map(move |x| (x, y)))
        .flat_map(|(x, y)| indices(x, y).map(move |i| (x, y, i)));
    Box::new(samples.map(|sample| Grouped {
        sample,
        group: None,
    }))
}

/// A sample of the tile (pixel and index), and its group where paths are
/// reused: the group's number in the tile and how many samples it holds.
pub(super) struct Grouped {
    pub sample: (u32, u32, u32),
    pub group: Option<(u64, usize)>,
}

/// The tile's samples in groups, rank by rank (every pixel's first
/// sample, then every pixel's second, …): for each rank, the pixels of
/// each 2 × 2 block of the image (as far as the tile holds it) that have a
/// sample of that rank.
pub(super) struct GroupedSamples<'a, F: Fn(u32, u32) -> Range<u32>> {
    rect: TileRect,
    indices: &'a F,
    /// The rank, and the most any pixel of the tile has.
    rank: u32,
    ranks: u32,
    /// The next block, in blocks of the image, row by row.
    block: (u32, u32),
    /// The current group's samples, the next one yielded, its number.
    members: [(u32, u32, u32); GROUP],
    count: usize,
    next: usize,
    seq: u64,
}

impl<'a, F: Fn(u32, u32) -> Range<u32>> GroupedSamples<'a, F> {
    pub(super) fn new(rect: TileRect, indices: &'a F) -> Self {
        let (x0, y0, w, h) = rect;
        let ranks = (y0..y0 + h)
            .flat_map(|y| (x0..x0 + w).map(move |x| (x, y)))
            .map(|(x, y)| indices(x, y).len() as u32)
            .max()
            .unwrap_or(0);
        GroupedSamples {
            rect,
            indices,
            rank: 0,
            ranks,
            block: (x0 / 2, y0 / 2),
            members: [(0, 0, 0); GROUP],
            count: 0,
            next: 0,
            seq: 0,
        }
    }

    /// Moves to the next group with a sample, its members in `members`;
    /// false past the last.
    fn next_group(&mut self) -> bool {
        let (x0, y0, w, h) = self.rect;
        let (last_bx, last_by) = ((x0 + w - 1) / 2, (y0 + h - 1) / 2);
        while self.rank < self.ranks {
            let (bx, by) = self.block;
            if by > last_by {
                self.rank += 1;
                self.block = (x0 / 2, y0 / 2);
                continue;
            }
            self.block = if bx < last_bx {
                (bx + 1, by)
            } else {
                (x0 / 2, by + 1)
            };
            self.count = 0;
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (x, y) = (2 * bx + dx, 2 * by + dy);
                if x < x0 || x >= x0 + w || y < y0 || y >= y0 + h {
                    continue;
                }
                let range = (self.indices)(x, y);
                if self.rank < range.len() as u32 {
                    self.members[self.count] = (x, y, range.start + self.rank);
                    self.count += 1;
                }
            }
            if self.count > 0 {
                return true;
            }
        }
        false
    }
}

impl<F: Fn(u32, u32) -> Range<u32>> Iterator for GroupedSamples<'_, F> {
    type Item = Grouped;

    fn next(&mut self) -> Option<Grouped> {
        if self.next == self.count {
            if self.count > 0 {
                self.seq += 1;
            }
            if !self.next_group() {
                // And None from now on (the packet loop asks again).
                (self.count, self.next) = (0, 0);
                return None;
            }
            self.next = 0;
        }
        self.next += 1;
        Some(Grouped {
            sample: self.members[self.next - 1],
            group: Some((self.seq, self.count)),
        })
    }
}

/// A group whose paths have not all ended: the members that have, in the
/// order the group's samples started.
struct PendingGroup {
    seq: u64,
    size: usize,
    /// Its first sample's place in the tile's order, and wavelengths.
    first_order: u64,
    wl: SampledWavelengths,
    ended: [Member; GROUP],
    count: usize,
}

/// The groups whose paths have not all ended (at most one per lane).
#[derive(Default)]
pub(super) struct PendingGroups(Vec<PendingGroup>);

impl PendingGroups {
    /// Sample `order` of `group` (its number and size) starts, having
    /// drawn `wl`: the wavelengths it takes, those of the group's first
    /// sample (a group's samples start one after another, and its first
    /// opens it).
    pub(super) fn start(
        &mut self,
        (seq, size): (u64, usize),
        order: u64,
        wl: SampledWavelengths,
    ) -> SampledWavelengths {
        match self.0.iter().find(|g| g.seq == seq) {
            Some(group) => group.wl,
            None => {
                self.0.push(PendingGroup {
                    seq,
                    size,
                    first_order: order,
                    wl,
                    ended: [Member::default(); GROUP],
                    count: 0,
                });
                wl
            }
        }
    }

    /// A path of group `seq` ended as `member`. Where it was the group's
    /// last, the group's members once they have shared their paths
    /// (`share`, its shadow rays answered by `occluded`), in the order
    /// they started; else none.
    pub(super) fn end(
        &mut self,
        seq: u64,
        member: Member,
        occluded: impl FnOnce(&[Ray], &mut [bool]),
    ) -> impl Iterator<Item = Member> {
        let at = self
            .0
            .iter()
            .position(|g| g.seq == seq)
            .expect("a lane's group is pending until its last path ends");
        // In start order, whichever ends first: the group's sums are then
        // the same for any packet width.
        let group = &mut self.0[at];
        group.ended[(member.order - group.first_order) as usize] = member;
        group.count += 1;
        let mut done = None;
        if group.count == group.size {
            let mut group = self.0.swap_remove(at);
            share(&mut group.ended[..group.size], occluded);
            done = Some(group);
        }
        done.into_iter()
            .flat_map(|g| g.ended.into_iter().take(g.size))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every sample of the tile comes once, in groups of at most four
    /// pixels of one 2 × 2 block, each group's samples one after another
    /// with its size; then None, however often asked.
    #[test]
    fn groups_hold_every_sample_once() {
        for rect in [(0, 0, 5, 3), (3, 7, 4, 4), (1, 1, 1, 1), (2, 5, 7, 6)] {
            // Pixels with 1 to 5 samples (as adaptive sampling gives them).
            let indices = |x: u32, y: u32| 10..(11 + (x + y) % 5);
            let mut samples = GroupedSamples::new(rect, &indices);
            let got: Vec<Grouped> = samples.by_ref().collect();
            assert!(samples.next().is_none() && samples.next().is_none());
            let mut seen: Vec<(u32, u32, u32)> = got.iter().map(|g| g.sample).collect();
            let mut want = vec![];
            for y in rect.1..rect.1 + rect.3 {
                for x in rect.0..rect.0 + rect.2 {
                    want.extend(indices(x, y).map(|i| (x, y, i)));
                }
            }
            seen.sort();
            want.sort();
            assert_eq!(seen, want, "{rect:?}");
            let mut k = 0;
            while k < got.len() {
                let (seq, size) = got[k].group.expect("grouped");
                assert!((1..=GROUP).contains(&size));
                let block = (got[k].sample.0 / 2, got[k].sample.1 / 2);
                for g in &got[k..k + size] {
                    assert_eq!(g.group, Some((seq, size)), "{rect:?}");
                    assert_eq!((g.sample.0 / 2, g.sample.1 / 2), block, "{rect:?}");
                    assert_eq!(g.sample.2, got[k].sample.2, "one rank: {rect:?}");
                }
                k += size;
            }
        }
    }
}
