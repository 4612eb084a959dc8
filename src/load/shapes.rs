//! Shapes: built-in quads and spheres, OBJ and glTF files (read once per
//! file, instanced), their transforms and material overrides.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::rc::Rc;

use glam::{Mat4, Quat, Vec3};

use super::spectra::Role;
use super::{list, AssetMaterialSlots, Loader, MAX_COORDINATE};
use crate::geometry::sphere::Sphere;
use crate::load::format::{
    ScaleSpec, SceneFile, ShapeGeometry, ShapeKind, ShapeSpec, SphereShape, TransformSpec,
};
use crate::load::import::{self, Asset};
use crate::load::SceneError;
use crate::material::Material;
use crate::scene::{Emission, Mesh, ShapeInstance, SphereInstance};

/// An OBJ or glTF shape's file and what to take from it.
pub(super) struct AssetFile<'a> {
    kind: ShapeKind,
    /// The path, relative to the scene file.
    rel: &'a Path,
    /// Only the pieces of this name.
    mesh: &'a Option<String>,
    /// Interpolate vertex normals (OBJ).
    smooth: bool,
}

/// Finest built-in sphere tessellation accepted.
const MAX_SPHERE_SEGMENTS: u32 = 4096;

impl Loader {
    /// Every `[[shape]]`, resolved to meshes with materials and emission.
    pub(super) fn shapes(
        &self,
        file: &SceneFile,
        material_index: &BTreeMap<String, u32>,
        materials: &mut Vec<Material>,
        default_material: u32,
    ) -> Result<(Vec<ShapeInstance>, Vec<SphereInstance>), SceneError> {
        let mut shapes = Vec::new();
        let mut spheres = Vec::new();
        let mut slots = AssetMaterialSlots::new();
        for (i, shape) in file.shapes.iter().enumerate() {
            let key = format!("shape[{i}]");
            let common = &shape.common;
            let material = match &common.material {
                None => None,
                Some(name) => Some(*material_index.get(name).ok_or_else(|| {
                    self.error(format!(
                        "`{key}.material`: no material named `{name}` (defined: {})",
                        list(file.materials.keys())
                    ))
                })?),
            };
            let emission = self.shape_emission(i, shape, file)?;
            let emission_of = emission.is_some().then_some(i as u32);
            let file_shape = match &shape.geometry {
                ShapeGeometry::Obj(f) => Some((&f.file, &f.mesh, &f.materials, f.smooth)),
                ShapeGeometry::Gltf(f) => Some((&f.file, &f.mesh, &f.materials, None)),
                _ => None,
            };
            match &shape.geometry {
                ShapeGeometry::Obj(_) | ShapeGeometry::Gltf(_) => {
                    let (rel, mesh, names, smooth) = file_shape.expect("a file shape");
                    let overrides = self.overrides(names, &key, material_index, file)?;
                    let asset_file = AssetFile {
                        kind: shape.geometry.kind(),
                        rel,
                        mesh,
                        smooth: smooth.unwrap_or(true),
                    };
                    for (mut mesh, m, e) in
                        self.asset_pieces(&asset_file, &key, &overrides, materials, &mut slots)?
                    {
                        self.place(&mut mesh, shape, &key)?;
                        self.hold_mesh(&key, &mesh)?;
                        shapes.push(ShapeInstance {
                            mesh,
                            material: material.unwrap_or(m.unwrap_or(default_material)),
                            emission: emission.clone().or(e),
                            emission_of,
                        });
                    }
                }
                ShapeGeometry::Sphere(sphere) if !sphere.tessellate => {
                    spheres.push(SphereInstance {
                        sphere: self.exact_sphere(sphere, shape, &key)?,
                        material: material.unwrap_or(default_material),
                        emission,
                        emission_of,
                        inward: common.flip_normals,
                    });
                }
                ShapeGeometry::Quad(_) | ShapeGeometry::Sphere(_) => {
                    let mut mesh = self.built_in_mesh(&shape.geometry, &key)?;
                    self.place(&mut mesh, shape, &key)?;
                    self.hold_mesh(&key, &mesh)?;
                    shapes.push(ShapeInstance {
                        mesh,
                        material: material.unwrap_or(default_material),
                        emission,
                        emission_of,
                    });
                }
            }
        }
        Ok((shapes, spheres))
    }

    /// The light a `[[shape]]` table's `emission` asks for (None without one).
    pub(super) fn shape_emission(
        &self,
        i: usize,
        shape: &ShapeSpec,
        file: &SceneFile,
    ) -> Result<Option<Emission>, SceneError> {
        let key = format!("shape[{i}]");
        let common = &shape.common;
        Ok(match &common.emission {
            None => {
                if common.emission_scale.is_some()
                    || common.two_sided.is_some()
                    || common.luminance.is_some()
                {
                    return Err(self.error(format!(
                        "`{key}`: `emission_scale`, `luminance` and `two_sided` need `emission`"
                    )));
                }
                None
            }
            Some(spec) => {
                let scale = common.emission_scale.unwrap_or(1.0);
                if scale < 0.0 {
                    return Err(self.error(format!("`{key}.emission_scale` must not be negative")));
                }
                let spectrum =
                    self.spectrum(spec, Role::Emission, file, &format!("{key}.emission"))?;
                let spectrum = match common.luminance {
                    None => spectrum.scaled(scale),
                    Some(_) if common.emission_scale.is_some() => {
                        return Err(self.error(format!(
                            "`{key}`: give `emission_scale` or `luminance`, not both"
                        )))
                    }
                    Some(l) => self.photometric(spectrum, l, &format!("{key}.luminance"))?,
                };
                Some(Emission {
                    spectrum: self.checked_emission(spectrum, &format!("{key}.emission"))?,
                    texture: None,
                    two_sided: common.two_sided.unwrap_or(false),
                })
            }
        })
    }

    /// An exact sphere: its centre and radius placed by the shape's
    /// transform, which must keep it a sphere (rotation, uniform scale,
    /// translation).
    fn exact_sphere(
        &self,
        spec: &SphereShape,
        shape: &ShapeSpec,
        key: &str,
    ) -> Result<Sphere, SceneError> {
        // The mesh's keys, given without asking for the mesh.
        for (name, given) in [
            ("segments", spec.segments.is_some()),
            ("smooth", spec.smooth.is_some()),
        ] {
            if given {
                return Err(self.error(format!(
                    "`{key}.{name}` applies to a tessellated sphere: give `tessellate = true` \
                     for a triangle mesh"
                )));
            }
        }
        let r = spec.radius;
        if !(r > 0.0 && r.is_finite()) {
            return Err(self.error(format!("`{key}.radius` must be positive")));
        }
        let mut sphere = Sphere::new(Vec3::from(spec.center.unwrap_or([0.0; 3])), r);
        if let Some(t) = &shape.common.transform {
            let m = self.transform(t, key)?;
            let linear = glam::Mat3::from_mat4(m);
            let scale = linear.x_axis.length();
            let similar = [linear.y_axis, linear.z_axis]
                .iter()
                .all(|a| (a.length() - scale).abs() <= 1e-4 * scale)
                && linear.x_axis.dot(linear.y_axis).abs() <= 1e-4 * scale * scale
                && linear.x_axis.dot(linear.z_axis).abs() <= 1e-4 * scale * scale
                && linear.y_axis.dot(linear.z_axis).abs() <= 1e-4 * scale * scale;
            if !similar {
                return Err(self.error(format!(
                    "`{key}.transform` does not keep a sphere round (it scales unevenly or shears): \
                     give `tessellate = true` for an ellipsoid mesh"
                )));
            }
            sphere = Sphere {
                centre: m.transform_point3(sphere.centre),
                radius: r * scale,
                rotation: linear * (1.0 / scale),
            };
        }
        let reach = sphere.centre.abs().max_element() + sphere.radius;
        if !(reach <= MAX_COORDINATE) {
            return Err(self.error(format!(
                "`{key}` reaches ±{reach:e}, beyond ±{MAX_COORDINATE:e}, the range of prism's \
                 single-precision geometry (after the transform)"
            )));
        }
        Ok(sphere)
    }

    /// Counts a mesh against the memory budget (until the scene is built).
    fn hold_mesh(&self, key: &str, mesh: &Mesh) -> Result<(), SceneError> {
        let bytes = mesh.heap_bytes();
        crate::memory::hold(&format!("`{key}`'s mesh"), bytes).map_err(|e| self.error(e))?;
        self.meshes_held.set(self.meshes_held.get() + bytes);
        Ok(())
    }

    /// A shape's `materials` table: asset material name → scene material.
    pub(super) fn overrides(
        &self,
        names: &Option<BTreeMap<String, String>>,
        key: &str,
        material_index: &BTreeMap<String, u32>,
        file: &SceneFile,
    ) -> Result<HashMap<String, u32>, SceneError> {
        let mut out = HashMap::new();
        for (asset_name, scene_name) in names.iter().flatten() {
            let index = material_index.get(scene_name).ok_or_else(|| {
                self.error(format!(
                    "`{key}.materials.{asset_name}`: no material named `{scene_name}` (defined: {})",
                    list(file.materials.keys())
                ))
            })?;
            out.insert(asset_name.clone(), *index);
        }
        Ok(out)
    }

    /// Reads an OBJ or glTF file once (later instances reuse it) and
    /// reports what it ignored.
    pub(super) fn asset(
        &self,
        path: &Path,
        kind: ShapeKind,
        smooth: bool,
        key: &str,
    ) -> Result<Rc<Asset>, SceneError> {
        if let Some(a) = self.assets.borrow().get(path) {
            return Ok(a.clone());
        }
        let textures = &mut self.textures.borrow_mut();
        let asset = match kind {
            ShapeKind::Obj => import::obj::load(path, smooth, textures),
            _ => import::gltf::load(path, textures),
        }
        .map_err(|e| self.error(format!("`{key}`: {}: {e}", path.display())))?;
        let mut warnings = self.warnings.borrow_mut();
        warnings.extend(asset.warnings.iter().cloned());
        if !asset.ignored.is_empty() {
            warnings.push(format!(
                "{}: not mapped, ignored: {}",
                path.display(),
                asset.ignored.join(", ")
            ));
        }
        for piece in &asset.pieces {
            self.hold_mesh(key, &piece.mesh)?;
        }
        let asset = Rc::new(asset);
        self.assets
            .borrow_mut()
            .insert(path.to_path_buf(), asset.clone());
        Ok(asset)
    }

    /// The meshes of an OBJ or glTF shape with their scene materials
    /// (`None`: the scene default) and emission.
    #[allow(clippy::type_complexity)]
    pub(super) fn asset_pieces(
        &self,
        shape: &AssetFile,
        key: &str,
        overrides: &HashMap<String, u32>,
        materials: &mut Vec<Material>,
        slots: &mut AssetMaterialSlots,
    ) -> Result<Vec<(Mesh, Option<u32>, Option<Emission>)>, SceneError> {
        let kind = if shape.kind == ShapeKind::Obj {
            "an OBJ"
        } else {
            "a glTF"
        };
        let path = self.input_file(shape.rel, &format!("{key}.file"))?;
        if path.is_dir() {
            return Err(self.error(format!(
                "`{key}.file`: {} is a directory, not {kind} file",
                path.display()
            )));
        }
        let asset = self.asset(&path, shape.kind, shape.smooth, &format!("{key}.file"))?;
        for name in overrides.keys() {
            if !asset.materials.iter().any(|m| &m.name == name) {
                let names: Vec<&String> = asset.materials.iter().map(|m| &m.name).collect();
                return Err(self.error(format!(
                    "`{key}.materials.{name}`: {} has no material `{name}` (it has: {})",
                    path.display(),
                    list(names.into_iter())
                )));
            }
        }
        let mut out = Vec::new();
        for piece in &asset.pieces {
            if shape.mesh.as_ref().is_some_and(|m| m != &piece.name) {
                continue;
            }
            let (material, emission) = match piece.material {
                None => (None, None),
                Some(i) => {
                    let m = &asset.materials[i];
                    let index = match overrides.get(&m.name) {
                        Some(&o) => o,
                        None => *slots.entry((path.clone(), i)).or_insert_with(|| {
                            materials.push(m.material.clone());
                            let index = materials.len() as u32 - 1;
                            if let Some(c) = &m.cutout {
                                self.cutouts.borrow_mut().insert(index, c.clone());
                            }
                            if m.single_sided {
                                self.single_sided.borrow_mut().insert(index);
                            }
                            index
                        }),
                    };
                    (Some(index), m.emission.clone())
                }
            };
            out.push((piece.mesh.clone(), material, emission));
        }
        if out.is_empty() {
            let mut names: Vec<&String> = asset.pieces.iter().map(|p| &p.name).collect();
            names.dedup();
            return Err(self.error(format!(
                "`{key}.mesh`: {} has no mesh `{}` (it has: {})",
                path.display(),
                shape.mesh.as_deref().unwrap_or(""),
                list(names.into_iter())
            )));
        }
        Ok(out)
    }

    /// Applies a shape's transform and winding flip, and checks the result.
    pub(super) fn place(
        &self,
        mesh: &mut Mesh,
        shape: &ShapeSpec,
        key: &str,
    ) -> Result<(), SceneError> {
        if let Some(t) = &shape.common.transform {
            mesh.transform(&self.transform(t, key)?);
        }
        if shape.common.flip_normals {
            mesh.flip();
        }
        let from = match &shape.geometry {
            ShapeGeometry::Obj(f) => format!(" ({})", self.base.join(&f.file).display()),
            ShapeGeometry::Gltf(f) => format!(" ({})", self.base.join(&f.file).display()),
            _ => String::new(),
        };
        if mesh.positions.iter().any(|p| !p.is_finite()) {
            return Err(self.error(format!(
                "`{key}`{from}: vertex positions are not finite (after the transform)"
            )));
        }
        // Single-precision geometry squares lengths (areas, distances to
        // lights): coordinates beyond this would overflow them.
        if let Some(p) = mesh
            .positions
            .iter()
            .find(|p| p.abs().max_element() > MAX_COORDINATE)
        {
            return Err(self.error(format!(
                "`{key}`{from}: vertex at {p} lies beyond ±{MAX_COORDINATE:e}, the range of prism's \
                 single-precision geometry (after the transform)"
            )));
        }
        Ok(())
    }

    /// The mesh of a built-in shape: a quad or a tessellated sphere.
    fn built_in_mesh(&self, geometry: &ShapeGeometry, key: &str) -> Result<Mesh, SceneError> {
        match geometry {
            ShapeGeometry::Quad(q) => Ok(Mesh::quad(q.vertices.map(Vec3::from))),
            ShapeGeometry::Sphere(sphere) => self.sphere_mesh(sphere, key),
            ShapeGeometry::Obj(_) | ShapeGeometry::Gltf(_) => Err(self.error(format!(
                "`{key}`: a shape of type `{}` is read from its file",
                geometry.kind().name()
            ))),
        }
    }

    /// A sphere as a triangle mesh.
    fn sphere_mesh(&self, spec: &SphereShape, key: &str) -> Result<Mesh, SceneError> {
        let r = spec.radius;
        if !(r > 0.0) {
            return Err(self.error(format!("`{key}.radius` must be positive")));
        }
        let segments = spec.segments.unwrap_or(64);
        if !(3..=MAX_SPHERE_SEGMENTS).contains(&segments) {
            return Err(self.error(format!(
                "`{key}.segments` must be between 3 and {MAX_SPHERE_SEGMENTS}, found {segments}"
            )));
        }
        crate::memory::check(
            &format!("`{key}` ({segments} segments)"),
            Mesh::sphere_bytes(segments),
        )
        .map_err(|e| self.error(e))?;
        Ok(Mesh::sphere(
            Vec3::from(spec.center.unwrap_or([0.0; 3])),
            r,
            segments,
            spec.smooth.unwrap_or(true),
        ))
    }

    pub(super) fn transform(&self, t: &TransformSpec, key: &str) -> Result<Mat4, SceneError> {
        let m = if let Some(m) = t.matrix {
            if t.scale.is_some() || t.rotate.is_some() || t.translate.is_some() {
                return Err(self.error(format!(
                    "`{key}.transform`: give `matrix` or scale/rotate/translate, not both"
                )));
            }
            Mat4::from_cols_array(&m).transpose()
        } else {
            let scale = match &t.scale {
                None => Vec3::ONE,
                Some(ScaleSpec::Uniform(s)) => Vec3::splat(*s),
                Some(ScaleSpec::PerAxis(s)) => Vec3::from(*s),
            };
            let rotation = match &t.rotate {
                None => Quat::IDENTITY,
                Some(r) => {
                    let axis = Vec3::from(r.axis);
                    if axis.length_squared() == 0.0 {
                        return Err(
                            self.error(format!("`{key}.transform.rotate.axis` must not be zero"))
                        );
                    }
                    Quat::from_axis_angle(axis.normalize(), r.degrees.to_radians())
                }
            };
            Mat4::from_scale_rotation_translation(
                scale,
                rotation,
                Vec3::from(t.translate.unwrap_or([0.0; 3])),
            )
        };
        let det = m.determinant();
        if !(det.abs() > 0.0) || !m.is_finite() {
            return Err(self.error(format!(
                "`{key}.transform` is singular: it would flatten the shape"
            )));
        }
        Ok(m)
    }
}
