//! `[[light]]` tables (point, spot and directional lights) and the
//! `[environment]`.

use std::f32::consts::PI;
use std::sync::Arc;

use glam::Vec3;

use super::spectra::{Role, MAX_RADIANCE};
use super::{Loader, MAX_COORDINATE};
use crate::light::{
    band_wavelength, Cone, DirectionalLight, EnvironmentMap, Light, PointLight, Sky, SkyModel, Sun,
    UniformEnvironment, SKY_BANDS, SUN_DIAMETER_DEGREES,
};
use crate::load::format::{EnvironmentSpec, LightKind, LightSpec, SceneFile, SkySpec};
use crate::load::SceneError;
use crate::spectrum::{Spectrum, LAMBDA_MAX, LAMBDA_MIN};

impl Loader {
    pub(super) fn lights(&self, file: &SceneFile) -> Result<Vec<Light>, SceneError> {
        let mut lights = file
            .lights
            .iter()
            .enumerate()
            .map(|(i, spec)| self.light(spec, file, &format!("light[{i}]")))
            .collect::<Result<Vec<_>, _>>()?;
        if let Some(env) = &file.environment {
            lights.extend(self.environment(env, file)?);
        }
        Ok(lights)
    }

    fn environment(
        &self,
        env: &EnvironmentSpec,
        file: &SceneFile,
    ) -> Result<Vec<Light>, SceneError> {
        let scale = env.scale.unwrap_or(1.0);
        if !(scale >= 0.0) {
            return Err(self.error("`environment.scale` must not be negative"));
        }
        match (&env.radiance, &env.file, &env.sky) {
            (Some(radiance), None, None) => {
                if env.rotate.is_some() {
                    return Err(self.error(
                        "`environment.rotate` applies to a map (`file`), not to a constant `radiance`",
                    ));
                }
                let radiance = self.checked_emission(
                    self.spectrum(radiance, Role::Emission, file, "environment.radiance")?
                        .scaled(scale),
                    "environment.radiance",
                )?;
                Ok(vec![Light::Environment(UniformEnvironment::new(radiance))])
            }
            (None, Some(rel), None) => {
                let path = self.input_file(rel.as_ref(), "environment.file")?;
                let (w, h, rgb) = read_radiance_image(&path)
                    .map_err(|e| self.error(format!("`environment.file`: {e}")))?;
                let brightest = rgb.iter().fold(0.0f32, |m, c| m.max(c.max_element()));
                if !(brightest * scale <= MAX_RADIANCE) {
                    return Err(self.error(format!(
                        "`environment.file`: its brightest texel ({brightest:e}) times \
                         `environment.scale` ({scale:e}) is beyond what f32 arithmetic carries \
                         through a path (limit {MAX_RADIANCE:e})"
                    )));
                }
                let rotate = env.rotate.unwrap_or(0.0);
                Ok(vec![Light::EnvironmentMap(EnvironmentMap::new(
                    w as usize, h as usize, &rgb, scale, rotate,
                ))])
            }
            (None, None, Some(sky)) => {
                if env.rotate.is_some() {
                    return Err(self.error(
                        "`environment.rotate` applies to a map (`file`); turn a sky with `sky.sun_azimuth`",
                    ));
                }
                self.sky(sky, scale, file)
            }
            _ => Err(self.error(
                "`[environment]` takes one of `radiance` (a constant sky), `file` (a map) or `sky` (sun and sky)",
            )),
        }
    }

    /// The Hosek–Wilkie sky dome and sun disc, each a light.
    fn sky(&self, sky: &SkySpec, scale: f32, file: &SceneFile) -> Result<Vec<Light>, SceneError> {
        // Large numbers in e-notation: 1e38, not 39 digits.
        let num = |v: f32| {
            if v.abs() >= 1e6 {
                format!("{v:e}")
            } else {
                format!("{v}")
            }
        };
        let in_range = |key: &str, v: f32, lo: f32, hi: f32, what: &str| {
            if (lo..=hi).contains(&v) {
                Ok(v)
            } else {
                Err(self.error(format!(
                    "`environment.sky.{key}` = {} is outside [{}, {}]{what}",
                    num(v),
                    num(lo),
                    num(hi)
                )))
            }
        };
        let elevation = in_range(
            "sun_elevation",
            sky.sun_elevation,
            0.0,
            90.0,
            " degrees: the Hosek–Wilkie model covers a sun above the horizon",
        )?;
        let azimuth = sky.sun_azimuth.unwrap_or(0.0);
        let turbidity = in_range(
            "turbidity",
            sky.turbidity.unwrap_or(3.0),
            1.0,
            10.0,
            ", the model's range (1 very clear, 10 hazy)",
        )?;
        // The model's radiances reach about 1e5 (the sun's disc): scales
        // up to MAX_SKY_SCALE keep every product within f32.
        let sun_scale = in_range(
            "sun_scale",
            sky.sun_scale.unwrap_or(1.0),
            0.0,
            MAX_SKY_SCALE,
            ": larger, the radiance would overflow f32",
        )?;
        let sky_scale = in_range(
            "sky_scale",
            sky.sky_scale.unwrap_or(1.0),
            0.0,
            MAX_SKY_SCALE,
            ": larger, the radiance would overflow f32",
        )?;
        if !(sun_scale.max(sky_scale) * scale <= MAX_SKY_SCALE) {
            return Err(self.error(format!(
                "`environment.scale` times `environment.sky.sun_scale` or `sky_scale` is \
                 {:e}, beyond {MAX_SKY_SCALE:e}: the sky's radiance would overflow f32",
                sun_scale.max(sky_scale) * scale
            )));
        }
        let aperture = sky.sun_aperture.unwrap_or(SUN_DIAMETER_DEGREES);
        if !(aperture > 0.0 && aperture <= 45.0) {
            return Err(self.error(format!(
                "`environment.sky.sun_aperture` = {aperture} must lie in (0, 45] degrees"
            )));
        }
        let albedo_spectrum = match &sky.ground_albedo {
            Some(s) => {
                self.spectrum(s, Role::Reflectance, file, "environment.sky.ground_albedo")?
            }
            None => Spectrum::Constant(0.3),
        };
        // The model's bands start at 320 nm, below the spectra prism keeps.
        let albedo: [f32; SKY_BANDS] = std::array::from_fn(|b| {
            albedo_spectrum.eval(band_wavelength(b).clamp(LAMBDA_MIN, LAMBDA_MAX))
        });
        if let Some(a) = albedo.iter().find(|a| !(0.0..=1.0).contains(*a)) {
            return Err(self.error(format!(
                "`environment.sky.ground_albedo` must lie in [0, 1], found {a}"
            )));
        }
        let (e, a) = (elevation.to_radians(), azimuth.to_radians());
        let towards_sun = Vec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos());
        let model = Arc::new(SkyModel::new(e, turbidity, albedo));
        let mut lights = Vec::new();
        if sky_scale * scale > 0.0 {
            lights.push(Light::Sky(Sky::new(
                model.clone(),
                towards_sun,
                sky_scale * scale,
            )));
        }
        if sun_scale * scale > 0.0 {
            lights.push(Light::Sun(Sun::new(
                model,
                towards_sun,
                aperture,
                sun_scale * scale,
            )));
        }
        Ok(lights)
    }

    fn light(&self, spec: &LightSpec, file: &SceneFile, key: &str) -> Result<Light, SceneError> {
        let scale = spec.common.scale.unwrap_or(1.0);
        if !(scale >= 0.0) {
            return Err(self.error(format!("`{key}.scale` must not be negative")));
        }
        let spectrum = |s, name: &str| -> Result<Spectrum, SceneError> {
            let key = format!("{key}.{name}");
            let s = self.spectrum(s, Role::Emission, file, &key)?.scaled(scale);
            self.checked_emission(s, &key)
        };
        let point = |name: &str, p: [f32; 3]| -> Result<Vec3, SceneError> {
            let p = Vec3::from(p);
            if p.abs().max_element() > MAX_COORDINATE {
                return Err(self.error(format!(
                    "`{key}.{name}` lies beyond ±{MAX_COORDINATE:e}, the range of prism's single-precision geometry"
                )));
            }
            Ok(p)
        };
        // With `lumens` or `lux` (`target`, the key `name`) instead of
        // `scale`: the spectrum's shape scaled to that photometric value,
        // then by `per` (1 / the solid angle, for a flux), and checked as
        // any emission.
        let photometric = |s: Spectrum, target: Option<f32>, name: &str, per: f32| {
            let Some(value) = target else {
                return Ok(s);
            };
            if spec.common.scale.is_some() {
                return Err(self.error(format!("`{key}`: give `scale` or `{name}`, not both")));
            }
            let key = format!("{key}.{name}");
            let s = self.photometric(s, value, &key)?.scaled(per);
            self.checked_emission(s, &key)
        };
        // Radiant intensity from `intensity`, or from `power` spread over
        // the solid angle the light fills.
        let intensity = |intensity, power, solid_angle: f32, lumens: Option<f32>| {
            let i = match (intensity, power) {
                (Some(i), None) => spectrum(i, "intensity")?,
                (None, Some(p)) => spectrum(p, "power")?.scaled(1.0 / solid_angle),
                _ => return Err(self.error(format!("`{key}`: give either `intensity` or `power`"))),
            };
            photometric(i, lumens, "lumens", 1.0 / solid_angle)
        };
        match &spec.kind {
            LightKind::Directional(d) => {
                let direction = point("direction", d.direction)?;
                if direction.length_squared() == 0.0 {
                    return Err(self.error(format!("`{key}.direction` must not be zero")));
                }
                let e = photometric(spectrum(&d.irradiance, "irradiance")?, d.lux, "lux", 1.0)?;
                Ok(Light::Directional(DirectionalLight::new(
                    direction.normalize(),
                    e,
                )))
            }
            LightKind::Point(p) => {
                let position = point("position", p.position)?;
                let i = intensity(p.intensity.as_ref(), p.power.as_ref(), 4.0 * PI, p.lumens)?;
                Ok(Light::Point(PointLight::new(position, i, None)))
            }
            LightKind::Spot(s) => {
                let position = point("position", s.position)?;
                let axis = point("look_at", s.look_at)? - position;
                if axis.length_squared() == 0.0 {
                    return Err(self.error(format!("`{key}.look_at` must differ from `position`")));
                }
                let end = s.cone_angle.unwrap_or(30.0);
                if !(MIN_CONE_DEGREES..=180.0).contains(&end) {
                    return Err(self.error(format!(
                        "`{key}.cone_angle` must be in [{MIN_CONE_DEGREES}, 180] degrees (a narrower \
                         cone's cosine is 1 in single precision: it would light nothing), found {end}"
                    )));
                }
                let start = s.falloff_start.unwrap_or((end - 5.0).max(0.0));
                if !(start >= 0.0 && start <= end) {
                    return Err(self.error(format!(
                        "`{key}.falloff_start` must be in [0, cone_angle], found {start}"
                    )));
                }
                let cone = Cone {
                    axis: axis.normalize(),
                    cos_falloff_start: start.to_radians().cos(),
                    cos_falloff_end: end.to_radians().cos(),
                };
                // 2π(1 − (cos θs + cos θe)/2), written with 1 − cos θ =
                // 2 sin²(θ/2) so that narrow cones keep their digits.
                let half_sin2 = |degrees: f32| (0.5 * degrees.to_radians()).sin().powi(2);
                let solid_angle = 2.0 * PI * (half_sin2(start) + half_sin2(end));
                let i = intensity(
                    s.intensity.as_ref(),
                    s.power.as_ref(),
                    solid_angle,
                    s.lumens,
                )?;
                Ok(Light::Point(PointLight::new(position, i, Some(cone))))
            }
        }
    }
}

/// The largest factor on the Hosek–Wilkie sky and sun (see `sky`).
const MAX_SKY_SCALE: f32 = 1e20;

/// Narrowest spot cone accepted, in degrees: cos(0.1°) = 1 − 1.5e-6 still
/// has about 25 steps of single precision below 1.
const MIN_CONE_DEGREES: f32 = 0.1;

/// Largest environment map side (texels); a map is kept as 16 bytes a texel
/// plus its sampling tables.
const MAX_MAP_SIDE: u32 = 16384;

/// An environment map's texels as linear RGB, rows from the top: OpenEXR
/// and Radiance HDR are linear; other images (PNG, JPEG, …) are sRGB-encoded.
/// Refuses non-finite or negative radiance, naming the first such texel.
fn read_radiance_image(path: &std::path::Path) -> Result<(u32, u32, Vec<Vec3>), String> {
    // Both readers below open only regular files (see `input`).
    let name = path.display();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    let (w, h, rgb) = if ext == "exr" {
        let (w, h, rgb) = crate::film::output::read_rgb_exr(path).map_err(|e| format!("{e:#}"))?;
        crate::memory::hold(
            &format!("{name}: the environment map ({w}x{h} texels)"),
            w as u64 * h as u64 * 24,
        )?;
        (w, h, rgb)
    } else {
        let bytes = crate::input::read(path).map_err(|e| format!("{name}: {e}"))?;
        // 12 bytes a texel while converting; kept: 12 of radiance and the
        // sampling tables.
        let image =
            crate::texture::decode_image(&bytes, 12, 24).map_err(|e| format!("{name}: {e}"))?;
        let linear = ext == "hdr";
        let (w, h) = (image.width(), image.height());
        let rgb = image
            .to_rgb32f()
            .pixels()
            .map(|p| {
                let c = Vec3::new(p[0], p[1], p[2]);
                if linear {
                    c
                } else {
                    Vec3::new(
                        crate::spectrum::cie::srgb_decode(c.x),
                        crate::spectrum::cie::srgb_decode(c.y),
                        crate::spectrum::cie::srgb_decode(c.z),
                    )
                }
            })
            .collect();
        (w, h, rgb)
    };
    if w == 0 || h == 0 {
        return Err(format!("{name}: the image is empty"));
    }
    if w > MAX_MAP_SIDE || h > MAX_MAP_SIDE {
        return Err(format!(
            "{name}: {w}x{h} texels; an environment map may have at most {MAX_MAP_SIDE} a side"
        ));
    }
    if let Some(k) = rgb
        .iter()
        .position(|c| !(c.is_finite() && c.min_element() >= 0.0))
    {
        let (x, y) = (k as u32 % w, k as u32 / w);
        return Err(format!(
            "{name}: texel ({x}, {y}) is {}: radiance must be finite and not negative",
            rgb[k]
        ));
    }
    Ok((w, h, rgb))
}
