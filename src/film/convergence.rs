//! The error of a render estimated from how its image changes as samples
//! double. A pixel's samples are one Owen-scrambled Sobol sequence, which
//! converges faster than independent samples, so the spread of a pixel's
//! samples (`Film::estimated_rel_mse`) overstates its error more and more
//! as samples grow (2.5× at 64 spp on the Cornell Box). Its nested
//! prefixes do not: if the image of n samples has variance V(n) ∝ n^-α and
//! the two halves of its samples are alike, the images at n and n/2 differ
//! by D with E[D²] = V(n/2) − V(n) = V(n) (2^α − 1). Owen scrambling
//! converges at least as fast as independent samples (α ≥ 1), so D² is an
//! estimate of V(n) that errs high, by 2^α − 1 (α ≈ 1.2, 1.25× on the
//! Cornell Box), never low. Fitting α from a third image was tried: at a
//! few samples per pixel rare bright paths made it optimistic by 2–6×.

use super::Film;

/// Luminance means of a uniform render's region at the last two powers
/// of two of samples per pixel.
pub struct PrefixError {
    region: [u32; 4],
    /// (samples per pixel, each pixel's mean luminance), older first.
    snapshots: Vec<(u64, Vec<f32>)>,
}

/// Bytes per pixel that [`PrefixError`] holds.
/// ε of the relative MSE, (x − r)² / (r² + ε): keeps black pixels from
/// dominating (Rousselle et al. 2011 use 0.01 as well).
pub const REL_MSE_EPSILON: f64 = 1e-2;

pub const BYTES_PER_PIXEL: u64 = 2 * 4;

impl PrefixError {
    pub fn new(region: [u32; 4]) -> Self {
        Self {
            region,
            snapshots: Vec::with_capacity(2),
        }
    }

    /// Notes the film when every pixel of the region has `spp` samples
    /// (a power of two, at least 4, so that estimates start at 8 samples
    /// a pixel; other counts are ignored).
    pub fn record(&mut self, film: &Film, spp: u64) {
        if spp < 4 || !spp.is_power_of_two() || self.snapshots.last().is_some_and(|s| s.0 >= spp) {
            return;
        }
        let [x0, y0, x1, y1] = self.region;
        let means = (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .map(|(x, y)| film.luminance_and_variance(x, y).0 as f32)
            .collect();
        if self.snapshots.len() == 2 {
            self.snapshots.remove(0);
        }
        self.snapshots.push((spp, means));
    }

    /// The estimated relMSE (luminance, ε of `prism bench`) of the film at
    /// `spp` samples per pixel, once two successive powers of two are
    /// recorded: the mean weighted squared difference between them, scaled
    /// as independent samples would scale to `spp` (again erring high).
    pub fn estimate(&self, film: &Film, spp: u64) -> Option<f64> {
        let [(n0, a), (n1, b)] = self.snapshots.as_slice() else {
            return None;
        };
        if *n1 != 2 * n0 || spp < *n1 {
            return None;
        }
        let [x0, y0, x1, y1] = self.region;
        let mut d = 0.0f64;
        let pixels = (y0..y1).flat_map(|y| (x0..x1).map(move |x| (x, y)));
        for (i, (x, y)) in pixels.enumerate() {
            let m = film.luminance_and_variance(x, y).0;
            let w = 1.0 / (m * m + REL_MSE_EPSILON);
            d += w * (b[i] as f64 - a[i] as f64).powi(2);
        }
        Some(d / (a.len() as f64).max(1.0) * (*n1 as f64 / spp as f64))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::PixelSums;

    /// A film whose pixels hold the given luminance samples.
    fn film(w: u32, samples: &[Vec<f64>]) -> Film {
        Film::from_pixel_sums(w, samples.len() as u32 / w, |x, y| {
            let s = &samples[(y * w + x) as usize];
            PixelSums {
                xyz: glam::DVec3::splat(s.iter().sum()),
                y_squared: s.iter().map(|v| v * v).sum(),
                samples: s.len() as u64,
                rays: 0,
            }
        })
    }

    /// Independent samples (α = 1): the squared difference between the
    /// images of the first n/2 and all n samples estimates the variance of
    /// the mean, σ²/n, in the relMSE's weights.
    #[test]
    fn independent_samples_give_the_variance_of_the_mean() {
        let mut random = crate::test_random::XorShift64(0x2545_f491_4f6c_dd1d);
        let mut uniform = || random.next_f64();
        let (w, h, n) = (80u32, 50u32, 64usize);
        // Samples uniform on [0, 1): mean 0.5, variance 1/12.
        let samples: Vec<Vec<f64>> = (0..w * h)
            .map(|_| (0..n).map(|_| uniform()).collect())
            .collect();
        let firsts: Vec<Vec<f64>> = samples.iter().map(|s| s[..n / 2].to_vec()).collect();
        let (half, full) = (film(w, &firsts), film(w, &samples));
        let mut e = PrefixError::new([0, 0, w, h]);
        assert!(e.estimate(&full, n as u64).is_none());
        e.record(&half, n as u64 / 2);
        e.record(&full, 48); // not a power of two: ignored
        assert!(e.estimate(&full, n as u64).is_none());
        e.record(&full, n as u64);
        // Each pixel's weight uses its own mean, close to 0.5.
        let expected = (1.0 / 12.0) / n as f64 / (0.25 + REL_MSE_EPSILON);
        let estimate = e.estimate(&full, n as u64).unwrap();
        // 4000 pixels: the mean of squares is good to about 2.2%
        // (√(2/4000)), and the weights move it by about 1%; 5σ.
        assert!(
            (estimate / expected - 1.0).abs() < 0.12,
            "{estimate} vs {expected}"
        );
        // More samples than the last doubling: scaled as independent ones.
        let later = e.estimate(&full, 2 * n as u64).unwrap();
        assert!((later * 2.0 / estimate - 1.0).abs() < 1e-12);
    }
}
