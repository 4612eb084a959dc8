//! Scene file → runtime [`Scene`]: parse, validate, resolve names, spectra
//! and files. Every failure names the file and the key at fault.

use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use glam::{Mat4, Quat, Vec3};

use super::format::{MaterialSpec, ScaleSpec, SceneFile, ShapeKind, ShapeSpec, TransformSpec};
use super::import::{self, Asset, TextureCache};
use super::spectrum_spec::{IorSpec, SpectrumSpec};
use super::{Emission, Mesh, RenderSettings, Scene, ShapeInstance};
use crate::camera::{fov_from_focal_length, Camera};
use crate::material::microfacet::alpha_from_roughness;
use crate::material::{ior, metals, Ior, Material};
use crate::spectrum::{cie, csv, Spectrum, TabulatedSpectrum, LAMBDA_MAX, LAMBDA_MIN};
use crate::texture::{Encoding, TextureRef};

/// The largest vertex coordinate a scene may hold (see `Loader::place`).
const MAX_COORDINATE: f32 = 1e12;

/// Largest image side accepted.
const MAX_RESOLUTION: u32 = 32_768;
/// Largest film memory accepted (pixel sums and spectral buckets).
const MAX_FILM_BYTES: u64 = 16 << 30;
/// Finest built-in sphere tessellation accepted.
const MAX_SPHERE_SEGMENTS: u32 = 4096;

/// A scene that could not be loaded: which file, and what is wrong.
#[derive(Debug)]
pub struct SceneError {
    pub file: PathBuf,
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.file.display(), self.message)
    }
}

impl std::error::Error for SceneError {}

/// Loads a scene file; relative paths in it are relative to its folder.
pub fn load(path: &Path) -> Result<Scene, SceneError> {
    let err = |message: String| SceneError {
        file: path.to_path_buf(),
        message,
    };
    if path.is_dir() {
        return Err(err("is a directory, not a scene file".into()));
    }
    let text = std::fs::read_to_string(path)
        .map_err(|e| err(format!("cannot read the scene file: {e}")))?;
    let base = path.parent().unwrap_or(Path::new("."));
    Loader::new(path.to_path_buf(), base.to_path_buf()).load(&text)
}

/// Loads a scene from TOML text; `base` is the folder relative paths start from.
pub fn load_str(text: &str, base: &Path) -> Result<Scene, SceneError> {
    Loader::new(PathBuf::from("<scene>"), base.to_path_buf()).load(text)
}

struct Loader {
    scene_file: PathBuf,
    base: PathBuf,
    /// Images decoded so far, shared by every material that uses them.
    textures: RefCell<TextureCache>,
    /// OBJ and glTF files read so far: instances of one file read it once.
    assets: RefCell<HashMap<PathBuf, Rc<Asset>>>,
    warnings: RefCell<Vec<String>>,
}

/// Where an asset's materials went in the scene's list, per asset file.
type AssetMaterialSlots = HashMap<(PathBuf, usize), u32>;

/// Which physical quantity a spectrum stands for: it decides how RGB is
/// upsampled and which values are allowed.
#[derive(Clone, Copy, PartialEq)]
enum Role {
    Reflectance,
    Emission,
}

impl Loader {
    fn new(scene_file: PathBuf, base: PathBuf) -> Self {
        Self {
            scene_file,
            base,
            textures: RefCell::default(),
            assets: RefCell::default(),
            warnings: RefCell::default(),
        }
    }

    fn error(&self, message: impl Into<String>) -> SceneError {
        SceneError {
            file: self.scene_file.clone(),
            message: message.into(),
        }
    }

    fn load(&self, text: &str) -> Result<Scene, SceneError> {
        let value: toml::Table =
            toml::from_str(text).map_err(|e| self.error(with_suggestion(e.to_string())))?;
        if let Some(key) = first_non_finite(&toml::Value::Table(value), "") {
            return Err(self.error(format!(
                "`{key}` is not a finite number; numbers in a scene must be finite"
            )));
        }
        let file: SceneFile =
            toml::from_str(text).map_err(|e| self.error(with_suggestion(e.to_string())))?;

        let settings = self.settings(&file)?;
        let camera = self.camera(&file, &settings)?;

        let mut material_index = BTreeMap::new();
        let mut materials = Vec::new();
        for (name, spec) in &file.materials {
            let m = self.material(name, spec, &file)?;
            material_index.insert(name.clone(), materials.len() as u32);
            materials.push(m);
        }
        let default_material = materials.len() as u32;
        materials.push(Material::Diffuse {
            reflectance: Spectrum::Constant(0.5).into(),
        });

        let mut shapes = Vec::new();
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
                    Some(Emission {
                        spectrum: self
                            .spectrum(spec, Role::Emission, &file, &format!("{key}.emission"))?
                            .scaled(scale),
                        texture: None,
                        two_sided: shape.two_sided.unwrap_or(false),
                    })
                }
            };
            match shape.kind {
                ShapeKind::Obj | ShapeKind::Gltf => {
                    let overrides = self.overrides(shape, &key, &material_index, &file)?;
                    for (mut mesh, m, e) in
                        self.asset_pieces(shape, &key, &overrides, &mut materials, &mut slots)?
                    {
                        self.place(&mut mesh, shape, &key)?;
                        shapes.push(ShapeInstance {
                            mesh,
                            material: material.unwrap_or(m.unwrap_or(default_material)),
                            emission: emission.clone().or(e),
                        });
                    }
                }
                ShapeKind::Quad | ShapeKind::Sphere => {
                    let mut mesh = self.mesh(shape, &key)?;
                    self.place(&mut mesh, shape, &key)?;
                    shapes.push(ShapeInstance {
                        mesh,
                        material: material.unwrap_or(default_material),
                        emission,
                    });
                }
            }
        }
        let mut scene = Scene::build(camera, settings, materials, shapes);
        scene.warnings = self.warnings.take();
        Ok(scene)
    }

    /// A shape's `materials` table: asset material name → scene material.
    fn overrides(
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
    fn asset(
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
        let asset = Rc::new(asset);
        self.assets
            .borrow_mut()
            .insert(path.to_path_buf(), asset.clone());
        Ok(asset)
    }

    /// The meshes of an OBJ or glTF shape with their scene materials
    /// (`None`: the scene default) and emission.
    #[allow(clippy::type_complexity)]
    fn asset_pieces(
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
                            materials.len() as u32 - 1
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
    fn place(&self, mesh: &mut Mesh, shape: &ShapeSpec, key: &str) -> Result<(), SceneError> {
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
    fn only(&self, shape: &ShapeSpec, key: &str, allowed: &[&str]) -> Result<(), SceneError> {
        let given = [
            ("file", shape.file.is_some()),
            ("mesh", shape.mesh.is_some()),
            ("materials", shape.materials.is_some()),
            ("vertices", shape.vertices.is_some()),
            ("center", shape.center.is_some()),
            ("radius", shape.radius.is_some()),
            ("segments", shape.segments.is_some()),
            ("smooth", shape.smooth.is_some()),
        ];
        for (name, present) in given {
            if present && !allowed.contains(&name) {
                return Err(self.error(format!(
                    "`{key}.{name}` does not apply to a shape of type {:?}",
                    shape.kind
                )));
            }
        }
        Ok(())
    }

    fn material(
        &self,
        name: &str,
        spec: &MaterialSpec,
        file: &SceneFile,
    ) -> Result<Material, SceneError> {
        let key = format!("materials.{name}");
        let roughness_alpha = |r: f32| {
            if !(0.0..=1.0).contains(&r) {
                return Err(self.error(format!("`{key}.roughness` must lie in [0, 1], found {r}")));
            }
            Ok(alpha_from_roughness(r))
        };
        Ok(match spec {
            MaterialSpec::Diffuse {
                reflectance,
                texture,
            } => Material::Diffuse {
                reflectance: crate::material::Reflectance {
                    factor: self.spectrum(
                        reflectance,
                        Role::Reflectance,
                        file,
                        &format!("{key}.reflectance"),
                    )?,
                    texture: match texture {
                        None => None,
                        Some(rel) => {
                            let path = self.base.join(rel);
                            let t = self
                                .textures
                                .borrow_mut()
                                .file(&path, Encoding::SrgbColour)
                                .map_err(|e| self.error(format!("`{key}.texture`: {e}")))?;
                            Some(TextureRef::new(t))
                        }
                    },
                },
            },
            MaterialSpec::Conductor {
                metal,
                eta,
                k,
                roughness,
            } => {
                let (eta, k) = match (metal, eta, k) {
                    (Some(m), None, None) => metals::metal(m).ok_or_else(|| {
                        self.error(format!(
                            "`{key}.metal`: unknown metal `{m}` (known: {})",
                            metals::NAMES.join(", ")
                        ))
                    })?,
                    (None, Some(eta), Some(k)) => (
                        self.spectrum(eta, Role::Emission, file, &format!("{key}.eta"))?,
                        self.spectrum(k, Role::Emission, file, &format!("{key}.k"))?,
                    ),
                    _ => {
                        return Err(self.error(format!(
                            "`{key}`: give either `metal`, or both `eta` and `k`"
                        )))
                    }
                };
                Material::Conductor {
                    eta,
                    k,
                    alpha: roughness_alpha(*roughness)?,
                }
            }
            MaterialSpec::Dielectric {
                ior,
                roughness,
                priority,
            } => Material::Dielectric {
                ior: self.ior(ior, file, &format!("{key}.ior"))?,
                alpha: roughness_alpha(*roughness)?,
                priority: *priority,
            },
        })
    }

    fn ior(&self, spec: &IorSpec, file: &SceneFile, key: &str) -> Result<Ior, SceneError> {
        let ior = match spec {
            IorSpec::Constant(n) => Ior::Constant(*n),
            IorSpec::Named(name) => Ior::preset(name).ok_or_else(|| {
                let names: Vec<&str> = ior::PRESETS.iter().map(|p| p.0).collect();
                self.error(format!(
                    "`{key}`: unknown glass `{name}` (known: {})",
                    names.join(", ")
                ))
            })?,
            IorSpec::Cauchy([a, b]) => Ior::Cauchy { a: *a, b: *b },
            IorSpec::Abbe([nd, vd]) => {
                if !(*vd > 0.0) {
                    return Err(self.error(format!("`{key}`: the Abbe number must be positive")));
                }
                Ior::abbe(*nd, *vd)
            }
            IorSpec::Sellmeier { b, c } => {
                let (mut bb, mut cc) = ([0.0; 4], [0.0; 4]);
                bb[..b.len()].copy_from_slice(b);
                cc[..c.len()].copy_from_slice(c);
                Ior::Sellmeier { b: bb, c: cc }
            }
            IorSpec::Spectrum(s) => Ior::Table(self.spectrum(s, Role::Emission, file, key)?),
        };
        // The index must be a sensible positive number over the whole range.
        let worst = (0..=(LAMBDA_MAX - LAMBDA_MIN) as usize)
            .map(|i| ior.eval(LAMBDA_MIN + i as f32))
            .find(|n| !(n.is_finite() && *n >= 1e-3 && *n <= 100.0));
        if let Some(n) = worst {
            return Err(self.error(format!(
                "`{key}`: the index of refraction must be finite and between 0.001 and 100 over {LAMBDA_MIN}-{LAMBDA_MAX} nm, found {n}"
            )));
        }
        Ok(ior)
    }

    fn settings(&self, file: &SceneFile) -> Result<RenderSettings, SceneError> {
        let f = &file.film;
        let [width, height] = f.resolution;
        if width == 0 || height == 0 {
            return Err(self.error(format!(
                "`film.resolution` must be positive, found [{width}, {height}]"
            )));
        }
        if f.spp == 0 {
            return Err(self.error("`film.spp` must be at least 1"));
        }
        check_film_size(width, height, f.spectral_buckets).map_err(|e| self.error(e))?;
        check_spectral_layout(f.spectral_range, f.spectral_buckets)
            .map_err(|e| self.error(format!("`film.{e}")))?;
        Ok(RenderSettings {
            width,
            height,
            spp: f.spp,
            max_depth: f.max_depth,
            rr_depth: file.integrator.rr_depth,
            seed: f.seed,
            strategy: file.integrator.strategy,
            exposure: f.exposure,
            tonemap: f.tonemap,
            spectral_range: f.spectral_range,
            spectral_buckets: f.spectral_buckets,
            spectral_output: f.spectral,
        })
    }

    fn camera(&self, file: &SceneFile, s: &RenderSettings) -> Result<Camera, SceneError> {
        let c = &file.camera;
        if let Some(rel) = &c.from_file {
            return self.asset_camera(rel, file, s);
        }
        if c.name.is_some() {
            return Err(self.error("`camera.name` needs `camera.from_file`"));
        }
        let (Some(position), Some(look_at)) = (c.position, c.look_at) else {
            return Err(self.error(
                "`camera` needs `position` and `look_at` (or `from_file` with a glTF camera)",
            ));
        };
        let fov = match (c.fov, c.focal_length) {
            (Some(_), Some(_)) => {
                return Err(self.error("`camera`: give either `fov` or `focal_length`, not both"))
            }
            (Some(fov), None) => fov,
            (None, Some(f)) => {
                if f <= 0.0 || c.film_height <= 0.0 {
                    return Err(self
                        .error("`camera.focal_length` and `camera.film_height` must be positive"));
                }
                fov_from_focal_length(f, c.film_height)
            }
            (None, None) => 40.0,
        };
        if !(fov > 0.0 && fov < 180.0) {
            return Err(self.error(format!(
                "`camera.fov` must be between 0 and 180 degrees, found {fov}"
            )));
        }
        let (pos, at, up) = (Vec3::from(position), Vec3::from(look_at), Vec3::from(c.up));
        let forward = at - pos;
        if forward.length_squared() == 0.0 {
            return Err(self.error("`camera.look_at` must differ from `camera.position`"));
        }
        if pos.abs().max_element() > MAX_COORDINATE {
            return Err(self.error(format!(
                "`camera.position` {pos} lies beyond ±{MAX_COORDINATE:e}, the range of prism's single-precision geometry"
            )));
        }
        if forward.normalize().cross(up).length_squared() < 1e-12 {
            return Err(self.error("`camera.up` must not be parallel to the viewing direction"));
        }
        Ok(Camera::look_at(pos, at, up, fov, s.width, s.height))
    }

    /// The camera of a glTF file: the one called `camera.name`, or the first.
    fn asset_camera(
        &self,
        rel: &Path,
        file: &SceneFile,
        s: &RenderSettings,
    ) -> Result<Camera, SceneError> {
        let c = &file.camera;
        if c.position.is_some()
            || c.look_at.is_some()
            || c.fov.is_some()
            || c.focal_length.is_some()
        {
            return Err(self.error(
                "`camera.from_file` takes the whole camera from the file: drop position, look_at, fov and focal_length",
            ));
        }
        let path = self.base.join(rel);
        if !path.is_file() {
            return Err(self.error(format!(
                "`camera.from_file`: {} does not exist or is not a file",
                path.display()
            )));
        }
        let asset = self.asset(&path, ShapeKind::Gltf, true, "camera.from_file")?;
        let names: Vec<&String> = asset.cameras.iter().map(|c| &c.name).collect();
        let found = match &c.name {
            Some(name) => asset.cameras.iter().find(|cam| &cam.name == name),
            None => asset.cameras.first(),
        };
        let Some(cam) = found else {
            return Err(self.error(format!(
                "`camera.from_file`: {} has no {} (cameras: {})",
                path.display(),
                c.name
                    .as_ref()
                    .map_or("perspective camera".to_string(), |n| format!(
                        "camera `{n}`"
                    )),
                list(names.into_iter())
            )));
        };
        let finite = cam.position.is_finite() && cam.forward.is_finite() && cam.up.is_finite();
        if !finite || !(cam.forward.cross(cam.up).length_squared() >= 1e-12) {
            return Err(self.error(format!(
                "`camera.from_file`: {}: camera `{}` has a degenerate transform",
                path.display(),
                cam.name
            )));
        }
        if cam.position.abs().max_element() > MAX_COORDINATE {
            return Err(self.error(format!(
                "`camera.from_file`: {}: camera `{}` at {} lies beyond ±{MAX_COORDINATE:e}, the range of prism's single-precision geometry",
                path.display(),
                cam.name,
                cam.position
            )));
        }
        if !(cam.yfov > 0.0 && cam.yfov < 180.0) {
            return Err(self.error(format!(
                "`camera.from_file`: {}: camera `{}` has a field of view of {} degrees",
                path.display(),
                cam.name,
                cam.yfov
            )));
        }
        // Looking along the direction, not at position + forward: far from
        // the origin that sum rounds back to the position.
        Ok(Camera::looking(
            cam.position,
            cam.forward,
            cam.up,
            cam.yfov,
            s.width,
            s.height,
        ))
    }

    fn spectrum(
        &self,
        spec: &SpectrumSpec,
        role: Role,
        file: &SceneFile,
        key: &str,
    ) -> Result<Spectrum, SceneError> {
        let spectrum = match spec {
            SpectrumSpec::Named(name) => match file.spectra.get(name) {
                Some(SpectrumSpec::Named(inner)) => self.builtin(inner, role, key)?,
                Some(defined) => self.spectrum(defined, role, file, &format!("spectra.{name}"))?,
                None => self.builtin(name, role, key)?,
            },
            SpectrumSpec::Constant(c) => Spectrum::Constant(*c),
            SpectrumSpec::Table(rows) => {
                let (l, v): (Vec<f32>, Vec<f32>) = rows.iter().map(|r| (r[0], r[1])).unzip();
                self.table(l, v, key)?
            }
            SpectrumSpec::File { path, scale } => {
                let full = self.base.join(path);
                let text = std::fs::read_to_string(&full).map_err(|e| {
                    self.error(format!(
                        "`{key}`: cannot read spectrum file {}: {e}",
                        full.display()
                    ))
                })?;
                let t = csv::parse(&text)
                    .map_err(|e| self.error(format!("`{key}`: {}: {e}", full.display())))?;
                Spectrum::Table(TabulatedSpectrum::new(t.wavelengths, t.columns[0].clone()))
                    .scaled(*scale)
            }
            SpectrumSpec::Blackbody { kelvin, scale } => {
                if !(*kelvin > 0.0) {
                    return Err(
                        self.error(format!("`{key}`: blackbody temperature must be positive"))
                    );
                }
                normalised(Spectrum::Blackbody {
                    kelvin: *kelvin,
                    scale: 1.0,
                })
                .scaled(*scale)
            }
            SpectrumSpec::Rgb { rgb, scale } => {
                let rgb = Vec3::from(*rgb);
                if rgb.min_element() < 0.0 {
                    return Err(self.error(format!("`{key}`: RGB components must not be negative")));
                }
                match role {
                    Role::Reflectance => {
                        if rgb.max_element() > 1.0 {
                            return Err(self
                                .error(format!("`{key}`: a reflectance RGB must lie in [0, 1]")));
                        }
                        Spectrum::rgb_reflectance(rgb).scaled(*scale)
                    }
                    Role::Emission => Spectrum::rgb_emission(rgb).scaled(*scale),
                }
            }
        };
        self.check_range(&spectrum, role, key)?;
        Ok(spectrum)
    }

    /// A built-in illuminant, normalised to luminance Y = 1.
    fn builtin(&self, name: &str, role: Role, key: &str) -> Result<Spectrum, SceneError> {
        match cie::illuminant(name) {
            Some(t) if role == Role::Emission => Ok(normalised(Spectrum::Table(t.clone()))),
            Some(_) => Err(self.error(format!(
                "`{key}`: `{name}` is an illuminant, not a reflectance"
            ))),
            None => Err(self.error(format!(
                "`{key}`: unknown spectrum `{name}` (built-in: {}; or define it under [spectra])",
                cie::ILLUMINANT_NAMES.join(", ")
            ))),
        }
    }

    fn table(&self, l: Vec<f32>, v: Vec<f32>, key: &str) -> Result<Spectrum, SceneError> {
        if l.len() < 2 {
            return Err(self.error(format!(
                "`{key}`: a spectrum table needs at least two [nm, value] rows"
            )));
        }
        if let Some(w) = l.windows(2).find(|w| !(w[0] < w[1])) {
            return Err(self.error(format!(
                "`{key}`: wavelengths must increase ({} nm then {} nm)",
                w[0], w[1]
            )));
        }
        if l[0] <= 0.0 {
            return Err(self.error(format!("`{key}`: wavelengths must be positive")));
        }
        Ok(Spectrum::Table(TabulatedSpectrum::new(l, v)))
    }

    fn check_range(&self, s: &Spectrum, role: Role, key: &str) -> Result<(), SceneError> {
        let (lo, hi) = sampled_range(s);
        if lo < 0.0 {
            return Err(self.error(format!("`{key}`: spectrum values must not be negative")));
        }
        if role == Role::Reflectance && hi > 1.0 + 1e-6 {
            return Err(self.error(format!(
                "`{key}`: a reflectance must lie in [0, 1], found values up to {hi}"
            )));
        }
        Ok(())
    }

    /// The mesh of a built-in shape (quad or sphere).
    fn mesh(&self, shape: &ShapeSpec, key: &str) -> Result<Mesh, SceneError> {
        let missing = |name: &str| {
            self.error(format!(
                "`{key}`: a shape of type {:?} needs `{name}`",
                shape.kind
            ))
        };
        Ok(match shape.kind {
            ShapeKind::Quad => {
                self.only(shape, key, &["vertices"])?;
                let v = shape.vertices.ok_or_else(|| missing("vertices"))?;
                Mesh::quad(v.map(Vec3::from))
            }
            _ => {
                self.only(shape, key, &["center", "radius", "segments", "smooth"])?;
                let r = shape.radius.ok_or_else(|| missing("radius"))?;
                if !(r > 0.0) {
                    return Err(self.error(format!("`{key}.radius` must be positive")));
                }
                let segments = shape.segments.unwrap_or(64);
                if !(3..=MAX_SPHERE_SEGMENTS).contains(&segments) {
                    return Err(self.error(format!(
                        "`{key}.segments` must be between 3 and {MAX_SPHERE_SEGMENTS}, found {segments}"
                    )));
                }
                Mesh::sphere(
                    Vec3::from(shape.center.unwrap_or([0.0; 3])),
                    r,
                    segments,
                    shape.smooth.unwrap_or(true),
                )
            }
        })
    }

    fn transform(&self, t: &TransformSpec, key: &str) -> Result<Mat4, SceneError> {
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

/// Checks that a film fits: at most 32768 pixels a side and 16 GiB of sums.
pub fn check_film_size(width: u32, height: u32, buckets: u32) -> Result<(), String> {
    if width > MAX_RESOLUTION || height > MAX_RESOLUTION {
        return Err(format!(
            "`film.resolution` [{width}, {height}] is larger than {MAX_RESOLUTION} pixels on a side"
        ));
    }
    let film_bytes = width as u64 * height as u64 * (48 + 4 * buckets as u64);
    if film_bytes > MAX_FILM_BYTES {
        return Err(format!(
            "the film ({width}x{height} pixels, {buckets} spectral buckets) would need {:.1} GiB: use fewer pixels or buckets",
            film_bytes as f64 / (1u64 << 30) as f64
        ));
    }
    Ok(())
}

/// Checks a film's spectral bucket layout; the message starts with the key.
pub fn check_spectral_layout(range: [f32; 2], buckets: u32) -> Result<(), String> {
    let [lo, hi] = range;
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lo)
        || !(LAMBDA_MIN..=LAMBDA_MAX).contains(&hi)
        || lo >= hi
    {
        return Err(format!(
            "spectral_range` must be an increasing pair within [{LAMBDA_MIN}, {LAMBDA_MAX}] nm, found [{lo}, {hi}]"
        ));
    }
    if buckets == 0 || buckets > 4096 {
        return Err(format!(
            "spectral_buckets` must be between 1 and 4096, found {buckets}"
        ));
    }
    Ok(())
}

/// Scales an illuminant so that its luminance (CIE Y, as the film computes it) is 1.
fn normalised(s: Spectrum) -> Spectrum {
    let y = cie::spectrum_to_xyz(&s).y;
    if y > 0.0 {
        s.scaled(1.0 / y)
    } else {
        s
    }
}

/// Smallest and largest value of a spectrum over the rendered range.
fn sampled_range(s: &Spectrum) -> (f32, f32) {
    (0..=(LAMBDA_MAX - LAMBDA_MIN) as usize)
        .map(|i| s.eval(LAMBDA_MIN + i as f32))
        .chain(match s {
            Spectrum::Table(t) => t.values().to_vec(),
            _ => vec![],
        })
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
}

fn list<'a>(names: impl Iterator<Item = &'a String>) -> String {
    let v: Vec<&str> = names.map(String::as_str).collect();
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

/// Adds "did you mean `spp`?" to serde's "unknown field `samples`, expected
/// one of ..." (and "unknown variant") when one of the expected names is close.
fn with_suggestion(message: String) -> String {
    let Some(start) = message
        .find("unknown field `")
        .or_else(|| message.find("unknown variant `"))
    else {
        return message;
    };
    let rest = &message[start..];
    let Some(open) = rest.find('`') else {
        return message;
    };
    let Some(close) = rest[open + 1..].find('`') else {
        return message;
    };
    let unknown = &rest[open + 1..open + 1 + close];
    let Some(expected) = rest.find("expected") else {
        return message;
    };
    let candidates: Vec<&str> = rest[expected..]
        .split('`')
        .skip(1)
        .step_by(2)
        .take_while(|c| !c.contains('\n'))
        .collect();
    let best = candidates
        .iter()
        .map(|c| {
            (
                edit_distance(&unknown.to_lowercase(), &c.to_lowercase()),
                *c,
            )
        })
        .min();
    match best {
        Some((d, c)) if d > 0 && d <= 2.max(unknown.len() / 3) => {
            format!("{message}\ndid you mean `{c}`?")
        }
        _ => message,
    }
}

/// Levenshtein distance.
fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for j in 0..b.len() {
            let cur = row[j + 1];
            row[j + 1] = (prev + (ca != b[j]) as usize).min(row[j] + 1).min(cur + 1);
            prev = cur;
        }
    }
    row[b.len()]
}

/// The dotted key of the first NaN or infinite number in a TOML value.
fn first_non_finite(v: &toml::Value, key: &str) -> Option<String> {
    match v {
        toml::Value::Float(f) if !f.is_finite() => Some(key.to_string()),
        toml::Value::Table(t) => t.iter().find_map(|(k, v)| {
            let sub = if key.is_empty() {
                k.clone()
            } else {
                format!("{key}.{k}")
            };
            first_non_finite(v, &sub)
        }),
        toml::Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, v)| first_non_finite(v, &format!("{key}[{i}]"))),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggestions_for_near_misses_only() {
        let m = "TOML parse error at line 5, column 1\n  |\n5 | spq = 4\n  | ^^^\nunknown field `spq`, expected one of `resolution`, `spp`, `max_depth`\n".to_string();
        assert!(with_suggestion(m).ends_with("did you mean `spp`?"));
        let m = "unknown field `zzzzzz`, expected one of `resolution`, `spp`".to_string();
        assert!(!with_suggestion(m).contains("did you mean"));
        let m =
            "unknown variant `dielectirc`, expected one of `diffuse`, `conductor`, `dielectric`"
                .to_string();
        assert!(with_suggestion(m).ends_with("did you mean `dielectric`?"));
        assert_eq!(edit_distance("kitten", "sitting"), 3);
    }
}
