//! Wavefront OBJ (read in parallel by `obj_text`) with MTL materials
//! (tobj). Polygons of any size are
//! triangulated in their own plane by ear clipping (concave ones too),
//! negative indices resolved, objects and groups split by
//! material; a missing or broken .mtl is a warning (the scene's default
//! material is used), never a failure.
//!
//! MTL → prism:
//! - `Ke` (and `map_Ke`) → emission, RGB relative to D65 as in scene files;
//! - illum 6 or 7 (refraction) → dielectric with index `Ni` (1.5 unless
//!   `Ni` > 1), roughness from `Ns`; illum 4 or 9 (glass models), or
//!   dissolve `d` < 1 (`Tr` > 0), → the same, only with an index `Ni` > 1
//!   (else illum 2, noted: Maya writes `illum 4` and `Ni 1.00` everywhere);
//! - illum 3, 5 or 8 (reflection) → a Fresnel mirror: metal with colour
//!   `Ks` (`Kd` × `map_Kd` where `Ks` is black);
//! - illum above 9 → illum 2, noted;
//! - `Ks` > 0 otherwise → glTF-style plastic: diffuse `Kd` × `map_Kd` under
//!   a GGX coat of index `Ni` (default 1.5), roughness from `Ns`;
//! - otherwise → Lambertian `Kd` × `map_Kd` (default Kd 0.8, as Blender).
//!
//! `Ns` (Phong exponent) becomes α = √(2 / (Ns + 2)) (Walter et al. 2007's
//! Phong–Beckmann match). Colours (Kd, Ks, Ke) are linear; textures sRGB.
//! - `d` < 1 (`Tr` > 0) or `map_d` on a surface that is not glass → a
//!   cut-out: the surface is there with probability d × map_d (the map's
//!   alpha channel, or its grey level without one).
//!
//! Ignored, and listed once per file for the materials faces use: `Tf` off
//! glass, `map_Ks`, `map_Ns`, bump/normal maps, ambient terms (a `Ka` above 1
//! without `Ke`, a lamp written as ambient colour, is warned about).
//! Texture names may use Windows separators and differ in case from the
//! files (with a warning).

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::{polygon, Asset, AssetMaterial, Piece, TextureCache};
use crate::material::{Cutout, CutoutMode, Ior, Material, PbrMaterial, Reflectance};
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
    let bytes = crate::input::read_mapped(path)?;
    let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    // The geometry is read in parallel (obj_text); the material libraries
    // by tobj.
    // Parsing holds the text, the vertices, 12 bytes a corner (a corner
    // can be 6 bytes of text: `1/1/1 `) and the pieces' own copies of
    // them while it gathers: up to four times the file.
    crate::memory::check(
        &format!("reading the OBJ ({} bytes)", bytes.len()),
        4 * bytes.len() as u64,
    )?;
    let geometry = super::obj_text::parse(&bytes)?;
    drop(bytes);
    let mut asset = Asset::default();
    if let Some(warning) = &geometry.broken_normal {
        asset
            .warnings
            .push(format!("{}: {warning}", path.display()));
    }
    // Each material with the library file it came from.
    let mut mtl_materials: Vec<(tobj::Material, PathBuf)> = Vec::new();
    let mut by_name: std::collections::HashMap<String, usize> = Default::default();
    // Values of the MTL files that were out of range, by material.
    let mut value_warnings: std::collections::HashMap<String, Vec<String>> = Default::default();
    let libraries: Vec<String> = geometry
        .material_libraries
        .iter()
        .flat_map(|line| library_names(&base, line))
        .collect();
    for library in &libraries {
        let full = base.join(library);
        let read = crate::input::read(&full).and_then(|text| {
            let checked = check_mtl_values(&String::from_utf8_lossy(&text), &full);
            tobj::load_mtl_buf(&mut std::io::Cursor::new(text))
                .map(|(materials, _)| (materials, checked))
                .map_err(|e| format!("cannot be read ({e})"))
        });
        match read {
            Ok((materials, checked)) => {
                for (name, warning) in checked? {
                    value_warnings.entry(name).or_default().push(warning);
                }
                for m in materials {
                    by_name.insert(m.name.clone(), mtl_materials.len());
                    mtl_materials.push((m, full.clone()));
                }
            }
            Err(why) => asset.warnings.push(format!(
                "{} {why}: its faces use the default material",
                full.display()
            )),
        }
    }
    // Each material's warnings and unmapped features, reported only for
    // the materials that faces use.
    let mut said: Vec<(Vec<String>, Vec<String>)> = Vec::new();
    for (m, library) in &mtl_materials {
        let (mut warnings, mut ignored) = (Vec::new(), Vec::new());
        warnings.extend(value_warnings.remove(&m.name).unwrap_or_default());
        asset
            .materials
            .push(material(m, library, textures, &mut warnings, &mut ignored));
        said.push((warnings, ignored));
    }

    let pieces: Vec<Result<Option<Piece>, String>> = geometry
        .pieces
        .into_par_iter()
        .map(|p| {
            let material = p.material.as_ref().and_then(|m| by_name.get(m).copied());
            piece(p, material, smooth)
        })
        .collect();
    for p in pieces {
        asset.pieces.extend(p?);
    }
    if asset.pieces.is_empty() {
        return Err("the OBJ file has no faces".into());
    }
    let mut used: Vec<usize> = asset.pieces.iter().filter_map(|p| p.material).collect();
    used.sort_unstable();
    used.dedup();
    let mut ignored = Vec::new();
    for i in used {
        let (warnings, notes) = std::mem::take(&mut said[i]);
        asset.warnings.extend(warnings);
        ignored.extend(notes);
    }
    ignored.sort();
    ignored.dedup();
    asset.ignored = ignored;
    Ok(asset)
}

/// The files an `mtllib` line names: the whole line where a file has that
/// name (some exporters write names with spaces), otherwise its words,
/// where `\ ` is a space within a name.
fn library_names(base: &Path, line: &str) -> Vec<String> {
    if base.join(line).is_file() {
        return vec![line.to_string()];
    }
    let mut names = vec![String::new()];
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '\\' if chars.peek().is_some_and(|n| n.is_whitespace()) => {
                names.last_mut().unwrap().push(chars.next().unwrap());
            }
            c if c.is_whitespace() => {
                if !names.last().unwrap().is_empty() {
                    names.push(String::new());
                }
            }
            c => names.last_mut().unwrap().push(c),
        }
    }
    names.retain(|n| !n.is_empty());
    names
}

/// A piece of the OBJ as a mesh: polygons triangulated in their own
/// planes, OBJ's upward v turned into ours. None if it has no triangles.
fn piece(
    p: super::obj_text::ObjPiece,
    material: Option<usize>,
    smooth: bool,
) -> Result<Option<Piece>, String> {
    let mut mesh = Mesh {
        positions: p.positions,
        // OBJ's v runs up from the bottom of the image; ours runs down.
        uvs: p
            .uvs
            .map(|uvs| uvs.into_iter().map(|t| Vec2::new(t.x, 1.0 - t.y)).collect()),
        normals: p
            .normals
            .filter(|n| smooth && n.iter().all(|n| n.is_finite())),
        ..Default::default()
    };
    mesh.indices = polygon::triangles_of_faces(p.corners, &p.arities, &mesh.positions);
    if mesh.indices.is_empty() {
        return Ok(None);
    }
    if p.broken_normals && smooth {
        mesh.normals = Some(super::vertex_normals(&mesh));
    }
    Ok(Some(Piece {
        mesh,
        material,
        name: p.name,
    }))
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
    let path = match find_texture(dir, name) {
        Found::Exact(path) => path,
        Found::IgnoringCase(path) => {
            warnings.push(format!(
                "texture {} not found as written; using {} (the name differs in case)",
                dir.join(file_name_of(name)).display(),
                path.display()
            ));
            path
        }
        Found::Missing => dir.join(file_name_of(name)),
    };
    match textures.file(&path, encoding) {
        Ok(t) => Some(TextureRef::new(t)),
        Err(e) => {
            warnings.push(format!("{e}; the material uses its colour alone"));
            None
        }
    }
}

/// Where a texture named in an MTL file is.
enum Found {
    Exact(PathBuf),
    /// Only by matching names without regard to case (files made on
    /// Windows or macOS, whose file systems ignore it).
    IgnoringCase(PathBuf),
    Missing,
}

/// The file an MTL texture statement names: its last word (options such as
/// `-s 1 1 1` come first), with `/` between directories.
fn file_name_of(statement: &str) -> String {
    last_word(statement).replace('\\', "/")
}

fn last_word(statement: &str) -> &str {
    statement.split_whitespace().last().unwrap_or(statement)
}

/// Finds the texture `name` relative to `dir`: options such as `-s 1 1 1`
/// may precede the file name, Windows writes `\` between directories
/// (`.\wall.jpg`, `..\textures\a.png`), and names may differ in case from
/// the files.
fn find_texture(dir: &Path, name: &str) -> Found {
    let candidates = [name, last_word(name)];
    for candidate in candidates {
        for form in [candidate.to_string(), candidate.replace('\\', "/")] {
            let path = dir.join(&form);
            if path.is_file() {
                return Found::Exact(path);
            }
        }
    }
    for candidate in candidates {
        if let Some(path) = ignoring_case(dir, &candidate.replace('\\', "/")) {
            return Found::IgnoringCase(path);
        }
    }
    Found::Missing
}

/// `relative` under `dir`, each component matched without regard to case.
fn ignoring_case(dir: &Path, relative: &str) -> Option<PathBuf> {
    let mut path = dir.to_path_buf();
    for part in relative.split('/').filter(|p| !p.is_empty() && *p != ".") {
        if part == ".." {
            path.push("..");
            continue;
        }
        let exact = path.join(part);
        if exact.exists() {
            path = exact;
            continue;
        }
        let entry = std::fs::read_dir(&path)
            .ok()?
            .filter_map(Result::ok)
            .find(|e| e.file_name().to_string_lossy().eq_ignore_ascii_case(part))?;
        path.push(entry.file_name());
    }
    path.is_file().then_some(path)
}

/// Checks the numbers of an MTL file as the scene file's are checked: a
/// value that is not finite, or out of its range, is a warning naming the
/// file, line, key and material, with what is used instead; an emission
/// beyond what f32 carries is an error. Returns the warnings by material.
fn check_mtl_values(text: &str, path: &Path) -> Result<Vec<(String, String)>, String> {
    let mut out = Vec::new();
    let mut material = String::new();
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        if key == "newmtl" {
            material = words.collect::<Vec<_>>().join(" ");
            continue;
        }
        // The range each key's numbers must lie in, and what is done
        // otherwise.
        let (lo, hi, instead) = match key {
            "Kd" => (0.0, f32::MAX, "0.8 is used"),
            "Ks" | "Ka" | "Tf" => (0.0, f32::MAX, "0 is used"),
            "Ke" => (0.0, MAX_EMISSION, "0 is used"),
            "d" => (0.0, 1.0, "it is clamped to [0, 1] (1 where not a number)"),
            "Tr" => (0.0, 1.0, "it is clamped to [0, 1] (0 where not a number)"),
            "Ni" => (
                *IOR_RANGE.start(),
                *IOR_RANGE.end(),
                "the index is ignored (glass takes 1.5)",
            ),
            "Ns" => (0.0, f32::MAX, "0 is used"),
            _ => continue,
        };
        let at = format!("{}:{}", path.display(), i + 1);
        for word in words.take(3) {
            let Ok(v) = word.parse::<f32>() else { continue };
            if key == "Ke" && !(v <= MAX_EMISSION) {
                return Err(format!(
                    "{at}: `Ke` of material `{material}` is {v:e}, beyond what f32 arithmetic \
                     carries through a path (limit {MAX_EMISSION:e})"
                ));
            }
            if !(lo..=hi).contains(&v) {
                let what = if v.is_finite() {
                    "outside"
                } else {
                    "not a number in"
                };
                out.push((
                    material.clone(),
                    format!(
                        "{at}: `{key}` of material `{material}` is {v}, {what} [{lo}, {}]: {instead}",
                        if hi == f32::MAX { "∞".to_string() } else { hi.to_string() }
                    ),
                ));
                break;
            }
        }
    }
    Ok(out)
}

/// The diffuse colour of a material without a usable `Kd` (as Blender).
const DEFAULT_KD: f32 = 0.8;

/// The indices of refraction `Ni` may give; others are ignored.
const IOR_RANGE: std::ops::RangeInclusive<f32> = 1.0..=10.0;

/// The brightest MTL emission accepted (the scene file's limit).
const MAX_EMISSION: f32 = 1e30;

/// What an illumination model makes of a material.
struct Model {
    glass: bool,
    mirror: bool,
}

/// The illumination models as renderers read them: 6 and 7 are refraction
/// (glass, Ni or 1.5); 4 and 9 are glass only with an index above 1 (Maya
/// writes `illum 4` and `Ni 1.00` on every material), as is a dissolved
/// surface; 3, 5 and 8 are reflection (a Fresnel mirror). What is not
/// mapped is noted.
fn model(illum: u8, ni: Option<f32>, see_through: bool, note: &mut impl FnMut(&str)) -> Model {
    let refracts = ni.is_some_and(|n| n > 1.0);
    match illum {
        4 | 9 if !refracts => note(&format!(
            "illum {illum} without an index Ni above 1 (not glass: shaded as illum 2)"
        )),
        6 | 7 if ni.is_some() && !refracts => {
            note(&format!("illum {illum} with Ni ≤ 1 (glass of index 1.5)"))
        }
        0..=9 => {}
        _ => note(&format!("illum {illum} (shaded as illum 2)")),
    }
    Model {
        glass: matches!(illum, 6 | 7) || ((matches!(illum, 4 | 9) || see_through) && refracts),
        mirror: matches!(illum, 3 | 5 | 8),
    }
}

/// One MTL material (from the library file `library`; its textures are
/// relative to that file).
fn material(
    m: &tobj::Material,
    library: &Path,
    textures: &mut TextureCache,
    warnings: &mut Vec<String>,
    ignored: &mut Vec<String>,
) -> AssetMaterial {
    let dir = library.parent().unwrap_or(Path::new("."));
    // Not finite: the default; below zero: zero (`check_mtl_values` warns).
    let rgb = |c: Option<[f32; 3]>| {
        c.map(Vec3::from)
            .filter(|c| c.is_finite())
            .map(|c| c.max(Vec3::ZERO))
    };
    let kd = rgb(m.diffuse).unwrap_or(Vec3::splat(DEFAULT_KD));
    let ks = rgb(m.specular).unwrap_or(Vec3::ZERO);
    let ke = rgb(m.emissive).unwrap_or(Vec3::ZERO);
    // Some files (the Embree Cornell Box) write their lamps as a bright
    // ambient colour: say so, or the scene renders dark without a word.
    if rgb(m.ambient).is_some_and(|ka| ka.max_element() > 1.0) && ke == Vec3::ZERO {
        warnings.push(format!(
            "{}: material `{}` has an ambient colour Ka above 1 and no Ke: if it is meant to be a light, give it Ke (Ka is not light)",
            library.display(),
            m.name
        ));
    }
    let ni = m.optical_density.filter(|n| IOR_RANGE.contains(n));
    let roughness = roughness_from_phong(m.shininess.filter(|s| s.is_finite()).unwrap_or(0.0));
    let illum = m
        .illumination_model
        .unwrap_or(if ks.max_element() > 0.0 { 2 } else { 1 });

    let tr = m
        .unknown_param
        .get("Tr")
        .and_then(|t| t.trim().parse::<f32>().ok());
    let see_through = m.dissolve.is_some_and(|d| d < 1.0) || tr.is_some_and(|t| t > 0.0);
    let mut note = |what: &str| ignored.push(format!("{what} (material `{}`)", m.name));
    let Model { glass, mirror } = model(illum, ni, see_through, &mut note);
    // Tf r g b on glass: the colour light keeps after one unit of path
    // inside (a filter), as an absorbing medium; elsewhere it means nothing.
    let filter = m.unknown_param.get("Tf").and_then(|t| parse_filter(t));
    if m.unknown_param.contains_key("Tf") && !(glass && filter.is_some()) {
        note("transmission filter Tf (used on glass only, as r g b)");
    }
    for (name, tex) in [
        ("map_Ks", &m.specular_texture),
        ("map_Ns", &m.shininess_texture),
        ("bump/normal map", &m.normal_texture),
    ] {
        if tex.is_some() {
            note(name);
        }
    }

    // A black Kd beside map_Kd is how Maya writes a textured colour (the
    // colour attribute is connected): the texture alone, as Blender reads it.
    let kd = if kd == Vec3::ZERO && m.diffuse_texture.is_some() {
        Vec3::ONE
    } else {
        kd
    };
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
            ior: Ior::Constant(ni.filter(|&n| n > 1.0).unwrap_or(1.5)),
            alpha: crate::material::microfacet::alpha_from_roughness(roughness),
            priority: 0,
            medium: filter
                .filter(|c| c.iter().any(|&v| v < 1.0))
                .map(|c| Box::new(Medium::absorbing(c, 1.0))),
            tint: None,
            opaque: None,
        },
        // A mirror without Ks takes Kd (× map_Kd), not black.
        _ if mirror && ks.max_element() > 0.0 => {
            pbr(Spectrum::rgb_reflectance(ks).into(), 1.0, roughness, 1.5)
        }
        _ if mirror => pbr(diffuse(), 1.0, roughness, 1.5),
        _ if ks.max_element() > 0.0 && illum >= 2 => {
            pbr(diffuse(), 0.0, roughness, ni.unwrap_or(1.5))
        }
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
    let cutout = cutout(m, glass, tr, dir, textures, warnings);
    AssetMaterial {
        name: m.name.clone(),
        material,
        emission,
        cutout,
        single_sided: false,
    }
}

/// The glTF BRDF: a metal (metallic 1) or plastic (0) of `base_color`.
fn pbr(base_color: Reflectance, metallic: f32, roughness: f32, ior: f32) -> Material {
    Material::Pbr(Box::new(PbrMaterial {
        base_color,
        metallic,
        roughness,
        metallic_roughness: None,
        ior,
        normal_map: None,
        layers: Default::default(),
    }))
}

/// Dissolve (`d`, `Tr`, `map_d`) on a surface that is not glass: a
/// cut-out, the surface there with probability d × map_d.
fn cutout(
    m: &tobj::Material,
    glass: bool,
    tr: Option<f32>,
    dir: &Path,
    textures: &mut TextureCache,
    warnings: &mut Vec<String>,
) -> Option<Cutout> {
    // Dissolve on a surface that is not glass: a cut-out (the surface is
    // there with probability d × map_d).
    let matte = m
        .dissolve_texture
        .as_ref()
        .filter(|_| !glass)
        .and_then(|_| {
            texture(
                &m.dissolve_texture,
                dir,
                Encoding::Matte,
                textures,
                warnings,
            )
        });
    let dissolve = m
        .dissolve
        .or(tr.map(|t| 1.0 - t))
        .filter(|d| d.is_finite())
        .unwrap_or(1.0)
        .clamp(0.0, 1.0);
    (!glass && (dissolve < 1.0 || matte.is_some())).then_some(Cutout {
        factor: dissolve,
        texture: matte,
        mode: CutoutMode::Blend,
    })
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
