//! Directions at infinity on a latitude-longitude grid, +y up, and a
//! piecewise-constant distribution over its cells: how the environment map
//! and the sky pick directions in proportion to their radiance.
//!
//! Grid coordinates (u, v) ∈ [0, 1)²: v = θ/π from the zenith (+y); u = 0.5
//! looks along +z and u grows towards +x. A rotation turns the grid about
//! +y (positive: from +z towards +x).

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use crate::geometry::angles;

/// A piecewise-constant distribution over [0, 1)² on a grid of cells.
#[derive(Clone, Debug)]
struct Distribution2d {
    width: usize,
    height: usize,
    /// Per row: the cumulative sums of its cells, normalised (len width + 1).
    conditional: Vec<f32>,
    /// Per row: its guide table (`guide_table`, len GUIDE + 1).
    row_guides: Vec<u32>,
    /// Cumulative row sums, normalised (len height + 1).
    marginal: Vec<f32>,
    marginal_guide: Vec<u32>,
    /// Each cell's probability.
    cell: Vec<f32>,
}

/// Buckets of a guide table (Chen & Asau 1974): bucket k holds how many
/// entries of a cdf are ≤ k/GUIDE, so a u in [k/GUIDE, (k+1)/GUIDE) is
/// found among the few entries between bucket k's count and the next
/// one's, not by a binary search over the row. That search's chain of
/// dependent loads, over a large map's rows, was 13% of the CPU of
/// `metals-studio` (`perf`). 260 bytes a row: beside a map's 24 a texel,
/// nothing.
const GUIDE: usize = 64;

/// The guide table of `cdf` (len GUIDE + 1).
fn guide_table(cdf: &[f32]) -> impl Iterator<Item = u32> + '_ {
    (0..=GUIDE).map(|k| cdf.partition_point(|&c| c <= k as f32 / GUIDE as f32) as u32)
}

/// Index i with cdf[i] ≤ u < cdf[i + 1] (skipping empty cells), and the
/// position of u within it: `invert`'s answer, bit for bit, for u in
/// [0, 1), from the entries between the guide's bounds alone.
#[inline]
fn invert_guided(cdf: &[f32], guide: &[u32], u: f32) -> (usize, f32) {
    debug_assert!((0.0..1.0).contains(&u), "u = {u}");
    // u·GUIDE is exact (a power of two), and its truncation the floor.
    let k = ((u * GUIDE as f32) as usize).min(GUIDE - 1);
    let (lo, hi) = (guide[k] as usize, guide[k + 1] as usize);
    at(cdf, lo + cdf[lo..hi].partition_point(|&c| c <= u), u)
}

/// `invert_guided` by a binary search over the whole cdf.
#[cfg(test)]
fn invert(cdf: &[f32], u: f32) -> (usize, f32) {
    at(cdf, cdf.partition_point(|&c| c <= u), u)
}

/// The interval below the first of `cdf`'s entries above u (entry
/// `above`), and where u lies in it.
#[inline]
fn at(cdf: &[f32], above: usize, u: f32) -> (usize, f32) {
    let n = cdf.len() - 1;
    let i = above.clamp(1, n) - 1;
    let width = cdf[i + 1] - cdf[i];
    let t = if width > 0.0 {
        ((u - cdf[i]) / width).clamp(0.0, 1.0 - f32::EPSILON / 2.0)
    } else {
        0.5
    };
    (i, t)
}

fn cumulative(weights: &[f64]) -> (Vec<f32>, f64) {
    let total: f64 = weights.iter().sum();
    let mut cdf = Vec::with_capacity(weights.len() + 1);
    let mut sum = 0.0;
    cdf.push(0.0);
    for w in weights {
        sum += w;
        cdf.push(if total > 0.0 {
            (sum / total) as f32
        } else {
            0.0
        });
    }
    *cdf.last_mut().expect("one entry at least") = 1.0;
    (cdf, total)
}

impl Distribution2d {
    fn new(weights: &[f64], width: usize, height: usize) -> Self {
        let total: f64 = weights.iter().sum();
        let mut conditional = Vec::with_capacity(height * (width + 1));
        let mut row_guides = Vec::with_capacity(height * (GUIDE + 1));
        let mut rows = Vec::with_capacity(height);
        for row in weights.chunks_exact(width) {
            let (cdf, sum) = cumulative(row);
            row_guides.extend(guide_table(&cdf));
            conditional.extend(cdf);
            rows.push(sum);
        }
        let (marginal, _) = cumulative(&rows);
        let marginal_guide = guide_table(&marginal).collect();
        let cell = weights
            .iter()
            .map(|w| if total > 0.0 { (w / total) as f32 } else { 0.0 })
            .collect();
        Self {
            width,
            height,
            conditional,
            row_guides,
            marginal,
            marginal_guide,
            cell,
        }
    }

    /// A point of [0, 1)², its cell (column, row) and its density there.
    fn sample(&self, u: (f32, f32)) -> (Vec2, (usize, usize), f32) {
        let (j, tv) = invert_guided(&self.marginal, &self.marginal_guide, u.1);
        let row = &self.conditional[j * (self.width + 1)..(j + 1) * (self.width + 1)];
        let guide = &self.row_guides[j * (GUIDE + 1)..(j + 1) * (GUIDE + 1)];
        let (i, tu) = invert_guided(row, guide, u.0);
        let p = Vec2::new(
            (i as f32 + tu) / self.width as f32,
            (j as f32 + tv) / self.height as f32,
        );
        (p, (i, j), self.pdf_cell(i, j))
    }

    fn pdf_cell(&self, i: usize, j: usize) -> f32 {
        self.cell[j * self.width + i] * (self.width * self.height) as f32
    }
}

/// Grid coordinates → direction in the grid's own frame, and sin θ.
pub fn grid_direction(uv: Vec2) -> (Vec3, f32) {
    let phi = (2.0 * uv.x - 1.0) * PI;
    let theta = uv.y * PI;
    let (sin_t, cos_t) = theta.sin_cos();
    // atan2(x, z) = φ.
    (
        Vec3::new(sin_t * phi.sin(), cos_t, sin_t * phi.cos()),
        sin_t,
    )
}

/// A direction drawn from a [`SphericalDistribution`].
#[derive(Clone, Copy, Debug)]
pub struct DirectionSample {
    /// Towards the sky, unit.
    pub w: Vec3,
    /// The cell (column, row) it was drawn in: what the grid's values are
    /// looked up by, without mapping `w` back.
    pub cell: (usize, usize),
    /// Solid-angle density.
    pub pdf: f32,
}

/// A distribution over directions from one over the cells of a
/// `width` × `height` latitude-longitude grid.
#[derive(Clone, Debug)]
pub struct SphericalDistribution {
    width: usize,
    height: usize,
    cells: Distribution2d,
    /// Rotation about +y, as cos and sin.
    rotation: (f32, f32),
}

impl SphericalDistribution {
    /// `weights` per cell, rows from the zenith, each the cell's share of
    /// the wanted density per unit of (u, v) (radiance × sin θ).
    pub fn new(weights: &[f64], width: usize, height: usize, rotate_degrees: f32) -> Self {
        assert_eq!(weights.len(), width * height);
        let a = rotate_degrees.to_radians();
        Self {
            width,
            height,
            cells: Distribution2d::new(weights, width, height),
            rotation: (a.cos(), a.sin()),
        }
    }

    /// World direction (towards the sky) → grid coordinates in [0, 1)².
    pub fn uv(&self, w: Vec3) -> Vec2 {
        let (c, s) = self.rotation;
        // Undo the rotation about +y.
        let x = c * w.x - s * w.z;
        let z = s * w.x + c * w.z;
        let u = 0.5 * (1.0 + angles::atan2(x, z) / PI);
        let v = angles::polar_angle(w.y, x, z) / PI;
        Vec2::new(u.rem_euclid(1.0), v.min(1.0 - f32::EPSILON))
    }

    /// Grid coordinates → world direction, and sin θ.
    pub fn direction(&self, uv: Vec2) -> (Vec3, f32) {
        let (g, sin_t) = grid_direction(uv);
        let (c, s) = self.rotation;
        let w = Vec3::new(c * g.x + s * g.z, g.y, -s * g.x + c * g.z);
        (w, sin_t)
    }

    /// The cell (column, row) holding grid coordinates `uv`.
    pub fn cell(&self, uv: Vec2) -> (usize, usize) {
        let i = ((uv.x * self.width as f32) as usize).min(self.width - 1);
        let j = ((uv.y * self.height as f32) as usize).min(self.height - 1);
        (i, j)
    }

    /// Solid-angle density of `sample` for direction `w` (towards the sky).
    pub fn pdf(&self, w: Vec3) -> f32 {
        self.pdf_in_cell(self.cell(self.uv(w)), w)
    }

    /// `pdf(w)` for a `w` already known to lie in `cell`: the cell's
    /// inverse map (two atan2s) is most of what `pdf` costs.
    pub fn pdf_in_cell(&self, (i, j): (usize, usize), w: Vec3) -> f32 {
        // Not √(1 − y²): near the poles that cancels to a few bits, and
        // the density would disagree with the one `sample` gave.
        let sin_t = (w.x * w.x + w.z * w.z).sqrt();
        if sin_t == 0.0 {
            return 0.0;
        }
        self.cells.pdf_cell(i, j) / (2.0 * PI * PI * sin_t)
    }

    /// A direction (towards the sky) drawn in proportion to the cells'
    /// weights; None where the density vanishes.
    pub fn sample(&self, u: (f32, f32)) -> Option<DirectionSample> {
        let (uv, cell, pdf_uv) = self.cells.sample(u);
        let (w, sin_t) = self.direction(uv);
        if pdf_uv == 0.0 || sin_t == 0.0 {
            return None;
        }
        Some(DirectionSample {
            w,
            cell,
            pdf: pdf_uv / (2.0 * PI * PI * sin_t),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The guide table's search finds what the binary search over the
    /// whole cdf finds, bit for bit: rows with empty cells (runs of equal
    /// entries), an empty row, mass in one cell, and u at every bucket's
    /// bounds, just below them and at random.
    #[test]
    fn guided_inversion_is_the_binary_search() {
        let mut rng = crate::sampler::Sampler::new(11, 5);
        let mut rows: Vec<Vec<f64>> = vec![
            vec![0.0; 9],
            vec![0.0, 0.0, 5.0, 0.0, 0.0],
            vec![1.0; 513],
            (0..300)
                .map(|k| if k % 7 == 0 { 0.0 } else { 1.0 + k as f64 })
                .collect(),
        ];
        rows.extend((0..20).map(|n| {
            (0..(1 + n * 37))
                .map(|_| {
                    let u = rng.next_f32() as f64;
                    if u < 0.3 {
                        0.0
                    } else {
                        (u * 40.0).exp()
                    }
                })
                .collect()
        }));
        for weights in &rows {
            let (cdf, _) = cumulative(weights);
            let table: Vec<u32> = guide_table(&cdf).collect();
            let mut us: Vec<f32> = (0..GUIDE)
                .flat_map(|k| {
                    let b = k as f32 / GUIDE as f32;
                    [b, f32::from_bits(b.to_bits().saturating_sub(1)).max(0.0)]
                })
                .collect();
            us.extend((0..2000).map(|_| rng.next_f32()));
            us.extend(cdf.iter().copied().filter(|&c| c < 1.0));
            us.push(1.0 - f32::EPSILON / 2.0);
            for u in us {
                let (a, b) = (invert_guided(&cdf, &table, u), invert(&cdf, u));
                assert_eq!(
                    (a.0, a.1.to_bits()),
                    (b.0, b.1.to_bits()),
                    "u = {u}, {} cells",
                    weights.len()
                );
            }
        }
    }
}
