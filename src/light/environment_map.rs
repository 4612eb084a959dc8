//! An environment map: radiance at infinity from an equirectangular
//! (latitude-longitude) image, +y up. The top row is the zenith, the
//! image's centre looks along +z (what a camera looking along +z sees), and
//! u grows towards +x. `rotate` turns the map about +y (positive: from +z
//! towards +x).
//!
//! RGB radiance becomes a spectrum the way an illuminant does: each texel's
//! chromaticity as a smooth spectrum (Jakob–Hanika) times D65, normalised so
//! that RGB (1, 1, 1) has luminance 1 (pbrt-v4's RGBIlluminantSpectrum).
//! Texels are constant over their solid angle (nearest lookup), and light
//! sampling picks them with a piecewise-constant 2D distribution
//! proportional to luminance × sin θ, so directions follow the radiance.

use std::f32::consts::PI;

use glam::Vec3;

use super::lat_long::SphericalDistribution;
use super::{LightLeSample, LightLiSample, SceneSphere};
use crate::spectrum::cie;
use crate::spectrum::rgb2spec::{self, SigmoidPolynomial};
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum};

#[derive(Clone, Debug)]
pub struct EnvironmentMap {
    width: usize,
    /// Per texel: sigmoid coefficients and scale (user scale and the D65
    /// normalisation included).
    texels: Vec<[f32; 4]>,
    d65: Spectrum,
    /// The grid of texels, and light sampling over it.
    sphere: SphericalDistribution,
    /// Mean luminance over the sphere (for the light's power).
    mean_luminance: f64,
    scene: SceneSphere,
}

impl EnvironmentMap {
    /// A map of `width` × `height` linear sRGB radiances, rows from the top,
    /// times `scale`, turned by `rotate_degrees` about +y. Values must be
    /// finite and not negative (the loader checks, naming the file).
    pub fn new(width: usize, height: usize, rgb: &[Vec3], scale: f32, rotate_degrees: f32) -> Self {
        assert_eq!(rgb.len(), width * height);
        let d65 = cie::d65();
        let y_d65 = cie::spectrum_to_xyz(&Spectrum::Table(d65.clone())).y;
        let mut texels = Vec::with_capacity(rgb.len());
        let mut weights = Vec::with_capacity(rgb.len());
        let mut luminance_integral = 0.0f64;
        for (k, &c) in rgb.iter().enumerate() {
            let c = c.max(Vec3::ZERO) * scale;
            let (s, sc) = rgb2spec::unbounded(c);
            texels.push([s.c[0], s.c[1], s.c[2], sc / y_d65]);
            let y = (0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z) as f64;
            let row = k / width;
            let theta = PI * (row as f32 + 0.5) / height as f32;
            weights.push(y * theta.sin() as f64);
            // Solid angle of the texel: Δφ (cos θ₀ − cos θ₁).
            let (t0, t1) = (
                PI * row as f32 / height as f32,
                PI * (row + 1) as f32 / height as f32,
            );
            luminance_integral += y * (2.0 * PI / width as f32 * (t0.cos() - t1.cos())) as f64;
        }
        Self {
            width,
            texels,
            d65: Spectrum::Table(d65.clone()),
            sphere: SphericalDistribution::new(&weights, width, height, rotate_degrees),
            mean_luminance: luminance_integral / (4.0 * PI as f64),
            scene: SceneSphere::default(),
        }
    }

    /// The same light for a scene within `scene`.
    pub fn with_scene(self, scene: SceneSphere) -> Self {
        Self { scene, ..self }
    }

    /// The shape its texels share: D65, which each texel's smooth factor
    /// (its colour) multiplies.
    pub fn spectrum(&self) -> &Spectrum {
        &self.d65
    }

    /// Mean luminance × 4π × the scene's cross-section.
    pub fn power(&self) -> f64 {
        let r = self.scene.radius as f64;
        self.mean_luminance * 4.0 * std::f64::consts::PI * std::f64::consts::PI * r * r
    }

    /// Radiance arriving from direction `w` (towards the sky).
    pub fn radiance(&self, w: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        self.texel_radiance(self.sphere.cell(self.sphere.uv(w)), wl)
    }

    /// `radiance(w)` and `pdf_li(w)` from one inverse map of `w`.
    pub fn radiance_and_pdf(&self, w: Vec3, wl: &SampledWavelengths) -> (SampledSpectrum, f32) {
        let cell = self.sphere.cell(self.sphere.uv(w));
        (
            self.texel_radiance(cell, wl),
            self.sphere.pdf_in_cell(cell, w),
        )
    }

    /// The radiance of the texel at `cell` (column, row).
    fn texel_radiance(&self, (i, j): (usize, usize), wl: &SampledWavelengths) -> SampledSpectrum {
        let [c0, c1, c2, scale] = self.texels[j * self.width + i];
        if scale == 0.0 {
            return SampledSpectrum::ZERO;
        }
        let smooth = SigmoidPolynomial { c: [c0, c1, c2] }.sample(wl.lambda);
        smooth * self.d65.sample(wl) * scale
    }

    /// Solid-angle density of `sample_li` for direction `w` (towards the sky).
    pub fn pdf_li(&self, w: Vec3) -> f32 {
        self.sphere.pdf(w)
    }

    /// Light from a direction drawn in proportion to the map's luminance;
    /// its radiance is the texel it was drawn in.
    pub fn sample_li(&self, u: (f32, f32), wl: &SampledWavelengths) -> Option<LightLiSample> {
        let s = self.sphere.sample(u)?;
        LightLiSample::from_infinity(s.w, self.texel_radiance(s.cell, wl), s.pdf)
    }

    /// A ray into the scene: a direction from the map's distribution, from
    /// a uniform point of the disc of the scene's radius facing it.
    pub fn sample_le(
        &self,
        u_pos: (f32, f32),
        u_dir: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLeSample> {
        let s = self.sphere.sample(u_dir)?;
        self.scene
            .ray_from_infinity(-s.w, u_pos, self.texel_radiance(s.cell, wl), s.pdf)
    }

    /// Densities of `sample_le` for a ray travelling along `dir`.
    pub fn pdf_le(&self, dir: Vec3) -> (f32, f32) {
        (self.scene.disc_pdf(), self.pdf_li(-dir))
    }
}

light_at_infinity!(EnvironmentMap, |l| Some(EnvironmentMap::spectrum(l)));

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    fn map(width: usize, height: usize, f: impl Fn(usize, usize) -> Vec3) -> EnvironmentMap {
        let rgb: Vec<Vec3> = (0..height)
            .flat_map(|j| (0..width).map(move |i| (i, j)))
            .map(|(i, j)| f(i, j))
            .collect();
        EnvironmentMap::new(width, height, &rgb, 1.0, 30.0)
    }

    #[test]
    fn directions_and_map_coordinates_invert() {
        let m = map(8, 4, |_, _| Vec3::ONE);
        for uv in [
            Vec2::new(0.1, 0.2),
            Vec2::new(0.77, 0.5),
            Vec2::new(0.5, 0.9),
        ] {
            let (w, _) = m.sphere.direction(uv);
            assert!((w.length() - 1.0).abs() < 1e-5);
            assert!(
                (m.sphere.uv(w) - uv).length() < 1e-4,
                "{uv} → {w} → {}",
                m.sphere.uv(w)
            );
        }
        // Unrotated, the image's centre looks along +z and its top is +y.
        let m = EnvironmentMap::new(2, 2, &[Vec3::ONE; 4], 1.0, 0.0);
        assert!((m.sphere.direction(Vec2::new(0.5, 0.5)).0 - Vec3::Z).length() < 1e-5);
        assert!(m.sphere.direction(Vec2::new(0.3, 0.01)).0.y > 0.99);
    }

    #[test]
    fn sampling_density_matches_pdf_and_integrates_to_one() {
        let m = map(16, 8, |i, j| {
            Vec3::new(1.0 + i as f32, 0.5 + (i * j) as f32 * 0.1, 0.2)
        });
        let mut s = crate::sampler::Sampler::new(5, 9);
        for _ in 0..2000 {
            let d = m.sphere.sample(s.next_2d()).unwrap();
            let (w, pdf) = (d.w, d.pdf);
            assert!(
                (m.pdf_li(w) - pdf).abs() <= 1e-4 * pdf,
                "{} vs {pdf}",
                m.pdf_li(w)
            );
        }
        // ∫ pdf dω over the sphere by a fine grid.
        let (n_t, n_p) = (400, 800);
        let mut total = 0.0f64;
        for a in 0..n_t {
            let theta = PI * (a as f32 + 0.5) / n_t as f32;
            for b in 0..n_p {
                let phi = 2.0 * PI * (b as f32 + 0.5) / n_p as f32;
                let w = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                );
                let d_omega = theta.sin() * (PI / n_t as f32) * (2.0 * PI / n_p as f32);
                total += (m.pdf_li(w) * d_omega) as f64;
            }
        }
        assert!((total - 1.0).abs() < 2e-3, "{total}");
    }

    /// Light sampling takes the radiance of the texel it drew and escaped
    /// rays answer radiance and density from one lookup: both must be what
    /// `radiance(w)` and `pdf_li(w)` say of the same direction, or MIS
    /// would weigh the two strategies by different densities.
    #[test]
    fn sampled_and_escaped_lookups_agree_with_the_direction() {
        let m = map(16, 8, |i, j| {
            Vec3::new(1.0 + i as f32, 0.3 * j as f32, 0.2 + (i % 3) as f32)
        });
        let mut s = crate::sampler::Sampler::new(3, 7);
        let wl = SampledWavelengths::sample_visible(0.37);
        let (n, mut other_cell) = (4000, 0);
        for _ in 0..n {
            let u = s.next_2d();
            let d = m.sphere.sample(u).unwrap();
            let li = m.sample_li(u, &wl).unwrap();
            assert_eq!((li.wi, li.pdf), (d.w, d.pdf));
            let (le, pdf) = m.radiance_and_pdf(d.w, &wl);
            assert_eq!((le, pdf), (m.radiance(d.w, &wl), m.pdf_li(d.w)));
            // The inverse map may round a direction drawn on a texel's
            // edge into its neighbour; anywhere else it finds the texel.
            if m.sphere.cell(m.sphere.uv(d.w)) == d.cell {
                assert_eq!(li.li, le);
                assert!((pdf - d.pdf).abs() <= 1e-4 * d.pdf, "{pdf} vs {}", d.pdf);
            } else {
                other_cell += 1;
            }
        }
        assert!(
            other_cell * 1000 < n,
            "{other_cell} of {n} in another texel"
        );
    }

    #[test]
    fn grey_texels_are_d65_of_their_luminance() {
        let m = map(4, 2, |_, _| Vec3::splat(0.5));
        // The spectrum's luminance, integrated over the CMFs, is 0.5.
        let mut y = 0.0;
        let n = 4000;
        for k in 0..n {
            let wl = SampledWavelengths::sample_visible((k as f32 + 0.5) / n as f32);
            let l = m.radiance(Vec3::Z, &wl);
            y += cie::sampled_to_xyz(l, &wl).y as f64 / n as f64;
        }
        assert!((y - 0.5).abs() < 5e-3, "{y}");
    }
}
