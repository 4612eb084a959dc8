//! The light tracer: paths start at the lights and every vertex that can
//! scatter towards the camera is connected to it, adding light to whichever
//! pixel it lands in (a splat). This is bidirectional path tracing's t = 1
//! strategy alone (Veach 1997 §10; pbrt-v4's LightPathIntegrator, Mitsuba
//! 3's ptracer). It converges fast on caustics seen directly (light through
//! glass onto a diffuse floor) and cannot see Dirac surfaces from the
//! camera: a mirror or smooth glass in view is black.
//!
//! Light paths carry importance: the BSDF is evaluated in importance mode
//! (no 1/η'² at refraction, Veach's shading-normal correction). A light
//! path starts with the dielectrics that contain its light on its IOR
//! stack (`media_at`). Each sample of a pixel launches one light path, so a pixel's
//! value is the sum of its splats over its sample count, as the render
//! driver computes it.

use super::interface::transmittance_to_camera;
use super::light_path::{self, Scatterer};
use super::walk::PathContext;
use super::{lens_sample, PathCounters, PixelSample};
use super::{CommonParams, Configure, NoParams};
use crate::camera::CameraSample;
use crate::drive::splats::SplatEstimator;
use crate::film::FilmTile;
use crate::geometry::offset::offset_ray_origin;
use crate::geometry::Ray;
use crate::light::LightSource;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightTracer {
    /// Most bounces between the light and the camera.
    pub max_depth: u32,
    /// Bounces before Russian roulette may end a path.
    pub rr_depth: u32,
}

impl Default for LightTracer {
    fn default() -> Self {
        Self {
            max_depth: 16,
            rr_depth: 3,
        }
    }
}

impl Configure for LightTracer {
    type Params = NoParams;

    fn configure(common: &CommonParams, _: NoParams) -> Result<Self, String> {
        let d = LightTracer::default();
        Ok(LightTracer {
            max_depth: common.max_depth.unwrap_or(d.max_depth),
            rr_depth: common.rr_depth.unwrap_or(d.rr_depth),
        })
    }
}

impl SplatEstimator for LightTracer {
    fn name(&self) -> &'static str {
        "light"
    }

    fn max_depth(&self) -> u32 {
        self.max_depth
    }

    fn sample(
        &self,
        scene: &Scene,
        _: (u32, u32),
        sampler: &mut Sampler,
        tile: &mut FilmTile,
        counters: &mut PathCounters,
    ) -> PixelSample {
        self.trace(scene, sampler, tile, counters)
    }
}

renders_by_splats!(LightTracer);

impl LightTracer {
    /// Traces one light path and splats its connections to the camera
    /// into `tile`. Returns the (empty) measurement of the launching pixel.
    pub fn trace(
        &self,
        scene: &Scene,
        sampler: &mut Sampler,
        tile: &mut FilmTile,
        counters: &mut PathCounters,
    ) -> PixelSample {
        let [u_lambda, u_light, p0, p1] = sampler.next_4d();
        let [d0, d1, _, _] = sampler.next_4d();
        let mut wl = scene.wavelengths.sample(u_lambda);
        let none = |wl| PixelSample {
            l: SampledSpectrum::ZERO,
            wl,
        };
        let Some(start) = light_path::start(scene, u_light, (p0, p1), (d0, d1), &wl, counters)
        else {
            return none(wl);
        };
        let light = scene.lights.get(start.light);
        let (lp, pdf_pos) = (start.emitted.point, start.emitted.pdf_pos);

        // The light itself, seen by the camera: only a surface can be (a
        // point, a direction or the sky has no `l`).
        let seen = start.n != Vec3::ZERO;
        let u_lens = lens_sample(scene, sampler);
        if let Some(cs) = scene.camera.sample_wi(lp.p, u_lens).filter(|_| seen) {
            let le = light.l(lp.uv, cs.wi, &wl);
            let cos = lp.n.dot(cs.wi).abs();
            if le != SampledSpectrum::ZERO {
                let origin = offset_ray_origin(lp.p, lp.p_err, lp.n, cs.wi);
                let shadow = Ray::towards(origin, cs.p_lens);
                let tr = transmittance_to_camera(scene, &shadow, &start.stack, &wl, counters);
                let l = le * tr * (cs.weight * cos / (start.pmf * pdf_pos));
                if l != SampledSpectrum::ZERO {
                    splat(tile, scene, &cs, l, &wl);
                }
            }
        }

        let mut ctx = PathContext {
            scene,
            wl: &mut wl,
            sampler,
            counters,
        };
        light_path::walk(&mut ctx, start, self.max_depth, self.rr_depth, |mut v| {
            // Connect to the camera (Dirac lobes cannot turn towards it).
            if let Scatterer::Surface { bsdf, .. } = v.at {
                if bsdf.is_specular() {
                    return;
                }
            }
            let u_lens = lens_sample(scene, v.sampler);
            let Some(cs) = scene.camera.sample_wi(v.p(), u_lens) else {
                return;
            };
            let l = v.towards_camera(scene, &cs);
            if l != SampledSpectrum::ZERO {
                splat(tile, scene, &cs, l, v.wl);
            }
        });
        none(wl)
    }
}

fn splat(
    tile: &mut FilmTile,
    scene: &Scene,
    cs: &CameraSample,
    l: SampledSpectrum,
    wl: &SampledWavelengths,
) {
    let x = (cs.raster.x as u32).min(scene.camera.resolution().0 - 1);
    let y = (cs.raster.y as u32).min(scene.camera.resolution().1 - 1);
    tile.add_splat(x, y, l, wl);
}
