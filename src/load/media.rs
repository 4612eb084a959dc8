//! Participating media: a dielectric's or an interface's `medium`, and the
//! world's `[medium]`, with their coefficients converted to scene units.

use super::spectra::Role;
use super::Loader;
use crate::load::format::{MediumSpec, SceneFile};
use crate::load::spectrum_spec::SpectrumSpec;
use crate::load::SceneError;
use crate::medium::{water, HenyeyGreenstein, Medium};
use crate::spectrum::{Spectrum, LAMBDA_MAX, LAMBDA_MIN};

/// Coefficients above this (per scene unit) make every segment opaque in
/// f32 and say the scene's units are wrong.
const MAX_COEFFICIENT: f32 = 1e8;

impl Loader {
    /// The metres per scene unit (`units`, default 1).
    pub(super) fn units(&self, file: &SceneFile) -> Result<f32, SceneError> {
        match file.units {
            None => Ok(1.0),
            Some(u) if u > 0.0 && u.is_finite() => Ok(u),
            Some(u) => Err(self.error(format!(
                "`units` (metres per scene unit) must be a positive number, not {u}"
            ))),
        }
    }

    pub(super) fn medium(
        &self,
        spec: &MediumSpec,
        file: &SceneFile,
        key: &str,
    ) -> Result<Medium, SceneError> {
        let units = self.units(file)?;
        let sigma_a = match (
            &spec.absorption,
            spec.attenuation_color,
            spec.attenuation_distance,
        ) {
            (Some(a), None, None) => self.coefficient(a, file, &format!("{key}.absorption"))?,
            (None, Some(colour), Some(distance)) => {
                self.attenuation(colour, distance, &format!("{key}.attenuation_color"))?
            }
            (None, None, None) => Spectrum::Constant(0.0),
            (Some(_), _, _) => {
                return Err(self.error(format!(
                    "`{key}`: give `absorption`, or `attenuation_color` with `attenuation_distance`, not both"
                )))
            }
            _ => {
                return Err(self.error(format!(
                    "`{key}`: `attenuation_color` and `attenuation_distance` go together"
                )))
            }
        };
        let sigma_s = match &spec.scattering {
            None => None,
            Some(s) => Some(self.coefficient(s, file, &format!("{key}.scattering"))?),
        };
        let g = spec.phase.as_ref().map_or(0.0, |p| p.hg);
        if !(g > -1.0 && g < 1.0) {
            return Err(self.error(format!(
                "`{key}.phase.hg` is the mean cosine of scattering and must lie in (-1, 1), not {g}"
            )));
        }
        let per_unit = |s: Spectrum, what: &str| -> Result<Spectrum, SceneError> {
            let s = s.scaled(units);
            let worst = (LAMBDA_MIN as u32..=LAMBDA_MAX as u32)
                .map(|l| s.eval(l as f32))
                .fold(0.0f32, f32::max);
            if worst > MAX_COEFFICIENT {
                return Err(self.error(format!(
                    "`{key}.{what}` reaches {worst:e} per scene unit (`units` = {units} m): \
                     every ray would stop at once; check the units (coefficients are per metre)"
                )));
            }
            Ok(s)
        };
        let sigma_a = per_unit(sigma_a, "absorption")?;
        let sigma_s = match sigma_s {
            // A scattering coefficient of zero everywhere only absorbs.
            Some(s) if (LAMBDA_MIN as u32..=LAMBDA_MAX as u32).any(|l| s.eval(l as f32) > 0.0) => {
                Some(per_unit(s, "scattering")?)
            }
            _ => None,
        };
        Ok(Medium {
            sigma_a,
            sigma_s,
            phase: HenyeyGreenstein { g },
        })
    }

    /// A coefficient spectrum in 1/m: any spectrum form, or "water".
    fn coefficient(
        &self,
        spec: &SpectrumSpec,
        file: &SceneFile,
        key: &str,
    ) -> Result<Spectrum, SceneError> {
        let s = match spec {
            SpectrumSpec::Named(name)
                if name == water::NAME && !file.spectra.contains_key(name) =>
            {
                Spectrum::Table(water::absorption().clone())
            }
            _ => self.spectrum(spec, Role::Unbounded, file, key)?,
        };
        let bad = (LAMBDA_MIN as u32..=LAMBDA_MAX as u32)
            .map(|l| s.eval(l as f32))
            .find(|v| !(v.is_finite() && *v >= 0.0));
        if let Some(v) = bad {
            return Err(self.error(format!(
                "`{key}`: a coefficient must be finite and non-negative over {LAMBDA_MIN}-{LAMBDA_MAX} nm, found {v}"
            )));
        }
        Ok(s)
    }

    /// glTF's attenuation: white light becomes `colour` (linear sRGB,
    /// upsampled to a spectrum) after `distance` metres, so σa(λ) =
    /// −ln c(λ) / distance.
    fn attenuation(
        &self,
        colour: [f32; 3],
        distance: f32,
        key: &str,
    ) -> Result<Spectrum, SceneError> {
        if !colour.iter().all(|c| *c > 0.0 && *c <= 1.0) {
            return Err(self.error(format!(
                "`{key}` components must lie in (0, 1] (1: that primary passes unattenuated), found {colour:?}"
            )));
        }
        if !(distance > 0.0 && distance.is_finite()) {
            return Err(self.error(format!(
                "`{}` must be a positive distance in metres, not {distance}",
                key.replace("attenuation_color", "attenuation_distance")
            )));
        }
        Ok(Medium::attenuation(colour, distance))
    }
}
