//! The Trowbridge-Reitz (GGX) microfacet distribution with Smith masking,
//! and sampling of the normals visible from a direction (Heitz 2018,
//! "Sampling the GGX Distribution of Visible Normals"). All vectors are in
//! the local shading frame, normal +z.

use std::f32::consts::PI;

use glam::Vec3;

/// Below this α a surface is treated as perfectly smooth (a Dirac lobe).
pub const SMOOTH_ALPHA: f32 = 1e-3;

/// α from the user's roughness: α = roughness², as artists expect.
pub fn alpha_from_roughness(roughness: f32) -> f32 {
    (roughness * roughness).clamp(0.0, 1.0)
}

/// The mirror direction of `wo` about the unit normal `n`.
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    -wo + 2.0 * wo.dot(n) * n
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    pub alpha: f32,
}

impl Ggx {
    pub fn new(alpha: f32) -> Self {
        // Keep α away from 0: D() must stay finite where it is evaluated.
        Self {
            alpha: alpha.max(1e-4),
        }
    }

    pub fn is_smooth(&self) -> bool {
        self.alpha < SMOOTH_ALPHA
    }

    /// Microfacet normal density D(ωm) (per projected area).
    pub fn d(&self, wm: Vec3) -> f32 {
        let cos2 = wm.z * wm.z;
        if cos2 <= 0.0 {
            return 0.0;
        }
        let tan2 = (1.0 - cos2) / cos2;
        if !tan2.is_finite() {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let e = 1.0 + tan2 / a2;
        1.0 / (PI * a2 * cos2 * cos2 * e * e)
    }

    /// Smith's Λ(ω).
    pub fn lambda(&self, w: Vec3) -> f32 {
        let cos2 = w.z * w.z;
        if cos2 <= 0.0 {
            return f32::INFINITY;
        }
        let tan2 = (1.0 - cos2).max(0.0) / cos2;
        if !tan2.is_finite() {
            return f32::INFINITY;
        }
        ((1.0 + self.alpha * self.alpha * tan2).sqrt() - 1.0) * 0.5
    }

    pub fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking-shadowing G(ωo, ωi).
    pub fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Density of visible normals seen from ω: G1(ω)/|cos θ| · D(ωm) · |ω·ωm|.
    pub fn d_visible(&self, w: Vec3, wm: Vec3) -> f32 {
        let cos = w.z.abs();
        if cos == 0.0 {
            return 0.0;
        }
        self.g1(w) / cos * self.d(wm) * w.dot(wm).abs()
    }

    /// The reflection lobe without Fresnel, D(ωm)·G(ωo, ωi) / (4 cos θo cos θi),
    /// for ωo and ωi above the surface with half vector ωm.
    pub fn reflection(&self, wo: Vec3, wi: Vec3, wm: Vec3) -> f32 {
        self.d(wm) * self.g(wo, wi) / (4.0 * wo.z * wi.z)
    }

    /// Solid-angle density of ωi = reflect(ωo, ωm) when ωm is sampled by
    /// [`Ggx::sample_wm`] (the Jacobian of reflection is 1 / (4 |ωo·ωm|)).
    pub fn reflection_pdf(&self, wo: Vec3, wm: Vec3) -> f32 {
        self.d_visible(wo, wm) / (4.0 * wo.dot(wm).abs())
    }

    /// Samples a microfacet normal (upper hemisphere) with density
    /// `d_visible(w, ·)`.
    pub fn sample_wm(&self, w: Vec3, u: (f32, f32)) -> Vec3 {
        // Stretch to the hemisphere configuration.
        let mut wh = Vec3::new(self.alpha * w.x, self.alpha * w.y, w.z).normalize();
        if wh.z < 0.0 {
            wh = -wh;
        }
        let t1 = if wh.z < 0.999_99 {
            Vec3::Z.cross(wh).normalize()
        } else {
            Vec3::X
        };
        let t2 = wh.cross(t1);
        // Uniform disk sample, warped to the projected visible hemisphere.
        let r = u.0.sqrt();
        let phi = 2.0 * PI * u.1;
        let (mut px, mut py) = (r * phi.cos(), r * phi.sin());
        let h = (1.0 - px * px).max(0.0).sqrt();
        let t = (1.0 + wh.z) * 0.5;
        py = (1.0 - t) * h + t * py;
        px = px.clamp(-1.0, 1.0);
        let pz = (1.0 - px * px - py * py).max(0.0).sqrt();
        let nh = px * t1 + py * t2 + pz * wh;
        // Unstretch.
        Vec3::new(self.alpha * nh.x, self.alpha * nh.y, nh.z.max(1e-6)).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;

    #[test]
    fn projected_normal_density_integrates_to_one() {
        // ∫ D(ωm) cos θm dωm = 1, by a midpoint rule in (cos θ, φ).
        for alpha in [0.05f32, 0.3, 1.0] {
            let g = Ggx::new(alpha);
            let n = 4000;
            let mut sum = 0.0f64;
            for i in 0..n {
                let c = (i as f32 + 0.5) / n as f32;
                let wm = Vec3::new((1.0 - c * c).sqrt(), 0.0, c);
                sum += (g.d(wm) * c) as f64 * 2.0 * PI as f64 / n as f64;
            }
            assert!((sum - 1.0).abs() < 2e-2, "α {alpha}: {sum}");
        }
    }

    #[test]
    fn visible_normals_are_sampled_with_their_density() {
        // E[1/pdf] over samples equals the measure of the support the density
        // covers: ∫ over wm of d_visible/d_visible = area of hemisphere part.
        // Check instead the mean of cos(wo, wm) against quadrature.
        let g = Ggx::new(0.4);
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let mut s = Sampler::new(5, 9);
        let n = 200_000;
        let mut mean = 0.0f64;
        for _ in 0..n {
            let wm = g.sample_wm(wo, s.next_2d());
            assert!(wm.z > 0.0 && (wm.length() - 1.0).abs() < 1e-4);
            mean += wm.z as f64 / n as f64;
        }
        // Quadrature of ∫ d_visible(wo, wm) · wm.z dωm over the hemisphere.
        let (nt, np) = (800, 800);
        let mut quad = 0.0f64;
        let mut norm = 0.0f64;
        for i in 0..nt {
            let c = (i as f32 + 0.5) / nt as f32;
            let st = (1.0 - c * c).sqrt();
            for j in 0..np {
                let phi = 2.0 * PI * (j as f32 + 0.5) / np as f32;
                let wm = Vec3::new(st * phi.cos(), st * phi.sin(), c);
                let dv = g.d_visible(wo, wm) as f64 * if wo.dot(wm) > 0.0 { 1.0 } else { 0.0 };
                let dw = (1.0 / nt as f64) * (2.0 * PI as f64 / np as f64);
                quad += dv * c as f64 * dw;
                norm += dv * dw;
            }
        }
        assert!(
            (norm - 1.0).abs() < 1e-2,
            "visible normals integrate to {norm}"
        );
        assert!(
            (mean - quad / norm).abs() < 3e-3,
            "sampled {mean}, quadrature {}",
            quad / norm
        );
    }
}
