//! The path tracer's own keys of `[integrator]`, and how they configure it.

use super::PathTracer;
use crate::integrator::{CommonParams, Configure, Strategy, MAX_SPLIT};
use serde::Deserialize;

/// The path tracer's own keys of `[integrator]`.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PathParams {
    /// How direct light is found: "mis" (default), "nee" or "bsdf".
    pub strategy: Option<Strategy>,
    /// Continuations per camera sample from its first surface that is not
    /// a Dirac one (default 1: no splitting).
    pub split: Option<u32>,
    /// Follow each wavelength on its own past the first smooth dispersive
    /// interface (default true).
    pub split_dispersion: Option<bool>,
    /// Follow both the reflection and the transmission of glass met first
    /// (default true).
    pub split_glass: Option<bool>,
    /// Trace ahead the lobes of smooth glass that leave every object, in
    /// camera paths through mirrors and smooth glass alone (default false).
    pub look_ahead: Option<bool>,
    /// In the packet core, reuse the paths of a 2 × 2 block of pixels from
    /// their first bounce on (default: where every surface is diffuse).
    pub reuse: Option<bool>,
}

impl Configure for PathTracer {
    type Params = PathParams;

    fn configure(common: &CommonParams, own: PathParams) -> Result<Self, String> {
        let d = PathTracer::default();
        let split = check_split(own.split.unwrap_or(d.split))?;
        Ok(PathTracer {
            max_depth: common.max_depth.unwrap_or(d.max_depth),
            rr_depth: common.rr_depth.unwrap_or(d.rr_depth),
            strategy: own.strategy.unwrap_or(d.strategy),
            split,
            split_dispersion: own.split_dispersion.unwrap_or(d.split_dispersion),
            split_glass: own.split_glass.unwrap_or(d.split_glass),
            look_ahead: own.look_ahead.unwrap_or(d.look_ahead),
            reuse: own.reuse.or(d.reuse),
        })
    }
}

/// `integrator.split`, refused outside 1..=`MAX_SPLIT`.
pub(in crate::integrator) fn check_split(split: u32) -> Result<u32, String> {
    if (1..=MAX_SPLIT).contains(&split) {
        Ok(split)
    } else {
        Err(format!(
            "`integrator.split` must be between 1 and {MAX_SPLIT}, not {split}"
        ))
    }
}
