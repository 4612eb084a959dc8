//! Path tracing with caustics from photons: the path tracer, with the light
//! that reaches a diffuse surface through glass or off metal (a caustic:
//! light → glass or metal … → diffuse surface) estimated by a photon map
//! instead (Jensen's caustic map, in the probabilistic progressive form of
//! Knaus & Zwicker 2011 that `sppm` uses). Every other path is the path
//! tracer's, with light sampling and MIS.
//!
//! Why: a caustic's light is found by a camera path only when BSDF
//! sampling, from the diffuse surface through the glass, happens to hit
//! the light. For the sun (a 0.5° disc) or a small lamp that is rare and
//! the image speckles. From the light the same path is easy: photons are
//! aimed at a sphere around the scene's glass and metal (Jensen's
//! projection map), so none is spent on the rest of the scene, and each
//! lands where the caustic is.
//!
//! Each full path is counted once. A caustic here is Jensen's L S+ D with
//! S any surface without a diffuse lobe (glass and metal, smooth or rough:
//! the sun off gold of roughness 0.08 speckles as much as through glass).
//! A camera path adds the photons' estimate at each diffuse surface it
//! meets, and leaves out the light it would find after it through such
//! surfaces alone (`path::Caustics`); photons are stored only at the first
//! diffuse surface after such a chain (and end there). Scattering in a
//! medium breaks a chain on both sides. Keeping rough surfaces with the
//! path tracer instead made the sunset 5× noisier for the time and left
//! gem-studio as it was. Photons of iteration i use the radius r_i = r_1 (i + 1)^((α−1)/2)
//! and a wavelength kernel that shrinks alike: consistent, not unbiased.

use std::sync::{Arc, Mutex};

use super::light_path::{self, Scatterer};
use super::path::{check_split, Caustics, PathTracer};
use super::photon_map::{Photon, PhotonMap, MAP_BYTES_PER_STORED, PHOTON_ROW};
use super::sppm::{Sppm, SppmParams};
use super::walk::{Flow, PathContext};
use super::{camera_ray, CommonParams, Configure, PathCounters, PixelSample};
use crate::drive::pixels::PixelEstimator;
use crate::light::{LightSet, LightSource, SceneSphere};
use crate::material::{Bsdf, BsdfFlags};
use crate::sampler::Sampler;
use crate::scene::{Scene, SurfaceHit};
use crate::spectrum::{SampledSpectrum, SampledWavelengths};
use serde::Deserialize;

/// Path tracing with a caustic photon map (`type = "path_caustics"`).
#[derive(Clone, Debug)]
pub struct PathCaustics {
    /// The camera paths' tracer: depth, roulette (the photons' too) and
    /// how they split (`split`, `split_dispersion`, `split_glass`,
    /// `look_ahead`).
    pub camera: PathTracer,
    /// The photon side: its counts, radii and kernels.
    photons: Sppm,
    /// Per scene (keyed by `Scene::id`): where photons are aimed.
    aim: AimCache,
}

/// The last scene's id and its `Aim`.
type AimCache = Arc<Mutex<Option<(u64, Arc<Aim>)>>>;

/// Where a scene's caustic photons are aimed, and what a photon leaves.
#[derive(Debug)]
struct Aim {
    /// The sphere around every surface that may focus light; None when the
    /// scene has none (then there are no caustics to map).
    sphere: Option<SceneSphere>,
    /// The scene's lights, those at infinity bounded by the sphere.
    lights: LightSet,
    /// Photons stored per photon emitted, from a pilot.
    stored_per_photon: f64,
    /// Rays traced per photon emitted, and per camera sample, from pilots:
    /// what each costs, for the default photon count.
    rays_per_photon: f64,
    rays_per_camera_sample: f64,
    /// The share of the camera samples' second moment (mean square of
    /// their light) that photons bring, from the pilots.
    photon_moment_share: f64,
}

/// The default photon count of `path_caustics` and the pilots' measures
/// it follows (`PathCaustics::photon_budget`).
#[derive(Clone, Copy, Debug)]
pub struct PhotonBudget {
    pub per_iteration: u32,
    pub rays_per_photon: f64,
    pub rays_per_camera_sample: f64,
    pub photon_moment_share: f64,
}

/// Its own keys of `[integrator]`: photon mapping's, for the caustic
/// photons, but for the wavelength kernel, which it does not need.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CausticParams {
    /// Photons per iteration (default: from pilots, `PathCaustics::photon_budget`).
    pub photons: Option<u32>,
    /// The first iteration's radius (default: four pixels' width at the
    /// glass and metal).
    pub radius: Option<f32>,
    /// Radius reduction exponent α in (0, 1] (default 2/3).
    pub alpha: Option<f32>,
    /// As the path tracer's (default true).
    pub split_dispersion: Option<bool>,
    /// As the path tracer's (default 1).
    pub split: Option<u32>,
    /// As the path tracer's (default true).
    pub split_glass: Option<bool>,
    /// As the path tracer's (default false).
    pub look_ahead: Option<bool>,
}

impl Configure for PathCaustics {
    type Params = CausticParams;

    fn configure(common: &CommonParams, spec: CausticParams) -> Result<Self, String> {
        let d = PathTracer::default();
        let split_dispersion = spec.split_dispersion.unwrap_or(d.split_dispersion);
        let split = check_split(spec.split.unwrap_or(1))?;
        let split_glass = spec.split_glass.unwrap_or(d.split_glass);
        let look_ahead = spec.look_ahead.unwrap_or(d.look_ahead);
        let spec = SppmParams {
            photons: spec.photons,
            radius: spec.radius,
            alpha: spec.alpha,
            spectral_radius: None,
        };
        let photons = Sppm::configure(common, spec)?;
        let camera = PathTracer {
            max_depth: photons.max_depth,
            rr_depth: photons.rr_depth,
            split_dispersion,
            split,
            split_glass,
            look_ahead,
            ..d
        };
        Ok(Self {
            camera,
            photons,
            aim: Arc::default(),
        })
    }
}

impl Default for PathCaustics {
    fn default() -> Self {
        Self::configure(&CommonParams::default(), CausticParams::default())
            .expect("the defaults are valid")
    }
}

impl PartialEq for PathCaustics {
    fn eq(&self, other: &Self) -> bool {
        self.photons == other.photons && self.camera == other.camera
    }
}

/// One iteration's caustic photons, as the path tracer asks for them, and
/// the iteration's wavelengths, which every photon and camera path share.
pub struct CausticMap {
    map: PhotonMap,
    max_depth: u32,
    wl: SampledWavelengths,
}

impl Caustics for CausticMap {
    fn reflected(
        &self,
        hit: &SurfaceHit,
        wo: glam::Vec3,
        bsdf: &Bsdf,
        wl: &SampledWavelengths,
        depth: u32,
    ) -> SampledSpectrum {
        // Photons of up to max_depth + 1 − depth surfaces keep the whole
        // path within max_depth bounces.
        let most = (self.max_depth + 1).saturating_sub(depth);
        self.map.gather_matched(hit.p, wo, bsdf, wl, &self.wl, most)
    }
}

impl PixelEstimator for PathCaustics {
    type Shared = CausticMap;

    fn prepares(&self) -> bool {
        true
    }

    fn prepare(&self, scene: &Scene, seed: u64, index: u32) -> (CausticMap, PathCounters) {
        let aim = self.aim(scene);
        let n = self.photons_per_iteration(scene);
        let shrink = (index as f32 + 1.0).powf(0.5 * (self.photons.alpha - 1.0));
        let radius = self.initial_radius(scene, &aim) * shrink;
        let wl = scene.wavelengths.sample(iteration_u(seed, index));
        let (map, counters) = match aim.sphere {
            Some(_) => PhotonMap::traced(n, seed, index, radius, 0.0, |s, out, c| {
                self.trace_photon(scene, &aim, wl, s, out, c)
            }),
            None => (PhotonMap::default(), PathCounters::default()),
        };
        let max_depth = self.camera.max_depth;
        (CausticMap { map, max_depth, wl }, counters)
    }

    fn shared_bytes(&self, scene: &Scene) -> u64 {
        let aim = self.aim(scene);
        let stored = self.photons_per_iteration(scene) as f64 * aim.stored_per_photon;
        (stored * MAP_BYTES_PER_STORED as f64) as u64
    }

    fn sample(
        &self,
        scene: &Scene,
        (x, y): (u32, u32),
        sampler: &mut Sampler,
        caustics: &CausticMap,
        counters: &mut PathCounters,
    ) -> PixelSample {
        // The iteration's wavelengths, not the pixel's own: a photon then
        // counts at exactly its wavelengths (no kernel, which blurs or, as
        // narrow as a dispersed caustic needs, leaves colour grain).
        let [dx, dy, _, _] = sampler.next_4d();
        let mut wl = caustics.wl;
        let seen = wl.lambda;
        let ray = camera_ray(scene, x as f32 + dx, y as f32 + dy, sampler);
        let mut ctx = PathContext {
            scene,
            wl: &mut wl,
            sampler,
            counters,
        };
        let l = self.camera.radiance_with(&mut ctx, ray, caustics);
        // Fluorescence may have moved the wavelengths the path carries;
        // the film bins the light at those the camera saw.
        wl.lambda = seen;
        PixelSample { l, wl }
    }
}

renders_by_pixels!(PathCaustics, camera.max_depth);

/// Iteration `index`'s wavelength number: the base-2 radical inverse of
/// the index, turned by a number of the seed (Cranley–Patterson), so that
/// any 2^k consecutive iterations from 0 stratify the spectrum.
fn iteration_u(seed: u64, index: u32) -> f32 {
    let shift = Sampler::for_sample(seed, 0, u32::MAX - 1, 0).next_4d()[0];
    let u = index.reverse_bits() as f32 * (1.0 / 4_294_967_296.0) + shift;
    (u - u.floor()).min(1.0 - f32::EPSILON / 2.0)
}

/// The pilot photons that measure how many a photon stores.
const PILOT: u32 = 1 << 14;
const PILOT_SEED: u64 = 0xca05_0000;
/// Camera samples of the pilot that measures what one costs.
const CAMERA_PILOT: u32 = 1 << 12;
/// The default photon count's rays against the camera samples' rays, at
/// least (`PathCaustics::photon_budget`).
const MIN_PHOTON_SHARE: f64 = 0.125;

impl PathCaustics {
    /// Where the scene's photons are aimed (computed once per scene).
    fn aim(&self, scene: &Scene) -> Arc<Aim> {
        let mut cached = self.aim.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, aim)) = cached.as_ref().filter(|(id, _)| *id == scene.id()) {
            return aim.clone();
        }
        let bounds = scene.bounds_where(|m| m.may_focus_light());
        let sphere = (bounds.min.cmple(bounds.max).all()).then(|| SceneSphere {
            centre: bounds.centroid(),
            // A little more, so that a ray grazing a sphere's edge in f32
            // is not left out.
            radius: 0.5 * bounds.diagonal().length() * 1.001 + 1e-6,
        });
        let lights = match sphere {
            Some(s) => LightSet::new(
                scene
                    .lights
                    .clone()
                    .into_lights()
                    .into_iter()
                    .map(|l| l.with_scene_bounds(s))
                    .collect(),
            ),
            None => LightSet::default(),
        };
        let mut aim = Aim {
            sphere,
            lights,
            stored_per_photon: 0.0,
            rays_per_photon: 0.0,
            rays_per_camera_sample: 0.0,
            photon_moment_share: 0.0,
        };
        if sphere.is_some() {
            let (mut stored, mut counters) = (Vec::new(), PathCounters::default());
            let wl = scene.wavelengths.sample(0.5);
            for j in 0..PILOT {
                let mut sampler = Sampler::for_sample(PILOT_SEED, j, PHOTON_ROW, 0);
                self.trace_photon(scene, &aim, wl, &mut sampler, &mut stored, &mut counters);
            }
            aim.stored_per_photon = counters.photons_stored as f64 / PILOT as f64;
            aim.rays_per_photon = counters.rays as f64 / PILOT as f64;
            let radius = self.initial_radius(scene, &aim);
            let map = PhotonMap::new(stored, PILOT as u64, radius, 0.0);
            (aim.rays_per_camera_sample, aim.photon_moment_share) =
                self.camera_pilot(scene, map, wl);
        }
        let aim = Arc::new(aim);
        *cached = Some((scene.id(), aim.clone()));
        aim
    }

    /// What camera samples cost and what the photons give them: the rays
    /// a sample traces, and the share of the mean square of its light that
    /// the photons of `map` (the pilot's) bring, over `CAMERA_PILOT`
    /// samples spread evenly over the image. Each sample is taken twice on
    /// the same stream, with the map and with none (the photons only add
    /// light; the paths are the same).
    fn camera_pilot(&self, scene: &Scene, map: PhotonMap, wl: SampledWavelengths) -> (f64, f64) {
        let (w, h) = scene.camera.resolution();
        let max_depth = self.camera.max_depth;
        let with = CausticMap { map, max_depth, wl };
        let without = CausticMap {
            map: PhotonMap::default(),
            max_depth,
            wl,
        };
        let (mut counters, mut ignored) = (PathCounters::default(), PathCounters::default());
        let (mut all, mut photons) = (0.0f64, 0.0f64);
        let side = (CAMERA_PILOT as f64).sqrt() as u32;
        for j in 0..side * side {
            let x = ((j % side) as u64 * w as u64 / side as u64) as u32;
            let y = ((j / side) as u64 * h as u64 / side as u64) as u32;
            let sample = |map: &CausticMap, counters: &mut PathCounters| {
                let mut sampler = Sampler::for_sample(PILOT_SEED, x, y, 0);
                let s = self.sample(scene, (x, y), &mut sampler, map, counters);
                s.l.to_array()
                    .iter()
                    .map(|&v| v as f64)
                    .filter(|v| v.is_finite())
                    .sum::<f64>()
            };
            let (l_with, l_without) =
                (sample(&with, &mut ignored), sample(&without, &mut counters));
            all += l_with * l_with;
            photons += (l_with - l_without) * (l_with - l_without);
        }
        let share = if all > 0.0 {
            (photons / all).clamp(0.0, 1.0)
        } else {
            0.0
        };
        (counters.rays as f64 / (side * side) as f64, share)
    }

    /// Photons per iteration: the given number, or the default of
    /// `photon_budget`.
    fn photons_per_iteration(&self, scene: &Scene) -> u32 {
        self.photons
            .photons
            .unwrap_or_else(|| self.photon_budget(scene).per_iteration)
    }

    /// The default photon count and what the pilots measured for it.
    /// Photon paths and camera paths share an iteration's time; the
    /// variance × time of the sum of two estimators is least where the
    /// time spent on each goes as the square root of its variance. So the
    /// photons get √(m / (1 − m)) of the camera samples' rays (m: the
    /// share of the camera samples' mean square that the pilot's photons
    /// bring), at least an eighth and at most as many, within [2¹⁴, 2²²]
    /// photons an iteration: about 1.4 a pixel on the glass of water,
    /// whose camera paths wind through the glass, 0.7 on the rainbow,
    /// whose spectrum photons make, 0.14-0.27 on the sunset and
    /// gem-studio, whose photons are dear beside their camera paths.
    /// Against one a pixel, variance × CPU 1.25-1.4× lower on those two,
    /// the same on the others (docs/integrators.md).
    pub fn photon_budget(&self, scene: &Scene) -> PhotonBudget {
        let aim = self.aim(scene);
        let m = aim.photon_moment_share.min(0.99);
        let share = (m / (1.0 - m)).sqrt().clamp(MIN_PHOTON_SHARE, 1.0);
        let (w, h) = scene.camera.resolution();
        let per_pixel = if aim.rays_per_photon > 0.0 {
            share * aim.rays_per_camera_sample / aim.rays_per_photon
        } else {
            1.0
        };
        let per_iteration = ((w as f64) * (h as f64) * per_pixel)
            .clamp((1u32 << 14) as f64, (1u32 << 22) as f64) as u32;
        PhotonBudget {
            per_iteration,
            rays_per_photon: aim.rays_per_photon,
            rays_per_camera_sample: aim.rays_per_camera_sample,
            photon_moment_share: aim.photon_moment_share,
        }
    }

    /// What the log says of the photons: how many, aimed where, and the
    /// first radius.
    pub fn summary(&self, scene: &Scene) -> String {
        let aim = self.aim(scene);
        match aim.sphere {
            Some(s) => format!(
                "caustic photons: {} per iteration, aimed at a sphere of radius {:.4} around the \
                 glass and metal ({:.3} stored per photon; {:.2} rays per photon against {:.2} per \
                 camera sample, which owes {:.3} of its mean square to photons), radius {:.4} \
                 (scene units) in the first",
                self.photons_per_iteration(scene),
                s.radius,
                aim.stored_per_photon,
                aim.rays_per_photon,
                aim.rays_per_camera_sample,
                aim.photon_moment_share,
                self.initial_radius(scene, &aim)
            ),
            None => "caustic photons: none (no glass or metal in the scene)".to_string(),
        }
    }

    /// The first iteration's radius: the given one, or four pixels' width
    /// where the camera sees the glass and metal.
    fn initial_radius(&self, scene: &Scene, aim: &Aim) -> f32 {
        if let Some(r) = self.photons.radius {
            return r;
        }
        let centre = aim.sphere.map_or(scene.sphere.centre, |s| s.centre);
        let distance = (centre - scene.camera.position).length();
        let r = 4.0 * scene.camera.pixel_footprint(distance);
        if r > 0.0 && r.is_finite() {
            r
        } else {
            self.photons.initial_radius(scene)
        }
    }

    /// One photon aimed at the glass and metal: stored at the first diffuse
    /// surface it reaches after one or more without a diffuse lobe (glass,
    /// metal), and ended there; dropped when it meets a diffuse surface
    /// first, or scatters in a medium.
    fn trace_photon(
        &self,
        scene: &Scene,
        aim: &Aim,
        mut wl: SampledWavelengths,
        sampler: &mut Sampler,
        out: &mut Vec<Photon>,
        counters: &mut PathCounters,
    ) {
        let Some(sphere) = aim.sphere else {
            return;
        };
        let [u_lead, u_light, p0, p1] = sampler.next_4d();
        let [d0, d1, _, _] = sampler.next_4d();
        // Led by one of the four at random: a photon that disperses keeps
        // its lead alone, and each of the path's wavelengths must be one's
        // lead as often (`PhotonMap::gather_matched`).
        wl = wl.led_by(((u_lead * 4.0) as usize).min(3));
        let start = light_path::start_aimed(
            scene,
            &aim.lights,
            sphere,
            u_light,
            (p0, p1),
            (d0, d1),
            &wl,
            counters,
        );
        let Some(start) = start else {
            return;
        };
        let mut ctx = PathContext {
            scene,
            wl: &mut wl,
            sampler,
            counters,
        };
        let (max_depth, rr_depth) = (self.camera.max_depth, self.camera.rr_depth);
        light_path::walk_until(&mut ctx, start, max_depth, rr_depth, |v| {
            let Scatterer::Surface { hit, bsdf, .. } = v.at else {
                return Flow::End;
            };
            if !bsdf.flags().contains(BsdfFlags::DIFFUSE) {
                return Flow::Go;
            }
            if v.depth >= 2 {
                if let Some(photon) = Photon::landed(&v, hit.p) {
                    v.counters.photons_stored += 1;
                    out.push(photon);
                }
            }
            Flow::End
        });
    }
}
