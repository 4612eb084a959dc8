//! The node tree (matrix or TRS transforms) and its triangle primitives.

use glam::{Mat4, Quat, Vec2, Vec3, Vec4};
use gltf::mesh::Mode;

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
    pub(super) fn primitive(
        &mut self,
        p: &gltf::Primitive,
        what: &str,
    ) -> Result<Option<Mesh>, String> {
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
