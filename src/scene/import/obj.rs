//! Wavefront OBJ with MTL materials (tobj). Polygons of any size are
//! triangulated, negative indices resolved, objects and groups split by
//! material; a missing or broken .mtl is a warning (the scene's default
//! material is used), never a failure.
//!
//! MTL → prism:
//! - `Ke` (and `map_Ke`) → emission, RGB relative to D65 as in scene files;
//! - illum 4, 6, 7 or 9 (glass models), or dissolve `d` < 1 (`Tr` > 0)
//!   together with an index `Ni` > 1 → dielectric with index `Ni` (default
//!   1.5), roughness from `Ns`;
//! - illum 3 (mirror/ray-traced reflection) → metal with colour `Ks`;
//! - `Ks` > 0 otherwise → glTF-style plastic: diffuse `Kd` × `map_Kd` under
//!   a GGX coat of index `Ni` (default 1.5), roughness from `Ns`;
//! - otherwise → Lambertian `Kd` × `map_Kd` (default Kd 0.8, as Blender).
//!
//! `Ns` (Phong exponent) becomes α = √(2 / (Ns + 2)) (Walter et al. 2007's
//! Phong–Beckmann match). Colours (Kd, Ks, Ke) are linear; textures sRGB.
//! Ignored, and listed once per file: `d`/`Tr` without an index (cut-out
//! transparency), `Tf`, `map_Ks`, `map_Ns`, `map_d`, bump/normal maps,
//! ambient terms.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use super::{Asset, AssetMaterial, Piece, TextureCache};
use crate::material::{Ior, Material, PbrMaterial, Reflectance};
use crate::medium::Medium;
use crate::scene::{Emission, Mesh};
use crate::spectrum::Spectrum;
use crate::texture::{Encoding, TextureRef};

/// GGX roughness (√α) for a Phong exponent.
fn roughness_from_phong(ns: f32) -> f32 {
    let alpha = (2.0 / (ns.max(0.0) + 2.0)).sqrt();
    alpha.sqrt().clamp(0.0, 1.0)
}

/// Reads an OBJ file and its materials. `smooth`: use the file's vertex
/// normals where every vertex of a piece has one.
pub fn load(path: &Path, smooth: bool, textures: &mut TextureCache) -> Result<Asset, String> {
    let file = File::open(path).map_err(|e| format!("cannot read: {e}"))?;
    let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ..Default::default()
    };
    // tobj's material loader is a `Fn`: note the library's path in a cell.
    let mtl_path: std::cell::RefCell<Option<PathBuf>> = Default::default();
    let (models, materials) = tobj::load_obj_buf(&mut BufReader::new(file), &options, |p| {
        let full = base.join(p);
        *mtl_path.borrow_mut() = Some(full.clone());
        tobj::load_mtl(&full)
    })
    .map_err(|e| format!("cannot read OBJ: {e}"))?;

    let mtl_path = mtl_path.into_inner();
    let mut asset = Asset::default();
    let mtl_materials = match materials {
        Ok(m) => m,
        Err(e) => {
            let which = mtl_path
                .as_ref()
                .map_or("the material library".to_string(), |p| {
                    p.display().to_string()
                });
            let why = match e {
                tobj::LoadError::OpenFileFailed => "cannot be opened".to_string(),
                other => format!("cannot be read ({other})"),
            };
            asset
                .warnings
                .push(format!("{which} {why}: its faces use the default material"));
            Vec::new()
        }
    };
    let mtl_dir = mtl_path
        .as_ref()
        .and_then(|p| p.parent())
        .unwrap_or(&base)
        .to_path_buf();
    let mut ignored = Vec::new();
    for m in &mtl_materials {
        asset.materials.push(material(
            m,
            &mtl_dir,
            textures,
            &mut asset.warnings,
            &mut ignored,
        ));
    }
    ignored.sort();
    ignored.dedup();
    asset.ignored = ignored;

    for model in &models {
        let m = &model.mesh;
        let count = m.positions.len() / 3;
        let mut mesh = Mesh {
            positions: m
                .positions
                .chunks_exact(3)
                .map(|v| Vec3::new(v[0], v[1], v[2]))
                .collect(),
            ..Default::default()
        };
        if smooth && m.normals.len() == m.positions.len() {
            let normals: Vec<Vec3> = m
                .normals
                .chunks_exact(3)
                .map(|n| Vec3::new(n[0], n[1], n[2]))
                .collect();
            if normals.iter().all(|n| n.is_finite()) {
                mesh.normals = Some(normals);
            }
        }
        if m.texcoords.len() == 2 * count {
            // OBJ's v runs up from the bottom of the image; ours runs down.
            mesh.uvs = Some(
                m.texcoords
                    .chunks_exact(2)
                    .map(|t| Vec2::new(t[0], 1.0 - t[1]))
                    .collect(),
            );
        }
        for f in m.indices.chunks_exact(3) {
            if f.iter().any(|&i| i as usize >= count) {
                return Err(format!(
                    "face index out of range in object `{}`",
                    model.name
                ));
            }
            mesh.indices.push([f[0], f[1], f[2]]);
        }
        if mesh.indices.is_empty() {
            continue;
        }
        if let Some(bad) = mesh.positions.iter().position(|p| !p.is_finite()) {
            return Err(format!(
                "vertex {} of object `{}` is not finite",
                bad + 1,
                model.name
            ));
        }
        let material = m.material_id.filter(|&id| id < asset.materials.len());
        asset.pieces.push(Piece {
            mesh,
            material,
            name: model.name.clone(),
        });
    }
    if asset.pieces.is_empty() {
        return Err("the OBJ file has no faces".into());
    }
    Ok(asset)
}

/// A texture named in the MTL file; a missing or broken one is a warning.
fn texture(
    name: &Option<String>,
    dir: &Path,
    encoding: Encoding,
    textures: &mut TextureCache,
    warnings: &mut Vec<String>,
) -> Option<TextureRef> {
    let name = name.as_ref()?;
    // Options such as `-s 1 1 1` may precede the file name.
    let path = dir.join(name);
    let path = if path.exists() {
        path
    } else {
        dir.join(name.split_whitespace().last().unwrap_or(name))
    };
    match textures.file(&path, encoding) {
        Ok(t) => Some(TextureRef::new(t)),
        Err(e) => {
            warnings.push(format!("{e}; the material uses its colour alone"));
            None
        }
    }
}

fn material(
    m: &tobj::Material,
    dir: &Path,
    textures: &mut TextureCache,
    warnings: &mut Vec<String>,
    ignored: &mut Vec<String>,
) -> AssetMaterial {
    let rgb = |c: Option<[f32; 3]>| c.map(Vec3::from).filter(|c| c.is_finite());
    let kd = rgb(m.diffuse).unwrap_or(Vec3::splat(0.8));
    let ks = rgb(m.specular).unwrap_or(Vec3::ZERO);
    let ke = rgb(m.emissive).unwrap_or(Vec3::ZERO);
    let ni = m
        .optical_density
        .filter(|n| n.is_finite() && *n >= 1.0 && *n <= 10.0);
    let roughness = roughness_from_phong(m.shininess.filter(|s| s.is_finite()).unwrap_or(0.0));
    let illum = m
        .illumination_model
        .unwrap_or(if ks.max_element() > 0.0 { 2 } else { 1 });

    let tr = m
        .unknown_param
        .get("Tr")
        .and_then(|t| t.trim().parse::<f32>().ok());
    let see_through = m.dissolve.is_some_and(|d| d < 1.0) || tr.is_some_and(|t| t > 0.0);
    let glass = matches!(illum, 4 | 6 | 7 | 9) || (see_through && ni.is_some_and(|n| n > 1.0));
    let mut note = |what: &str| ignored.push(format!("{what} (material `{}`)", m.name));
    if see_through && !glass {
        note("dissolve d/Tr without an index Ni");
    }
    // Tf r g b on glass: the colour light keeps after one unit of path
    // inside (a filter), as an absorbing medium; elsewhere it means nothing.
    let filter = m.unknown_param.get("Tf").and_then(|t| parse_filter(t));
    if m.unknown_param.contains_key("Tf") && !(glass && filter.is_some()) {
        note("transmission filter Tf (used on glass only, as r g b)");
    }
    for (name, tex) in [
        ("map_Ks", &m.specular_texture),
        ("map_Ns", &m.shininess_texture),
        ("map_d", &m.dissolve_texture),
        ("bump/normal map", &m.normal_texture),
    ] {
        if tex.is_some() {
            note(name);
        }
    }

    let mut diffuse = || Reflectance {
        factor: Spectrum::rgb_reflectance(kd),
        texture: texture(
            &m.diffuse_texture,
            dir,
            Encoding::SrgbColour,
            textures,
            warnings,
        ),
    };
    let material = match illum {
        _ if glass => Material::Dielectric {
            ior: Ior::Constant(ni.unwrap_or(1.5)),
            alpha: crate::material::microfacet::alpha_from_roughness(roughness),
            priority: 0,
            medium: filter
                .filter(|c| c.iter().any(|&v| v < 1.0))
                .map(|c| Box::new(Medium::absorbing(c, 1.0))),
            tint: None,
        },
        3 => Material::Pbr(Box::new(PbrMaterial {
            base_color: Spectrum::rgb_reflectance(ks).into(),
            metallic: 1.0,
            roughness,
            metallic_roughness: None,
            ior: 1.5,
            normal_map: None,
        })),
        _ if ks.max_element() > 0.0 && illum >= 2 => Material::Pbr(Box::new(PbrMaterial {
            base_color: diffuse(),
            metallic: 0.0,
            roughness,
            metallic_roughness: None,
            ior: ni.unwrap_or(1.5),
            normal_map: None,
        })),
        _ => Material::Diffuse {
            reflectance: diffuse(),
        },
    };
    let emission_texture = m
        .unknown_param
        .get("map_Ke")
        .cloned()
        .and_then(|name| texture(&Some(name), dir, Encoding::SrgbColour, textures, warnings));
    let emission = (ke.max_element() > 0.0).then(|| Emission {
        spectrum: Spectrum::rgb_emission(ke),
        texture: emission_texture,
        two_sided: false,
    });
    AssetMaterial {
        name: m.name.clone(),
        material,
        emission,
    }
}

/// `Tf r g b` (or one grey value) as a colour in (0, 1]; None for the
/// spectral and CIE XYZ forms, or values out of range.
fn parse_filter(text: &str) -> Option<[f32; 3]> {
    let v: Vec<f32> = text
        .split_whitespace()
        .map(|t| t.parse::<f32>())
        .collect::<Result<_, _>>()
        .ok()?;
    let c = match v[..] {
        [g] => [g; 3],
        [r, g, b] => [r, g, b],
        _ => return None,
    };
    c.iter().all(|x| *x > 0.0 && *x <= 1.0).then_some(c)
}
