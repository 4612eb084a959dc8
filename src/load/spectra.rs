//! Spectra: named (the scene's own or built-in illuminants), constants,
//! tables, CSV files, blackbodies and RGB, each checked for its role.

use glam::Vec3;

use std::path::{Path, PathBuf};

use super::{spectrum_spec, Loader};
use crate::load::format::SceneFile;
use crate::load::spectrum_spec::SpectrumSpec;
use crate::load::SceneError;
use crate::spectrum::formats;
use crate::spectrum::{cie, Spectrum, TabulatedSpectrum, LAMBDA_MAX, LAMBDA_MIN};

/// Which physical quantity a spectrum stands for: it decides how RGB is
/// upsampled and which values are allowed.
#[derive(Clone, Copy, PartialEq)]
pub(super) enum Role {
    /// In [0, 1]: reflectances, transmittances.
    Reflectance,
    /// A radiance: illuminant names and blackbodies are normalised to
    /// luminance 1, RGB is relative to the sRGB white (D65).
    Emission,
    /// Any non-negative optical constant (a metal's η and k, an index of
    /// refraction): taken as given, never normalised, no illuminants.
    Unbounded,
}

/// The brightest emission accepted: f32 arithmetic must carry it through
/// a path's products and a film's sums.
pub(super) const MAX_RADIANCE: f32 = 1e30;

impl Loader {
    pub(super) fn spectrum(
        &self,
        spec: &SpectrumSpec,
        role: Role,
        file: &SceneFile,
        key: &str,
    ) -> Result<Spectrum, SceneError> {
        let spectrum = match spec {
            SpectrumSpec::Named(name) => match file.spectra.get(name) {
                Some(SpectrumSpec::Named(inner)) => self.builtin(inner, role, key)?,
                Some(defined) => self.spectrum(defined, role, file, &format!("spectra.{name}"))?,
                None if cie::illuminant(name).is_none() => {
                    return Err(self.unknown_spectrum(name, file, key))
                }
                None => self.builtin(name, role, key)?,
            },
            SpectrumSpec::Constant(c) => Spectrum::Constant(*c),
            SpectrumSpec::Table(rows) => {
                let (l, v): (Vec<f32>, Vec<f32>) = rows.iter().map(|r| (r[0], r[1])).unzip();
                self.table(l, v, key)?
            }
            SpectrumSpec::File {
                path,
                scale,
                column,
            } => {
                let full = self.input_file(path.as_ref(), key)?;
                let text = crate::input::read_to_string(&full).map_err(|e| {
                    self.error(format!("`{key}`: spectrum file {}: {e}", full.display()))
                })?;
                let t = formats::parse_any(&text)
                    .map_err(|e| self.error(format!("`{key}`: {}: {e}", full.display())))?;
                if let Some(note) = &t.note {
                    self.warn(format!("`{key}`: {}: {note}", full.display()));
                }
                let k = t
                    .column(column.as_ref())
                    .map_err(|e| self.error(format!("`{key}`: {}: {e}", full.display())))?;
                Spectrum::Table(TabulatedSpectrum::new(t.wavelengths, t.columns[k].clone()))
                    .scaled(*scale)
            }
            SpectrumSpec::Daylight { kelvin, scale } => {
                if role != Role::Emission {
                    return Err(self.error(format!(
                        "`{key}`: a daylight illuminant is an emission spectrum"
                    )));
                }
                let table = cie::daylight(*kelvin).ok_or_else(|| {
                    self.error(format!(
                        "`{key}`: the CIE D series is defined from 4000 to 25000 K, not {kelvin}"
                    ))
                })?;
                normalised(Spectrum::Table(table)).scaled(*scale)
            }
            SpectrumSpec::Blackbody { kelvin, scale } => {
                if role == Role::Unbounded {
                    return Err(self.error(format!(
                        "`{key}`: a blackbody is an emission spectrum, not an optical constant"
                    )));
                }
                if !(*kelvin > 0.0) {
                    return Err(
                        self.error(format!("`{key}`: blackbody temperature must be positive"))
                    );
                }
                normalised(Spectrum::Blackbody {
                    kelvin: *kelvin,
                    scale: 1.0,
                })
                .scaled(*scale)
            }
            SpectrumSpec::Rgb { rgb, scale } => {
                let rgb = Vec3::from(*rgb);
                if rgb.min_element() < 0.0 {
                    return Err(self.error(format!("`{key}`: RGB components must not be negative")));
                }
                match role {
                    Role::Reflectance => {
                        if rgb.max_element() > 1.0 {
                            return Err(self
                                .error(format!("`{key}`: a reflectance RGB must lie in [0, 1]")));
                        }
                        Spectrum::rgb_reflectance(rgb).scaled(*scale)
                    }
                    Role::Emission => Spectrum::rgb_emission(rgb).scaled(*scale),
                    Role::Unbounded => Spectrum::rgb_unbounded(rgb).scaled(*scale),
                }
            }
        };
        self.check_range(&spectrum, role, key)?;
        Ok(spectrum)
    }

    /// `s` scaled so that its photometric value (683 lm/W × ∫ S ȳ dλ) is
    /// `target`: cd/m², lumens or lux, as `key` says.
    pub(super) fn photometric(
        &self,
        s: Spectrum,
        target: f32,
        key: &str,
    ) -> Result<Spectrum, SceneError> {
        if !(0.0..=MAX_RADIANCE).contains(&target) {
            return Err(self.error(format!(
                "`{key}` must be a number from 0 to {MAX_RADIANCE:e}, found {target}"
            )));
        }
        let now = cie::photometric(&s);
        if !(now > 0.0 && now.is_finite()) {
            return Err(self.error(format!(
                "`{key}`: the spectrum has no visible light to scale"
            )));
        }
        Ok(s.scaled((target as f64 / now) as f32))
    }

    /// A built-in illuminant, normalised to luminance Y = 1.
    /// An emission spectrum after its scale, refused when its radiance
    /// would overflow the renderer's f32 arithmetic (paths multiply it by
    /// throughputs and divide it by densities): better an error than a
    /// black image with a count of dropped samples.
    pub(super) fn checked_emission(&self, s: Spectrum, key: &str) -> Result<Spectrum, SceneError> {
        let peak = (LAMBDA_MIN as u32..=LAMBDA_MAX as u32)
            .map(|l| s.eval(l as f32))
            .fold(
                0.0f32,
                |a, v| if v.is_nan() { f32::INFINITY } else { a.max(v) },
            );
        if peak > MAX_RADIANCE {
            return Err(self.error(format!(
                "`{key}` reaches {peak:e}, beyond what f32 arithmetic carries through a path (limit {MAX_RADIANCE:e}): scale the emission down and raise `film.exposure`"
            )));
        }
        Ok(s)
    }

    pub(super) fn builtin(
        &self,
        name: &str,
        role: Role,
        key: &str,
    ) -> Result<Spectrum, SceneError> {
        match cie::illuminant(name) {
            Some(t) if role == Role::Emission => Ok(normalised(Spectrum::Table(t.clone()))),
            Some(_) => Err(self.error(format!(
                "`{key}`: `{name}` is an illuminant, not {}",
                if role == Role::Reflectance {
                    "a reflectance"
                } else {
                    "an optical constant (η, k or an index of refraction)"
                }
            ))),
            None => Err(self.error(format!(
                "`{key}`: unknown spectrum `{name}` (built-in: {}; or define it under [spectra])",
                cie::illuminant_names().join(", ")
            ))),
        }
    }

    /// An unknown spectrum name: the names there are (the scene's and the
    /// built-in ones), and the nearest as a suggestion.
    fn unknown_spectrum(&self, name: &str, file: &SceneFile, key: &str) -> SceneError {
        let own: Vec<&str> = file.spectra.keys().map(String::as_str).collect();
        let known = own.iter().copied().chain(cie::illuminant_names());
        let nearest = known
            .clone()
            .map(|k| {
                (
                    super::messages::edit_distance(&name.to_lowercase(), &k.to_lowercase()),
                    k,
                )
            })
            .min();
        let mut message = format!(
            "`{key}`: unknown spectrum `{}` (built-in: {}; the scene's [spectra]: {})",
            truncated(name),
            cie::illuminant_names().join(", "),
            if own.is_empty() {
                "none".to_string()
            } else {
                own.join(", ")
            }
        );
        if let Some((d, k)) = nearest {
            if d > 0 && d <= 2.max(name.len() / 3) {
                message.push_str(&format!("\ndid you mean `{k}`?"));
            }
        }
        self.error(message)
    }

    pub(super) fn table(
        &self,
        l: Vec<f32>,
        v: Vec<f32>,
        key: &str,
    ) -> Result<Spectrum, SceneError> {
        if l.len() < 2 {
            return Err(self.error(format!(
                "`{key}`: a spectrum table needs at least two [nm, value] rows"
            )));
        }
        if let Some(w) = l.windows(2).find(|w| !(w[0] < w[1])) {
            return Err(self.error(format!(
                "`{key}`: wavelengths must increase ({} nm then {} nm)",
                w[0], w[1]
            )));
        }
        if l[0] <= 0.0 {
            return Err(self.error(format!("`{key}`: wavelengths must be positive")));
        }
        Ok(Spectrum::Table(TabulatedSpectrum::new(l, v)))
    }

    pub(super) fn check_range(
        &self,
        s: &Spectrum,
        role: Role,
        key: &str,
    ) -> Result<(), SceneError> {
        let (lo, hi) = sampled_range(s);
        if lo < 0.0 {
            return Err(self.error(format!("`{key}`: spectrum values must not be negative")));
        }
        if role == Role::Reflectance && hi > 1.0 + 1e-6 {
            return Err(self.error(format!(
                "`{key}`: a reflectance must lie in [0, 1], found values up to {hi}"
            )));
        }
        Ok(())
    }
}

/// Scales an illuminant so that its luminance (CIE Y, as the film computes it) is 1.
fn normalised(s: Spectrum) -> Spectrum {
    let y = cie::spectrum_to_xyz(&s).y;
    if y > 0.0 {
        s.scaled(1.0 / y)
    } else {
        s
    }
}

/// Smallest and largest value of a spectrum over the rendered range.
fn sampled_range(s: &Spectrum) -> (f32, f32) {
    (0..=(LAMBDA_MAX - LAMBDA_MIN) as usize)
        .map(|i| s.eval(LAMBDA_MIN + i as f32))
        .chain(match s {
            Spectrum::Table(t) => t.values().to_vec(),
            _ => vec![],
        })
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
}

/// A name as quoted in a message: at most 60 characters.
fn truncated(name: &str) -> String {
    if name.chars().count() <= 60 {
        name.to_string()
    } else {
        format!("{}…", name.chars().take(60).collect::<String>())
    }
}

/// A spectrum written as a scene writes one (`value`: a number, a name
/// such as "D65", a table of [nm, value] rows, `{ blackbody = 2856 }`, ...)
/// for `role`: "emission" (illuminants normalised to luminance 1),
/// "reflectance" (in [0, 1]) or "unbounded" (optical constants). Files it
/// names are relative to `base`. Errors name `key`.
pub fn spectrum(
    value: toml::Value,
    role: &str,
    base: &Path,
    key: &str,
) -> Result<Spectrum, SceneError> {
    let loader = Loader::new(PathBuf::from("<spectrum>"), base.to_path_buf());
    let role = match role {
        "emission" => Role::Emission,
        "reflectance" => Role::Reflectance,
        "unbounded" => Role::Unbounded,
        other => {
            return Err(loader.error(format!(
                "unknown spectrum role {other:?}: emission, reflectance or unbounded"
            )))
        }
    };
    let spec: spectrum_spec::SpectrumSpec = value
        .try_into()
        .map_err(|e: toml::de::Error| loader.error(format!("`{key}`: {}", e.message())))?;
    let mut empty = toml::Table::new();
    empty.insert("camera".into(), toml::Value::Table(toml::Table::new()));
    let file: SceneFile = toml::Value::Table(empty)
        .try_into()
        .map_err(|e: toml::de::Error| loader.error(e.to_string()))?;
    loader.spectrum(&spec, role, &file, key)
}
