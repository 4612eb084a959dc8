//! Adaptive sampling: a pilot of every pixel's first samples chooses how
//! many samples each pixel takes, and passes advance every pixel by the
//! same share of its count.

use crate::film::convergence::REL_MSE_EPSILON;
use crate::film::Film;

/// Samples per pixel of the adaptive pilot for an average of `spp`: a
/// sixteenth, at least 4, at most 64, and at most `spp` (the pilot's
/// samples are the image's first); below 8 samples, 2, which leaves
/// something to spend (a pixel's count follows its ~80 neighbours'
/// errors, so two samples each are enough to go by). Cornell 512², two
/// seeds: at 4 spp a pilot of 2 lowers the variance 10% (a pilot of 4 is
/// every sample: uniform); at 8 spp 2 and 4 are within 1.5%; at 16 spp 2
/// is 1.7% worse than 4.
pub fn pilot_spp(spp: u32) -> u32 {
    let pilot = if spp < 8 { 2 } else { (spp / 16).clamp(4, 64) };
    pilot.min(spp)
}

/// Where an adaptive pixel with `target` samples stands when the render has
/// advanced `k` of its `spp` samples a pixel (the index its samples reach):
/// during the pilot, at `k`; after it, at the same share of its own count
/// past the pilot as the render is of `spp`, reaching `target` at `spp`.
/// So every pass spreads over the whole image (a pass that advanced only
/// the pixels still short of their counts would leave threads idle on the
/// few tiles holding them), and a render stopped early by a time budget or
/// an error target is adaptive already, each pixel with its share.
pub fn progress(k: u32, target: u32, pilot: u32, spp: u32) -> u32 {
    if k <= pilot || spp <= pilot {
        return k.min(target);
    }
    let past = u64::from(target.saturating_sub(pilot)) * u64::from(k - pilot);
    pilot + (past / u64::from(spp - pilot)) as u32
}

/// Pixels on each side of a pixel whose pilot errors decide its count
/// (Cornell Box, 64 spp: radius 1, 3 and 6 lowered the variance 6%, 9%
/// and 10%).
const ADAPTIVE_RADIUS: i64 = 4;

/// Counts follow the relative error per sample to this power. The
/// Lagrange optimum for independent samples (variance σ²/n) is 1; Sobol
/// points converge faster (variance ∝ n^-α, α > 1), which flattens the
/// optimum to 2/(1 + α). Cornell Box, 64 spp: 0.7 and 1 lowered the
/// variance 10% and 9%, 1.4 only 4%.
const ADAPTIVE_POWER: f64 = 0.75;

/// Fixed cost of a sample, in rays: the camera ray's set-up, the sampler,
/// adding the sample to the film. So that a pixel whose paths end at once
/// (sky, a light seen directly) does not look nearly free.
const SAMPLE_OVERHEAD_RAYS: f64 = 1.0;

/// Adaptive sampling: how many samples each pixel of `region` takes so
/// that they average `spp`, from a film holding the first `pilot` samples
/// of every pixel. Each pixel gets at least a quarter of `spp` (and the
/// pilot); the rest goes in proportion to a power (`ADAPTIVE_POWER`) of
/// the relative error per sample, σ / √(mean² + 0.01) (luminance, the ε
/// of the relMSE), over the square root of the cost of a sample (the rays
/// it traced, and `SAMPLE_OVERHEAD_RAYS`): the counts that lower the summed
/// relative variance σ²/(n (mean² + ε)) most for the CPU time they take
/// (Lagrange: n ∝ σ/√cost). Without the cost, samples moved to the pixels
/// whose paths are long, and the render took 8–35% more CPU time for the
/// same samples, eating most of the variance it saved. At most 16 × `spp`.
///
/// A pixel's error and cost are the means of its neighbours' (the pixels
/// within `ADAPTIVE_RADIUS`, itself and its 2 × 2 block left out): a few
/// pilot samples give a noisy error per pixel, and a count that followed
/// it would chase the noise. Leaving the pixel out keeps the image
/// unbiased with the pilot in it (and its block, whose pilot samples may
/// share its paths, `reuse`): a pixel's count does not depend on its own
/// samples, so its value is
/// the mean of a number of samples fixed independently of them (but for
/// the budget's normalisation over the region, in which its samples weigh
/// about one part in the region's pixels).
pub fn targets(film: &Film, region: [u32; 4], spp: u32, pilot: u32) -> Vec<u32> {
    let [x0, y0, x1, y1] = region;
    let (w, h) = (
        x1.saturating_sub(x0) as usize,
        y1.saturating_sub(y0) as usize,
    );
    let per_pixel = |f: &dyn Fn(u32, u32) -> f64| -> Vec<f64> {
        (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .map(|(x, y)| f(x, y))
            .map(|v| if v.is_finite() { v } else { 0.0 })
            .collect()
    };
    let errors = per_pixel(&|x, y| {
        let (m, var_of_mean) = film.luminance_and_variance(x, y);
        let n = film.sums(x, y).samples as f64;
        let sigma = (var_of_mean * n).max(0.0).sqrt();
        sigma / (m * m + REL_MSE_EPSILON).sqrt()
    });
    let costs = per_pixel(&|x, y| {
        let s = film.sums(x, y);
        s.rays as f64 / s.samples.max(1) as f64 + SAMPLE_OVERHEAD_RAYS
    });
    let (errors, costs) = (
        neighbours_mean(&errors, w, h, (x0, y0)),
        neighbours_mean(&costs, w, h, (x0, y0)),
    );
    let scores: Vec<f64> = errors
        .iter()
        .zip(&costs)
        .map(|(&e, &c)| match e / c.sqrt() {
            s if s.is_finite() && s > 0.0 => s.powf(ADAPTIVE_POWER),
            _ => 0.0,
        })
        .collect();
    let scores = block_means(&scores, w, h, (x0, y0));
    let floor = (spp / 4).max(pilot).max(1).min(spp.max(1));
    let cap = spp.saturating_mul(16).max(floor);
    let spare = (spp - floor.min(spp)) as f64 * scores.len() as f64;
    let total: f64 = scores.iter().sum();
    scores
        .iter()
        .map(|&e| {
            let share = if total > 0.0 {
                spare * e / total
            } else {
                (spp - floor.min(spp)) as f64
            };
            (floor + share.round() as u32).min(cap)
        })
        .collect()
}

/// Each of a `w` × `h` image's values replaced by the mean of the values
/// within `ADAPTIVE_RADIUS` of it, leaving out its own and those of its
/// 2 × 2 block of the image (`x0`, `y0`: the image's pixel at the first
/// value), whose paths the path tracer may share with its own (`reuse`);
/// 0 with no neighbour.
fn neighbours_mean(values: &[f64], w: usize, h: usize, (x0, y0): (u32, u32)) -> Vec<f64> {
    // Summed-area table: each window's sum in four lookups.
    let mut table = vec![0.0f64; (w + 1) * (h + 1)];
    for y in 0..h {
        let mut row = 0.0;
        for x in 0..w {
            row += values[y * w + x];
            table[(y + 1) * (w + 1) + x + 1] = table[y * (w + 1) + x + 1] + row;
        }
    }
    let r = ADAPTIVE_RADIUS;
    let at = |x: usize, y: usize| table[y * (w + 1) + x];
    let sum = |(ax, ay): (i64, i64), (bx, by): (i64, i64)| {
        let (ax, bx) = (
            ax.clamp(0, w as i64) as usize,
            bx.clamp(0, w as i64) as usize,
        );
        let (ay, by) = (
            ay.clamp(0, h as i64) as usize,
            by.clamp(0, h as i64) as usize,
        );
        let count = (bx.saturating_sub(ax) * by.saturating_sub(ay)) as f64;
        (at(bx, by) - at(ax, by) - at(bx, ay) + at(ax, ay), count)
    };
    (0..h as i64)
        .flat_map(|y| (0..w as i64).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (window, in_window) = sum((x - r, y - r), (x + r + 1, y + r + 1));
            let (bx, by) = (block_start(x, x0), block_start(y, y0));
            let (block, in_block) = sum((bx, by), (bx + 2, by + 2));
            let count = in_window - in_block;
            if count > 0.0 {
                ((window - block) / count).max(0.0)
            } else {
                0.0
            }
        })
        .collect()
}

/// Each value replaced by the mean of its 2 × 2 block of the image's (as
/// far as the region holds it; `x0`, `y0` as in `neighbours_mean`): the
/// pixels of a block take the same count, so the path tracer's groups of
/// a block's samples (`reuse`) stay whole at every sample index. With
/// counts pixel by pixel they came apart, and adaptive sampling raised the
/// Cornell Box's relMSE × CPU 8–13% at 16 and 64 samples.
fn block_means(values: &[f64], w: usize, h: usize, (x0, y0): (u32, u32)) -> Vec<f64> {
    (0..h as i64)
        .flat_map(|y| (0..w as i64).map(move |x| (x, y)))
        .map(|(x, y)| {
            let (bx, by) = (block_start(x, x0).max(0), block_start(y, y0).max(0));
            let block = (by..(by + 2).min(h as i64))
                .flat_map(|y| (bx..(bx + 2).min(w as i64)).map(move |x| (x, y)));
            let (sum, n) = block.fold((0.0, 0.0), |(s, n), (x, y)| {
                (s + values[y as usize * w + x as usize], n + 1.0)
            });
            sum / n
        })
        .collect()
}

/// The first pixel of the 2 × 2 block of the image holding the region's
/// pixel `i` (along one axis; `origin`: the image's pixel at the region's
/// first), in the region's coordinates (−1 where the region starts at the
/// block's second pixel).
fn block_start(i: i64, origin: u32) -> i64 {
    i - (i + origin as i64) % 2
}

/// What a render asks for that adaptive sampling would spoil: the reason a
/// render whose scene asks for it samples every pixel alike instead, for a
/// line on the terminal. `integrator_adapts`: the integrator takes a
/// scene's adaptive sampling (`RenderSettings::adaptive`); `part` is a
/// render of some sample indices or some pixels only, for `prism merge`.
pub fn uniform_instead(
    integrator_adapts: bool,
    part: bool,
    target_error: bool,
) -> Option<&'static str> {
    if !integrator_adapts {
        Some("uniform sampling: the scene asks for adaptive sampling, which only the path tracer takes (`path`; splats have no per-pixel error, and other integrators' counts were not measured to help)")
    } else if part {
        // Merged parts must each hold the same sample indices in every
        // pixel: adaptive counts differ pixel by pixel.
        Some("uniform sampling: this is a part of a render (a sample range or a tile), and `prism merge` joins parts that hold the same samples in every pixel")
    } else if target_error {
        // Adaptive renders estimate their error from the spread of each
        // pixel's samples, which overstates the error of Sobol points
        // (docs/features.md, "Error target"): the render would run on.
        Some("uniform sampling: an error target is estimated best from uniform samples (adaptive ones would overstate it and render longer)")
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pilots_leave_samples_to_spend() {
        let pilots: Vec<u32> = [1, 2, 4, 7, 8, 16, 64, 256, 1024, 4096]
            .map(pilot_spp)
            .to_vec();
        assert_eq!(pilots, [1, 2, 2, 2, 4, 4, 4, 16, 64, 64]);
    }

    #[test]
    fn adaptive_passes_advance_every_pixel_by_its_share() {
        let (pilot, spp) = (4, 64);
        let targets = [16, 64, 100, 142, 1024];
        for &t in &targets {
            // The pilot as it is; the whole count at the end; never back.
            for k in 0..=pilot {
                assert_eq!(progress(k, t, pilot, spp), k);
            }
            assert_eq!(progress(spp, t, pilot, spp), t);
            let steps: Vec<u32> = (0..=spp).map(|k| progress(k, t, pilot, spp)).collect();
            assert!(steps.windows(2).all(|w| w[0] <= w[1]), "{steps:?}");
        }
        // Halfway through the rest, each pixel is halfway through its own rest.
        let half = pilot + (spp - pilot) / 2;
        assert_eq!(progress(half, 142, pilot, spp), 4 + 69);
        assert_eq!(progress(half, 16, pilot, spp), 4 + 6);
        // A pass's samples spread over the pixels in proportion to their
        // counts: counts averaging 64 take the pass's 16 samples a pixel on
        // average (within rounding), not 16 each until some are full.
        let counts = [16u32, 40, 64, 88, 112];
        let taken: u32 = counts
            .iter()
            .map(|&t| progress(36, t, pilot, spp) - progress(20, t, pilot, spp))
            .sum();
        assert!((taken as i32 - 16 * 5).abs() <= 5, "{taken}");
        // Budgets no bigger than the pilot: every pixel takes them all.
        assert_eq!(progress(3, 4, 4, 4), 3);
    }

    /// A film whose pixels have `n` samples of luminance `value(x, y)`
    /// half the time and 0 otherwise (variance from the spread).
    fn pilot_film(w: u32, h: u32, n: u64, value: impl Fn(u32, u32) -> f64) -> Film {
        costly_pilot_film(w, h, n, value, |_, _| 0)
    }

    /// The same, each sample having traced `rays(x, y)` rays.
    fn costly_pilot_film(
        w: u32,
        h: u32,
        n: u64,
        value: impl Fn(u32, u32) -> f64,
        rays: impl Fn(u32, u32) -> u64,
    ) -> Film {
        Film::from_pixel_sums(w, h, |x, y| {
            let v = value(x, y);
            crate::film::PixelSums {
                xyz: glam::DVec3::splat(v * n as f64 / 2.0),
                y_squared: v * v * n as f64 / 2.0,
                samples: n,
                rays: rays(x, y) * n,
            }
        })
    }

    #[test]
    fn costly_pixels_take_fewer_samples_for_the_same_error() {
        // Equal errors everywhere; the left half's samples trace 15 rays,
        // the right half's none (cost 16 against 1 with the overhead).
        let (w, h, spp, pilot) = (32, 16, 64, 4);
        let rays = |x: u32, _| if x < w / 2 { 15 } else { 0 };
        let film = costly_pilot_film(w, h, pilot as u64, |_, _| 1.0, rays);
        let t = targets(&film, [0, 0, w, h], spp, pilot);
        let mean = t.iter().map(|&n| n as f64).sum::<f64>() / t.len() as f64;
        assert!((mean - spp as f64).abs() < 1.0, "mean {mean}");
        // Far from the edge: spare samples in the ratio (1/√16)^0.75 = 0.35.
        let (costly, cheap) = (t[8 * w as usize + 2] - 16, t[8 * w as usize + 29] - 16);
        let ratio = costly as f64 / cheap as f64;
        assert!((ratio - 0.354).abs() < 0.02, "{costly} vs {cheap}");
        // A pixel's own cost does not move its count, only its neighbours'
        // (and, through the budget's normalisation, every count alike: the
        // pixel keeps the count of a far pixel of equal score).
        let (px, py) = (24u32, 8u32);
        let far = (w + 30) as usize;
        assert_eq!(t[(py * w + px) as usize], t[far]);
        let own = |x, y| if (x, y) == (px, py) { 1000 } else { rays(x, y) };
        let u = targets(
            &costly_pilot_film(w, h, pilot as u64, |_, _| 1.0, own),
            [0, 0, w, h],
            spp,
            pilot,
        );
        let i = (py * w + px) as usize;
        assert_eq!(u[i], u[far]);
        assert!(u[i] > t[i], "the others gain what its neighbours lose");
        // A neighbour outside its 2 × 2 block (x 24–25, y 8–9).
        assert!(
            u[i + 2] < t[i + 2],
            "a neighbour: {} vs {}",
            u[i + 2],
            t[i + 2]
        );
    }

    #[test]
    fn adaptive_counts_follow_the_neighbours_error_never_the_pixels_own() {
        // The left half is noisy, the right half has no spread.
        let (w, h, spp, pilot) = (32, 16, 64, 4);
        let base = pilot_film(w, h, pilot as u64, |x, _| if x < w / 2 { 1.0 } else { 0.0 });
        let t = targets(&base, [0, 0, w, h], spp, pilot);
        let mean = t.iter().map(|&n| n as f64).sum::<f64>() / t.len() as f64;
        assert!((mean - spp as f64).abs() < 1.0, "mean {mean}");
        assert!(t.iter().all(|&n| (spp / 4..=16 * spp).contains(&n)));
        // Each 2 × 2 block of pixels takes one count.
        let w = w as usize;
        for (y, x) in (0..h as usize)
            .step_by(2)
            .flat_map(|y| (0..w).step_by(2).map(move |x| (y, x)))
        {
            let i = y * w + x;
            assert!(
                [i + 1, i + w, i + w + 1].iter().all(|&k| t[k] == t[i]),
                "block at {x}, {y}"
            );
        }
        let w = w as u32;
        // Far from the edge: noisy pixels take the floor and nearly twice
        // the spare samples (half the pixels share most of them), quiet
        // ones the floor.
        assert!(
            t[8 * w as usize + 2] >= 16 + 3 * 48 / 2,
            "{}",
            t[8 * w as usize + 2]
        );
        assert_eq!(t[8 * w as usize + 29], spp / 4);
        // Making one pixel's own samples wildly noisier changes no count
        // of its own or of its 2 × 2 block (which may share its paths),
        // only its other neighbours'.
        let (px, py) = (24u32, 8u32);
        let changed = pilot_film(w, h, pilot as u64, |x, y| {
            if (x, y) == (px, py) {
                50.0
            } else if x < w / 2 {
                1.0
            } else {
                0.0
            }
        });
        let u = targets(&changed, [0, 0, w, h], spp, pilot);
        let i = (py * w + px) as usize;
        assert_eq!(u[i], t[i]);
        let block = [i + 1, i + w as usize, i + w as usize + 1];
        assert!(block.iter().all(|&k| u[k] == t[k]), "its block");
        assert!(
            u[i + 2] > t[i + 2],
            "a neighbour: {} vs {}",
            u[i + 2],
            t[i + 2]
        );
    }
}
