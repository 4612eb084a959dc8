//! Gathering an OBJ's pieces: each piece's faces with vertices of its own,
//! one per distinct (v, vt, vn) its corners use.

use std::collections::HashMap;
use std::sync::atomic::{AtomicU32, Ordering::Relaxed};

use rayon::prelude::*;

use glam::{Vec2, Vec3};

use super::{Chunk, ObjPiece, BROKEN, NONE};

/// A piece before its vertices are gathered: its faces as (chunk, first
/// face, end face) ranges.
#[derive(Default)]
pub(super) struct Plan {
    pub(super) name: String,
    pub(super) material: Option<String>,
    pub(super) ranges: Vec<(usize, usize, usize)>,
}

/// The whole file's vertex arrays (as the chunks hold them) and chunks,
/// for gathering pieces.
pub(super) struct Sources<'a> {
    pub(super) chunks: &'a [Chunk],
    pub(super) positions: Joined<'a, Vec3>,
    pub(super) uvs: Joined<'a, Vec2>,
    pub(super) normals: Joined<'a, Vec3>,
}

/// Slices read as one, without copying them into one (on a big file,
/// hundreds of megabytes of fresh pages).
pub(super) struct Joined<'a, T> {
    parts: Vec<&'a [T]>,
    /// Where each part starts in the whole.
    starts: Vec<usize>,
}

impl<'a, T: Copy> Joined<'a, T> {
    pub(super) fn new(parts: impl Iterator<Item = &'a [T]>) -> Self {
        let parts: Vec<&[T]> = parts.collect();
        let starts = starts_of(parts.iter().map(|p| p.len()));
        Self { parts, starts }
    }

    /// The item at `index` of the whole (which must have one).
    fn get(&self, index: u32) -> T {
        let index = index as usize;
        let part = self.starts.partition_point(|&s| s <= index) - 1;
        self.parts[part][index - self.starts[part]]
    }
}

/// Corners per parallel task while gathering.
const BLOCK: usize = 1 << 16;

impl Sources<'_> {
    /// The piece's faces with their own vertices: one per distinct
    /// (v, vt, vn) its corners use (vt and vn only where every corner has
    /// them), numbered in the order the corners first use them.
    pub(super) fn piece(&self, plan: Plan) -> ObjPiece {
        // Corner offsets of each chunk's faces.
        let corner_ranges: Vec<(&[u32], &[[u32; 3]])> = plan
            .ranges
            .iter()
            .map(|&(k, a, b)| {
                let c = &self.chunks[k];
                let (first, end) = (c.face_starts[a] as usize, c.face_starts[b] as usize);
                (&c.arities[a..b], &c.corners[first..end])
            })
            .collect();
        let blocks: Vec<&[[u32; 3]]> = corner_ranges
            .iter()
            .flat_map(|r| r.1.chunks(BLOCK))
            .collect();
        let seen = blocks
            .par_iter()
            .map(|b| Seen::of(b))
            .reduce(Seen::default, Seen::join);
        let key = |c: &[u32; 3]| {
            [
                c[0],
                if seen.with_uv { c[1] } else { NONE },
                if seen.with_normal { c[2] } else { NONE },
            ]
        };
        // A dense table over the positions the piece uses where they lie
        // together (exporters write an object's vertices together).
        let dense = seen.span().filter(|&span| span <= 4 * seen.corners + 1024);
        let (keys, corners) = match dense {
            Some(span) => gather_by_position(&blocks, seen.lo, span, &key)
                .unwrap_or_else(|| gather(&blocks, dense.map(|span| (seen.lo, span)), &key)),
            None => gather(&blocks, None, &key),
        };
        ObjPiece {
            name: plan.name,
            material: plan.material,
            positions: keys.par_iter().map(|k| self.positions.get(k[0])).collect(),
            uvs: seen
                .with_uv
                .then(|| keys.par_iter().map(|k| self.uvs.get(k[1])).collect()),
            normals: seen
                .with_normal
                .then(|| keys.par_iter().map(|k| self.normals.get(k[2])).collect()),
            corners,
            arities: corner_ranges
                .iter()
                .flat_map(|r| r.0.iter().copied())
                .collect(),
            broken_normals: seen.broken_normals,
        }
    }
}

/// What a piece's corners hold, found in one pass.
struct Seen {
    corners: usize,
    with_uv: bool,
    with_normal: bool,
    broken_normals: bool,
    /// The least and greatest position index.
    lo: u32,
    hi: u32,
}

impl Default for Seen {
    fn default() -> Self {
        Seen {
            corners: 0,
            with_uv: true,
            with_normal: true,
            broken_normals: false,
            lo: u32::MAX,
            hi: 0,
        }
    }
}

impl Seen {
    fn of(corners: &[[u32; 3]]) -> Seen {
        corners.iter().fold(Seen::default(), |s, c| Seen {
            corners: s.corners + 1,
            with_uv: s.with_uv && c[1] != NONE,
            with_normal: s.with_normal && c[2] != NONE && c[2] != BROKEN,
            broken_normals: s.broken_normals || c[2] == BROKEN,
            lo: s.lo.min(c[0]),
            hi: s.hi.max(c[0]),
        })
    }

    fn join(self, other: Seen) -> Seen {
        Seen {
            corners: self.corners + other.corners,
            with_uv: self.with_uv && other.with_uv,
            with_normal: self.with_normal && other.with_normal,
            broken_normals: self.broken_normals || other.broken_normals,
            lo: self.lo.min(other.lo),
            hi: self.hi.max(other.hi),
        }
    }

    /// How many position indices lie from the least to the greatest.
    fn span(&self) -> Option<usize> {
        (self.lo <= self.hi).then(|| (self.hi - self.lo) as usize + 1)
    }
}

/// The distinct keys in the order of first use, and each corner's index
/// among them, one corner after another. Each position's first vertex is
/// found in a dense table over `dense` (lowest position, count) where
/// given, otherwise in a map, as further (vt, vn) pairs of a position are.
fn gather(
    blocks: &[&[[u32; 3]]],
    dense: Option<(u32, usize)>,
    key: &impl Fn(&[u32; 3]) -> [u32; 3],
) -> (Vec<[u32; 3]>, Vec<u32>) {
    let count: usize = blocks.iter().map(|b| b.len()).sum();
    let all = || blocks.iter().flat_map(|b| b.iter());
    let (lo, span) = dense.unwrap_or((0, 0));
    let mut first = vec![NONE; span];
    let mut others: HashMap<[u32; 3], u32> = HashMap::new();
    let mut keys: Vec<[u32; 3]> = Vec::new();
    let mut corners = Vec::with_capacity(count);
    for c in all() {
        let k = key(c);
        let slot = if dense.is_some() {
            &mut first[(k[0] - lo) as usize]
        } else {
            others.entry([k[0], NONE - 1, NONE - 1]).or_insert(NONE)
        };
        let index = if *slot == NONE {
            *slot = keys.len() as u32;
            keys.push(k);
            *slot
        } else if keys[*slot as usize] == k {
            *slot
        } else {
            let next = keys.len() as u32;
            let index = *others.entry(k).or_insert(next);
            if index == next {
                keys.push(k);
            }
            index
        };
        corners.push(index);
    }
    (keys, corners)
}

/// `gather`'s result on every thread, where each position is used with
/// one (vt, vn) only (what most files hold); None otherwise. A vertex's
/// number is how many first uses of a position come before its own.
fn gather_by_position(
    blocks: &[&[[u32; 3]]],
    lo: u32,
    span: usize,
    key: &(impl Fn(&[u32; 3]) -> [u32; 3] + Sync),
) -> Option<(Vec<[u32; 3]>, Vec<u32>)> {
    let starts = starts_of(blocks.iter().map(|b| b.len()));
    let count = starts
        .last()
        .map_or(0, |s| s + blocks[blocks.len() - 1].len());
    let table = || -> Vec<AtomicU32> {
        (0..span)
            .into_par_iter()
            .map(|_| AtomicU32::new(NONE))
            .collect()
    };
    // Each position's first corner.
    let first = table();
    blocks.par_iter().zip(&starts).for_each(|(b, &start)| {
        for (j, c) in b.iter().enumerate() {
            let slot = &first[(c[0] - lo) as usize];
            let g = (start + j) as u32;
            if slot.load(Relaxed) > g {
                slot.fetch_min(g, Relaxed);
            }
        }
    });
    let is_first = |c: &[u32; 3], g: usize| first[(c[0] - lo) as usize].load(Relaxed) == g as u32;
    // First uses per block, and so where each block's vertices start.
    let firsts: Vec<usize> = blocks
        .par_iter()
        .zip(&starts)
        .map(|(b, &start)| {
            b.iter()
                .enumerate()
                .filter(|(j, c)| is_first(c, start + j))
                .count()
        })
        .collect();
    let mut keys = vec![[NONE; 3]; firsts.iter().sum()];
    let vertex = table();
    split_by_lengths(&mut keys, firsts.iter().copied())
        .into_par_iter()
        .zip(blocks.par_iter().zip(&starts))
        .for_each(|(slice, (b, &start))| {
            let mut next = 0;
            for (j, c) in b.iter().enumerate() {
                if is_first(c, start + j) {
                    slice[next] = key(c);
                    next += 1;
                }
            }
        });
    // Vertex numbers: the blocks' first uses counted before each.
    let bases = starts_of(firsts.iter().copied());
    blocks
        .par_iter()
        .zip(&starts)
        .zip(&bases)
        .for_each(|((b, &start), &base)| {
            let mut next = base as u32;
            for (j, c) in b.iter().enumerate() {
                if is_first(c, start + j) {
                    vertex[(c[0] - lo) as usize].store(next, Relaxed);
                    next += 1;
                }
            }
        });
    // Each corner's vertex, and whether its (vt, vn) is its position's.
    let mut corners = vec![0u32; count];
    let consistent = split_by_lengths(&mut corners, blocks.iter().map(|b| b.len()))
        .into_par_iter()
        .zip(blocks.par_iter())
        .all(|(out, b)| {
            b.iter().zip(out.iter_mut()).all(|(c, o)| {
                *o = vertex[(c[0] - lo) as usize].load(Relaxed);
                keys[*o as usize] == key(c)
            })
        });
    consistent.then_some((keys, corners))
}

/// Where each of consecutive parts of these lengths starts.
fn starts_of(lengths: impl Iterator<Item = usize>) -> Vec<usize> {
    lengths
        .scan(0, |at, n| {
            let start = *at;
            *at += n;
            Some(start)
        })
        .collect()
}

/// `items` cut into consecutive parts of these lengths, to be written on
/// every thread.
fn split_by_lengths<T>(mut items: &mut [T], lengths: impl Iterator<Item = usize>) -> Vec<&mut [T]> {
    lengths
        .map(|n| {
            let (part, rest) = std::mem::take(&mut items).split_at_mut(n);
            items = rest;
            part
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Corners over `positions` positions from 1000 on, in a scrambled
    /// order, each position with the (vt, vn) that `pair` gives it.
    fn corners(
        count: usize,
        positions: u32,
        pair: impl Fn(u32, usize) -> [u32; 2],
    ) -> Vec<[u32; 3]> {
        let mut state = 12345u32;
        (0..count)
            .map(|i| {
                state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                let v = 1000 + (state >> 8) % positions;
                let [t, n] = pair(v, i);
                [v, t, n]
            })
            .collect()
    }

    #[test]
    fn gathering_by_position_on_every_thread_numbers_vertices_as_one_thread_does() {
        let all = corners(3 * BLOCK + 777, 50_000, |v, _| [v / 2, v % 7]);
        let blocks: Vec<&[[u32; 3]]> = all.chunks(BLOCK).collect();
        let key = |c: &[u32; 3]| *c;
        let parallel = gather_by_position(&blocks, 1000, 50_000, &key).unwrap();
        let serial = gather(&blocks, Some((1000, 50_000)), &key);
        assert_eq!(parallel, serial);
        // Every position used, numbered by first use.
        assert!(parallel.0.len() > 49_000, "{}", parallel.0.len());
        assert_eq!(parallel.1[0], 0);
        assert_eq!(parallel.0[0], all[0]);
        let sparse = gather(&blocks, None, &key);
        assert_eq!(sparse, serial);
    }

    #[test]
    fn a_position_with_two_pairs_is_gathered_on_one_thread() {
        // Every 1000th corner gives its position another normal.
        let all = corners(2 * BLOCK, 20_000, |v, i| {
            [v, if i % 1000 == 999 { 7 } else { 3 }]
        });
        let blocks: Vec<&[[u32; 3]]> = all.chunks(BLOCK).collect();
        let key = |c: &[u32; 3]| *c;
        assert!(gather_by_position(&blocks, 1000, 20_000, &key).is_none());
        let (keys, indices) = gather(&blocks, Some((1000, 20_000)), &key);
        for (c, &i) in all.iter().zip(&indices) {
            assert_eq!(keys[i as usize], *c);
        }
        assert!(keys.len() > 20_000);
    }
}
