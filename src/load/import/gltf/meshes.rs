//! The node tree (matrix or TRS transforms) and its triangle primitives.

use glam::{Mat4, Quat, Vec2, Vec3, Vec4};
use gltf::mesh::Mode;

use super::attributes::{DracoPrimitive, Source};
use super::validate::{check_accessor, check_index_accessor, check_layout};
use super::{Context, MAX_NODE_DEPTH};
use crate::load::import::{generate_tangents, Asset, AssetCamera, Piece};
use crate::material::Material;
use crate::scene::Mesh;

impl Context<'_> {
    pub(super) fn node(
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
                let material = primitive.material().index().unwrap_or(default_material);
                let uv_set = self.uv_sets.get(material).copied().unwrap_or(0);
                let Some(mut piece) = self.primitive(&primitive, &what, uv_set)? else {
                    continue;
                };
                piece.transform(&world);
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

    /// One primitive's triangles, or `None` for points and lines. Its
    /// texture coordinates are set `uv_set` (the one its material's
    /// textures use).
    pub(super) fn primitive(
        &mut self,
        p: &gltf::Primitive,
        what: &str,
        uv_set: u32,
    ) -> Result<Option<Mesh>, String> {
        let uv_semantic = gltf::Semantic::TexCoords(uv_set);
        let (source, unusable) = match p.extension_value("KHR_draco_mesh_compression") {
            Some(extension) => (
                Source::Draco(Box::new(
                    DracoPrimitive::decode(extension, self.document, self.buffers)
                        .map_err(|e| format!("{what}: {e}"))?,
                )),
                Vec::new(),
            ),
            None => (
                Source::Accessors(self.buffers),
                self.check_accessors(p, what, &uv_semantic)?,
            ),
        };
        let read = |semantic: &gltf::Semantic| !unusable.contains(semantic);
        // The checks above leave the reader nothing to refuse (validation
        // requires POSITION); should it still, that is an error, not a panic.
        let unreadable = |attr: &str| format!("{what}: the data of its {attr} cannot be read");
        let positions: Vec<Vec3> = source
            .rows::<3>(p, &gltf::Semantic::Positions)
            .ok_or_else(|| unreadable("POSITION"))?
            .into_iter()
            .map(Vec3::from)
            .collect();
        let n = positions.len();
        if let Some(bad) = positions.iter().position(|v| !v.is_finite()) {
            return Err(format!("{what}: vertex {bad} is not finite"));
        }
        let indices: Vec<u32> = match source.indices(p) {
            Some(i) => i,
            None if p.indices().is_some() => return Err(unreadable("indices")),
            None => (0..n as u32).collect(),
        };
        if let Some(&bad) = indices.iter().find(|&&i| i as usize >= n) {
            return Err(format!(
                "{what}: index {bad} is out of range ({n} vertices)"
            ));
        }
        let Some(triangles) = triangles(p.mode(), &indices) else {
            self.ignored.insert("points and lines primitives".into());
            return Ok(None);
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
        let normals = gltf::Semantic::Normals;
        if let Some(v) = read(&normals)
            .then(|| source.rows::<3>(p, &normals))
            .flatten()
        {
            // Quantised normals are unit only to within their precision.
            let v: Vec<Vec3> = v
                .into_iter()
                .map(|n| Vec3::from(n).normalize_or_zero())
                .collect();
            if attribute("NORMAL", v.len(), v.iter().all(|n| n.is_finite())) {
                mesh.normals = Some(v);
            }
        }
        if let Some(v) = read(&uv_semantic)
            .then(|| source.rows::<2>(p, &uv_semantic))
            .flatten()
        {
            let v: Vec<Vec2> = v.into_iter().map(Vec2::from).collect();
            if attribute(
                &uv_semantic.to_string(),
                v.len(),
                v.iter().all(|t| t.is_finite()),
            ) {
                mesh.uvs = Some(v);
            }
        }
        let tangents = gltf::Semantic::Tangents;
        if let Some(v) = read(&tangents)
            .then(|| source.rows::<4>(p, &tangents))
            .flatten()
        {
            let v: Vec<Vec4> = v
                .into_iter()
                .map(|t| {
                    let xyz = Vec3::new(t[0], t[1], t[2]).normalize_or_zero();
                    xyz.extend(if t[3] < 0.0 { -1.0 } else { 1.0 })
                })
                .collect();
            if attribute("TANGENT", v.len(), v.iter().all(|t| t.is_finite())) {
                mesh.tangents = Some(v);
            }
        }
        Ok(Some(mesh))
    }

    /// Checks what the crate's accessor iterators trust: each accessor's
    /// element type and layout. Broken required data is an error, broken
    /// optional data a warning, and returned: the primitive is read without
    /// it.
    fn check_accessors(
        &mut self,
        p: &gltf::Primitive,
        what: &str,
        uv_semantic: &gltf::Semantic,
    ) -> Result<Vec<gltf::Semantic>, String> {
        let buffers = self.buffers;
        let mut unusable = Vec::new();
        for (semantic, required) in [
            (gltf::Semantic::Positions, true),
            (gltf::Semantic::Normals, false),
            (uv_semantic.clone(), false),
            (gltf::Semantic::Tangents, false),
        ] {
            let Some(accessor) = p.get(&semantic) else {
                continue;
            };
            let checked = check_accessor(&accessor, &semantic)
                .and_then(|()| check_layout(&accessor, &semantic.to_string(), buffers));
            match checked {
                Ok(()) => {}
                Err(e) if required => return Err(format!("{what}: {e}")),
                Err(e) => {
                    self.warnings
                        .push(format!("{}: {what}: {e}; not used", self.file));
                    unusable.push(semantic);
                }
            }
        }
        if let Some(indices) = p.indices() {
            check_index_accessor(&indices)
                .and_then(|()| check_layout(&indices, "index", buffers))
                .map_err(|e| format!("{what}: {e}"))?;
        }
        Ok(unusable)
    }
}

/// The triangles of a primitive's indices in its mode; None for points and
/// lines.
fn triangles(mode: Mode, indices: &[u32]) -> Option<Vec<[u32; 3]>> {
    Some(match mode {
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
        _ => return None,
    })
}
