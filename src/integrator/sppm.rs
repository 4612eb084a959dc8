//! Stochastic progressive photon mapping (Hachisuka & Jensen 2009), in
//! the probabilistic formulation of Knaus & Zwicker 2011, spectral.
//!
//! Each iteration (one sample index of every pixel) first traces photons
//! from the lights into a hash grid (`Sppm::photon_map`), then traces one
//! camera path per pixel through specular and glossy surfaces, as the path
//! tracer does, to its first surface with a diffuse lobe: the visible
//! point. There, light sampling gives the direct light and the photons
//! within the iteration's radius give the rest, caustics included, also
//! when the visible point is seen through glass or in a mirror (which no
//! connection of bidirectional path tracing can reach).
//!
//! Knaus & Zwicker's formulation: iteration i uses the radius
//! r_i = r_1 (i + 1)^((α − 1)/2) for every pixel, so each iteration is an
//! independent estimate and the image is their plain mean (α = 2/3 by
//! default). This is Hachisuka & Jensen's progressive radius reduction
//! without its per-pixel photon statistics, which buys what prism's other
//! integrators have: images split by iteration range merge exactly, every
//! thread count gives the same image, and the per-pixel variance is a true
//! error estimate. The estimate is consistent, not unbiased: its bias
//! shrinks with the radius.
//!
//! Photons carry their own four wavelengths (terminated at smooth
//! dispersive interfaces, like any path), which are not the visible point's:
//! a photon at λ' counts at the visible point's λ through a box kernel of
//! half-width h_i = h_1 (i + 1)^((α − 1)/2) nm — density estimation in
//! wavelength as well as in space. Both bandwidths shrink together; the
//! variance of iteration i grows as (r_i² h_i)⁻¹ ∝ i^(3(1 − α)/2), slower
//! than i for α > 1/3, so the mean converges.

use std::sync::{Arc, Mutex};

use super::light_path::{self, Scatterer};
use super::path::{PathTracer, Stop};
use super::photon_map::{Photon, PhotonMap, MAP_BYTES_PER_STORED, PHOTON_ROW};
use super::walk::PathContext;
use super::{camera_ray, PathCounters, PixelSample, Strategy};
use super::{CommonParams, Configure};
use crate::drive::pixels::PixelEstimator;
use crate::material::BsdfFlags;
use crate::sampler::Sampler;
use crate::scene::Scene;
use serde::Deserialize;

#[derive(Clone, Debug)]
pub struct Sppm {
    /// Most bounces of a full path (camera side and photon together).
    pub max_depth: u32,
    /// Bounces before Russian roulette may end a path or a photon.
    pub rr_depth: u32,
    /// Photons per iteration; None: `default_photons`.
    pub photons: Option<u32>,
    /// Radius of the first iteration (scene units); None: derived from the
    /// scene (`initial_radius`).
    pub radius: Option<f32>,
    /// Radius reduction exponent α in (0, 1]: 1 keeps the first radius
    /// (biased for good: for tests and previews).
    pub alpha: f32,
    /// Half-width of the wavelength kernel in the first iteration (nm).
    pub spectral_radius: f32,
    /// Photons stored per photon emitted, measured by a pilot once per
    /// scene (keyed by `Scene::id`: one integrator may render several).
    stored_per_photon: Arc<Mutex<Option<(u64, f64)>>>,
}

impl Sppm {
    pub fn new(
        max_depth: u32,
        rr_depth: u32,
        photons: Option<u32>,
        radius: Option<f32>,
        alpha: f32,
        spectral_radius: f32,
    ) -> Self {
        Self {
            max_depth,
            rr_depth,
            photons,
            radius,
            alpha,
            spectral_radius,
            stored_per_photon: Arc::default(),
        }
    }
}

/// The most photons an iteration may trace: 2²⁶ (the default is at most
/// 2²²), a few seconds an iteration; more would make one pass unending.
pub const MAX_PHOTONS: u32 = 1 << 26;

/// The smallest photon radius, in scene units.
const MIN_RADIUS: f32 = 1e-6;

/// The smallest wavelength kernel half-width, in nm.
const MIN_SPECTRAL_RADIUS: f32 = 1e-3;

/// Photon mapping's own keys of `[integrator]`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SppmParams {
    /// Photons per iteration (default: about one stored per pixel).
    pub photons: Option<u32>,
    /// The first iteration's radius in scene units (default: four pixels'
    /// width where the camera looks).
    pub radius: Option<f32>,
    /// Radius reduction exponent α in (0, 1] (default 2/3; 1 keeps the
    /// radius, which never converges).
    pub alpha: Option<f32>,
    /// The first iteration's wavelength kernel half-width (nm).
    pub spectral_radius: Option<f32>,
}

impl Configure for Sppm {
    type Params = SppmParams;

    fn configure(common: &CommonParams, spec: SppmParams) -> Result<Self, String> {
        let d = Sppm::default();
        // Below `least`, a kernel's 1/r² (or 1/width) overflows the f32
        // sums it is added to.
        let positive = |key: &str, v: Option<f32>, least: f32| match v {
            Some(v) if !(v >= least && v.is_finite()) => Err(format!(
                "`integrator.{key}` must be a number of at least {least:e}, not {v}"
            )),
            _ => Ok(v),
        };
        let alpha = spec.alpha.unwrap_or(d.alpha);
        if !(alpha > 0.0 && alpha <= 1.0) {
            return Err(format!(
                "`integrator.alpha` must lie in (0, 1], not {alpha}"
            ));
        }
        if let Some(n) = spec.photons.filter(|n| !(1..=MAX_PHOTONS).contains(n)) {
            return Err(format!(
                "`integrator.photons` must be between 1 and {MAX_PHOTONS} per iteration, not {n}"
            ));
        }
        Ok(Sppm::new(
            common.max_depth.unwrap_or(d.max_depth),
            common.rr_depth.unwrap_or(d.rr_depth),
            spec.photons,
            positive("radius", spec.radius, MIN_RADIUS)?,
            alpha,
            positive("spectral_radius", spec.spectral_radius, MIN_SPECTRAL_RADIUS)?
                .unwrap_or(d.spectral_radius),
        ))
    }
}

impl PixelEstimator for Sppm {
    type Shared = PhotonMap;

    fn prepares(&self) -> bool {
        true
    }

    fn prepare(&self, scene: &Scene, seed: u64, index: u32) -> (PhotonMap, PathCounters) {
        self.photon_map(scene, seed, index)
    }

    fn shared_bytes(&self, scene: &Scene) -> u64 {
        self.map_bytes(scene)
    }

    fn sample(
        &self,
        scene: &Scene,
        (x, y): (u32, u32),
        sampler: &mut Sampler,
        map: &PhotonMap,
        counters: &mut PathCounters,
    ) -> PixelSample {
        self.trace(scene, x, y, sampler, map, counters)
    }
}

renders_by_pixels!(Sppm);

impl Default for Sppm {
    fn default() -> Self {
        Self::new(16, 3, None, None, 2.0 / 3.0, 10.0)
    }
}

impl PartialEq for Sppm {
    fn eq(&self, other: &Self) -> bool {
        (self.max_depth, self.rr_depth, self.photons, self.radius)
            == (other.max_depth, other.rr_depth, other.photons, other.radius)
            && (self.alpha, self.spectral_radius) == (other.alpha, other.spectral_radius)
    }
}

/// The seed of the pilot photons that size the default photon count.
const PILOT_SEED: u64 = 0x9107_0000;

impl Sppm {
    /// Photons per iteration: the given number, or enough that about one
    /// is stored per pixel in an iteration, within [2¹⁴, 2²²].
    pub fn photons_per_iteration(&self, scene: &Scene) -> u32 {
        self.photons.unwrap_or_else(|| {
            let (w, h) = scene.camera.resolution();
            let pixels = (w as f64) * (h as f64);
            let per_photon = self.stored_per_photon(scene).max(1e-4);
            (pixels / per_photon).clamp((1u32 << 14) as f64, (1u32 << 22) as f64) as u32
        })
    }

    /// The bytes an iteration's photon map takes at its peak, estimated
    /// from the pilot (`MAP_BYTES_PER_STORED`).
    pub fn map_bytes(&self, scene: &Scene) -> u64 {
        let stored = self.photons_per_iteration(scene) as f64 * self.stored_per_photon(scene);
        (stored * MAP_BYTES_PER_STORED as f64) as u64
    }

    /// How many photons a photon leaves on diffuse surfaces, measured by a
    /// pilot of 2¹⁴ photons (a fixed stream, so the count is the same for
    /// every render of the scene). A scene lit through a small prism
    /// stores one photon in a hundred; a closed room several per photon.
    fn stored_per_photon(&self, scene: &Scene) -> f64 {
        let mut cached = self
            .stored_per_photon
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        match *cached {
            Some((id, value)) if id == scene.id() => value,
            _ => {
                const PILOT: u32 = 1 << 14;
                let (mut stored, mut counters) = (Vec::new(), PathCounters::default());
                for j in 0..PILOT {
                    let mut sampler = Sampler::for_sample(PILOT_SEED, j, PHOTON_ROW, 0);
                    self.trace_photon(scene, &mut sampler, &mut stored, &mut counters);
                    stored.clear();
                }
                let value = counters.photons_stored as f64 / PILOT as f64;
                *cached = Some((scene.id(), value));
                value
            }
        }
    }

    /// The first iteration's radius: the given one, or four pixels' width
    /// where the camera looks at the scene's centre.
    pub fn initial_radius(&self, scene: &Scene) -> f32 {
        if let Some(r) = self.radius {
            return r;
        }
        let distance = (scene.sphere.centre - scene.camera.position).length();
        let footprint = scene.camera.pixel_footprint(distance);
        let r = 4.0 * footprint;
        if r > 0.0 && r.is_finite() {
            r
        } else {
            1e-3 * scene.sphere.radius.max(1.0)
        }
    }

    /// The factor by which iteration `index` scales both kernels' radii.
    fn shrink(&self, index: u32) -> f32 {
        (index as f32 + 1.0).powf(0.5 * (self.alpha - 1.0))
    }

    /// Traces iteration `index`'s photons and files them in a hash grid.
    pub fn photon_map(&self, scene: &Scene, seed: u64, index: u32) -> (PhotonMap, PathCounters) {
        let n = self.photons_per_iteration(scene);
        let radius = self.initial_radius(scene) * self.shrink(index);
        let spectral_radius = self.spectral_radius * self.shrink(index);
        PhotonMap::traced(
            n,
            seed,
            index,
            radius,
            spectral_radius,
            |sampler, out, counters| self.trace_photon(scene, sampler, out, counters),
        )
    }

    /// One photon path: stored wherever it meets a diffuse surface after
    /// its first bounce.
    fn trace_photon(
        &self,
        scene: &Scene,
        sampler: &mut Sampler,
        out: &mut Vec<Photon>,
        counters: &mut PathCounters,
    ) {
        let [u_lambda, u_light, p0, p1] = sampler.next_4d();
        let [d0, d1, _, _] = sampler.next_4d();
        let mut wl = scene.wavelengths.sample(u_lambda);
        let Some(start) = light_path::start(scene, u_light, (p0, p1), (d0, d1), &wl, counters)
        else {
            return;
        };
        let mut ctx = PathContext {
            scene,
            wl: &mut wl,
            sampler,
            counters,
        };
        light_path::walk(&mut ctx, start, self.max_depth, self.rr_depth, |v| {
            // Photons stay on diffuse surfaces (not in media: the
            // camera paths find light scattered there themselves).
            let Scatterer::Surface { hit, bsdf, .. } = v.at else {
                return;
            };
            if v.depth < 2 || !bsdf.flags().contains(BsdfFlags::DIFFUSE) {
                return;
            }
            if let Some(photon) = Photon::landed(&v, hit.p) {
                v.counters.photons_stored += 1;
                out.push(photon);
            }
        });
    }

    /// One sample of pixel (x, y) in the iteration of `map`.
    pub fn trace(
        &self,
        scene: &Scene,
        x: u32,
        y: u32,
        sampler: &mut Sampler,
        map: &PhotonMap,
        counters: &mut PathCounters,
    ) -> PixelSample {
        let [dx, dy, u_lambda, _] = sampler.next_4d();
        let mut wl = scene.wavelengths.sample(u_lambda);
        let ray = camera_ray(scene, x as f32 + dx, y as f32 + dy, sampler);
        let tracer = PathTracer {
            max_depth: self.max_depth,
            rr_depth: self.rr_depth,
            strategy: Strategy::Mis,
            split: 1,
            // `stop` ends the path at its visible point: no branches.
            split_dispersion: false,
            split_glass: false,
            look_ahead: false,
            reuse: Some(false),
        };
        // At the visible point the path ends: light sampling alone finds
        // the direct light (no BSDF sample follows to share it with).
        let direct = PathTracer {
            strategy: Strategy::Nee,
            ..tracer
        };
        let mut ctx = PathContext {
            scene,
            wl: &mut wl,
            sampler,
            counters,
        };
        let l = tracer.radiance_until(&mut ctx, ray, |at: Stop| {
            if !at.bsdf.flags().contains(BsdfFlags::DIFFUSE) {
                return None;
            }
            let ld =
                direct.sample_direct(at.ctx, (at.hit, at.wo, at.bsdf), at.stack, at.medium, None);
            // Photons of up to max_depth + 1 − depth surfaces keep the
            // whole path within max_depth bounces.
            let max_photon_depth = self.max_depth + 1 - at.depth;
            Some(ld + map.gather(at.hit.p, at.wo, at.bsdf, at.ctx.wl, max_photon_depth))
        });
        PixelSample { l, wl }
    }
}
