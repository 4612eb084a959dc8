//! Integrators: how a sample of a pixel becomes a radiance estimate. Each
//! integrator is a variant of [`Integrator`] that owns its parameters
//! (parsed from the scene's `[integrator]` table by [`Integrator::from_spec`]).
//!
//! The render driver asks for one sample of a pixel at a time
//! ([`Integrator::sample`]). An integrator returns what that sample
//! measures for its own pixel and may also *splat*: add contributions to any
//! pixel of the film tile it is given (light tracing connects to the camera
//! wherever a light path lands). The driver keeps both deterministic for
//! any thread count.

mod bdpt;
mod interface;
pub mod ior_stack;
mod light_tracer;
mod path;

use serde::Deserialize;

pub use bdpt::Bdpt;
pub use light_tracer::LightTracer;
pub use path::PathTracer;

use crate::film::FilmTile;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::{SampledSpectrum, SampledWavelengths};

/// How the path tracer finds direct light. All converge to the same image;
/// `Mis` has the least noise.
#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Strategy {
    /// Light sampling and BSDF sampling, combined by MIS.
    #[default]
    Mis,
    /// Light sampling only (next-event estimation).
    Nee,
    /// BSDF sampling only.
    Bsdf,
}

/// The `[integrator]` table: which integrator, and its parameters (each
/// applies to the integrators that name it in README.md).
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorSpec {
    #[serde(default, rename = "type")]
    pub kind: IntegratorKind,
    /// Most bounces: 1 is direct lighting only (default 16).
    pub max_depth: Option<u32>,
    /// Bounces before Russian roulette may end a path (default 3).
    pub rr_depth: Option<u32>,
    /// How the path tracer finds direct light: "mis" (default), "nee" or "bsdf".
    pub strategy: Option<Strategy>,
}

#[derive(Clone, Copy, Debug, Default, Deserialize, PartialEq, Eq, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum IntegratorKind {
    /// Paths from the camera with light sampling (the default).
    #[default]
    Path,
    /// Paths from the lights, connected to the camera (splats).
    Light,
    /// Bidirectional: camera and light subpaths joined by every strategy,
    /// weighted by MIS (splats).
    Bdpt,
}

/// Counts kept per path, summed by the renderer.
#[derive(Clone, Copy, Debug, Default)]
pub struct PathCounters {
    /// Closest-hit and shadow rays traced.
    pub rays: u64,
    /// Media that could not be entered because the IOR stack was full.
    pub stack_overflows: u64,
}

/// What one sample of a pixel measured, at its wavelengths.
#[derive(Clone, Copy, Debug)]
pub struct PixelSample {
    pub l: SampledSpectrum,
    pub wl: SampledWavelengths,
}

/// Every integrator. Adding one: a module with its type (parameters as
/// fields, a `sample` method), and here a variant, an `IntegratorKind`, and
/// its arms in `from_spec`, `name`, `splats` and `sample`.
#[derive(Clone, Debug, PartialEq)]
pub enum Integrator {
    Path(PathTracer),
    Light(LightTracer),
    Bdpt(Bdpt),
}

impl Default for Integrator {
    fn default() -> Self {
        Integrator::Path(PathTracer::default())
    }
}

impl Integrator {
    /// From the scene file's `[integrator]` table; the error names the key.
    pub fn from_spec(spec: &IntegratorSpec) -> Result<Self, String> {
        match spec.kind {
            IntegratorKind::Path => {
                let d = PathTracer::default();
                Ok(Integrator::Path(PathTracer {
                    max_depth: spec.max_depth.unwrap_or(d.max_depth),
                    rr_depth: spec.rr_depth.unwrap_or(d.rr_depth),
                    strategy: spec.strategy.unwrap_or(d.strategy),
                }))
            }
            IntegratorKind::Light | IntegratorKind::Bdpt => {
                if spec.strategy.is_some() {
                    return Err(format!(
                        "`integrator.strategy` applies to the path tracer, not to `{}`",
                        if spec.kind == IntegratorKind::Light {
                            "light"
                        } else {
                            "bdpt"
                        }
                    ));
                }
                let (max_depth, rr_depth) = (spec.max_depth, spec.rr_depth);
                Ok(if spec.kind == IntegratorKind::Light {
                    let d = LightTracer::default();
                    Integrator::Light(LightTracer {
                        max_depth: max_depth.unwrap_or(d.max_depth),
                        rr_depth: rr_depth.unwrap_or(d.rr_depth),
                    })
                } else {
                    let d = Bdpt::default();
                    Integrator::Bdpt(Bdpt {
                        max_depth: max_depth.unwrap_or(d.max_depth),
                        rr_depth: rr_depth.unwrap_or(d.rr_depth),
                    })
                })
            }
        }
    }

    /// The name the scene file and the command line use.
    pub fn name(&self) -> &'static str {
        match self {
            Integrator::Path(_) => "path",
            Integrator::Light(_) => "light",
            Integrator::Bdpt(_) => "bdpt",
        }
    }

    /// Whether `sample` adds to pixels other than its own. Such renders
    /// must cover the whole film with the same number of samples per pixel.
    pub fn splats(&self) -> bool {
        match self {
            Integrator::Path(_) => false,
            Integrator::Light(_) | Integrator::Bdpt(_) => true,
        }
    }

    /// Sample `sampler` of pixel (x, y): what it measures there; splats go
    /// to `tile`.
    pub fn sample(
        &self,
        scene: &Scene,
        x: u32,
        y: u32,
        sampler: &mut Sampler,
        tile: &mut FilmTile,
        counters: &mut PathCounters,
    ) -> PixelSample {
        match self {
            Integrator::Path(p) => {
                let [dx, dy, u_lambda, _] = sampler.next_4d();
                let mut wl = SampledWavelengths::sample_visible(u_lambda);
                let ray = scene.camera.generate_ray(x as f32 + dx, y as f32 + dy);
                let l = p.radiance(scene, ray, &mut wl, sampler, counters);
                PixelSample { l, wl }
            }
            Integrator::Light(t) => t.sample(scene, sampler, tile, counters),
            Integrator::Bdpt(b) => b.sample(scene, x, y, sampler, tile, counters),
        }
    }
}

/// Veach's power heuristic (β = 2) for two strategies with one sample each.
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a.is_infinite() {
        return 1.0;
    }
    if a + b == 0.0 {
        0.0
    } else {
        a / (a + b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0, 2.0), (0.3, 0.0), (5.0, 5.0)] {
            assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-6);
        }
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
    }
}
