//! Lights: what emits, how to sample a point or a ray on it, and which one
//! to pick. Every light implements [`LightSource`] whole and is a line of
//! the `lights!` list, which makes the [`Light`] enum; integrators use only
//! its methods and [`LightSet`], so adding a light (point, spot,
//! environment) touches this folder alone.
//!
//! - `sample_li` / `pdf_li`: light arriving at a point (next-event
//!   estimation), with its solid-angle density.
//! - `l` (for surfaces a ray hits) and `le` (for rays that escape the
//!   scene, which infinite lights answer).
//! - `sample_le` / `pdf_le`: rays leaving the light, for paths that start
//!   at lights (light tracing, bidirectional methods, photons).
//! - `power`: for the selection distribution ([`PowerSelection`]).

#[macro_use]
mod at_infinity;
mod area;
mod directional;
mod environment;
mod environment_map;
mod examples;
mod hosek_wilkie;
mod lat_long;
mod point;
mod selection;
mod set;
mod sky;
mod sphere;
mod sun;

use std::f32::consts::PI;
use std::sync::Arc;

use glam::{Vec2, Vec3};

pub use area::AreaLight;
pub use directional::DirectionalLight;
pub use environment::UniformEnvironment;
pub use environment_map::EnvironmentMap;
pub use hosek_wilkie::{band_wavelength, SkyModel, BANDS as SKY_BANDS, SUN_DIAMETER_DEGREES};
pub use point::{Cone, PointLight};
pub use selection::PowerSelection;
pub use set::LightSet;
pub use sky::Sky;
pub use sphere::SphereLight;
pub use sun::Sun;

use crate::geometry::Frame;
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum, LAMBDA_MAX, LAMBDA_MIN};
use crate::texture::TextureRef;

/// What an emitter sends out: a spectral radiance, times a colour texture
/// (in [0, 1]) over the surface when there is one.
#[derive(Clone, Debug)]
pub struct Emitter {
    pub spectrum: Spectrum,
    pub texture: Option<TextureRef>,
}

impl Emitter {
    fn mean(&self) -> f64 {
        let m = self.spectrum.average(LAMBDA_MIN, LAMBDA_MAX).max(0.0) as f64;
        match &self.texture {
            Some(t) => m * (t.texture.mean_rgb().element_sum() / 3.0).max(0.0) as f64,
            None => m,
        }
    }

    /// Radiance at texture coordinates `uv`.
    #[inline]
    pub fn radiance(&self, uv: Vec2, wl: &SampledWavelengths) -> SampledSpectrum {
        self.radiance_by(uv, wl, |s| s.sample(wl))
    }

    /// `radiance`, its spectrum at `wl` told by `sample` (a caller that
    /// remembers spectra, `SpectrumMemo`).
    #[inline]
    pub fn radiance_by(
        &self,
        uv: Vec2,
        wl: &SampledWavelengths,
        sample: impl FnOnce(&Spectrum) -> SampledSpectrum,
    ) -> SampledSpectrum {
        let le = sample(&self.spectrum);
        match &self.texture {
            Some(t) => le * t.spectrum(uv, wl),
            None => le,
        }
    }
}

/// The scene's bounding sphere, as lights at infinity see it: light paths
/// from them start on a disc of its radius that faces their direction, one
/// radius back from the centre (outside the scene).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SceneSphere {
    pub centre: Vec3,
    pub radius: f32,
}

impl SceneSphere {
    /// The area of the disc (the scene's cross-section).
    pub fn disc_area(&self) -> f32 {
        PI * self.radius * self.radius
    }

    /// Density of `disc_point` per unit area (0 for an empty scene).
    pub fn disc_pdf(&self) -> f32 {
        if self.radius > 0.0 {
            1.0 / self.disc_area()
        } else {
            0.0
        }
    }

    /// A uniform point of the disc facing `dir` (unit); None for an empty
    /// scene.
    pub fn disc_point(&self, dir: Vec3, u: (f32, f32)) -> Option<Vec3> {
        if !(self.radius > 0.0) {
            return None;
        }
        let r = self.radius * u.0.sqrt();
        let phi = 2.0 * PI * u.1;
        let on_disc =
            Frame::from_normal(dir).to_world(Vec3::new(r * phi.cos(), r * phi.sin(), 0.0));
        Some(self.centre - dir * self.radius + on_disc)
    }
}

impl SceneSphere {
    /// A ray from infinity along `dir` (unit) carrying `le`: from a uniform
    /// point of the disc facing it; None for an empty scene or no light.
    pub fn ray_from_infinity(
        &self,
        dir: Vec3,
        u_pos: (f32, f32),
        le: SampledSpectrum,
        pdf_dir: f32,
    ) -> Option<LightLeSample> {
        let p = self.disc_point(dir, u_pos)?;
        if le == SampledSpectrum::ZERO {
            return None;
        }
        Some(LightLeSample {
            point: LightPoint {
                p,
                p_err: Vec3::ZERO,
                n: dir,
                uv: Vec2::ZERO,
            },
            dir,
            le,
            pdf_pos: self.disc_pdf(),
            pdf_dir,
        })
    }
}

/// A cosine-weighted direction leaving a surface of front normal `n`
/// (either side, evenly, when `two_sided`: the first number's lower half
/// picks the back), and the normal of the side it leaves.
pub(crate) fn cosine_emission(n: Vec3, two_sided: bool, u: (f32, f32)) -> (Vec3, Vec3) {
    let (mut u0, mut side) = (u.0, 1.0);
    if two_sided {
        if u0 < 0.5 {
            side = -1.0;
            u0 *= 2.0;
        } else {
            u0 = 2.0 * u0 - 1.0;
        }
        u0 = u0.min(1.0 - f32::EPSILON / 2.0);
    }
    let n = n * side;
    let dir = Frame::from_normal(n).to_world(crate::material::cosine_hemisphere((u0, u.1)));
    (dir, n)
}

/// The solid-angle density of `cosine_emission` for `dir`.
pub(crate) fn cosine_emission_pdf(n: Vec3, two_sided: bool, dir: Vec3) -> f32 {
    let cos = n.dot(dir);
    if two_sided {
        0.5 * cos.abs() / PI
    } else {
        cos.max(0.0) / PI
    }
}

/// A point on a light, with what a robust shadow ray needs.
#[derive(Clone, Copy, Debug)]
pub struct LightPoint {
    pub p: Vec3,
    /// Bound on the absolute error of `p`.
    pub p_err: Vec3,
    /// Unit normal on the emitting side.
    pub n: Vec3,
    /// Texture coordinates (zero without them), for textured emitters.
    pub uv: Vec2,
}

/// Light arriving at a point from a sampled point (or direction) of a light.
#[derive(Clone, Copy, Debug)]
pub struct LightLiSample {
    /// Unit direction from the receiving point towards the light.
    pub wi: Vec3,
    pub li: SampledSpectrum,
    /// Solid-angle density (without the light's selection probability).
    pub pdf: f32,
    /// The point on the light; None for a light at infinity.
    pub point: Option<LightPoint>,
}

impl LightLiSample {
    /// Light `li` arriving from a light at infinity along `wi` (unit,
    /// towards the light), drawn with solid-angle density `pdf`; None when
    /// nothing arrives.
    pub fn from_infinity(wi: Vec3, li: SampledSpectrum, pdf: f32) -> Option<Self> {
        (li != SampledSpectrum::ZERO).then_some(Self {
            wi,
            li,
            pdf,
            point: None,
        })
    }
}

/// A ray leaving a light.
#[derive(Clone, Copy, Debug)]
pub struct LightLeSample {
    pub point: LightPoint,
    /// Unit direction of the ray.
    pub dir: Vec3,
    pub le: SampledSpectrum,
    /// Density of the origin per unit area.
    pub pdf_pos: f32,
    /// Density of the direction per solid angle.
    pub pdf_dir: f32,
}

/// What every kind of light answers, whole: the compiler refuses a light
/// that leaves a method out, so none answers zero by omission. A light
/// that a ray cannot hit says so in `pdf_li`, `l` and `le` itself.
pub trait LightSource {
    /// A Dirac delta in position or direction (point, spot, directional):
    /// never hit by a ray, sampled by next-event estimation only.
    fn is_delta(&self) -> bool;

    /// At infinity: escaped rays would see it (`le`), and it must know the
    /// scene's bounds (`with_scene_bounds`).
    fn is_infinite(&self) -> bool;

    /// The light for a scene within `sphere` (lights at infinity start
    /// their rays on its disc).
    fn with_scene_bounds(self, sphere: SceneSphere) -> Self
    where
        Self: Sized;

    /// Relative power, for the selection distribution.
    fn power(&self) -> f64;

    /// The shape of the light's emission over wavelength, where one
    /// spectrum describes it (an image's D65, which every texel's colour
    /// multiplies); None for the sky model, which counts as flat. (Its
    /// integrated radiance was tried: the sunset's sun outweighs its sky by
    /// power, yet the image shows the sky, and blue's variance tripled.)
    fn spectrum(&self) -> Option<&Spectrum>;

    /// Light arriving at `p_ref` from a point or direction of the light
    /// drawn with `u` (next-event estimation).
    fn sample_li(
        &self,
        p_ref: Vec3,
        u: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLiSample>;

    /// Solid-angle density of `sample_li` from `p_ref` along `wi` (unit),
    /// which meets the light at `p_light` (None: the ray escaped the scene,
    /// as it does for lights at infinity). Zero for delta lights: no ray
    /// finds them.
    fn pdf_li(&self, p_ref: Vec3, wi: Vec3, p_light: Option<Vec3>) -> f32;

    /// Radiance a surface light sends towards `w` (unit, away from the
    /// light) from a point with texture coordinates `uv`.
    fn l(&self, uv: Vec2, w: Vec3, wl: &SampledWavelengths) -> SampledSpectrum;

    /// Radiance arriving along an escaped ray of direction `dir` from a
    /// light at infinity that has extent (a directional light has none).
    fn le(&self, dir: Vec3, wl: &SampledWavelengths) -> SampledSpectrum;

    /// `le(dir)` and `pdf_li` of a ray from `origin` along `dir` that
    /// escaped the scene, in one: what an escaped path needs for its MIS
    /// weight. An image answers both from one inverse map of `dir` (atan2
    /// and acos were 7% of a studio render's instructions).
    fn le_and_pdf_li(
        &self,
        origin: Vec3,
        dir: Vec3,
        wl: &SampledWavelengths,
    ) -> (SampledSpectrum, f32) {
        (self.le(dir, wl), self.pdf_li(origin, dir, None))
    }

    /// A ray leaving the light, for paths that start at lights.
    fn sample_le(
        &self,
        u_pos: (f32, f32),
        u_dir: (f32, f32),
        wl: &SampledWavelengths,
    ) -> Option<LightLeSample>;

    /// (per-area, per-solid-angle) densities of `sample_le` for a ray
    /// leaving in `dir` from its point of texture coordinates `uv` (0 for
    /// the delta part of a delta light).
    fn pdf_le(&self, uv: Vec2, dir: Vec3) -> (f32, f32);
}

/// The list of lights: each line a variant of [`Light`] with the type that
/// implements [`LightSource`]. `Light` answers every method by its
/// variant's, so a new light is its module and one line here.
macro_rules! lights {
    ($($(#[doc = $doc:literal])* $variant:ident($ty:ty),)*) => {
        /// Every kind of light.
        #[derive(Clone, Debug)]
        pub enum Light {
            $($(#[doc = $doc])* $variant($ty),)*
        }

        /// Which kind of light, without its parameters: `LightKind::ALL`
        /// enumerates the list, and `LightKind::example` (light/examples.rs)
        /// makes one of each, so tests that must cover every light iterate
        /// them.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum LightKind {
            $($variant,)*
        }

        impl LightKind {
            /// Every kind of light, in the list's order.
            pub const ALL: &'static [LightKind] = &[$(LightKind::$variant,)*];
        }

        impl Light {
            /// Which kind of light this is.
            pub fn kind(&self) -> LightKind {
                match self {
                    $(Light::$variant(_) => LightKind::$variant,)*
                }
            }
        }

        impl Light {
            /// The light's own answers.
            #[inline]
            fn source(&self) -> &dyn LightSource {
                match self {
                    $(Light::$variant(l) => l,)*
                }
            }
        }

        impl LightSource for Light {
            #[inline]
            fn is_delta(&self) -> bool {
                match self {
                    $(Light::$variant(l) => LightSource::is_delta(l),)*
                }
            }

            #[inline]
            fn is_infinite(&self) -> bool {
                match self {
                    $(Light::$variant(l) => LightSource::is_infinite(l),)*
                }
            }

            fn with_scene_bounds(self, sphere: SceneSphere) -> Self {
                match self {
                    $(Light::$variant(l) => Light::$variant(LightSource::with_scene_bounds(l, sphere)),)*
                }
            }

            fn power(&self) -> f64 {
                self.source().power()
            }

            fn spectrum(&self) -> Option<&Spectrum> {
                self.source().spectrum()
            }

            #[inline]
            fn sample_li(
                &self,
                p_ref: Vec3,
                u: (f32, f32),
                wl: &SampledWavelengths,
            ) -> Option<LightLiSample> {
                match self {
                    $(Light::$variant(l) => LightSource::sample_li(l, p_ref, u, wl),)*
                }
            }

            #[inline]
            fn pdf_li(&self, p_ref: Vec3, wi: Vec3, p_light: Option<Vec3>) -> f32 {
                match self {
                    $(Light::$variant(l) => LightSource::pdf_li(l, p_ref, wi, p_light),)*
                }
            }

            #[inline]
            fn l(&self, uv: Vec2, w: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
                match self {
                    $(Light::$variant(l) => LightSource::l(l, uv, w, wl),)*
                }
            }

            #[inline]
            fn le(&self, dir: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
                match self {
                    $(Light::$variant(l) => LightSource::le(l, dir, wl),)*
                }
            }

            #[inline]
            fn le_and_pdf_li(
                &self,
                origin: Vec3,
                dir: Vec3,
                wl: &SampledWavelengths,
            ) -> (SampledSpectrum, f32) {
                match self {
                    $(Light::$variant(l) => LightSource::le_and_pdf_li(l, origin, dir, wl),)*
                }
            }

            fn sample_le(
                &self,
                u_pos: (f32, f32),
                u_dir: (f32, f32),
                wl: &SampledWavelengths,
            ) -> Option<LightLeSample> {
                match self {
                    $(Light::$variant(l) => LightSource::sample_le(l, u_pos, u_dir, wl),)*
                }
            }

            fn pdf_le(&self, uv: Vec2, dir: Vec3) -> (f32, f32) {
                match self {
                    $(Light::$variant(l) => LightSource::pdf_le(l, uv, dir),)*
                }
            }
        }
    };
}

lights! {
    /// An emissive triangle.
    Area(AreaLight),
    /// A point or spot light.
    Point(PointLight),
    Directional(DirectionalLight),
    /// The same radiance from every direction at infinity.
    Environment(UniformEnvironment),
    /// Radiance at infinity from an equirectangular image.
    EnvironmentMap(EnvironmentMap),
    /// The Hosek–Wilkie sky dome.
    Sky(Sky),
    /// The Hosek–Wilkie sun: a small disc at infinity.
    Sun(Sun),
    /// An emissive exact sphere.
    Sphere(SphereLight),
}

impl Light {
    /// The same surface light sending out `emitter` (an edit of its
    /// shape's emission); a light that is no surface's is returned as it is.
    pub fn with_emitter(&self, emitter: Arc<Emitter>, two_sided: bool) -> Light {
        match self {
            Light::Area(l) => Light::Area(l.with_emitter(emitter, two_sided)),
            Light::Sphere(l) => Light::Sphere(l.with_emitter(emitter, two_sided)),
            // No emitter of a surface to replace.
            other => other.clone(),
        }
    }
}

#[cfg(test)]
mod tests;
