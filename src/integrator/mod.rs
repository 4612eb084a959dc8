//! Integrators: how samples become an image. Each integrator is a type
//! that owns its parameters (parsed from the scene's `[integrator]` table
//! by its `from_spec`) and implements [`Integrate`]: it renders a whole
//! job, with a loop of its own or a shared driver's (`crate::drive`). The
//! list of integrators is one macro call, `integrators!`, below.

#[macro_use]
mod drivers;
pub mod aov;
mod bdpt;
mod interface;
pub mod ior_stack;
mod light_path;
mod light_tracer;
mod path;
mod path_caustics;
mod path_packet;
mod path_stream;
mod photon_map;
mod sppm;
pub mod volume;
pub mod walk;

use serde::Deserialize;

pub use bdpt::Bdpt;
pub use interface::flight_end;
pub use light_tracer::LightTracer;
pub use path::PathTracer;
pub use path_caustics::{PathCaustics, PhotonBudget};
pub use photon_map::PhotonMap;
pub use sppm::Sppm;

pub use crate::drive::{PathCounters, PixelSample};

use crate::camera::Camera;
use crate::drive::{RenderError, RenderJob, RenderOptions, RenderStats};
use crate::film::{Film, FilmSettings};
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::SampledSpectrum;

/// How the path tracer finds direct light. All converge to the same image;
/// `Mis` has the least noise.
#[derive(Clone, Copy, Debug, Default, Deserialize, serde::Serialize, PartialEq, Eq)]
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

/// The most bounces a path may take (`max_depth`): in a medium that
/// scatters without absorbing, Russian roulette never ends a path, so the
/// bound is what ends it; bdpt holds this many vertices per subpath.
pub const MAX_DEPTH: u32 = 131_072;

/// Most continuations a path tracer's camera sample may split into.
pub const MAX_SPLIT: u32 = 256;

/// The keys of `[integrator]` that every integrator takes.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommonParams {
    /// Most bounces: 1 is direct lighting only (default 16).
    pub max_depth: Option<u32>,
    /// Bounces before Russian roulette may end a path (default 3).
    pub rr_depth: Option<u32>,
}

/// The parameters of an integrator that takes no keys of its own.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NoParams {}

/// How an integrator is made from its `[integrator]` table.
pub trait Configure: Sized {
    /// Its own keys, beside [`CommonParams`]: a struct that denies
    /// unknown keys, with `Default` the table without them.
    type Params: serde::de::DeserializeOwned + Clone + Default + std::fmt::Debug;

    /// The integrator, or an error naming the key at fault.
    fn configure(common: &CommonParams, params: Self::Params) -> Result<Self, String>;
}

/// The `[integrator]` table, parsed by the schema of its `type` (the path
/// tracer when it gives none): the keys every integrator takes, and the
/// chosen integrator's own. A key of another integrator is an error that
/// names the integrator it belongs to.
#[derive(Clone, Debug)]
pub struct IntegratorSpec {
    pub common: CommonParams,
    pub params: IntegratorParams,
    /// The table as written, without `type`: what an override rewrites.
    table: toml::Table,
}

impl Default for IntegratorSpec {
    fn default() -> Self {
        Self::of(IntegratorKind::ALL[0])
    }
}

impl IntegratorSpec {
    /// `kind` with every parameter at its default.
    pub fn of(kind: IntegratorKind) -> Self {
        Self::parse(kind, toml::Table::new()).expect("an empty table is valid")
    }

    /// Parses a table as written in the scene file.
    pub fn from_table(mut table: toml::Table) -> Result<Self, String> {
        let kind = match table.remove("type") {
            None => IntegratorKind::ALL[0],
            Some(v) => IntegratorKind::deserialize(v).map_err(|e| e.message().to_string())?,
        };
        Self::parse(kind, table)
    }

    fn parse(kind: IntegratorKind, table: toml::Table) -> Result<Self, String> {
        let common_keys = crate::schema::keys_of::<CommonParams>();
        for key in table.keys() {
            if kind.takes(key) {
                continue;
            }
            let owners: Vec<String> = IntegratorKind::ALL
                .iter()
                .filter(|k| k.own_keys().contains(&key.as_str()))
                .map(|k| format!("`{}`", k.name()))
                .collect();
            return Err(if owners.is_empty() {
                let keys: Vec<String> = common_keys
                    .iter()
                    .chain(kind.own_keys())
                    .map(|k| format!("`{k}`"))
                    .collect();
                format!("unknown field `{key}`, expected one of {}", keys.join(", "))
            } else {
                format!(
                    "`integrator.{key}` applies to {}, not to `{}`",
                    owners.join(", "),
                    kind.name()
                )
            });
        }
        let (common, own): (toml::Table, toml::Table) = table
            .clone()
            .into_iter()
            .partition(|(k, _)| common_keys.contains(&k.as_str()));
        let common: CommonParams = parse_keys(common)?;
        for (key, depth) in [
            ("max_depth", common.max_depth),
            ("rr_depth", common.rr_depth),
        ] {
            if depth.is_some_and(|d| d > MAX_DEPTH) {
                return Err(format!(
                    "`integrator.{key}` must be at most {MAX_DEPTH}: a path that long carries \
                     nothing f32 can add, and the bound keeps every render finite"
                ));
            }
        }
        let params = IntegratorParams::parse(kind, own)?;
        Ok(Self {
            common,
            params,
            table,
        })
    }

    pub fn kind(&self) -> IntegratorKind {
        self.params.kind()
    }

    /// Sets one key (an override), checked as if the file gave it.
    pub fn set(&mut self, key: &str, value: impl Into<toml::Value>) -> Result<(), String> {
        let mut table = self.table.clone();
        table.insert(key.to_string(), value.into());
        *self = Self::parse(self.kind(), table)?;
        Ok(())
    }

    /// Whether the table gives `key`.
    pub fn gives(&self, key: &str) -> bool {
        self.table.contains_key(key)
    }

    /// Switches to another integrator (`--integrator`), dropping the keys
    /// that do not apply to it; returns their names.
    pub fn switch_to(&mut self, kind: IntegratorKind) -> Result<Vec<String>, String> {
        let (kept, dropped): (toml::Table, toml::Table) = self
            .table
            .clone()
            .into_iter()
            .partition(|(k, _)| kind.takes(k));
        *self = Self::parse(kind, kept)?;
        Ok(dropped.into_iter().map(|(k, _)| k).collect())
    }
}

impl IntegratorKind {
    /// Whether its `[integrator]` table takes `key`: one every integrator
    /// takes, or one of its own.
    pub fn takes(self, key: &str) -> bool {
        crate::schema::keys_of::<CommonParams>().contains(&key) || self.own_keys().contains(&key)
    }
}

impl<'de> Deserialize<'de> for IntegratorSpec {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        Self::from_table(toml::Table::deserialize(d)?).map_err(serde::de::Error::custom)
    }
}

/// Parses `table` as `T` (a struct of optional keys); an error names the
/// key at fault, found by parsing each key alone (serde's message for a
/// value of the wrong type does not say whose it is).
fn parse_keys<T: serde::de::DeserializeOwned>(table: toml::Table) -> Result<T, String> {
    T::deserialize(toml::Value::Table(table.clone())).map_err(|e| {
        let culprit = table.iter().find(|(key, value)| {
            let alone = toml::Table::from_iter([(key.to_string(), (*value).clone())]);
            T::deserialize(toml::Value::Table(alone)).is_err()
        });
        match culprit {
            Some((key, _)) => format!("`integrator.{key}`: {}", e.message()),
            None => format!("`[integrator]`: {}", e.message()),
        }
    })
}

/// The list of integrators: each line a variant of [`Integrator`] and of
/// [`IntegratorKind`], with the type that implements [`Integrate`] and
/// the name scene files and the command line use. Everything that lists
/// integrators (parsing, `--integrator`, the tests) comes from here.
macro_rules! integrators {
    ($($(#[doc = $doc:literal])* $variant:ident($ty:ty) = $name:literal,)*) => {
        /// Which integrator: the `type` of the `[integrator]` table.
        #[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq, clap::ValueEnum)]
        pub enum IntegratorKind {
            $($(#[doc = $doc])* #[serde(rename = $name)] #[value(name = $name)] $variant,)*
        }

        impl IntegratorKind {
            /// Every integrator, in the list's order (the first is the default).
            pub const ALL: &'static [IntegratorKind] = &[$(IntegratorKind::$variant,)*];

            /// The name the scene file and the command line use.
            pub fn name(self) -> &'static str {
                match self {
                    $(IntegratorKind::$variant => $name,)*
                }
            }

            /// The keys of its own (beside [`CommonParams`]'), from its
            /// parameters' schema.
            pub fn own_keys(self) -> &'static [&'static str] {
                match self {
                    $(IntegratorKind::$variant => {
                        crate::schema::keys_of::<<$ty as Configure>::Params>()
                    })*
                }
            }
        }

        /// The chosen integrator's own parameters.
        #[derive(Clone, Debug)]
        pub enum IntegratorParams {
            $($variant(<$ty as Configure>::Params),)*
        }

        impl IntegratorParams {
            /// `kind`'s parameters from its own keys.
            fn parse(kind: IntegratorKind, own: toml::Table) -> Result<Self, String> {
                Ok(match kind {
                    $(IntegratorKind::$variant => IntegratorParams::$variant(
                        parse_keys::<<$ty as Configure>::Params>(own)?,
                    ),)*
                })
            }

            pub fn kind(&self) -> IntegratorKind {
                match self {
                    $(IntegratorParams::$variant(_) => IntegratorKind::$variant,)*
                }
            }
        }

        /// An integrator with its parameters.
        #[derive(Clone, Debug, PartialEq)]
        pub enum Integrator {
            $($variant($ty),)*
        }

        impl Integrator {
            /// From the scene file's `[integrator]` table; the error names the key.
            pub fn from_spec(spec: &IntegratorSpec) -> Result<Self, String> {
                Ok(match spec.params.clone() {
                    $(IntegratorParams::$variant(p) => {
                        Integrator::$variant(<$ty>::configure(&spec.common, p)?)
                    })*
                })
            }

            pub fn kind(&self) -> IntegratorKind {
                match self {
                    $(Integrator::$variant(_) => IntegratorKind::$variant,)*
                }
            }

            /// What every integrator implements.
            pub fn as_integrate(&self) -> &dyn Integrate {
                match self {
                    $(Integrator::$variant(i) => i,)*
                }
            }
        }
    };
}

integrators! {
    /// Paths from the camera with light sampling (the default).
    Path(PathTracer) = "path",
    /// Paths from the lights, connected to the camera (splats).
    Light(LightTracer) = "light",
    /// Bidirectional: camera and light subpaths joined by every strategy,
    /// weighted by MIS (splats).
    Bdpt(Bdpt) = "bdpt",
    /// Stochastic progressive photon mapping: caustics, also seen through
    /// glass or in mirrors (consistent, not unbiased).
    Sppm(Sppm) = "sppm",
    /// Paths from the camera, with caustics (light through glass or off
    /// metal onto diffuse surfaces) from photons aimed at the glass and
    /// metal (consistent, not unbiased).
    PathCaustics(PathCaustics) = "path_caustics",
}

impl Default for IntegratorKind {
    fn default() -> Self {
        IntegratorKind::ALL[0]
    }
}

impl Default for Integrator {
    fn default() -> Self {
        Integrator::Path(PathTracer::default())
    }
}

/// What an integrator must fill in, whole: the compiler refuses one that
/// leaves a method out. An integrator renders a whole job with a loop of
/// its own, or hands it to a shared driver (`drive::pixels` for samples
/// that measure their own pixel, `drive::splats` for paths that add light
/// to any pixel).
pub trait Integrate: Sync {
    /// Refuses a camera or options its loop cannot honour, before anything
    /// is allocated (a region, an error target, adaptive sampling).
    fn check(
        &self,
        camera: &Camera,
        film: &FilmSettings,
        options: &RenderOptions,
    ) -> Result<(), RenderError>;

    /// Bytes its loop holds beyond the film's sums: planes of the film
    /// (adaptive counts, error images), and what it holds while rendering
    /// (tiles in flight, photon maps). For the memory estimate.
    fn loop_memory(
        &self,
        scene: &Scene,
        film: &FilmSettings,
        options: &RenderOptions,
    ) -> (u64, u64);

    /// Renders the job: every sample the options ask for, or fewer where
    /// a stop condition ends it after a pass.
    fn render(&self, job: RenderJob) -> (Film, RenderStats);

    /// The longest path it traces, in surface interactions.
    fn max_depth(&self) -> u32;
}

impl Integrator {
    /// The name the scene file and the command line use.
    pub fn name(&self) -> &'static str {
        self.kind().name()
    }

    /// The longest path it traces, in surface interactions.
    pub fn max_depth(&self) -> u32 {
        self.as_integrate().max_depth()
    }

    /// Whether its paths follow fluorescence: camera paths change
    /// wavelength backwards (`material::fluorescence`); light paths, bdpt's
    /// connections and photons would need the forward direction, which
    /// is not written.
    pub fn handles_fluorescence(&self) -> bool {
        matches!(self, Integrator::Path(_))
    }

    /// Refuses a scene its paths cannot follow.
    pub fn check_scene(&self, scene: &Scene) -> Result<(), RenderError> {
        if scene.has_fluorescence() && !self.handles_fluorescence() {
            return Err(RenderError::Fluorescence(self.name()));
        }
        Ok(())
    }
}

/// The camera ray through raster position (x, y): a thin lens takes a 4D
/// point of its own (drawn only then, so pinhole renders keep their
/// numbers).
pub fn camera_ray(scene: &Scene, x: f32, y: f32, sampler: &mut Sampler) -> crate::geometry::Ray {
    if scene.camera.has_lens() {
        let [l0, l1, _, _] = sampler.next_4d();
        scene.camera.ray(x, y, (l0, l1))
    } else {
        scene.camera.generate_ray(x, y)
    }
}

/// A lens point for a connection to the camera (the centre for a pinhole).
pub fn lens_sample(scene: &Scene, sampler: &mut Sampler) -> (f32, f32) {
    if scene.camera.has_lens() {
        sampler.next_2d()
    } else {
        (0.5, 0.5)
    }
}

/// How much likelier a path survives Russian roulette than its throughput
/// says: it goes on with probability min(1, 2·max(β)). Throughput alone (1,
/// as pbrt and Mitsuba do) ends too many paths that still matter where light
/// bounces often. Variance × time with 2 against 1: 16-21% lower on the
/// Cornell Box, 16% on `metals-studio`, 12% on `gltf-spheres-studio`, 3% on
/// `sunset`, the same on `colorchecker` (4 no better on the Cornell Box, no
/// roulette at all 30% worse). Bidirectional paths: variance −6%, time
/// +10% (Cornell, 256², 8 spp); light paths and photons carry throughputs
/// far above 1 and are not touched.
const ROULETTE_SURVIVAL: f32 = 2.0;

/// Russian roulette after `depth` bounces: ends a path of throughput `beta`
/// with probability 1 − 2·max(β)·`eta_scale` (`ROULETTE_SURVIVAL`) once
/// past `rr_depth`, and reweights the survivors so the estimate stays
/// unbiased. `eta_scale` is
/// the product of η'² over the path's transmissions for radiance (which
/// refraction scales by 1/η'², a change of units roulette must not mistake
/// for a dim path), 1 for importance. Returns whether the path goes on (not
/// when its throughput is zero or not a number).
#[inline]
pub fn russian_roulette(
    beta: &mut SampledSpectrum,
    eta_scale: f32,
    depth: u32,
    rr_depth: u32,
    u: f32,
) -> bool {
    let max_beta = beta.max_element();
    // Without branches: whether a path survives is a coin toss that a
    // branch would mispredict half the time, throwing away the work of the
    // packet core's next lane. Where roulette does not play, q is 0 and
    // the division by 1 − q leaves β as it is, bit for bit.
    let q = roulette_q(max_beta, eta_scale, depth >= rr_depth);
    *beta /= 1.0 - q;
    (u >= q) & (max_beta > 0.0)
}

/// The probability that `russian_roulette` ends a path whose throughput's
/// largest value is `max_beta`: 0 where roulette does not `play`.
#[inline(always)]
pub fn roulette_q(max_beta: f32, eta_scale: f32, plays: bool) -> f32 {
    let rr_beta = max_beta * eta_scale * ROULETTE_SURVIVAL;
    if plays {
        (1.0 - rr_beta).max(0.0)
    } else {
        0.0
    }
}

/// Veach's power heuristic (β = 2) for two strategies with one sample each.
#[inline(always)]
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

    #[test]
    fn roulette_survives_twice_the_throughput_and_stays_unbiased() {
        for b in [0.05f32, 0.2, 0.4, 0.7] {
            let beta = SampledSpectrum::new(b, b * 0.5, b * 0.25, 0.0);
            let n = 100_000;
            let (mut survived, mut sum) = (0u32, glam::DVec4::ZERO);
            for k in 0..n {
                let mut after = beta;
                if russian_roulette(&mut after, 1.0, 5, 3, (k as f32 + 0.5) / n as f32) {
                    survived += 1;
                    sum += after.as_dvec4();
                }
            }
            let p = survived as f32 / n as f32;
            assert!((p - (2.0 * b).min(1.0)).abs() < 1e-4, "β {b}: survived {p}");
            let mean = sum / n as f64;
            let err = (mean - beta.as_dvec4()).abs().max_element();
            assert!(err < 1e-5, "β {b}: {mean} vs {beta}");
        }
        // Before rr_depth, every path goes on unchanged.
        let mut early = SampledSpectrum::splat(0.01);
        assert!(russian_roulette(&mut early, 1.0, 2, 3, 0.999));
        assert_eq!(early, SampledSpectrum::splat(0.01));
    }
}
