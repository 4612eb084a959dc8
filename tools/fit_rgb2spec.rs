//! Fits the RGB → spectrum coefficient table of Jakob & Hanika 2019 for
//! linear sRGB under D65 and writes it in prism's binary table format.
//!
//!     cargo run --release --bin fit-rgb2spec -- spectra/rgb2spec_srgb.bin [RES]
//!
//! For every colour of a res³ grid (per largest component) it finds the
//! coefficients of `sigmoid(c0 t² + c1 t + c2)` whose reflectance under D65
//! has that colour, by Gauss-Newton on the CIELAB difference. Neighbouring
//! cells start from each other's solution, walking out from a mid brightness,
//! so that the solve stays in the basin of the smooth solution.

use std::time::Instant;

use glam::DVec3;
use prism::spectrum::cie;
use prism::spectrum::rgb2spec::Rgb2SpecTable;
use rayon::prelude::*;

/// One fitted cell: (z index, x index, coefficients, CIELAB residual).
type Cell = (usize, usize, [f64; 3], f64);

struct Problem {
    /// (t, x̄ȳz̄·D65 / Σ ȳ·D65) per 1 nm sample.
    samples: Vec<(f64, DVec3)>,
    white: DVec3,
    rgb_to_xyz: glam::DMat3,
}

impl Problem {
    fn new() -> Self {
        let c = cie::cmfs();
        let d65 = cie::d65();
        let mut samples = Vec::new();
        let mut norm = 0.0;
        for (i, bar) in c.xyz.iter().enumerate() {
            let lambda = (cie::CMF_START + i) as f32;
            let e = d65.eval(lambda) as f64;
            let t = prism::spectrum::rgb2spec::normalised_wavelength(lambda) as f64;
            samples.push((t, bar.as_dvec3() * e));
            norm += bar.y as f64 * e;
        }
        samples.iter_mut().for_each(|s| s.1 /= norm);
        let white = samples.iter().map(|s| s.1).sum();
        Self {
            samples,
            white,
            rgb_to_xyz: cie::XYZ_TO_SRGB.as_dmat3().inverse(),
        }
    }

    fn lab(&self, xyz: DVec3) -> DVec3 {
        fn f(t: f64) -> f64 {
            const D: f64 = 6.0 / 29.0;
            if t > D * D * D {
                t.cbrt()
            } else {
                t / (3.0 * D * D) + 4.0 / 29.0
            }
        }
        let (fx, fy, fz) = (
            f(xyz.x / self.white.x),
            f(xyz.y / self.white.y),
            f(xyz.z / self.white.z),
        );
        DVec3::new(116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz))
    }

    fn lab_of_coefficients(&self, c: [f64; 3]) -> DVec3 {
        let xyz: DVec3 = self
            .samples
            .iter()
            .map(|&(t, w)| {
                let x = (c[0] * t + c[1]) * t + c[2];
                w * (0.5 + x / (2.0 * (1.0 + x * x).sqrt()))
            })
            .sum();
        self.lab(xyz)
    }

    /// Gauss-Newton from `c`; returns the final CIELAB residual norm.
    fn solve(&self, rgb: DVec3, c: &mut [f64; 3]) -> f64 {
        let target = self.lab(self.rgb_to_xyz * rgb);
        let mut residual = f64::INFINITY;
        for _ in 0..50 {
            let r = self.lab_of_coefficients(*c) - target;
            residual = r.length();
            if residual < 1e-6 {
                break;
            }
            let mut jac = glam::DMat3::ZERO;
            for k in 0..3 {
                let h = 1e-4;
                let (mut lo, mut hi) = (*c, *c);
                lo[k] -= h;
                hi[k] += h;
                let col = (self.lab_of_coefficients(hi) - self.lab_of_coefficients(lo)) / (2.0 * h);
                *jac.col_mut(k) = col;
            }
            if jac.determinant().abs() < 1e-15 {
                break;
            }
            // Gauss-Newton step, halved until it reduces the residual: the
            // full step overshoots for dark saturated colours.
            let step = jac.inverse() * r;
            let mut scale = 1.0;
            let mut accepted = false;
            for _ in 0..20 {
                let trial = [
                    c[0] - scale * step[0],
                    c[1] - scale * step[1],
                    c[2] - scale * step[2],
                ];
                if (self.lab_of_coefficients(trial) - target).length() < residual {
                    *c = trial;
                    accepted = true;
                    break;
                }
                scale *= 0.5;
            }
            if !accepted {
                break;
            }
            // Keep the polynomial bounded: very large coefficients only make
            // the sigmoid a step, and the solve diverges.
            let m = c.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            if m > 200.0 {
                c.iter_mut().for_each(|v| *v *= 200.0 / m);
            }
        }
        residual
    }
}

fn smoothstep(x: f64) -> f64 {
    x * x * (3.0 - 2.0 * x)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let out = args
        .get(1)
        .map(String::as_str)
        .unwrap_or("spectra/rgb2spec_srgb.bin");
    let res: usize = args
        .get(2)
        .map(|r| r.parse().expect("RES is a number"))
        .unwrap_or(32);
    let start = Instant::now();
    let problem = Problem::new();
    let scale: Vec<f64> = (0..res)
        .map(|k| smoothstep(smoothstep(k as f64 / (res - 1) as f64)))
        .collect();
    let first = res / 5;

    // One task per (largest component, y index); each walks z out from `first`.
    let tasks: Vec<(usize, usize)> = (0..3).flat_map(|l| (0..res).map(move |j| (l, j))).collect();
    let results: Vec<(usize, usize, Vec<Cell>)> = tasks
        .par_iter()
        .map(|&(l, j)| {
            let mut cells = Vec::new();
            for i in 0..res {
                let x = i as f64 / (res - 1) as f64;
                let y = j as f64 / (res - 1) as f64;
                let fit = |k: usize, c: &mut [f64; 3]| {
                    let z = scale[k];
                    let mut rgb = [0.0; 3];
                    rgb[l] = z;
                    rgb[(l + 1) % 3] = x * z;
                    rgb[(l + 2) % 3] = y * z;
                    let err = problem.solve(DVec3::from_array(rgb), c);
                    (k, i, *c, err)
                };
                let mut c = [0.0; 3];
                for k in first..res {
                    cells.push(fit(k, &mut c));
                }
                let mut c = cells[cells.len() - (res - first)].2;
                for k in (0..first).rev() {
                    cells.push(fit(k, &mut c));
                }
            }
            (l, j, cells)
        })
        .collect();

    let mut data = vec![[0.0f32; 3]; 3 * res * res * res];
    // Very dark saturated colours (largest component below ~0.05) and the
    // most saturated bright ones lie outside what a smooth reflectance
    // reaches; report them apart from the rest.
    let (mut worst, mut poor) = (0.0f64, 0usize);
    for (l, j, cells) in results {
        for (k, i, c, err) in cells {
            if scale[k] >= 0.05 {
                worst = worst.max(err);
            }
            if err > 1e-2 {
                poor += 1;
            }
            data[((l * res + k) * res + j) * res + i] = [c[0] as f32, c[1] as f32, c[2] as f32];
        }
    }
    let table = Rgb2SpecTable {
        res,
        scale: scale.iter().map(|&s| s as f32).collect(),
        data,
    };
    std::fs::write(out, table.to_bytes()).expect("write the table");
    println!(
        "wrote {out}: resolution {res}, {poor} of {} cells off by more than 0.01 ΔE(Lab), \
         worst {worst:.2} where the largest component ≥ 0.05, {:.1} s",
        3 * res * res * res,
        start.elapsed().as_secs_f64()
    );
}
