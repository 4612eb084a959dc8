//! The sky dome of the Hosek–Wilkie model (`[environment] sky = {...}`):
//! spectral radiance at infinity from the upper hemisphere, evaluated from
//! the model for every ray; below the horizon it is dark (the scene brings
//! its own ground). Light sampling follows the sky's luminance on a
//! latitude-longitude grid; the sun's disc is a light of its own
//! ([`super::Sun`]).

use std::f32::consts::PI;
use std::sync::Arc;

use glam::{Vec2, Vec3};

use super::hosek_wilkie::{band_weights, SkyModel, SkyView, BANDS};
use super::lat_long::{grid_direction, SphericalDistribution};
use super::{LightLeSample, LightLiSample, SceneSphere};
use crate::spectrum::{cie, SampledSpectrum, SampledWavelengths};

/// Sampling grid: 1.4° cells, fine for the sky's smooth gradients and its
/// circumsolar brightening; the sun itself is sampled as a disc.
const GRID_WIDTH: usize = 256;
const GRID_HEIGHT: usize = 128;
/// Model evaluations per grid cell and axis when building the grid.
const CELL_SAMPLES: usize = 2;

#[derive(Clone, Debug)]
pub struct Sky {
    model: Arc<SkyModel>,
    /// Unit direction towards the sun's centre.
    sun: Vec3,
    scale: f32,
    sphere: SphericalDistribution,
    /// ∫ spectral-mean radiance dω over the sky (for the light's power).
    radiance_integral: f64,
    scene: SceneSphere,
}

impl Sky {
    /// The sky of `model` with the sun towards `sun` (unit), times `scale`.
    pub fn new(model: Arc<SkyModel>, sun: Vec3, scale: f32) -> Self {
        let luminance = band_weights(|l| cie::cmf(l).y);
        let mean = band_weights(|_| 1.0);
        let mut weights = vec![0.0f64; GRID_WIDTH * GRID_HEIGHT];
        let mut radiance_integral = 0.0f64;
        // Only the upper half of the rows sees the sky.
        for j in 0..GRID_HEIGHT / 2 {
            for i in 0..GRID_WIDTH {
                let (mut y, mut m) = (0.0f64, 0.0f64);
                for a in 0..CELL_SAMPLES {
                    for b in 0..CELL_SAMPLES {
                        let uv = Vec2::new(
                            (i as f32 + (b as f32 + 0.5) / CELL_SAMPLES as f32) / GRID_WIDTH as f32,
                            (j as f32 + (a as f32 + 0.5) / CELL_SAMPLES as f32)
                                / GRID_HEIGHT as f32,
                        );
                        let (w, sin_t) = grid_direction(uv);
                        let bands = band_radiances(&model, sun, w);
                        let sum = |weights: &[f64; BANDS]| -> f64 {
                            bands.iter().zip(weights).map(|(r, w)| *r as f64 * w).sum()
                        };
                        y += sum(&luminance) * sin_t as f64;
                        m += sum(&mean);
                    }
                }
                let n = (CELL_SAMPLES * CELL_SAMPLES) as f64;
                weights[j * GRID_WIDTH + i] = y / n;
                let (t0, t1) = (
                    PI * j as f32 / GRID_HEIGHT as f32,
                    PI * (j + 1) as f32 / GRID_HEIGHT as f32,
                );
                let d_omega = 2.0 * PI / GRID_WIDTH as f32 * (t0.cos() - t1.cos());
                radiance_integral += m / n * d_omega as f64;
            }
        }
        Self {
            model,
            sun,
            scale,
            sphere: SphericalDistribution::new(&weights, GRID_WIDTH, GRID_HEIGHT, 0.0),
            radiance_integral: radiance_integral * scale as f64,
            scene: SceneSphere::default(),
        }
    }

    /// The same light for a scene within `scene`.
    pub fn with_scene(self, scene: SceneSphere) -> Self {
        Self { scene, ..self }
    }

    /// ∫ mean radiance dω × the scene's cross-section.
    pub fn power(&self) -> f64 {
        self.radiance_integral * self.scene.disc_area() as f64
    }

    /// Radiance arriving from direction `w` (unit, towards the sky).
    #[inline]
    pub fn radiance(&self, w: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        if !(w.y > 0.0) {
            return SampledSpectrum::ZERO;
        }
        let view = SkyView::new(w.y, w.dot(self.sun));
        let l = wl
            .lambda
            .to_array()
            .map(|lambda| self.model.sky(lambda, &view));
        SampledSpectrum::from_array(l) * self.scale
    }

    /// Solid-angle density of `sample_li` for direction `w` (towards the sky).
    pub fn pdf_li(&self, w: Vec3) -> f32 {
        self.sphere.pdf(w)
    }

    /// `radiance(w)` and `pdf_li(w)`.
    pub fn radiance_and_pdf(&self, w: Vec3, wl: &SampledWavelengths) -> (SampledSpectrum, f32) {
        (self.radiance(w, wl), self.pdf_li(w))
    }

    pub fn sample_li(&self, u: (f32, f32), wl: &SampledWavelengths) -> Option<LightLiSample> {
        let s = self.sphere.sample(u)?;
        LightLiSample::from_infinity(s.w, self.radiance(s.w, wl), s.pdf)
    }

    /// A ray into the scene: a direction from the sky's distribution, from
    /// a uniform point of the disc of the scene's radius facing it.
    pub fn sample_le(
        &self,
        u_pos: (f32, f32),
        u_dir: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLeSample> {
        let s = self.sphere.sample(u_dir)?;
        self.scene
            .ray_from_infinity(-s.w, u_pos, self.radiance(s.w, wl), s.pdf)
    }

    /// Densities of `sample_le` for a ray travelling along `dir`.
    pub fn pdf_le(&self, dir: Vec3) -> (f32, f32) {
        (self.scene.disc_pdf(), self.pdf_li(-dir))
    }
}

/// The model's radiance in every band towards `w` (upper hemisphere).
fn band_radiances(model: &SkyModel, sun: Vec3, w: Vec3) -> [f32; BANDS] {
    let view = SkyView::new(w.y, w.dot(sun));
    std::array::from_fn(|b| model.sky_band(b, &view))
}

// The sky model's spectrum varies over the dome: it counts as flat.
light_at_infinity!(Sky, |_l| None);

#[cfg(test)]
mod tests {
    use super::*;

    fn sky(elevation_deg: f32) -> Sky {
        let e = elevation_deg.to_radians();
        let sun = Vec3::new(0.3 * e.cos(), e.sin(), -0.954 * e.cos()).normalize();
        Sky::new(Arc::new(SkyModel::new(e, 3.0, [0.3; BANDS])), sun, 1.0)
    }

    #[test]
    fn sampling_density_matches_pdf_and_stays_above_the_horizon() {
        let sky = sky(20.0);
        let wl = SampledWavelengths::sample_visible(0.3);
        let mut s = crate::sampler::Sampler::new(3, 4);
        for _ in 0..2000 {
            let smp = sky.sample_li(s.next_2d(), &wl).unwrap();
            assert!(smp.wi.y > 0.0);
            let pdf = sky.pdf_li(smp.wi);
            assert!((pdf - smp.pdf).abs() <= 1e-4 * pdf, "{pdf} vs {}", smp.pdf);
        }
        assert_eq!(sky.pdf_li(Vec3::new(0.0, -0.5, 0.8).normalize()), 0.0);
        assert_eq!(
            sky.radiance(Vec3::new(0.6, -0.1, 0.8), &wl),
            SampledSpectrum::ZERO
        );
    }

    #[test]
    fn the_sky_brightens_towards_the_sun() {
        let sky = sky(30.0);
        let wl = SampledWavelengths::sample_visible(0.5);
        let towards = |w: Vec3| cie::sampled_to_xyz(sky.radiance(w.normalize(), &wl), &wl).y;
        let near_sun = towards(sky.sun + Vec3::new(0.0, 0.05, 0.0));
        let away = towards(Vec3::new(-sky.sun.x, sky.sun.y, -sky.sun.z));
        assert!(near_sun > 3.0 * away, "{near_sun} vs {away}");
    }
}
