//! Gathering an OBJ's pieces: each piece's faces with vertices of its own,
//! one per distinct (v, vt, vn) its corners use.

use std::collections::HashMap;

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

/// The whole file's vertex arrays and chunks, for gathering pieces.
pub(super) struct Sources<'a> {
    pub(super) chunks: &'a [Chunk],
    pub(super) positions: &'a [Vec3],
    pub(super) uvs: &'a [Vec2],
    pub(super) normals: &'a [Vec3],
}

impl Sources<'_> {
    /// The piece's faces with their own vertices: one per distinct
    /// (v, vt, vn) its corners use (vt and vn only where every corner has
    /// them).
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
        let all = || corner_ranges.iter().flat_map(|r| r.1.iter());
        let with_uv = all().all(|c| c[1] != NONE);
        let with_normal = all().all(|c| c[2] != NONE && c[2] != BROKEN);
        let broken_normals = all().any(|c| c[2] == BROKEN);
        let key = |c: &[u32; 3]| {
            [
                c[0],
                if with_uv { c[1] } else { NONE },
                if with_normal { c[2] } else { NONE },
            ]
        };
        // Each position's first vertex in a dense table over the range of
        // positions the piece uses (exporters write an object's vertices
        // together); further (vt, vn) pairs of a position in a map.
        let (lo, hi) = all().fold((u32::MAX, 0), |(lo, hi), c| (lo.min(c[0]), hi.max(c[0])));
        let corners_count: usize = corner_ranges.iter().map(|r| r.1.len()).sum();
        let dense = (hi - lo) as usize <= 4 * corners_count + 1024;
        let mut first = if dense {
            vec![NONE; (hi - lo) as usize + 1]
        } else {
            Vec::new()
        };
        let mut others: HashMap<[u32; 3], u32> = HashMap::new();
        let mut keys: Vec<[u32; 3]> = Vec::new();
        let mut corners = Vec::with_capacity(corners_count);
        for c in all() {
            let k = key(c);
            let slot = if dense {
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
        ObjPiece {
            name: plan.name,
            material: plan.material,
            positions: keys.iter().map(|k| self.positions[k[0] as usize]).collect(),
            uvs: with_uv.then(|| keys.iter().map(|k| self.uvs[k[1] as usize]).collect()),
            normals: with_normal
                .then(|| keys.iter().map(|k| self.normals[k[2] as usize]).collect()),
            corners,
            arities: corner_ranges
                .iter()
                .flat_map(|r| r.0.iter().copied())
                .collect(),
            broken_normals,
        }
    }
}
