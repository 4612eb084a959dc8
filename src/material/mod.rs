//! Materials and the BSDFs they produce at a hit. A material is what a
//! scene file describes (spectra, textures, roughness); at a hit it becomes
//! a [`Bsdf`]: one lobe, evaluated at the path's wavelengths, in a shading
//! frame. Dispatch is an enum: the hot path avoids virtual calls.

pub mod bsdf;
mod conductor;
pub mod cutout;
pub mod dielectric;
mod diffuse;
pub mod fluorescence;
pub mod fresnel;
pub mod hemisphere;
pub mod ior;
pub mod metals;
pub mod microfacet;
pub mod pbr;
pub mod sheen;
pub mod thin_film;

use std::sync::Arc;

use glam::{Vec2, Vec3, Vec4};

pub use bsdf::{Bsdf, BsdfEval, BsdfFlags, BsdfSample, Lobe, TransportMode};
pub use conductor::ConductorLobe;
pub use cutout::{Cutout, CutoutMode};
pub use dielectric::DielectricLobe;
pub use diffuse::DiffuseLobe;
pub use fluorescence::Fluorescence;
pub use hemisphere::cosine_hemisphere;
pub use ior::Ior;
pub use pbr::PbrLobe;

use crate::geometry::Frame;
use crate::medium::Medium;
use crate::spectrum::{SampledSpectrum, SampledWavelengths, Spectrum};
use crate::texture::TextureRef;

/// A reflectance that may vary over the surface: a spectrum, times a colour
/// texture when there is one.
#[derive(Clone, Debug, PartialEq)]
pub struct Reflectance {
    pub factor: Spectrum,
    pub texture: Option<TextureRef>,
}

impl Reflectance {
    pub fn sample(&self, uv: Vec2, wl: &SampledWavelengths) -> SampledSpectrum {
        self.sample_by(uv, wl, |s| s.sample(wl))
    }

    /// `sample`, the factor's spectrum at `wl` told by `sample` (a caller
    /// that remembers spectra, `SpectrumMemo`).
    #[inline]
    pub fn sample_by(
        &self,
        uv: Vec2,
        wl: &SampledWavelengths,
        sample: impl FnOnce(&Spectrum) -> SampledSpectrum,
    ) -> SampledSpectrum {
        let f = sample(&self.factor);
        match &self.texture {
            Some(t) => f * t.spectrum(uv, wl),
            None => f,
        }
    }
}

impl From<Spectrum> for Reflectance {
    fn from(factor: Spectrum) -> Self {
        Self {
            factor,
            texture: None,
        }
    }
}

/// The glTF 2.0 metallic-roughness material (see [`pbr`]).
#[derive(Clone, Debug, PartialEq)]
pub struct PbrMaterial {
    pub base_color: Reflectance,
    pub metallic: f32,
    pub roughness: f32,
    /// Roughness in the green channel, metalness in blue (glTF), linear.
    pub metallic_roughness: Option<TextureRef>,
    /// Index of refraction of the dielectric coat (KHR_materials_ior).
    pub ior: f32,
    pub normal_map: Option<NormalMap>,
    /// The glTF extensions layered on it.
    pub layers: PbrLayers,
}

/// glTF extensions layered on the metallic-roughness BRDF (see
/// [`pbr::LobeLayers`] for how each enters it).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PbrLayers {
    /// KHR_materials_specular.
    pub specular: Option<SpecularLayer>,
    /// KHR_materials_clearcoat.
    pub clearcoat: Option<ClearcoatLayer>,
    /// KHR_materials_iridescence.
    pub iridescence: Option<IridescenceLayer>,
    /// KHR_materials_sheen.
    pub sheen: Option<SheenLayer>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct SheenLayer {
    /// sheenColorFactor (× sheenColorTexture).
    pub colour: Reflectance,
    /// sheenRoughnessFactor (× sheenRoughnessTexture's alpha; the Charlie
    /// distribution's r is its square).
    pub roughness: f32,
    pub roughness_texture: Option<TextureRef>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct SpecularLayer {
    /// specularFactor: the coat's weight and F90 (× specularTexture's alpha).
    pub weight: f32,
    pub texture: Option<TextureRef>,
    /// specularColorFactor: tints the coat's F0 (× specularColorTexture).
    pub colour: Reflectance,
}

#[derive(Clone, Debug, PartialEq)]
pub struct ClearcoatLayer {
    /// clearcoatFactor (× clearcoatTexture's red).
    pub weight: f32,
    pub texture: Option<TextureRef>,
    /// clearcoatRoughnessFactor (× clearcoatRoughnessTexture's green).
    pub roughness: f32,
    pub roughness_texture: Option<TextureRef>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct IridescenceLayer {
    /// iridescenceFactor (× iridescenceTexture's red).
    pub weight: f32,
    pub texture: Option<TextureRef>,
    /// The film's index (iridescenceIor).
    pub ior: f32,
    /// Thickness in nm: minimum and maximum (the texture's green channel
    /// goes between them; without a texture, the maximum).
    pub thickness: [f32; 2],
    pub thickness_texture: Option<TextureRef>,
}

/// A transmissive glTF material whose metalness is textured: a texel is
/// glass where transmission × (1 − metallic) ≥ ½ (the threshold prism uses
/// for whole materials), else the glTF BRDF of `pbr` shades it.
#[derive(Clone, Debug, PartialEq)]
pub struct OpaqueTexels {
    pub pbr: PbrMaterial,
    pub transmission: f32,
}

impl OpaqueTexels {
    /// The glTF BRDF's parameters where the texel at `uv` is opaque.
    fn at(&self, uv: Vec2) -> Option<&PbrMaterial> {
        let t = self.pbr.metallic_roughness.as_ref()?;
        let metallic = self.pbr.metallic * t.linear(uv).z;
        (self.transmission * (1.0 - metallic) < 0.5).then_some(&self.pbr)
    }

    /// The glass's microfacet α at `uv`: roughnessFactor × the texture's
    /// green channel, as glTF defines roughness for every texel.
    fn alpha_at(&self, uv: Vec2) -> Option<f32> {
        let t = self.pbr.metallic_roughness.as_ref()?;
        let roughness = (self.pbr.roughness * t.linear(uv).y).clamp(0.0, 1.0);
        Some(microfacet::alpha_from_roughness(roughness))
    }
}

/// A tangent-space normal map (glTF convention: +Y up, MikkTSpace tangents).
#[derive(Clone, Debug, PartialEq)]
pub struct NormalMap {
    pub texture: TextureRef,
    /// Scales the map's X and Y (glTF `normalTexture.scale`).
    pub scale: f32,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Material {
    /// Lambertian reflection.
    Diffuse { reflectance: Reflectance },
    /// A metal with complex index n + ik (relative to the outside medium);
    /// α = 0 is a mirror.
    Conductor {
        eta: Spectrum,
        k: Spectrum,
        alpha: f32,
    },
    /// A transparent dielectric; `priority` resolves overlapping volumes
    /// (higher wins, Schmidt & Budge 2002); `medium` fills its inside;
    /// `tint` filters what crosses the surface (glTF's base colour).
    Dielectric {
        ior: Ior,
        alpha: f32,
        priority: i32,
        medium: Option<Box<Medium>>,
        tint: Option<Box<Reflectance>>,
        /// glTF: the metallic-roughness texture, which makes metal texels
        /// opaque and gives every texel its roughness.
        opaque: Option<Box<OpaqueTexels>>,
    },
    /// An index-matched boundary around a medium (fog, smoke): rays cross
    /// it without scattering or refracting, entering or leaving `medium`.
    /// Its inside has the index of the ambient medium (n = 1).
    Interface { priority: i32, medium: Box<Medium> },
    /// glTF metallic-roughness (imported assets).
    Pbr(Box<PbrMaterial>),
    /// A diffuse surface that fluoresces: Lambertian reflection of
    /// `reflectance`, plus light absorbed at shorter wavelengths and
    /// re-emitted diffusely at longer ones (see [`fluorescence`]).
    Fluorescent {
        reflectance: Reflectance,
        fluorescence: Arc<Fluorescence>,
    },
}

/// The list of kinds of material, one line each: `MaterialKind::ALL`
/// enumerates them and `MaterialKind::example` makes one of each, so tests
/// that must cover every material iterate them. `Material::kind` and
/// `example` match exhaustively: a new `Material` variant does not compile
/// until it has a kind here and an example.
macro_rules! material_kinds {
    ($($kind:ident => $name:literal,)*) => {
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum MaterialKind {
            $($kind,)*
        }

        impl MaterialKind {
            /// Every kind of material.
            pub const ALL: &'static [MaterialKind] = &[$(MaterialKind::$kind,)*];

            /// The name scene files use (`pbr` is what imported glTF
            /// materials become).
            pub fn name(self) -> &'static str {
                match self {
                    $(MaterialKind::$kind => $name,)*
                }
            }
        }
    };
}

material_kinds! {
    Diffuse => "diffuse",
    Conductor => "conductor",
    Dielectric => "dielectric",
    Interface => "interface",
    Pbr => "pbr",
    Fluorescent => "fluorescent",
}

impl MaterialKind {
    /// A typical material of the kind, rough where it can be (so that its
    /// BSDF has a density to test), for tests.
    pub fn example(self) -> Material {
        match self {
            MaterialKind::Diffuse => Material::Diffuse {
                reflectance: Spectrum::Constant(0.6).into(),
            },
            MaterialKind::Conductor => Material::Conductor {
                eta: Spectrum::Constant(0.2),
                k: Spectrum::Constant(3.5),
                alpha: 0.3,
            },
            MaterialKind::Dielectric => Material::Dielectric {
                ior: Ior::Constant(1.5),
                alpha: 0.3,
                priority: 0,
                medium: None,
                tint: None,
                opaque: None,
            },
            MaterialKind::Interface => Material::Interface {
                priority: 0,
                medium: Box::new(Medium::absorbing([0.5, 0.6, 0.7], 1.0)),
            },
            MaterialKind::Pbr => Material::Pbr(Box::new(PbrMaterial {
                base_color: Spectrum::Constant(0.7).into(),
                metallic: 0.5,
                roughness: 0.4,
                metallic_roughness: None,
                ior: 1.5,
                normal_map: None,
                layers: Default::default(),
            })),
            // Excited at 400-450 nm, emitting at 500-540 nm: r + c stays
            // below 1 at every wavelength, so energy checks apply.
            MaterialKind::Fluorescent => Material::Fluorescent {
                reflectance: Spectrum::Constant(0.5).into(),
                fluorescence: Arc::new(
                    Fluorescence::from_density(|x, m| {
                        if (400.0..450.0).contains(&x) && (500.0..540.0).contains(&m) {
                            0.2 / 40.0
                        } else {
                            0.0
                        }
                    })
                    .expect("a matrix with support"),
                ),
            },
        }
    }
}

/// Geometry of the hit a BSDF is built for.
#[derive(Clone, Copy, Debug)]
pub struct ShadingGeometry {
    /// Geometric normal (unit, from the triangle's winding).
    pub ng: Vec3,
    /// Shading normal (unit; interpolated vertex normals, or `ng`).
    pub ns: Vec3,
    /// Direction towards where the path came from (unit).
    pub wo: Vec3,
}

impl Material {
    /// Whether its surfaces may scatter without a diffuse lobe (glass,
    /// metal, and glTF materials, which may be either): where caustics
    /// come from.
    pub fn may_focus_light(&self) -> bool {
        matches!(
            self,
            Material::Conductor { .. } | Material::Dielectric { .. } | Material::Pbr(_)
        )
    }

    /// Which kind of material this is.
    pub fn kind(&self) -> MaterialKind {
        match self {
            Material::Diffuse { .. } => MaterialKind::Diffuse,
            Material::Conductor { .. } => MaterialKind::Conductor,
            Material::Dielectric { .. } => MaterialKind::Dielectric,
            Material::Interface { .. } => MaterialKind::Interface,
            Material::Pbr(_) => MaterialKind::Pbr,
            Material::Fluorescent { .. } => MaterialKind::Fluorescent,
        }
    }

    /// The BSDF at a hit. `eta` is n_inside / n_outside per wavelength (used
    /// by dielectrics). A smooth dispersive interface terminates the
    /// secondary wavelengths: they cannot follow the hero's direction.
    pub fn bsdf(
        &self,
        geom: &ShadingGeometry,
        uv: Vec2,
        wl: &mut SampledWavelengths,
        eta: SampledSpectrum,
    ) -> Bsdf {
        match self {
            Material::Diffuse { reflectance } => {
                let (frame, ng) = facing_frame(geom);
                Bsdf::new(
                    frame,
                    ng,
                    Lobe::Diffuse(DiffuseLobe::new(reflectance.sample(uv, wl))),
                    geom.wo,
                )
            }
            Material::Fluorescent {
                reflectance,
                fluorescence,
            } => {
                // The bounce weighs the total radiance factor at the
                // wavelengths the path carries here; `fluoresce` then
                // moves them to where the light was absorbed.
                let (frame, ng) = facing_frame(geom);
                let r = reflectance.sample(uv, wl);
                let factor = fluorescence.radiance_factor(r.clamp(Vec4::ZERO, Vec4::ONE), wl);
                Bsdf::new(
                    frame,
                    ng,
                    Lobe::Diffuse(DiffuseLobe::radiance_factor(factor)),
                    geom.wo,
                )
            }
            Material::Pbr(m) => pbr::bsdf(m, geom, uv, wl),
            Material::Conductor { eta, k, alpha } => {
                let (frame, ng) = facing_frame(geom);
                let lobe = ConductorLobe::new(eta.sample(wl), k.sample(wl), *alpha);
                Bsdf::new(frame, ng, Lobe::Conductor(lobe), geom.wo)
            }
            Material::Interface { .. } => {
                // Paths cross interfaces without scattering (`integrator::
                // interface::meet`); should one be shaded, it is what it
                // is: a smooth boundary of relative index 1, which
                // transmits everything straight on.
                let lobe = DielectricLobe::new(SampledSpectrum::ONE, 0.0, true);
                Bsdf::new(
                    Frame::from_normal(geom.ng),
                    geom.ng,
                    Lobe::Dielectric(lobe),
                    geom.wo,
                )
            }
            Material::Dielectric {
                opaque: Some(o), ..
            } if o.at(uv).is_some() => pbr::bsdf(&o.pbr, geom, uv, wl),
            Material::Dielectric {
                alpha,
                tint,
                opaque,
                ..
            } => {
                let alpha = opaque
                    .as_ref()
                    .and_then(|o| o.alpha_at(uv))
                    .unwrap_or(*alpha);
                // The frame's +z points outside: `eta` is inside / outside.
                let ns = if geom.ns.dot(geom.ng) < 0.0 {
                    -geom.ns
                } else {
                    geom.ns
                };
                let mut lobe = DielectricLobe::new(eta, alpha, !wl.secondary_terminated());
                if let Some(t) = tint {
                    lobe = lobe.tinted(
                        t.sample(uv, wl)
                            .clamp(SampledSpectrum::ZERO, SampledSpectrum::ONE),
                    );
                }
                if dielectric::is_dispersive(eta) && lobe.is_specular() {
                    wl.terminate_secondary();
                }
                Bsdf::new(
                    Frame::from_normal(ns),
                    geom.ng,
                    Lobe::Dielectric(lobe),
                    geom.wo,
                )
            }
        }
    }

    /// At a fluorescent surface, after its BSDF is built: moves each of a
    /// camera path's wavelengths to where the light it carries was
    /// absorbed, with one number of `u` each, and returns what the path's
    /// throughput is multiplied by (1 elsewhere; see
    /// `Fluorescence::excite`).
    pub fn fluoresce(&self, uv: Vec2, wl: &mut SampledWavelengths, u: [f32; 4]) -> SampledSpectrum {
        match self {
            Material::Fluorescent {
                reflectance,
                fluorescence,
            } => {
                let r = reflectance.sample(uv, wl).clamp(Vec4::ZERO, Vec4::ONE);
                fluorescence.excite(r, wl, u)
            }
            _ => SampledSpectrum::ONE,
        }
    }

    pub fn is_fluorescent(&self) -> bool {
        matches!(self, Material::Fluorescent { .. })
    }

    /// The shading normal after the material's normal map, if it has one.
    /// `tangent` is the interpolated tangent (xyz) with the bitangent sign
    /// in w; a zero tangent (no texture coordinates) leaves `ns` as it is.
    pub fn shading_normal(&self, ns: Vec3, tangent: Vec4, uv: Vec2) -> Vec3 {
        let Material::Pbr(m) = self else {
            return ns;
        };
        let Some(map) = &m.normal_map else {
            return ns;
        };
        // Gram-Schmidt: the interpolated tangent need not be orthogonal.
        let t = (tangent.truncate() - ns * ns.dot(tangent.truncate())).normalize_or_zero();
        if t == Vec3::ZERO {
            return ns;
        }
        let b = ns.cross(t) * if tangent.w < 0.0 { -1.0 } else { 1.0 };
        let v = map.texture.linear(uv);
        let x = (2.0 * v.x - 1.0) * map.scale;
        let y = (2.0 * v.y - 1.0) * map.scale;
        let z = 2.0 * v.z - 1.0;
        let n = (t * x + b * y + ns * z).normalize_or_zero();
        if n == Vec3::ZERO {
            ns
        } else {
            n
        }
    }

    pub fn ior(&self) -> Option<&Ior> {
        match self {
            Material::Dielectric { ior, .. } => Some(ior),
            _ => None,
        }
    }

    pub fn priority(&self) -> i32 {
        match self {
            Material::Dielectric { priority, .. } | Material::Interface { priority, .. } => {
                *priority
            }
            _ => 0,
        }
    }

    /// Whether the material bounds a volume that paths enter and leave (a
    /// dielectric or an interface): such objects go on the IOR stack.
    pub fn bounds_volume(&self) -> bool {
        matches!(
            self,
            Material::Dielectric { .. } | Material::Interface { .. }
        )
    }

    pub fn is_interface(&self) -> bool {
        matches!(self, Material::Interface { .. })
    }

    /// Rescales the coefficients of its medium (per metre) by `units`
    /// (metres per scene unit).
    pub fn scale_medium(&mut self, units: f32) {
        let medium = match self {
            Material::Dielectric { medium, .. } => medium.as_deref_mut(),
            Material::Interface { medium, .. } => Some(&mut **medium),
            _ => None,
        };
        if let Some(m) = medium {
            *m = m.clone().scaled(units);
        }
    }

    /// The medium inside the volume this material bounds, if any.
    pub fn medium(&self) -> Option<&Medium> {
        match self {
            Material::Dielectric { medium, .. } => medium.as_deref(),
            Material::Interface { medium, .. } => Some(medium),
            _ => None,
        }
    }
}

/// A frame whose normal is the shading normal turned to the side of the
/// surface that `wo` is on, plus the geometric normal turned the same way.
/// The reflection lobes are symmetric (both faces reflect alike), so the
/// orientation only fixes which way the frame's axes point.
#[inline(always)]
pub fn facing_frame(geom: &ShadingGeometry) -> (Frame, Vec3) {
    let ng = if geom.ng.dot(geom.wo) < 0.0 {
        -geom.ng
    } else {
        geom.ng
    };
    let ns = if geom.ns.dot(ng) < 0.0 {
        -geom.ns
    } else {
        geom.ns
    };
    (Frame::from_normal(ns), ng)
}
