//! glTF materials → prism materials (see the module notes of `gltf`), and
//! their textures.

use glam::Vec3;
use gltf::texture::{MagFilter, WrappingMode};

use super::buffers::{percent_decode, read_uri};
use super::Context;
use crate::load::import::AssetMaterial;
use crate::material::{
    ClearcoatLayer, Cutout, CutoutMode, Ior, IridescenceLayer, Material, NormalMap, OpaqueTexels,
    PbrLayers, PbrMaterial, Reflectance, SheenLayer, SpecularLayer,
};
use crate::medium::Medium;
use crate::scene::Emission;
use crate::spectrum::Spectrum;
use crate::texture::{Encoding, Filter, TextureRef, Wrap};

fn wrap_mode(m: WrappingMode) -> Wrap {
    match m {
        WrappingMode::Repeat => Wrap::Repeat,
        WrappingMode::ClampToEdge => Wrap::Clamp,
        WrappingMode::MirroredRepeat => Wrap::Mirror,
    }
}

/// KHR_texture_transform of one texture reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct UvTransform {
    offset: [f32; 2],
    rotation: f32,
    scale: [f32; 2],
    /// The texture coordinate set it overrides the reference's with.
    tex_coord: Option<u32>,
}

impl UvTransform {
    /// The transform of a core texture slot.
    fn of(t: gltf::texture::TextureTransform) -> Self {
        Self {
            offset: t.offset(),
            rotation: t.rotation(),
            scale: t.scale(),
            tex_coord: t.tex_coord(),
        }
    }

    /// The transform under a texture reference's `extensions` in JSON, as
    /// extensions' own texture references carry it (the gltf crate reads it
    /// only for the core slots). Entries absent or not numbers keep their
    /// defaults.
    fn from_json(info: &gltf::json::Value) -> Option<Self> {
        Self::from_extension(info.get("extensions")?.get("KHR_texture_transform")?)
    }

    /// The transform from the extension's own object.
    fn from_extension(t: &gltf::json::Value) -> Option<Self> {
        let pair = |key: &str, default: [f32; 2]| {
            t.get(key)
                .and_then(|v| v.as_array())
                .filter(|v| v.len() == 2)
                .and_then(|v| Some([v[0].as_f64()? as f32, v[1].as_f64()? as f32]))
                .unwrap_or(default)
        };
        Some(Self {
            offset: pair("offset", [0.0, 0.0]),
            rotation: t.get("rotation").and_then(|r| r.as_f64()).unwrap_or(0.0) as f32,
            scale: pair("scale", [1.0, 1.0]),
            tex_coord: t.get("texCoord").and_then(|c| c.as_u64()).map(|c| c as u32),
        })
    }

    /// uv' = [m0 m1 m2; m3 m4 m5] · (u, v, 1): translation · rotation · scale.
    fn matrix(&self) -> [f32; 6] {
        let ([ox, oy], [sx, sy]) = (self.offset, self.scale);
        let (s, c) = self.rotation.sin_cos();
        [c * sx, s * sy, ox, -s * sx, c * sy, oy]
    }
}

impl Context<'_> {
    /// The texture behind a material's texture slot; a missing or broken
    /// image is a warning and the slot is left empty.
    pub(super) fn texture(
        &mut self,
        texture: gltf::Texture,
        tex_coord: u32,
        transform: Option<UvTransform>,
        encoding: Encoding,
        slot: &str,
    ) -> Option<TextureRef> {
        let set = transform.and_then(|t| t.tex_coord).unwrap_or(tex_coord);
        if !self.slot_sets.iter().any(|(s, _)| s == slot) {
            self.slot_sets.push((slot.to_string(), set));
        }
        let sampler = texture.sampler();
        let wrap = [wrap_mode(sampler.wrap_s()), wrap_mode(sampler.wrap_t())];
        let filter = match sampler.mag_filter() {
            Some(MagFilter::Nearest) => Filter::Nearest,
            _ => Filter::Bilinear,
        };
        let image = texture.source();
        let index = image.index();
        let (buffers, base) = (self.buffers, self.base);
        let key = match image.source() {
            gltf::image::Source::Uri { uri, .. } if !uri.starts_with("data:") => {
                base.join(percent_decode(uri)).display().to_string()
            }
            _ => format!("{}#image{index}", self.file),
        };
        let result = self
            .textures
            .get(key, encoding, wrap, filter, || match image.source() {
                gltf::image::Source::Uri { uri, .. } => read_uri(uri, base),
                gltf::image::Source::View { view, .. } => {
                    let data = &buffers[view.buffer().index()];
                    view.offset()
                        .checked_add(view.length())
                        .and_then(|end| data.get(view.offset()..end))
                        .map(<[u8]>::to_vec)
                        .ok_or_else(|| "its buffer view lies outside the buffer".to_string())
                }
            });
        match result {
            Ok(t) => Some(TextureRef {
                texture: t,
                transform: transform.map(|t| t.matrix()),
            }),
            Err(e) => {
                self.warnings.push(format!(
                    "{}: image {index} ({slot}): {e}; the material uses its factor alone",
                    self.file
                ));
                None
            }
        }
    }

    /// KHR_texture_transform on a material's normalTexture (the crate
    /// reads it only for texture infos).
    fn normal_texture_transform(&self, m: &gltf::Material) -> Option<UvTransform> {
        let json = self.document.as_json().materials.get(m.index()?)?;
        let others = &json.normal_texture.as_ref()?.extensions.as_ref()?.others;
        UvTransform::from_extension(others.get("KHR_texture_transform")?)
    }

    /// KHR_materials_volume's attenuation as an absorbing medium (per
    /// metre, glTF's unit); None for clear volumes.
    fn volume(&mut self, m: &gltf::Material) -> Option<Box<Medium>> {
        let v = m.volume()?;
        let (colour, distance) = (v.attenuation_color(), v.attenuation_distance());
        let clear = colour.iter().all(|&c| c >= 1.0);
        if clear || !(distance > 0.0 && distance.is_finite()) {
            return None;
        }
        if !colour.iter().all(|c| c.is_finite() && *c >= 0.0) {
            self.ignored
                .insert("KHR_materials_volume attenuationColor outside [0, 1]".into());
            return None;
        }
        let colour = colour.map(|c| c.clamp(1e-6, 1.0));
        Some(Box::new(Medium::absorbing(colour, distance)))
    }

    /// A texture an extension names (`{ "index": i, "texCoord": n }` under
    /// `key`).
    fn extension_texture(
        &mut self,
        v: &gltf::json::Value,
        key: &str,
        encoding: Encoding,
    ) -> Option<TextureRef> {
        let info = v.get(key)?;
        let index = info.get("index")?.as_u64()? as usize;
        let tex_coord = info.get("texCoord").and_then(|t| t.as_u64()).unwrap_or(0) as u32;
        let Some(texture) = self.document.textures().nth(index) else {
            self.warnings.push(format!(
                "{key} names texture {index}, which the file does not have"
            ));
            return None;
        };
        let transform = UvTransform::from_json(info);
        self.texture(texture, tex_coord, transform, encoding, key)
    }

    /// KHR_materials_specular, _clearcoat, _sheen and _iridescence: their
    /// factors times their textures.
    fn layers(&mut self, m: &gltf::Material) -> PbrLayers {
        let number = |v: &gltf::json::Value, key: &str, default: f32| {
            v.get(key)
                .and_then(|x| x.as_f64())
                .map(|x| x as f32)
                .filter(|x| x.is_finite())
                .unwrap_or(default)
        };
        let colour = |v: &gltf::json::Value, key: &str, default: f32| {
            v.get(key)
                .and_then(|c| c.as_array())
                .filter(|c| c.len() == 3)
                .map(|c| {
                    Vec3::from_array(
                        [0, 1, 2].map(|i| c[i].as_f64().unwrap_or(default as f64) as f32),
                    )
                })
                .filter(|c| c.is_finite())
                .unwrap_or(Vec3::splat(default))
                .max(Vec3::ZERO)
        };
        let mut layers = PbrLayers::default();
        if let Some(v) = m.extension_value("KHR_materials_specular") {
            layers.specular = Some(SpecularLayer {
                weight: number(v, "specularFactor", 1.0).clamp(0.0, 1.0),
                texture: self.extension_texture(v, "specularTexture", Encoding::Linear),
                colour: Reflectance {
                    factor: Spectrum::rgb_unbounded(colour(v, "specularColorFactor", 1.0)),
                    texture: self.extension_texture(
                        v,
                        "specularColorTexture",
                        Encoding::SrgbColour,
                    ),
                },
            });
        }
        if let Some(v) = m.extension_value("KHR_materials_clearcoat") {
            if v.get("clearcoatNormalTexture").is_some() {
                self.ignored
                    .insert("clearcoatNormalTexture (the coat takes the base's normal)".into());
            }
            let weight = number(v, "clearcoatFactor", 0.0).clamp(0.0, 1.0);
            if weight > 0.0 {
                layers.clearcoat = Some(ClearcoatLayer {
                    weight,
                    texture: self.extension_texture(v, "clearcoatTexture", Encoding::Linear),
                    roughness: number(v, "clearcoatRoughnessFactor", 0.0).clamp(0.0, 1.0),
                    roughness_texture: self.extension_texture(
                        v,
                        "clearcoatRoughnessTexture",
                        Encoding::Linear,
                    ),
                });
            }
        }
        if let Some(v) = m.extension_value("KHR_materials_sheen") {
            let c = colour(v, "sheenColorFactor", 0.0).min(Vec3::ONE);
            if c.max_element() > 0.0 {
                layers.sheen = Some(SheenLayer {
                    colour: Reflectance {
                        factor: Spectrum::rgb_reflectance(c),
                        texture: self.extension_texture(
                            v,
                            "sheenColorTexture",
                            Encoding::SrgbColour,
                        ),
                    },
                    roughness: number(v, "sheenRoughnessFactor", 0.0).clamp(0.0, 1.0),
                    roughness_texture: self.extension_texture(
                        v,
                        "sheenRoughnessTexture",
                        Encoding::Linear,
                    ),
                });
            }
        }
        if let Some(v) = m.extension_value("KHR_materials_iridescence") {
            let weight = number(v, "iridescenceFactor", 0.0).clamp(0.0, 1.0);
            if weight > 0.0 {
                layers.iridescence = Some(IridescenceLayer {
                    weight,
                    texture: self.extension_texture(v, "iridescenceTexture", Encoding::Linear),
                    ior: number(v, "iridescenceIor", 1.3).clamp(1.0, 5.0),
                    thickness: [
                        number(v, "iridescenceThicknessMinimum", 100.0).clamp(0.0, 1e5),
                        number(v, "iridescenceThicknessMaximum", 400.0).clamp(0.0, 1e5),
                    ],
                    thickness_texture: self.extension_texture(
                        v,
                        "iridescenceThicknessTexture",
                        Encoding::Linear,
                    ),
                });
            }
        }
        layers
    }

    pub(super) fn material(&mut self, m: &gltf::Material) -> AssetMaterial {
        let name = m
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("material{}", m.index().unwrap_or(0)));
        let pbr = m.pbr_metallic_roughness();
        let [r, g, b, _] = pbr.base_color_factor();
        let base_color = Reflectance {
            factor: Spectrum::rgb_reflectance(Vec3::new(r, g, b)),
            texture: pbr.base_color_texture().and_then(|info| {
                self.texture(
                    info.texture(),
                    info.tex_coord(),
                    info.texture_transform().map(UvTransform::of),
                    Encoding::SrgbColour,
                    "baseColorTexture",
                )
            }),
        };
        let metallic_roughness = pbr.metallic_roughness_texture().and_then(|info| {
            self.texture(
                info.texture(),
                info.tex_coord(),
                info.texture_transform().map(UvTransform::of),
                Encoding::Linear,
                "metallicRoughnessTexture",
            )
        });
        let normal_map = m.normal_texture().and_then(|n| {
            let scale = n.scale();
            let transform = self.normal_texture_transform(m);
            self.texture(
                n.texture(),
                n.tex_coord(),
                transform,
                Encoding::Linear,
                "normalTexture",
            )
            .map(|texture| NormalMap { texture, scale })
        });
        let layers = self.layers(m);
        let cutout = self.cutout(m);
        let ior = m
            .ior()
            .filter(|n| n.is_finite() && *n >= 1.0)
            .unwrap_or(1.5);
        let (metallic, roughness) = (
            pbr.metallic_factor().clamp(0.0, 1.0),
            pbr.roughness_factor().clamp(0.0, 1.0),
        );
        let transmission = self.transmission(m);
        // Glass where transmission × (1 − metallic) ≥ ½. With a metalness
        // texture that holds per texel: the material is glass that shades
        // its opaque texels with the glTF BRDF.
        let textured_metal = metallic_roughness.is_some();
        let material =
            if transmission * (1.0 - metallic) >= 0.5 || (transmission >= 0.5 && textured_metal) {
                let opaque = textured_metal.then(|| {
                    Box::new(OpaqueTexels {
                        pbr: PbrMaterial {
                            base_color: base_color.clone(),
                            metallic,
                            roughness,
                            metallic_roughness: metallic_roughness.clone(),
                            ior,
                            normal_map: normal_map.clone(),
                            layers: layers.clone(),
                        },
                        transmission,
                    })
                });
                // The base colour filters what crosses the surface (glTF's
                // specular BTDF times baseColor), at each crossing.
                let tint = (base_color.texture.is_some() || Vec3::new(r, g, b) != Vec3::ONE)
                    .then(|| Box::new(base_color.clone()));
                let dispersion = m
                    .extension_value("KHR_materials_dispersion")
                    .and_then(|v| v.get("dispersion"))
                    .and_then(|v| v.as_f64())
                    .unwrap_or(0.0) as f32;
                let ior = if dispersion > 0.0 {
                    Ior::abbe(ior, 20.0 / dispersion)
                } else {
                    Ior::Constant(ior)
                };
                Material::Dielectric {
                    ior,
                    alpha: crate::material::microfacet::alpha_from_roughness(roughness),
                    priority: 0,
                    medium: self.volume(m),
                    tint,
                    opaque,
                }
            } else {
                Material::Pbr(Box::new(PbrMaterial {
                    base_color,
                    metallic,
                    roughness,
                    metallic_roughness,
                    ior,
                    normal_map,
                    layers,
                }))
            };
        let emission = self.emission(m);
        AssetMaterial {
            name,
            material,
            emission,
            cutout,
            single_sided: !m.double_sided(),
        }
    }

    /// The cut-out of an alpha-masked or blended material.
    fn cutout(&mut self, m: &gltf::Material) -> Option<Cutout> {
        let pbr = m.pbr_metallic_roughness();
        let [.., alpha] = pbr.base_color_factor();
        let cutout_mode = match m.alpha_mode() {
            gltf::material::AlphaMode::Opaque => None,
            gltf::material::AlphaMode::Mask => Some(CutoutMode::Mask {
                cutoff: m.alpha_cutoff().unwrap_or(0.5),
            }),
            gltf::material::AlphaMode::Blend => Some(CutoutMode::Blend),
        };
        cutout_mode.map(|mode| Cutout {
            factor: alpha.clamp(0.0, 1.0),
            texture: pbr.base_color_texture().and_then(|info| {
                self.texture(
                    info.texture(),
                    info.tex_coord(),
                    info.texture_transform().map(UvTransform::of),
                    Encoding::Alpha,
                    "baseColorTexture",
                )
            }),
            mode,
        })
    }

    /// KHR_materials_transmission's factor (its texture is not read); notes
    /// KHR_materials_volume's thickness, which prism does not need.
    fn transmission(&mut self, m: &gltf::Material) -> f32 {
        let transmission = m
            .transmission()
            .map_or(0.0, |t| {
                if t.transmission_texture().is_some() {
                    self.ignored.insert("transmissionTexture".into());
                }
                t.transmission_factor()
            })
            .clamp(0.0, 1.0);
        if m.volume()
            .is_some_and(|v| v.thickness_factor() > 0.0 || v.thickness_texture().is_some())
        {
            self.ignored.insert(
                "KHR_materials_volume thickness (a rasteriser's stand-in: prism traces the mesh's own thickness)"
                    .into(),
            );
        }
        transmission
    }

    /// The emissive factor times KHR_materials_emissive_strength, with its
    /// texture.
    fn emission(&mut self, m: &gltf::Material) -> Option<Emission> {
        let strength = m.emissive_strength().unwrap_or(1.0).max(0.0);
        let emissive = Vec3::from(m.emissive_factor()).max(Vec3::ZERO) * strength;
        (emissive.max_element() > 0.0 && emissive.is_finite()).then(|| Emission {
            spectrum: Spectrum::rgb_emission(emissive),
            texture: m.emissive_texture().and_then(|info| {
                self.texture(
                    info.texture(),
                    info.tex_coord(),
                    info.texture_transform().map(UvTransform::of),
                    Encoding::SrgbColour,
                    "emissiveTexture",
                )
            }),
            two_sided: m.double_sided(),
        })
    }
}
