//! glTF 2.0 (`.gltf` with external or embedded base64 buffers, and `.glb`)
//! through the gltf crate. The default scene's node tree is walked with
//! its transforms (matrix or TRS); every triangle primitive becomes a piece.
//!
//! glTF → prism materials:
//! - metallic-roughness (factors and textures, base colour upsampled per
//!   texel) → the glTF BRDF of `material::pbr`, coat index from
//!   KHR_materials_ior (default 1.5);
//! - normalTexture (with scale) → normal mapping in MikkTSpace, tangents
//!   from the file or generated;
//! - emissiveFactor × emissiveTexture × KHR_materials_emissive_strength →
//!   emission (RGB relative to D65, as in scene files); double-sided
//!   materials emit from both faces;
//! - KHR_materials_transmission with transmission × (1 − metallic) ≥ ½ →
//!   a dielectric with KHR_materials_ior and roughness; KHR_materials_
//!   dispersion → Abbe number V = 20 / dispersion at n_d = ior (the
//!   extension's definition);
//! - KHR_texture_transform on every texture; samplers' wrap modes, and
//!   nearest magnification.
//!
//! Ignored, and listed once per file: alpha blending and masks (surfaces
//! are opaque), texture coordinate sets other than 0, transmission textures,
//! base colour tints of transmissive materials, KHR_materials_volume, and
//! every other extension. occlusionTexture is not used by design: a path
//! tracer computes occlusion. Cameras: perspective ones (orthographic are
//! skipped).

use std::collections::BTreeSet;
use std::path::Path;

use base64::Engine;
use glam::{Mat4, Quat, Vec2, Vec3, Vec4};
use gltf::mesh::Mode;
use gltf::texture::{MagFilter, WrappingMode};

use super::{generate_tangents, Asset, AssetCamera, AssetMaterial, Piece, TextureCache};
use crate::material::{Ior, Material, NormalMap, PbrMaterial, Reflectance};
use crate::scene::{Emission, Mesh};
use crate::spectrum::Spectrum;
use crate::texture::{Encoding, Filter, TextureRef, Wrap};

/// Extensions that are mapped (see the module notes).
const MAPPED_EXTENSIONS: [&str; 5] = [
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_emissive_strength",
    "KHR_materials_dispersion",
    "KHR_texture_transform",
];

/// Deeper node trees than this are refused (they can only be cycles).
const MAX_NODE_DEPTH: usize = 256;

/// Loads a glTF or GLB file.
pub fn load(path: &Path, textures: &mut TextureCache) -> Result<Asset, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read: {e}"))?;
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(describe)?;
    validate(gltf.as_json())?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(&gltf, base)?;

    let mut asset = Asset::default();
    let mut ignored = BTreeSet::new();
    for ext in gltf.extensions_used() {
        if !MAPPED_EXTENSIONS.contains(&ext) {
            ignored.insert(ext.to_string());
        }
    }

    let mut ctx = Context {
        file: path.display().to_string(),
        base,
        buffers: &buffers,
        textures,
        ignored,
        warnings: Vec::new(),
    };
    for m in gltf.materials() {
        let mapped = ctx.material(&m);
        asset.materials.push(mapped);
    }
    // Primitives without a material get glTF's default material.
    let default_material = asset.materials.len();
    asset.materials.push(AssetMaterial {
        name: "(glTF default)".into(),
        material: Material::Pbr(Box::new(PbrMaterial {
            base_color: Spectrum::Constant(1.0).into(),
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness: None,
            ior: 1.5,
            normal_map: None,
        })),
        emission: None,
    });

    let scene = gltf
        .default_scene()
        .or_else(|| gltf.scenes().next())
        .ok_or("the file has no scene to render")?;
    for node in scene.nodes() {
        ctx.node(&node, Mat4::IDENTITY, 0, &mut asset, default_material)?;
    }
    if asset.pieces.is_empty() {
        return Err("the scene has no triangles".into());
    }
    asset.ignored = ctx.ignored.into_iter().collect();
    asset.warnings = ctx.warnings;
    Ok(asset)
}

/// gltf's errors, with every validation problem spelled out.
fn describe(e: gltf::Error) -> String {
    match e {
        gltf::Error::Validation(errors) => {
            let list: Vec<String> = errors
                .iter()
                .take(5)
                .map(|(path, err)| format!("{path}: {err}"))
                .collect();
            format!("invalid glTF: {}", list.join("; "))
        }
        gltf::Error::Binary(e) => format!("broken GLB container: {e:?}"),
        other => format!("cannot parse glTF: {other}"),
    }
}

/// The element types the specification allows for the vertex attributes
/// prism reads, and a stride that holds an element.
fn check_accessor(a: &gltf::Accessor, semantic: &gltf::Semantic) -> Result<(), String> {
    use gltf::accessor::{DataType, Dimensions};
    let (name, dims, types): (&str, Dimensions, &[DataType]) = match semantic {
        gltf::Semantic::Positions => ("POSITION", Dimensions::Vec3, &[DataType::F32]),
        gltf::Semantic::Normals => ("NORMAL", Dimensions::Vec3, &[DataType::F32]),
        gltf::Semantic::Tangents => ("TANGENT", Dimensions::Vec4, &[DataType::F32]),
        _ => (
            "TEXCOORD_0",
            Dimensions::Vec2,
            &[DataType::F32, DataType::U8, DataType::U16],
        ),
    };
    if a.dimensions() != dims || !types.contains(&a.data_type()) {
        return Err(format!(
            "{name} accessor {} holds {:?} of {:?}, which the specification does not allow",
            a.index(),
            a.dimensions(),
            a.data_type()
        ));
    }
    Ok(())
}

fn check_index_accessor(a: &gltf::Accessor) -> Result<(), String> {
    use gltf::accessor::{DataType, Dimensions};
    if a.dimensions() != Dimensions::Scalar
        || ![DataType::U8, DataType::U16, DataType::U32].contains(&a.data_type())
    {
        return Err(format!(
            "index accessor {} holds {:?} of {:?}, not unsigned integer scalars",
            a.index(),
            a.dimensions(),
            a.data_type()
        ));
    }
    Ok(())
}

/// Elements an accessor without a buffer view (all zeros but its sparse
/// values) may declare: its count is not bounded by any data in the file.
const MAX_VIEWLESS_COUNT: usize = 1 << 26;

/// An accessor's elements inside their buffer view and the view inside its
/// buffer, in checked arithmetic: the crate's reader computes these ends
/// unchecked and trusts the stride.
fn check_layout(a: &gltf::Accessor, name: &str, buffers: &[Vec<u8>]) -> Result<(), String> {
    let fail = |why: String| format!("{name} accessor {}: {why}", a.index());
    let size = a.size();
    if a.count() == 0 {
        return Err(fail("count is 0".into()));
    }
    match (a.view(), a.sparse()) {
        (Some(view), _) => check_span(&view, a.offset(), a.count(), size, buffers).map_err(fail)?,
        (None, Some(_)) if a.count() > MAX_VIEWLESS_COUNT => {
            return Err(fail(format!(
                "{} elements without a buffer view (at most {MAX_VIEWLESS_COUNT})",
                a.count()
            )))
        }
        (None, _) => {}
    }
    if let Some(sparse) = a.sparse() {
        let n = sparse.count();
        if n == 0 || n > a.count() {
            return Err(fail(format!(
                "sparse count {n} is not within 1..={}",
                a.count()
            )));
        }
        let (indices, values) = (sparse.indices(), sparse.values());
        let index_size = indices.index_type().size();
        check_span(&indices.view(), indices.offset(), n, index_size, buffers)
            .map_err(|e| fail(format!("sparse indices: {e}")))?;
        check_span(&values.view(), values.offset(), n, size, buffers)
            .map_err(|e| fail(format!("sparse values: {e}")))?;
    }
    Ok(())
}

/// `count` elements of `size` bytes from `offset` in a buffer view.
fn check_span(
    view: &gltf::buffer::View,
    offset: usize,
    count: usize,
    size: usize,
    buffers: &[Vec<u8>],
) -> Result<(), String> {
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "byteStride {stride} is smaller than an element ({size} bytes)"
        ));
    }
    let buffer_len = buffers.get(view.buffer().index()).map_or(0, Vec::len);
    let view_end = view.offset().checked_add(view.length());
    if view_end.is_none_or(|end| end > buffer_len) {
        return Err(format!(
            "buffer view {} lies outside its buffer",
            view.index()
        ));
    }
    let end = stride
        .checked_mul(count - 1)
        .and_then(|x| x.checked_add(size))
        .and_then(|x| x.checked_add(offset));
    if end.is_none_or(|end| end > view.length()) {
        return Err(format!(
            "its data lies outside buffer view {}",
            view.index()
        ));
    }
    Ok(())
}

/// The gltf crate's validation, with what it leaves out. Its own check
/// that a primitive's POSITION accessor has bounds indexes the accessor
/// before the index is checked, so the index is checked first. Then rules
/// of the specification that it does not check but whose breach makes its
/// accessors panic: an image in a buffer view needs a MIME type, an image
/// needs a source, a camera needs the projection its type names.
fn validate(json: &gltf::json::Root) -> Result<(), String> {
    use gltf::json::mesh::Semantic;
    use gltf::json::validation::{Checked, Validate};
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(a) = primitive
                .attributes
                .get(&Checked::Valid(Semantic::Positions))
            {
                if a.value() >= json.accessors.len() {
                    return Err(format!(
                        "invalid glTF: meshes[{m}].primitives[{p}].attributes.POSITION: \
                         accessor {} does not exist",
                        a.value()
                    ));
                }
            }
        }
    }
    let mut errors = Vec::new();
    json.validate(json, gltf::json::Path::new, &mut |path, error| {
        errors.push((path(), error))
    });
    if !errors.is_empty() {
        return Err(describe(gltf::Error::Validation(errors)));
    }
    for (i, image) in json.images.iter().enumerate() {
        match (&image.buffer_view, &image.uri) {
            (Some(_), _) if image.mime_type.is_none() => {
                return Err(format!(
                    "invalid glTF: images[{i}] lies in a buffer view but has no mimeType"
                ))
            }
            (None, None) => {
                return Err(format!(
                    "invalid glTF: images[{i}] has neither a uri nor a bufferView"
                ))
            }
            _ => {}
        }
    }
    for (i, camera) in json.cameras.iter().enumerate() {
        use gltf::json::camera::Type;
        let present = match camera.type_ {
            gltf::json::validation::Checked::Valid(Type::Perspective) => {
                camera.perspective.is_some()
            }
            gltf::json::validation::Checked::Valid(Type::Orthographic) => {
                camera.orthographic.is_some()
            }
            gltf::json::validation::Checked::Invalid => true, // already refused
        };
        if !present {
            return Err(format!(
                "invalid glTF: cameras[{i}] has no object for its type"
            ));
        }
    }
    Ok(())
}

/// The bytes of a `data:` URI, or of a file relative to the asset.
fn read_uri(uri: &str, base: &Path) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, data) = rest
            .split_once(";base64,")
            .ok_or("a data URI that is not base64")?;
        return base64::engine::general_purpose::STANDARD
            .decode(data)
            .map_err(|e| format!("bad base64 data: {e}"));
    }
    let path = base.join(percent_decode(uri));
    std::fs::read(&path).map_err(|e| format!("cannot read {}: {e}", path.display()))
}

/// URIs in glTF are percent-encoded (spaces are %20).
fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            if let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

fn load_buffers(gltf: &gltf::Gltf, base: &Path) -> Result<Vec<Vec<u8>>, String> {
    let mut buffers = Vec::new();
    for buffer in gltf.buffers() {
        let i = buffer.index();
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().ok_or(format!(
                "buffer {i} refers to a GLB binary chunk the file does not have"
            ))?,
            gltf::buffer::Source::Uri(uri) => {
                read_uri(uri, base).map_err(|e| format!("buffer {i}: {e}"))?
            }
        };
        if data.len() < buffer.length() {
            return Err(format!(
                "buffer {i} holds {} bytes but declares {} (truncated file?)",
                data.len(),
                buffer.length()
            ));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

struct Context<'a> {
    file: String,
    base: &'a Path,
    buffers: &'a [Vec<u8>],
    textures: &'a mut TextureCache,
    ignored: BTreeSet<String>,
    warnings: Vec<String>,
}

fn wrap_mode(m: WrappingMode) -> Wrap {
    match m {
        WrappingMode::Repeat => Wrap::Repeat,
        WrappingMode::ClampToEdge => Wrap::Clamp,
        WrappingMode::MirroredRepeat => Wrap::Mirror,
    }
}

impl Context<'_> {
    /// The texture behind a material's texture slot; a missing or broken
    /// image is a warning and the slot is left empty.
    fn texture(
        &mut self,
        texture: gltf::Texture,
        tex_coord: u32,
        transform: Option<gltf::texture::TextureTransform>,
        encoding: Encoding,
        slot: &str,
    ) -> Option<TextureRef> {
        if tex_coord != 0 || transform.as_ref().and_then(|t| t.tex_coord()).unwrap_or(0) != 0 {
            self.ignored
                .insert(format!("texture coordinate sets other than 0 ({slot})"));
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
                transform: transform.map(|t| {
                    let ([ox, oy], r, [sx, sy]) = (t.offset(), t.rotation(), t.scale());
                    let (s, c) = r.sin_cos();
                    // KHR_texture_transform: translation · rotation · scale.
                    [c * sx, s * sy, ox, -s * sx, c * sy, oy]
                }),
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

    fn material(&mut self, m: &gltf::Material) -> AssetMaterial {
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
                    info.texture_transform(),
                    Encoding::SrgbColour,
                    "baseColorTexture",
                )
            }),
        };
        let metallic_roughness = pbr.metallic_roughness_texture().and_then(|info| {
            self.texture(
                info.texture(),
                info.tex_coord(),
                info.texture_transform(),
                Encoding::Linear,
                "metallicRoughnessTexture",
            )
        });
        let normal_map = m.normal_texture().and_then(|n| {
            let scale = n.scale();
            self.texture(
                n.texture(),
                n.tex_coord(),
                None,
                Encoding::Linear,
                "normalTexture",
            )
            .map(|texture| NormalMap { texture, scale })
        });
        if m.alpha_mode() != gltf::material::AlphaMode::Opaque {
            self.ignored
                .insert("alphaMode BLEND/MASK (surfaces are opaque)".into());
        }
        let ior = m
            .ior()
            .filter(|n| n.is_finite() && *n >= 1.0)
            .unwrap_or(1.5);
        let (metallic, roughness) = (
            pbr.metallic_factor().clamp(0.0, 1.0),
            pbr.roughness_factor().clamp(0.0, 1.0),
        );
        let transmission = m
            .transmission()
            .map_or(0.0, |t| {
                if t.transmission_texture().is_some() {
                    self.ignored.insert("transmissionTexture".into());
                }
                t.transmission_factor()
            })
            .clamp(0.0, 1.0);
        let material = if transmission * (1.0 - metallic) >= 0.5 {
            if base_color.texture.is_some() || Vec3::new(r, g, b) != Vec3::ONE {
                self.ignored
                    .insert("base colour tint of transmissive materials".into());
            }
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
            }
        } else {
            Material::Pbr(Box::new(PbrMaterial {
                base_color,
                metallic,
                roughness,
                metallic_roughness,
                ior,
                normal_map,
            }))
        };
        let strength = m.emissive_strength().unwrap_or(1.0).max(0.0);
        let emissive = Vec3::from(m.emissive_factor()).max(Vec3::ZERO) * strength;
        let emission = (emissive.max_element() > 0.0 && emissive.is_finite()).then(|| Emission {
            spectrum: Spectrum::rgb_emission(emissive),
            texture: m.emissive_texture().and_then(|info| {
                self.texture(
                    info.texture(),
                    info.tex_coord(),
                    info.texture_transform(),
                    Encoding::SrgbColour,
                    "emissiveTexture",
                )
            }),
            two_sided: m.double_sided(),
        });
        AssetMaterial {
            name,
            material,
            emission,
        }
    }

    fn node(
        &mut self,
        node: &gltf::Node,
        parent: Mat4,
        depth: usize,
        asset: &mut Asset,
        default_material: usize,
    ) -> Result<(), String> {
        if depth > MAX_NODE_DEPTH {
            return Err(format!(
                "the node hierarchy is deeper than {MAX_NODE_DEPTH} (a cycle?)"
            ));
        }
        let local = match node.transform() {
            gltf::scene::Transform::Matrix { matrix } => Mat4::from_cols_array_2d(&matrix),
            gltf::scene::Transform::Decomposed {
                translation,
                rotation,
                scale,
            } => {
                // The specification asks for a unit quaternion; exporters
                // round, and a scaled one would scale the node.
                let q = Quat::from_array(rotation);
                let len = q.length();
                if !(len > 1e-6 && len.is_finite()) {
                    return Err(format!(
                        "node {}: rotation {rotation:?} is not a rotation quaternion",
                        node.index()
                    ));
                }
                Mat4::from_scale_rotation_translation(scale.into(), q / len, translation.into())
            }
        };
        let world = parent * local;
        if !world.is_finite() {
            return Err(format!(
                "node {} has a transform that is not finite",
                node.index()
            ));
        }
        if let Some(camera) = node.camera() {
            match camera.projection() {
                gltf::camera::Projection::Perspective(p) => asset.cameras.push(AssetCamera {
                    name: camera
                        .name()
                        .or(node.name())
                        .map_or(format!("camera{}", camera.index()), str::to_string),
                    position: world.transform_point3(Vec3::ZERO),
                    forward: world.transform_vector3(-Vec3::Z).normalize_or_zero(),
                    up: world.transform_vector3(Vec3::Y).normalize_or_zero(),
                    yfov: p.yfov().to_degrees(),
                }),
                gltf::camera::Projection::Orthographic(_) => {
                    self.ignored.insert("orthographic cameras".into());
                }
            }
        }
        if let Some(mesh) = node.mesh() {
            let name = mesh
                .name()
                .map_or(format!("mesh{}", mesh.index()), str::to_string);
            for primitive in mesh.primitives() {
                let what = format!("mesh `{name}` primitive {}", primitive.index());
                let Some(mut piece) = self.primitive(&primitive, &what)? else {
                    continue;
                };
                piece.transform(&world);
                let material = primitive.material().index().unwrap_or(default_material);
                let needs_tangents = matches!(
                    &asset.materials[material].material,
                    Material::Pbr(m) if m.normal_map.is_some()
                );
                if needs_tangents && piece.tangents.is_none() {
                    if piece.uvs.is_some() {
                        generate_tangents(&mut piece).map_err(|e| format!("{what}: {e}"))?;
                    } else {
                        self.warnings.push(format!(
                            "{}: {what} has a normal map but no texture coordinates; the map is not used",
                            self.file
                        ));
                    }
                }
                asset.pieces.push(Piece {
                    mesh: piece,
                    material: Some(material),
                    name: name.clone(),
                });
            }
        }
        for child in node.children() {
            self.node(&child, world, depth + 1, asset, default_material)?;
        }
        Ok(())
    }

    /// One primitive's triangles, or `None` for points and lines.
    fn primitive(&mut self, p: &gltf::Primitive, what: &str) -> Result<Option<Mesh>, String> {
        // The crate's reader trusts an accessor's element type and layout;
        // they are checked first. Broken required data is an error, broken
        // optional data a warning.
        let buffers = self.buffers;
        let mut usable = |semantic: gltf::Semantic, required: bool| -> Result<bool, String> {
            let Some(accessor) = p.get(&semantic) else {
                return Ok(false);
            };
            let checked = check_accessor(&accessor, &semantic)
                .and_then(|()| check_layout(&accessor, &semantic.to_string(), buffers));
            match checked {
                Ok(()) => Ok(true),
                Err(e) if required => Err(format!("{what}: {e}")),
                Err(e) => {
                    self.warnings
                        .push(format!("{}: {what}: {e}; not used", self.file));
                    Ok(false)
                }
            }
        };
        usable(gltf::Semantic::Positions, true)?;
        let use_normals = usable(gltf::Semantic::Normals, false)?;
        let use_uvs = usable(gltf::Semantic::TexCoords(0), false)?;
        let use_tangents = usable(gltf::Semantic::Tangents, false)?;
        if let Some(indices) = p.indices() {
            check_index_accessor(&indices)
                .and_then(|()| check_layout(&indices, "index", buffers))
                .map_err(|e| format!("{what}: {e}"))?;
        }
        let reader = p.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        // The checks above leave the reader nothing to refuse (validation
        // requires POSITION); should it still, that is an error, not a panic.
        let unreadable = |attr: &str| format!("{what}: the gltf crate cannot read its {attr}");
        let positions: Vec<Vec3> = reader
            .read_positions()
            .ok_or_else(|| unreadable("POSITION"))?
            .map(Vec3::from)
            .collect();
        let n = positions.len();
        if let Some(bad) = positions.iter().position(|v| !v.is_finite()) {
            return Err(format!("{what}: vertex {bad} is not finite"));
        }
        let indices: Vec<u32> = match reader.read_indices() {
            Some(i) => i.into_u32().collect(),
            None if p.indices().is_some() => return Err(unreadable("indices")),
            None => (0..n as u32).collect(),
        };
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= n) {
            return Err(format!(
                "{what}: index {bad} is out of range ({n} vertices)"
            ));
        }
        let triangles: Vec<[u32; 3]> = match p.mode() {
            Mode::Triangles => indices
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]])
                .collect(),
            Mode::TriangleStrip => (2..indices.len())
                .map(|i| {
                    // Every other triangle of a strip is wound backwards.
                    if i % 2 == 0 {
                        [indices[i - 2], indices[i - 1], indices[i]]
                    } else {
                        [indices[i - 1], indices[i - 2], indices[i]]
                    }
                })
                .collect(),
            Mode::TriangleFan => (2..indices.len())
                .map(|i| [indices[0], indices[i - 1], indices[i]])
                .collect(),
            _ => {
                self.ignored.insert("points and lines primitives".into());
                return Ok(None);
            }
        };
        let mut mesh = Mesh {
            positions,
            indices: triangles,
            ..Default::default()
        };
        // Optional attributes are dropped (with a warning) when unusable.
        let mut attribute = |name: &str, len: usize, finite: bool| {
            if len != n || !finite {
                self.warnings.push(format!(
                    "{}: {what}: {name} is broken (another count than POSITION's, or not finite); not used",
                    self.file
                ));
                false
            } else {
                true
            }
        };
        if let Some(normals) = use_normals.then(|| reader.read_normals()).flatten() {
            let v: Vec<Vec3> = normals.map(Vec3::from).collect();
            if attribute("NORMAL", v.len(), v.iter().all(|n| n.is_finite())) {
                mesh.normals = Some(v);
            }
        }
        if let Some(uvs) = use_uvs.then(|| reader.read_tex_coords(0)).flatten() {
            let v: Vec<Vec2> = uvs.into_f32().map(Vec2::from).collect();
            if attribute("TEXCOORD_0", v.len(), v.iter().all(|t| t.is_finite())) {
                mesh.uvs = Some(v);
            }
        }
        if let Some(tangents) = use_tangents.then(|| reader.read_tangents()).flatten() {
            let v: Vec<Vec4> = tangents.map(Vec4::from).collect();
            if attribute("TANGENT", v.len(), v.iter().all(|t| t.is_finite())) {
                mesh.tangents = Some(v);
            }
        }
        Ok(Some(mesh))
    }
}
