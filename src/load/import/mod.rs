//! Assets made by other tools: glTF 2.0 and OBJ/MTL files become meshes in
//! the asset's own space, the asset's materials mapped to prism's, and any
//! cameras. The scene loader places them (transforms, instances) and lets
//! the scene file override their materials by name.

pub mod gltf;
pub mod obj;
mod obj_text;
mod polygon;

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use glam::{Vec2, Vec3, Vec4};

use crate::material::{Cutout, Material};
use crate::scene::mesh::Mesh;
use crate::scene::Emission;
use crate::texture::{Encoding, Filter, Texture, Wrap};

/// Everything taken from one asset file.
#[derive(Default)]
pub struct Asset {
    pub pieces: Vec<Piece>,
    pub materials: Vec<AssetMaterial>,
    pub cameras: Vec<AssetCamera>,
    /// Things the file uses that prism does not map (reported once per file).
    pub ignored: Vec<String>,
    /// Other problems that did not stop the import.
    pub warnings: Vec<String>,
}

/// A mesh with one material, in the asset's space (node transforms applied).
pub struct Piece {
    pub mesh: Mesh,
    /// Index into [`Asset::materials`]; `None`: the scene's default.
    pub material: Option<usize>,
    /// The mesh (glTF) or object/group (OBJ) it came from.
    pub name: String,
}

pub struct AssetMaterial {
    pub name: String,
    pub material: Material,
    pub emission: Option<Emission>,
    /// Where the surface is absent (alpha masks and blending).
    pub cutout: Option<Cutout>,
    /// The camera sees the front face only (glTF `doubleSided = false`).
    pub single_sided: bool,
}

/// A perspective camera found in the asset, in the asset's space.
#[derive(Clone, Debug)]
pub struct AssetCamera {
    pub name: String,
    pub position: Vec3,
    pub forward: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub yfov: f32,
}

/// Textures decoded so far, keyed by where they came from and how they are
/// read, so that every use of an image shares one decoded copy.
#[derive(Default)]
pub struct TextureCache {
    textures: HashMap<(String, Encoding, [Wrap; 2], Filter), Arc<Texture>>,
    /// Problems found in images that still decoded (truncated files).
    pub warnings: Vec<String>,
}

impl TextureCache {
    /// The texture for `key` (a path, or a file plus an image index),
    /// reading and decoding `bytes()` only the first time. Errors are as
    /// `bytes` and the decoder give them; callers say which image it was.
    pub fn get(
        &mut self,
        key: String,
        encoding: Encoding,
        wrap: [Wrap; 2],
        filter: Filter,
        bytes: impl FnOnce() -> Result<Vec<u8>, String>,
    ) -> Result<Arc<Texture>, String> {
        let k = (key, encoding, wrap, filter);
        if let Some(t) = self.textures.get(&k) {
            return Ok(t.clone());
        }
        let bytes = bytes()?;
        if crate::texture::jpeg_is_truncated(&bytes) {
            self.warnings.push(format!(
                "{}: the JPEG stops before its end-of-image marker (a truncated file?): what is missing decodes as grey",
                k.0
            ));
        }
        let mut texture = Texture::decode(&bytes, encoding)?;
        texture.wrap = wrap;
        texture.filter = filter;
        let texture = Arc::new(texture);
        self.textures.insert(k, texture.clone());
        Ok(texture)
    }

    /// A texture from an image file.
    pub fn file(&mut self, path: &Path, encoding: Encoding) -> Result<Arc<Texture>, String> {
        let key = path
            .canonicalize()
            .unwrap_or_else(|_| path.to_path_buf())
            .display()
            .to_string();
        self.get(key, encoding, [Wrap::Repeat; 2], Filter::Bilinear, || {
            crate::input::read(path)
        })
        .map_err(|e| format!("{}: {e}", path.display()))
    }
}

/// Smooth vertex normals: each the sum of its triangles' normals weighted
/// by their areas (the cross product's length), normalised; a vertex of
/// degenerate triangles only gets its neighbours' direction or +z.
pub fn vertex_normals(mesh: &Mesh) -> Vec<Vec3> {
    let mut sums = vec![Vec3::ZERO; mesh.positions.len()];
    for t in &mesh.indices {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            sums[i as usize] += n;
        }
    }
    sums.into_iter()
        .map(|n| n.try_normalize().unwrap_or(Vec3::Z))
        .collect()
}

/// Splits every vertex per triangle corner and fills in MikkTSpace tangents
/// (the glTF convention for normal maps). The mesh needs texture
/// coordinates; missing normals are taken as the flat face normals.
pub fn generate_tangents(mesh: &mut Mesh) -> Result<(), String> {
    let uvs = mesh.uvs.as_ref().ok_or("no texture coordinates")?;
    let mut corners = Corners {
        positions: Vec::with_capacity(mesh.indices.len() * 3),
        normals: Vec::with_capacity(mesh.indices.len() * 3),
        uvs: Vec::with_capacity(mesh.indices.len() * 3),
        tangents: vec![Vec4::ZERO; mesh.indices.len() * 3],
    };
    for f in &mesh.indices {
        let p = f.map(|i| mesh.positions[i as usize]);
        let flat = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
        for &i in f {
            corners.positions.push(mesh.positions[i as usize]);
            corners.uvs.push(uvs[i as usize]);
            corners.normals.push(match &mesh.normals {
                Some(n) => n[i as usize],
                None => flat,
            });
        }
    }
    bevy_mikktspace::generate_tangents(&mut corners)
        .map_err(|e| format!("cannot generate tangents: {e:?}"))?;
    let count = mesh.indices.len() as u32;
    mesh.indices = (0..count).map(|f| [3 * f, 3 * f + 1, 3 * f + 2]).collect();
    mesh.positions = corners.positions;
    mesh.uvs = Some(corners.uvs);
    if mesh.normals.is_some() {
        mesh.normals = Some(corners.normals);
    }
    mesh.tangents = Some(corners.tangents);
    Ok(())
}

struct Corners {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    tangents: Vec<Vec4>,
}

impl bevy_mikktspace::Geometry for Corners {
    fn num_faces(&self) -> usize {
        self.positions.len() / 3
    }
    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }
    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.positions[face * 3 + vert].to_array()
    }
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.normals[face * 3 + vert].to_array()
    }
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.uvs[face * 3 + vert].to_array()
    }
    fn set_tangent(
        &mut self,
        tangent_space: Option<bevy_mikktspace::TangentSpace>,
        face: usize,
        vert: usize,
    ) {
        if let Some(t) = tangent_space {
            self.tangents[face * 3 + vert] = Vec4::from_array(t.tangent_encoded());
        }
    }
}
