//! Shapes: built-in quads and spheres, OBJ and glTF files (read once per
//! file, instanced), their transforms and material overrides.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;
use std::rc::Rc;

use glam::{Mat4, Quat, Vec3};

use super::spectra::Role;
use super::{list, AssetMaterialSlots, Loader, MAX_COORDINATE};
use crate::geometry::sphere::Sphere;
use crate::load::format::{ScaleSpec, SceneFile, ShapeKind, ShapeSpec, TransformSpec};
use crate::load::import::{self, Asset};
use crate::load::SceneError;
use crate::material::Material;
use crate::scene::{Emission, Mesh, ShapeInstance, SphereInstance};

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
            let material = match &shape.material {
                None => None,
                Some(name) => Some(*material_index.get(name).ok_or_else(|| {
                    self.error(format!(
                        "`{key}.material`: no material named `{name}` (defined: {})",
                        list(file.materials.keys())
                    ))
                })?),
            };
            let emission = match &shape.emission {
                None => {
                    if shape.emission_scale.is_some() || shape.two_sided.is_some() {
                        return Err(self.error(format!(
                            "`{key}`: `emission_scale` and `two_sided` need `emission`"
                        )));
                    }
                    None
                }
                Some(spec) => {
                    let scale = shape.emission_scale.unwrap_or(1.0);
                    if scale < 0.0 {
                        return Err(
                            self.error(format!("`{key}.emission_scale` must not be negative"))
                        );
                    }
                    let spectrum = self
                        .spectrum(spec, Role::Emission, file, &format!("{key}.emission"))?
                        .scaled(scale);
                    Some(Emission {
                        spectrum: self.checked_emission(spectrum, &format!("{key}.emission"))?,
                        texture: None,
                        two_sided: shape.two_sided.unwrap_or(false),
                    })
                }
            };
            match shape.kind {
                ShapeKind::Obj | ShapeKind::Gltf => {
                    let overrides = self.overrides(shape, &key, material_index, file)?;
                    for (mut mesh, m, e) in
                        self.asset_pieces(shape, &key, &overrides, materials, &mut slots)?
                    {
                        self.place(&mut mesh, shape, &key)?;
                        self.hold_mesh(&key, &mesh)?;
                        shapes.push(ShapeInstance {
                            mesh,
                            material: material.unwrap_or(m.unwrap_or(default_material)),
                            emission: emission.clone().or(e),
                        });
                    }
                }
                ShapeKind::Sphere if shape.tessellate != Some(true) => {
                    spheres.push(SphereInstance {
                        sphere: self.exact_sphere(shape, &key)?,
                        material: material.unwrap_or(default_material),
                        emission,
                        inward: shape.flip_normals,
                    });
                }
                ShapeKind::Quad | ShapeKind::Sphere => {
                    let mut mesh = self.built_in_mesh(shape, &key)?;
                    self.place(&mut mesh, shape, &key)?;
                    self.hold_mesh(&key, &mesh)?;
                    shapes.push(ShapeInstance {
                        mesh,
                        material: material.unwrap_or(default_material),
                        emission,
                    });
                }
            }
        }
        Ok((shapes, spheres))
    }

    /// An exact sphere: its centre and radius placed by the shape's
    /// transform, which must keep it a sphere (rotation, uniform scale,
    /// translation).
    fn exact_sphere(&self, shape: &ShapeSpec, key: &str) -> Result<Sphere, SceneError> {
        let kind = "an exact sphere (`tessellate = true` makes a triangle mesh, which takes `segments` and `smooth`)";
        let given = self.given_keys(shape);
        self.only_keys(key, kind, &given, &["center", "radius", "tessellate"])?;
        let Some(r) = shape.radius else {
            return Err(self.error(format!("`{key}`: a sphere needs `radius`")));
        };
        if !(r > 0.0 && r.is_finite()) {
            return Err(self.error(format!("`{key}.radius` must be positive")));
        }
        let mut sphere = Sphere::new(Vec3::from(shape.center.unwrap_or([0.0; 3])), r);
        if let Some(t) = &shape.transform {
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
        shape: &ShapeSpec,
        key: &str,
        material_index: &BTreeMap<String, u32>,
        file: &SceneFile,
    ) -> Result<HashMap<String, u32>, SceneError> {
        let mut out = HashMap::new();
        for (asset_name, scene_name) in shape.materials.iter().flatten() {
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
        shape: &ShapeSpec,
        key: &str,
        overrides: &HashMap<String, u32>,
        materials: &mut Vec<Material>,
        slots: &mut AssetMaterialSlots,
    ) -> Result<Vec<(Mesh, Option<u32>, Option<Emission>)>, SceneError> {
        let allowed = ["file", "smooth", "mesh", "materials"];
        self.only(shape, key, &allowed)?;
        let kind = if shape.kind == ShapeKind::Obj {
            "an OBJ"
        } else {
            "a glTF"
        };
        let rel = shape.file.as_ref().ok_or_else(|| {
            self.error(format!(
                "`{key}`: a shape of type {:?} needs `file`",
                shape.kind
            ))
        })?;
        let path = self.base.join(rel);
        if path.is_dir() {
            return Err(self.error(format!(
                "`{key}.file`: {} is a directory, not {kind} file",
                path.display()
            )));
        }
        if !path.exists() {
            return Err(self.error(format!("`{key}.file`: {} does not exist", path.display())));
        }
        let smooth = shape.smooth.unwrap_or(true);
        let asset = self.asset(&path, shape.kind, smooth, &format!("{key}.file"))?;
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
        if let Some(t) = &shape.transform {
            mesh.transform(&self.transform(t, key)?);
        }
        if shape.flip_normals {
            mesh.flip();
        }
        let from = shape.file.as_ref().map_or(String::new(), |f| {
            format!(" ({})", self.base.join(f).display())
        });
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

    /// Rejects keys that do not apply to the shape's type.
    pub(super) fn only(
        &self,
        shape: &ShapeSpec,
        key: &str,
        allowed: &[&str],
    ) -> Result<(), SceneError> {
        let kind = format!("a shape of type {:?}", shape.kind);
        self.only_keys(key, &kind, &self.given_keys(shape), allowed)
    }

    /// Which of the keys that apply to some shape types only were given.
    fn given_keys(&self, shape: &ShapeSpec) -> [(&'static str, bool); 9] {
        [
            ("file", shape.file.is_some()),
            ("mesh", shape.mesh.is_some()),
            ("materials", shape.materials.is_some()),
            ("vertices", shape.vertices.is_some()),
            ("center", shape.center.is_some()),
            ("radius", shape.radius.is_some()),
            ("segments", shape.segments.is_some()),
            ("smooth", shape.smooth.is_some()),
            ("tessellate", shape.tessellate.is_some()),
        ]
    }

    /// The mesh of a built-in shape: a quad or a sphere.
    fn built_in_mesh(&self, shape: &ShapeSpec, key: &str) -> Result<Mesh, SceneError> {
        let missing = |name: &str| {
            self.error(format!(
                "`{key}`: a shape of type {:?} needs `{name}`",
                shape.kind
            ))
        };
        match shape.kind {
            ShapeKind::Quad => {
                self.only(shape, key, &["vertices"])?;
                let v = shape.vertices.ok_or_else(|| missing("vertices"))?;
                Ok(Mesh::quad(v.map(Vec3::from)))
            }
            ShapeKind::Sphere => {
                self.only(
                    shape,
                    key,
                    &["center", "radius", "segments", "smooth", "tessellate"],
                )?;
                let r = shape.radius.ok_or_else(|| missing("radius"))?;
                self.sphere_mesh(shape, key, r)
            }
            ShapeKind::Obj | ShapeKind::Gltf => Err(self.error(format!(
                "`{key}`: a shape of type {:?} is read from its file",
                shape.kind
            ))),
        }
    }

    /// A sphere of radius `r` as a triangle mesh.
    fn sphere_mesh(&self, shape: &ShapeSpec, key: &str, r: f32) -> Result<Mesh, SceneError> {
        if !(r > 0.0) {
            return Err(self.error(format!("`{key}.radius` must be positive")));
        }
        let segments = shape.segments.unwrap_or(64);
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
            Vec3::from(shape.center.unwrap_or([0.0; 3])),
            r,
            segments,
            shape.smooth.unwrap_or(true),
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
