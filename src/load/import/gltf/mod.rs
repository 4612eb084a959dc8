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
//!   extension's definition); KHR_materials_volume's attenuationColor and
//!   attenuationDistance → an absorbing medium inside it (Beer–Lambert,
//!   σa = −ln c / d per metre, scaled by the scene's `units`); the base
//!   colour (factor × texture) tints the transmission at each crossing;
//! - KHR_texture_transform on every texture; samplers' wrap modes, and
//!   nearest magnification.
//!
//! - KHR_materials_specular, KHR_materials_clearcoat,
//!   KHR_materials_sheen and KHR_materials_iridescence (thin-film
//!   interference, exact per wavelength) → layers of that BRDF
//!   (`material::pbr`), factors times textures (the clear coat's normal
//!   map excepted);
//! - alphaMode MASK and BLEND → cut-outs (`material::cutout`): alpha from
//!   baseColorFactor × baseColorTexture, tested against alphaCutoff or
//!   kept with probability alpha.
//!
//! - KHR_mesh_quantization and KHR_draco_mesh_compression geometry
//!   (`attributes`); texture coordinates of the set the material's
//!   textures ask for; `doubleSided = false` → single-sided (the camera
//!   sees the front face only); `extensionsRequired` judged by what is
//!   mapped or decoded here.
//!
//! Ignored, and listed once per file: transmission textures,
//! KHR_materials_volume's thickness (a rasteriser's stand-in for the
//! geometry prism traces), and every other extension. occlusionTexture is not used by design: a path
//! tracer computes occlusion. Cameras: perspective ones (orthographic are
//! skipped).

mod attributes;
mod buffers;
mod materials;
mod meshes;
mod validate;

use std::collections::BTreeSet;
use std::path::Path;

use glam::Mat4;

use super::{Asset, AssetMaterial, TextureCache};
use crate::material::{Material, PbrMaterial};
use crate::spectrum::Spectrum;
use buffers::load_buffers;
use validate::validate;

/// Extensions that are mapped (see the module notes).
const MAPPED_EXTENSIONS: [&str; 10] = [
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_clearcoat",
    "KHR_materials_iridescence",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_ior",
    "KHR_materials_emissive_strength",
    "KHR_materials_dispersion",
    "KHR_texture_transform",
];

/// Geometry encodings that are decoded (see `meshes`).
const DECODED_EXTENSIONS: [&str; 2] = ["KHR_mesh_quantization", "KHR_draco_mesh_compression"];

/// Whether a file may require `extension`: prism maps or decodes it.
pub(super) fn supports(extension: &str) -> bool {
    MAPPED_EXTENSIONS.contains(&extension) || DECODED_EXTENSIONS.contains(&extension)
}

/// Deeper node trees than this are refused (they can only be cycles).
pub(super) const MAX_NODE_DEPTH: usize = 256;

/// Loads a glTF or GLB file.
pub fn load(path: &Path, textures: &mut TextureCache) -> Result<Asset, String> {
    // The file's bytes go once parsed: the binary chunk is a copy of them.
    let mut gltf =
        gltf::Gltf::from_slice_without_validation(&crate::input::read(path)?).map_err(describe)?;
    validate(gltf.as_json())?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(&mut gltf, base)?;

    let mut asset = Asset::default();
    let mut ignored = BTreeSet::new();
    for ext in gltf.extensions_used() {
        if !supports(ext) {
            ignored.insert(ext.to_string());
        }
    }

    let mut ctx = Context {
        file: path.display().to_string(),
        document: &gltf.document,
        base,
        buffers: &buffers,
        textures,
        ignored,
        warnings: Vec::new(),
        uv_sets: Vec::new(),
        slot_sets: Vec::new(),
    };
    for m in gltf.materials() {
        let mapped = ctx.material(&m);
        let set = ctx.uv_set(&mapped.name);
        ctx.uv_sets.push(set);
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
            layers: Default::default(),
        })),
        emission: None,
        cutout: None,
        single_sided: true,
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
pub(super) fn describe(e: gltf::Error) -> String {
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

/// What loading one file needs: its buffers, the shared texture cache, and
/// what it ignored or warned about so far.
struct Context<'a> {
    file: String,
    document: &'a gltf::Document,
    base: &'a Path,
    buffers: &'a [Vec<u8>],
    textures: &'a mut TextureCache,
    ignored: BTreeSet<String>,
    warnings: Vec<String>,
    /// The texture coordinate set each material's textures use (by
    /// material index), which its primitives read.
    uv_sets: Vec<u32>,
    /// While a material is mapped: each texture slot and the set it asks
    /// for.
    slot_sets: Vec<(String, u32)>,
}

impl Context<'_> {
    /// The texture coordinate set of the material just mapped: the one its
    /// textures ask for. A mesh carries one set to the renderer, so where
    /// textures ask for different sets the base colour's (or the first
    /// slot's) wins, and the others are named in a warning.
    fn uv_set(&mut self, material: &str) -> u32 {
        let slots = std::mem::take(&mut self.slot_sets);
        let Some(&(_, first)) = slots
            .iter()
            .find(|(slot, _)| slot == "baseColorTexture")
            .or(slots.first())
        else {
            return 0;
        };
        let others: Vec<String> = slots
            .iter()
            .filter(|(_, set)| *set != first)
            .map(|(slot, set)| format!("{slot} (TEXCOORD_{set})"))
            .collect();
        if !others.is_empty() {
            self.warnings.push(format!(
                "{}: material `{material}` reads its textures through TEXCOORD_{first}; \
                 {} ask for another set and read TEXCOORD_{first} instead",
                self.file,
                others.join(", ")
            ));
        }
        first
    }
}
