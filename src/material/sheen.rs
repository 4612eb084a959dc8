//! The sheen of cloth and dust (KHR_materials_sheen): the "Charlie"
//! microfibre distribution of Estevez & Kulla (2017),
//! D(h) = (2 + 1/r) sin^(1/r) θh / (2π), with Neubelt & Pettineo's
//! visibility V = 1 / (4 (cos θi + cos θo − cos θi cos θo)), so the lobe is
//! f = colour · D · V. The base below loses what the sheen reflects: its
//! directional albedo E(μ, r) (colour 1) is tabulated once by quadrature.

use std::f32::consts::PI;
use std::sync::OnceLock;

use glam::Vec3;

/// Table resolution in cos θ and in roughness.
const N: usize = 32;

/// Smallest r: sharper sheens are all at grazing angles, where the
/// quadrature (and the visibility approximation) lose their footing.
const MIN_R: f32 = 0.01;

/// The sheen lobe's value (colour 1) for the local directions `wo`, `wi`
/// (upper hemisphere) at roughness `r` (α = roughness², kept above 1e-3).
pub fn value(wo: Vec3, wi: Vec3, r: f32) -> f32 {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    let h = (wo + wi).normalize_or_zero();
    if h == Vec3::ZERO {
        return 0.0;
    }
    let r = r.max(MIN_R);
    let sin = (1.0 - h.z * h.z).max(0.0).sqrt();
    let d = (2.0 + 1.0 / r) * sin.powf(1.0 / r) / (2.0 * PI);
    let v = 1.0 / (4.0 * (wi.z + wo.z - wi.z * wo.z));
    d * v
}

/// The directional albedo ∫ f cos θi dωi of the sheen lobe (colour 1) seen
/// from cos θo = `mu`, at roughness `r`: bilinear in the table.
pub fn albedo(mu: f32, r: f32) -> f32 {
    let table = TABLE.get_or_init(tabulate);
    let x = (mu.clamp(0.0, 1.0) * (N - 1) as f32).min((N - 1) as f32 - 1e-4);
    let y = (r.clamp(0.0, 1.0) * (N - 1) as f32).min((N - 1) as f32 - 1e-4);
    let (i, j) = (x as usize, y as usize);
    let (fx, fy) = (x - i as f32, y - j as f32);
    let at = |i: usize, j: usize| table[j * N + i];
    let e = (at(i, j) * (1.0 - fx) + at(i + 1, j) * fx) * (1.0 - fy)
        + (at(i, j + 1) * (1.0 - fx) + at(i + 1, j + 1) * fx) * fy;
    e.clamp(0.0, 1.0)
}

static TABLE: OnceLock<Vec<f32>> = OnceLock::new();

/// E(μ, r) on an N × N grid, by a midpoint quadrature over the hemisphere.
fn tabulate() -> Vec<f32> {
    let (nt, np) = (96, 96);
    let mut out = vec![0.0; N * N];
    for j in 0..N {
        let r = (j as f32 / (N - 1) as f32).max(MIN_R);
        for i in 0..N {
            let mu = (i as f32 / (N - 1) as f32).max(1e-3);
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let mut sum = 0.0f64;
            for a in 0..nt {
                // cos θi uniform: dω = d(cos θ) dφ.
                let ct = (a as f32 + 0.5) / nt as f32;
                let st = (1.0 - ct * ct).sqrt();
                for b in 0..np {
                    let phi = (b as f32 + 0.5) / np as f32 * 2.0 * PI;
                    let wi = Vec3::new(st * phi.cos(), st * phi.sin(), ct);
                    sum += (value(wo, wi, r) * ct) as f64;
                }
            }
            out[j * N + i] = (sum * (2.0 * PI as f64) / (nt * np) as f64) as f32;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sheen_albedo_stays_below_one_and_grows_with_roughness() {
        for r in [0.1f32, 0.5, 1.0] {
            for mu in [0.05f32, 0.5, 1.0] {
                let e = albedo(mu, r);
                assert!((0.0..1.0).contains(&e), "E({mu}, {r}) = {e}");
            }
        }
        assert!(albedo(0.7, 1.0) > albedo(0.7, 0.2));
        // Reciprocal.
        let (a, b) = (
            Vec3::new(0.3, 0.1, 0.9).normalize(),
            Vec3::new(-0.6, 0.2, 0.4).normalize(),
        );
        assert!((value(a, b, 0.4) - value(b, a, 0.4)).abs() < 1e-6);
    }
}
