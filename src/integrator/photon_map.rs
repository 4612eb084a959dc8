//! A photon map: the photons one iteration left on diffuse surfaces, filed
//! in a hash grid, and the density estimate that turns those within a
//! radius (and a wavelength kernel) into reflected radiance. Photon
//! mapping (`sppm`) and the path tracer's caustics (`path_caustics`) use it.

use glam::{IVec3, Vec3, Vec4};
use rayon::prelude::*;

use super::light_path::LightVertex;
use super::PathCounters;
use crate::sampler::Sampler;

use crate::material::{Bsdf, TransportMode};
use crate::spectrum::{lanes_led_by, SampledSpectrum, SampledWavelengths};

/// Photons traced by one task: small, so that an iteration of a few tens
/// of thousands of photons still keeps 16 threads busy. The map does not
/// depend on it (batches are concatenated in photon order).
const PHOTON_BATCH: u32 = 512;
/// Photons' random streams use this row of the sampler's pixel grid,
/// which no image reaches, so they never share a camera sample's numbers.
pub(super) const PHOTON_ROW: u32 = u32::MAX;
/// The bytes of a stored photon (for memory estimates).
const PHOTON_BYTES: u64 = std::mem::size_of::<Photon>() as u64;
/// The bytes an iteration's map takes at its peak per stored photon, an
/// upper bound: batches grow by doubling (up to twice their photons'
/// bytes) and are copied into one list; while that list is filed, the
/// grid's bucket starts and a copy of them as cursors take up to 128 bytes
/// a photon (`TABLE_PER_PHOTON`, rounded up to a power of two) and the
/// order 4; then the map copies the list into bucket order.
pub(super) const MAP_BYTES_PER_STORED: u64 = 3 * PHOTON_BYTES + 72;

/// A photon that landed on a diffuse surface.
#[derive(Clone, Copy, Debug)]
pub(super) struct Photon {
    pub p: Vec3,
    /// Towards where it came from.
    pub wi: Vec3,
    pub lambda: Vec4,
    /// Flux per wavelength over 4 × its wavelength density (zero for a
    /// terminated wavelength): what it adds through the wavelength kernel.
    pub weight: Vec4,
    /// Surfaces it met, this one included (2 or more: direct light is
    /// sampled at the visible point instead).
    pub depth: u32,
}

impl Photon {
    /// The photon a light path leaves at `p`, the point of vertex `v`
    /// (None when it carries nothing).
    pub(super) fn landed(v: &LightVertex, p: Vec3) -> Option<Photon> {
        let mut weight = Vec4::ZERO;
        for k in 0..4 {
            if v.wl.pdf[k] > 0.0 {
                weight[k] = v.beta[k] / (4.0 * v.wl.pdf[k]);
            }
        }
        (weight.is_finite() && weight != Vec4::ZERO).then_some(Photon {
            p,
            wi: v.wo,
            lambda: v.wl.lambda,
            weight,
            depth: v.depth,
        })
    }
}

/// One iteration's photons in a hash grid, with the iteration's kernels.
#[derive(Debug, Default)]
pub struct PhotonMap {
    photons: Vec<Photon>,
    grid: HashGrid,
    /// Photons emitted (stored or not).
    emitted: u64,
    radius: f32,
    spectral_radius: f32,
}

/// Photons by grid cell: cells of twice the radius, hashed into a table.
/// The map keeps its photons bucket after bucket, each bucket's in emission
/// order (so a gather sums them in a fixed order, whatever the thread
/// count): a gather reads a bucket's photons one after another, not
/// scattered over the whole map (which cost `path_caustics` a cache miss
/// per photon tested).
#[derive(Debug, Default)]
struct HashGrid {
    inv_cell: f32,
    mask: usize,
    /// Bucket b holds the map's photons `starts[b]..starts[b + 1]`.
    starts: Vec<u32>,
    /// One bit per bucket: whether it holds any. Most gathers find only
    /// empty buckets (where the camera sees no caustic), and these bits
    /// (a 32nd of `starts`' size, which outgrows the caches) say so
    /// without reading `starts`.
    occupied: Vec<u64>,
}

/// Hash-table buckets per photon: with fewer, a gather scans more photons
/// of other cells that share its buckets.
const TABLE_PER_PHOTON: usize = 8;

impl HashGrid {
    /// The grid of `count` points, and the order to keep them in: the
    /// index of each point, bucket after bucket.
    fn build(
        points: impl Iterator<Item = Vec3> + Clone,
        count: usize,
        cell: f32,
    ) -> (Self, Vec<u32>) {
        let size = (TABLE_PER_PHOTON * count).next_power_of_two().max(1);
        let mut grid = Self {
            inv_cell: 1.0 / cell,
            mask: size - 1,
            starts: vec![0; size + 1],
            occupied: vec![0; size.div_ceil(64)],
        };
        let mut order = vec![0; count];
        for p in points.clone() {
            let b = grid.bucket(grid.cell(p));
            grid.starts[b + 1] += 1;
            grid.occupied[b / 64] |= 1 << (b % 64);
        }
        for b in 0..size {
            grid.starts[b + 1] += grid.starts[b];
        }
        let mut next = grid.starts.clone();
        for (i, p) in points.enumerate() {
            let b = grid.bucket(grid.cell(p));
            order[next[b] as usize] = i as u32;
            next[b] += 1;
        }
        (grid, order)
    }

    fn cell(&self, p: Vec3) -> IVec3 {
        (p * self.inv_cell).floor().as_ivec3()
    }

    fn bucket(&self, c: IVec3) -> usize {
        let h = (c.x as u32).wrapping_mul(73_856_093)
            ^ (c.y as u32).wrapping_mul(19_349_663)
            ^ (c.z as u32).wrapping_mul(83_492_791);
        h as usize & self.mask
    }

    /// The buckets that may hold points within `r` of `p` (r at most half
    /// a cell: 2 × 2 × 2 cells), each once.
    fn buckets_near(&self, p: Vec3, r: f32) -> ([usize; 8], usize) {
        let (lo, hi) = (self.cell(p - Vec3::splat(r)), self.cell(p + Vec3::splat(r)));
        let mut out = [0; 8];
        let mut n = 0;
        for z in lo.z..=hi.z.min(lo.z + 1) {
            for y in lo.y..=hi.y.min(lo.y + 1) {
                for x in lo.x..=hi.x.min(lo.x + 1) {
                    let b = self.bucket(IVec3::new(x, y, z));
                    let holds_any = self.occupied[b / 64] & (1 << (b % 64)) != 0;
                    if holds_any && !out[..n].contains(&b) {
                        out[n] = b;
                        n += 1;
                    }
                }
            }
        }
        (out, n)
    }

    /// Where bucket `b`'s photons lie in the map.
    fn bucket_range(&self, b: usize) -> std::ops::Range<usize> {
        self.starts[b] as usize..self.starts[b + 1] as usize
    }
}

impl PhotonMap {
    /// Radiance towards `wo` reflected at `p` from the photons within the
    /// radius, where photons carry the camera path's wavelengths, each
    /// photon in its own order (`path_caustics`): a photon counts at each
    /// wavelength the path still carries, by its flux there (its weight
    /// times the density `start` drew the wavelengths with). A photon that
    /// lost its secondaries to dispersion carries its hero four times over;
    /// as photons lead with each of the four in turn, every wavelength of
    /// the path gets its share, and a camera path that loses its own
    /// secondaries later may weight its hero up as it does for any light.
    /// The camera path may lead with any of the four too (one that follows
    /// a wavelength alone after dispersing).
    pub(super) fn gather_matched(
        &self,
        p: Vec3,
        wo: Vec3,
        bsdf: &Bsdf,
        wl: &SampledWavelengths,
        start: &SampledWavelengths,
        max_depth: u32,
    ) -> SampledSpectrum {
        if self.photons.is_empty() || self.radius <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        // The path's lane a is lane (a + path_lead) mod 4 of `start`.
        let Some(path_lead) = (0..4).find(|&a| start.lambda[a] == wl.lambda[0]) else {
            return SampledSpectrum::ZERO;
        };
        let r2 = self.radius * self.radius;
        let live = wl.pdf.cmpgt(Vec4::ZERO);
        let start_pdf = lanes_led_by(start.pdf, path_lead);
        let flux_per_weight = Vec4::select(live, 4.0 * start_pdf, Vec4::ZERO);
        let mut sum = SampledSpectrum::ZERO;
        let (buckets, n) = self.grid.buckets_near(p, self.radius);
        for &b in &buckets[..n] {
            for photon in &self.photons[self.grid.bucket_range(b)] {
                if photon.depth > max_depth || (photon.p - p).length_squared() > r2 {
                    continue;
                }
                // The photon's lane k is lane (k + lead) mod 4 of `start`,
                // the path's lane (k + lead − path_lead) mod 4.
                let lead = (0..4).find(|&a| start.lambda[a] == photon.lambda[0]);
                let Some(lead) = lead else {
                    continue;
                };
                let weight = lanes_led_by(photon.weight, (4 + path_lead - lead) % 4);
                sum += bsdf.f(wo, photon.wi, TransportMode::Radiance) * (weight * flux_per_weight);
            }
        }
        sum * (1.0 / (self.emitted as f32 * std::f32::consts::PI * r2))
    }

    /// Iteration `index`'s map of `n` photons, each traced by `trace_one`
    /// with a sampler of its own (which may store any number), in batches
    /// on every thread; the map is the same for any thread count.
    pub(super) fn traced(
        n: u32,
        seed: u64,
        index: u32,
        radius: f32,
        spectral_radius: f32,
        trace_one: impl Fn(&mut Sampler, &mut Vec<Photon>, &mut PathCounters) + Sync,
    ) -> (Self, PathCounters) {
        let batches: Vec<(Vec<Photon>, PathCounters)> = (0..n.div_ceil(PHOTON_BATCH))
            .into_par_iter()
            .map(|b| {
                let mut photons = Vec::new();
                let mut counters = PathCounters::default();
                for j in b * PHOTON_BATCH..((b + 1) * PHOTON_BATCH).min(n) {
                    let mut sampler = Sampler::for_sample(seed, j, PHOTON_ROW, index as u64);
                    trace_one(&mut sampler, &mut photons, &mut counters);
                }
                (photons, counters)
            })
            .collect();
        let mut counters = PathCounters::default();
        let mut photons = Vec::with_capacity(batches.iter().map(|b| b.0.len()).sum());
        for (batch, c) in batches {
            photons.extend_from_slice(&batch);
            counters.add(&c);
        }
        (
            Self::new(photons, n as u64, radius, spectral_radius),
            counters,
        )
    }

    /// The map of `photons`, out of `emitted` traced, with the iteration's
    /// kernels.
    pub(super) fn new(
        photons: Vec<Photon>,
        emitted: u64,
        radius: f32,
        spectral_radius: f32,
    ) -> Self {
        let (grid, order) =
            HashGrid::build(photons.iter().map(|p| p.p), photons.len(), 2.0 * radius);
        Self {
            photons: order.iter().map(|&i| photons[i as usize]).collect(),
            grid,
            emitted,
            radius,
            spectral_radius,
        }
    }

    /// Radiance towards `wo` reflected at `p` from the photons within the
    /// radius (and, in wavelength, within the spectral radius).
    pub(super) fn gather(
        &self,
        p: Vec3,
        wo: Vec3,
        bsdf: &Bsdf,
        wl: &SampledWavelengths,
        max_depth: u32,
    ) -> SampledSpectrum {
        if self.photons.is_empty() || self.radius <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        let r2 = self.radius * self.radius;
        let h = self.spectral_radius;
        let mut sum = SampledSpectrum::ZERO;
        let (buckets, n) = self.grid.buckets_near(p, self.radius);
        for &b in &buckets[..n] {
            for photon in &self.photons[self.grid.bucket_range(b)] {
                if photon.depth > max_depth || (photon.p - p).length_squared() > r2 {
                    continue;
                }
                // The photon's flux near each of the visible point's wavelengths.
                let mut near = SampledSpectrum::ZERO;
                for a in 0..4 {
                    if wl.pdf[a] == 0.0 {
                        continue;
                    }
                    for k in 0..4 {
                        if (photon.lambda[k] - wl.lambda[a]).abs() < h {
                            near[a] += photon.weight[k];
                        }
                    }
                }
                if near == SampledSpectrum::ZERO {
                    continue;
                }
                sum += bsdf.f(wo, photon.wi, TransportMode::Radiance) * near;
            }
        }
        let kernel = 1.0 / (self.emitted as f32 * std::f32::consts::PI * r2 * 2.0 * h);
        sum * kernel
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Frame;
    use crate::material::{DiffuseLobe, Lobe};

    /// One photon per lead, each carrying its lead wavelength alone (it
    /// dispersed), gathered by camera paths that lead with each of the
    /// four: every lane of the path gets the photon of its own wavelength.
    #[test]
    fn gather_matched_counts_each_photon_at_its_own_wavelength() {
        let start = SampledWavelengths {
            lambda: Vec4::new(420.0, 500.0, 580.0, 660.0),
            pdf: Vec4::new(0.5, 1.0, 2.0, 4.0) / 470.0,
        };
        // The photon led by lane j carries 10^j (distinct per lane).
        let photons: Vec<Photon> = (0..4)
            .map(|j| Photon {
                p: Vec3::ZERO,
                wi: Vec3::Z,
                lambda: start.led_by(j).lambda,
                weight: Vec4::new(10f32.powi(j as i32), 0.0, 0.0, 0.0),
                depth: 2,
            })
            .collect();
        let map = PhotonMap::new(photons, 1, 0.1, 0.0);
        let n = Vec3::Z;
        let bsdf = Bsdf::new(
            Frame::from_normal(n),
            n,
            Lobe::Diffuse(DiffuseLobe::new(Vec4::ONE)),
            n,
        );
        let f = std::f32::consts::FRAC_1_PI;
        let per_photon = f / (std::f32::consts::PI * 0.01);
        for k in 0..4 {
            let mut wl = start.led_by(k);
            let all = map.gather_matched(Vec3::ZERO, n, &bsdf, &wl, &start, 16);
            for a in 0..4 {
                let lane = (a + k) % 4; // of `start`
                let want = 10f32.powi(lane as i32) * 4.0 * start.pdf[lane] * per_photon;
                assert!(
                    (all[a] - want).abs() <= 1e-4 * want,
                    "lead {k}, lane {a}: {all}"
                );
            }
            // A path that kept its hero alone gathers at it alone.
            wl.terminate_secondary();
            let hero = map.gather_matched(Vec3::ZERO, n, &bsdf, &wl, &start, 16);
            let want = 10f32.powi(k as i32) * 4.0 * start.pdf[k] * per_photon;
            assert!(
                (hero.x - want).abs() <= 1e-4 * want && (hero.y, hero.z, hero.w) == (0.0, 0.0, 0.0)
            );
        }
    }
}
