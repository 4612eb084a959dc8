//! The `[film]` table: image size, sampling defaults, spectral buckets and
//! PNG settings; and the `[integrator]` table.

use super::spectra::Role;
use super::Loader;
use crate::film::{AovSet, ColourTransform, FilmSettings, SpectralLayout};
use crate::integrator::Integrator;
use crate::load::format::SceneFile;
use crate::load::spectrum_spec::SpectrumSpec;
use crate::load::SceneError;
use crate::spectrum::Spectrum;
use crate::spectrum::{LAMBDA_MAX, LAMBDA_MIN};

/// Largest image side accepted.
const MAX_RESOLUTION: u32 = 32_768;

impl Loader {
    pub(super) fn film(&self, file: &SceneFile) -> Result<FilmSettings, SceneError> {
        let f = &file.film;
        let [width, height] = f.resolution;
        if width == 0 || height == 0 {
            return Err(self.error(format!(
                "`film.resolution` must be positive, found [{width}, {height}]"
            )));
        }
        if f.spp == 0 {
            return Err(self.error("`film.spp` must be at least 1"));
        }
        if !f.exposure.is_finite() {
            return Err(self.error("`film.exposure` must be a finite number of stops"));
        }
        if f.png_bits != 8 && f.png_bits != 16 {
            return Err(self.error(format!(
                "`film.png_bits` must be 8 or 16, found {}",
                f.png_bits
            )));
        }
        let mut aovs = AovSet::default();
        for name in &f.aovs {
            if !aovs.add(name) {
                return Err(self.error(format!(
                    "`film.aovs`: unknown output {name:?}; the outputs are {}",
                    AovSet::NAMES.join(", ")
                )));
            }
        }
        let white_balance = self.white_balance(file)?;
        let mut colour = ColourTransform::new(f.colour_space, f.observer, white_balance.as_ref());
        if f.photometric {
            // Y = 683 lm/W × ∫ L ȳ dλ: the film's Y is ∫ L ȳ dλ / Σ ȳ.
            let y_sum = f.observer.cmfs().y_integral as f64;
            colour = colour.scaled((crate::spectrum::cie::LUMINOUS_EFFICACY * y_sum) as f32);
        }
        let display_colour =
            ColourTransform::new(f.display.space(), f.observer, white_balance.as_ref());
        check_film_size(width, height, f.spectral_buckets).map_err(|e| self.error(e))?;
        check_spectral_layout(f.spectral_range, f.spectral_buckets)
            .map_err(|e| self.error(format!("`film.{e}")))?;
        Ok(FilmSettings {
            width,
            height,
            spp: f.spp,
            seed: f.seed,
            sampling: f.sampling,
            layout: SpectralLayout {
                min: f.spectral_range[0],
                max: f.spectral_range[1],
                count: f.spectral_buckets,
            },
            spectral_output: f.spectral,
            exposure: f.exposure,
            tonemap: f.tonemap,
            observer: f.observer,
            colour,
            display_colour,
            display: f.display,
            png_bits: f.png_bits,
            gamut: f.gamut,
            aovs,
            white_balance: f.white_balance.as_ref().map(|v| match v {
                toml::Value::String(name) => name.clone(),
                toml::Value::Table(t) => match (t.get("temperature"), t.get("daylight")) {
                    (Some(k), _) => format!("{k} K"),
                    (_, Some(k)) => format!("daylight {k} K"),
                    _ => v.to_string(),
                },
                other => other.to_string(),
            }),
        })
    }

    /// `film.white_balance`: the spectrum of the illuminant that renders
    /// neutral (a name, as emission spectra take them, or a Planckian
    /// temperature).
    fn white_balance(&self, file: &SceneFile) -> Result<Option<Spectrum>, SceneError> {
        const FORMS: &str = "`film.white_balance` takes an illuminant name such as \"A\" \
            (or a spectrum of [spectra]), a table { temperature = 3200 } (kelvin, Planckian) \
            or { daylight = 5500 } (kelvin, CIE D series)";
        let spectrum = match &file.film.white_balance {
            None => return Ok(None),
            Some(toml::Value::String(name)) => self.spectrum(
                &SpectrumSpec::Named(name.clone()),
                Role::Emission,
                file,
                "film.white_balance",
            )?,
            Some(toml::Value::Table(t)) if t.len() == 1 && t.contains_key("temperature") => {
                let kelvin = kelvin_of(&t["temperature"]).ok_or_else(|| self.error(FORMS))?;
                if !(1000.0..=40_000.0).contains(&kelvin) {
                    return Err(self.error(format!(
                        "`film.white_balance.temperature` = {kelvin} K is outside 1000–40000 K"
                    )));
                }
                Spectrum::Blackbody { kelvin, scale: 1.0 }
            }
            Some(toml::Value::Table(t)) if t.len() == 1 && t.contains_key("daylight") => {
                let kelvin = kelvin_of(&t["daylight"]).ok_or_else(|| self.error(FORMS))?;
                let table = crate::spectrum::cie::daylight(kelvin).ok_or_else(|| {
                    self.error(format!(
                        "`film.white_balance.daylight` = {kelvin} K is outside the D series' 4000–25000 K"
                    ))
                })?;
                Spectrum::Table(table)
            }
            Some(_) => return Err(self.error(FORMS)),
        };
        let y = file.film.observer.cmfs().spectrum_to_xyz(&spectrum).y;
        if !(y > 0.0 && y.is_finite()) {
            return Err(self
                .error("`film.white_balance`: the illuminant has no visible light to balance to"));
        }
        Ok(Some(spectrum))
    }

    /// The integrator and its parameters. `film.max_depth`, where the
    /// bounce limit used to be, is still read, with a warning.
    pub(super) fn integrator(&self, file: &mut SceneFile) -> Result<Integrator, SceneError> {
        if let Some(depth) = file.film.max_depth {
            if file.integrator.gives("max_depth") {
                return Err(self.error(
                    "`film.max_depth` and `integrator.max_depth` both given: keep `integrator.max_depth`",
                ));
            }
            self.warn("`film.max_depth` has moved to `integrator.max_depth`");
            file.integrator
                .set("max_depth", i64::from(depth))
                .map_err(|e| self.error(e))?;
        }
        Integrator::from_spec(&file.integrator).map_err(|e| self.error(e))
    }
}

/// Checks that a film fits: at most 32768 pixels a side, and its sums and
/// output buffers within the memory budget (the render checks the whole
/// estimate again, with the scene and the passes, before it starts).
pub fn check_film_size(width: u32, height: u32, buckets: u32) -> Result<(), String> {
    if width > MAX_RESOLUTION || height > MAX_RESOLUTION {
        return Err(format!(
            "`film.resolution` [{width}, {height}] is larger than {MAX_RESOLUTION} pixels on a side"
        ));
    }
    let (film, writing) =
        crate::film::film_bytes(width as u64 * height as u64, buckets, true, false);
    crate::memory::check(
        &format!("the film ({width}x{height} pixels, {buckets} spectral buckets)"),
        film + writing,
    )
    .map_err(|e| format!("{e}: use fewer pixels or buckets"))
}

/// Checks a film's spectral bucket layout; the message starts with the key.
pub fn check_spectral_layout(range: [f32; 2], buckets: u32) -> Result<(), String> {
    let [lo, hi] = range;
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lo)
        || !(LAMBDA_MIN..=LAMBDA_MAX).contains(&hi)
        || lo >= hi
    {
        return Err(format!(
            "spectral_range` must be an increasing pair within [{LAMBDA_MIN}, {LAMBDA_MAX}] nm, found [{lo}, {hi}]"
        ));
    }
    if buckets == 0 || buckets > 4096 {
        return Err(format!(
            "spectral_buckets` must be between 1 and 4096, found {buckets}"
        ));
    }
    // The spectral EXR names each bucket by its centre to 1e-6 nm: buckets
    // must be told apart that way, checked now rather than after the render.
    let layout = crate::film::SpectralLayout {
        min: lo,
        max: hi,
        count: buckets,
    };
    let names: std::collections::HashSet<String> = (0..buckets)
        .map(|i| crate::film::spectral_exr::channel_name(layout.centre(i) as f64))
        .collect();
    if names.len() < buckets as usize || !(layout.width() > 0.0) {
        return Err(format!(
            "spectral_range` [{lo}, {hi}] nm is too narrow for {buckets} buckets: the spectral EXR's channel names (centres to 1e-6 nm) would repeat"
        ));
    }
    Ok(())
}

/// A temperature in kelvin written as a TOML number.
fn kelvin_of(v: &toml::Value) -> Option<f32> {
    match v {
        toml::Value::Float(k) => Some(*k as f32),
        toml::Value::Integer(k) => Some(*k as f32),
        _ => None,
    }
}
