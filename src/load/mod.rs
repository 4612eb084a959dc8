//! Scene file → the runtime [`Scene`], the [`RenderSettings`] the file
//! asks for, and a [`LoadReport`]: parse, apply the command line's
//! overrides, validate, resolve names, spectra and files. Every failure
//! names the file and the key at fault. One submodule per part of the file;
//! `format` is the file's schema, `import` reads OBJ and glTF assets.

mod camera;
mod exact;
mod film;
mod fluorescence;
pub mod format;
pub mod import;
mod lights;
mod materials;
mod media;
mod messages;
mod shapes;
mod spectra;
pub mod spectrum_spec;

pub use spectra::spectrum;

use std::cell::{Cell, RefCell};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;

use crate::film::{Gamut, Tonemap};
use crate::integrator::{IntegratorKind, Strategy};
use crate::material::{Cutout, Material};
use crate::render::{RenderOptions, RenderSettings};
use crate::scene::{Scene, SceneGeometry};
use crate::spectrum::Spectrum;
use format::SceneFile;
use import::{Asset, TextureCache};
use messages::{in_typed_table, with_suggestion};

/// The largest vertex coordinate a scene may hold (see `Loader::place`).
const MAX_COORDINATE: f32 = 1e12;

/// A scene that could not be loaded: which file, and what is wrong.
#[derive(Debug, thiserror::Error)]
#[error("{}: {message}", file.display())]
pub struct SceneError {
    pub file: PathBuf,
    pub message: String,
}

/// Values that replace the scene file's before the scene is built (the
/// command line's flags), so that they pass the same checks as the file's.
#[derive(Clone, Debug, Default)]
pub struct Overrides {
    pub resolution: Option<(u32, u32)>,
    pub spectral_range: Option<[f32; 2]>,
    pub spectral_buckets: Option<u32>,
    pub no_spectral: bool,
    pub exposure: Option<f32>,
    pub tonemap: Option<Tonemap>,
    pub gamut: Option<Gamut>,
    pub strategy: Option<Strategy>,
    pub integrator: Option<IntegratorKind>,
    pub split: Option<u32>,
}

impl Overrides {
    /// Writes the overrides into the parsed file, adding to `set` the keys
    /// they set with the flag that set each (for error messages). Returns
    /// the keys of the file's integrator that the one `--integrator`
    /// chose does not take: they are dropped.
    fn apply(
        &self,
        file: &mut SceneFile,
        set: &mut Vec<(&'static str, &'static str)>,
    ) -> Result<Vec<String>, String> {
        if let Some((w, h)) = self.resolution {
            file.film.resolution = [w, h];
            set.push(("film.resolution", "--resolution"));
        }
        if let Some(r) = self.spectral_range {
            file.film.spectral_range = r;
            set.push(("film.spectral_range", "--spectral-range"));
        }
        if let Some(n) = self.spectral_buckets {
            file.film.spectral_buckets = n;
            set.push(("film.spectral_buckets", "--spectral-buckets"));
        }
        if self.no_spectral {
            file.film.spectral = false;
        }
        if let Some(e) = self.exposure {
            file.film.exposure = e;
            set.push(("film.exposure", "--exposure"));
        }
        if let Some(t) = self.tonemap {
            file.film.tonemap = t;
        }
        if let Some(g) = self.gamut {
            file.film.gamut = g;
        }
        let mut dropped = Vec::new();
        if let Some(kind) = self.integrator.filter(|&k| k != file.integrator.kind()) {
            dropped = file.integrator.switch_to(kind)?;
        }
        if let Some(s) = self.strategy {
            set.push(("integrator.strategy", "--strategy"));
            let name = toml::Value::try_from(s).map_err(|e| e.to_string())?;
            file.integrator.set("strategy", name)?;
        }
        if let Some(n) = self.split {
            set.push(("integrator.split", "--split"));
            file.integrator.set("split", i64::from(n))?;
        }
        Ok(dropped)
    }
}

/// A loaded scene file: the scene, how the file asks for it to be
/// rendered, and what loading found.
pub struct Loaded {
    pub scene: Scene,
    pub settings: RenderSettings,
    pub report: LoadReport,
    /// The built shapes, for a later load of an edited scene to reuse.
    shapes: Arc<BuiltShapes>,
}

/// What building a scene's shapes made, kept so that a load of the same
/// shapes (an edit of materials, lights, camera or film: `load_text` with
/// `previous`) reuses it instead of reading meshes and building a BVH.
struct BuiltShapes {
    /// Everything the shapes depend on (see `shapes_key`).
    key: String,
    geometry: Arc<SceneGeometry>,
    /// Materials the assets defined, after the scene's own and the default.
    asset_materials: Vec<Material>,
    cutouts: HashMap<u32, Cutout>,
    /// Materials whose back faces the camera does not see.
    single_sided: std::collections::HashSet<u32>,
    warnings: Vec<String>,
    /// Files the shapes were read from, with their hashes.
    inputs: Vec<(PathBuf, u64)>,
    /// Bytes the BVH build holds for a while (beside the loaded scene).
    build_bytes: u64,
}

/// What loading found beside the scene.
#[derive(Clone, Debug, Default)]
pub struct LoadReport {
    /// Problems that did not stop the load (printed by the command line).
    pub warnings: Vec<String>,
    /// Every file the scene was loaded from (the scene file first), with a
    /// hash of its bytes: what a partial render must share to be merged.
    pub inputs: Vec<(PathBuf, u64)>,
    /// Bytes held at the peak of loading (estimated: images, meshes and
    /// the BVH build).
    pub peak_bytes: u64,
}

impl LoadReport {
    /// Identifies what the scene was loaded from: the scene file and every
    /// file it read (meshes, materials, textures, buffers, spectra, maps),
    /// by content. Partial renders must share it to be merged; the bench
    /// keys its cached references by it.
    pub fn content_hash(&self) -> String {
        let bytes: Vec<u8> = self
            .inputs
            .iter()
            .flat_map(|(_, hash)| hash.to_le_bytes())
            .collect();
        crate::merge::scene_hash(&bytes)
    }
}

/// Loads a scene file; relative paths in it are relative to its folder.
pub fn load(path: &Path) -> Result<Loaded, SceneError> {
    load_with(path, &Overrides::default())
}

/// Loads a scene file with some of its values replaced.
pub fn load_with(path: &Path, overrides: &Overrides) -> Result<Loaded, SceneError> {
    let text = read_scene_file(path)?;
    let base = path.parent().unwrap_or(Path::new("."));
    load_text(&text, path, base, overrides, None)
}

/// The text of a scene file (within the input limits), or an error naming it.
pub fn read_scene_file(path: &Path) -> Result<String, SceneError> {
    let err = |message: String| SceneError {
        file: path.to_path_buf(),
        message,
    };
    if path.is_dir() {
        return Err(err("is a directory, not a scene file".into()));
    }
    crate::input::read_to_string(path).map_err(|e| err(format!("the scene file: {e}")))
}

/// Loads a scene from TOML text; `base` is the folder relative paths start from.
pub fn load_str(text: &str, base: &Path) -> Result<Loaded, SceneError> {
    load_text(
        text,
        Path::new("<scene>"),
        base,
        &Overrides::default(),
        None,
    )
}

/// Loads a scene from TOML text that errors call `name`; relative paths
/// start at `base`. Where `previous` (an earlier load) has the same shapes
/// (the same `[[shape]]` tables, `[spectra]`, `units`, material names and
/// `base`), its built geometry and imported materials are shared, not read
/// and built again: an edit of materials, lights, camera or film loads in
/// the time those take. Files are not read again then, so an edit of a
/// mesh on disk needs a load without `previous`.
pub fn load_text(
    text: &str,
    name: &Path,
    base: &Path,
    overrides: &Overrides,
    previous: Option<&Loaded>,
) -> Result<Loaded, SceneError> {
    let (scene, mut inputs) = crate::input::recording(|| {
        Loader::new(name.to_path_buf(), base.to_path_buf()).load(text, overrides, previous)
    });
    let mut loaded = scene?;
    inputs.insert(
        0,
        (
            name.to_path_buf(),
            crate::input::content_hash(text.as_bytes()),
        ),
    );
    loaded.report.inputs = inputs;
    Ok(loaded)
}

/// What a scene's shapes depend on, as text: two loads with equal keys
/// build the same geometry and asset materials.
fn shapes_key(value: &toml::Value, file: &SceneFile, base: &Path) -> String {
    let mut key = toml::Table::new();
    for part in ["shape", "spectra", "units"] {
        if let Some(v) = value.get(part) {
            key.insert(part.into(), v.clone());
        }
    }
    // A shape's emission is not geometry: an edit of it replaces the
    // lights of the shared geometry. Whether the shape emits is.
    if let Some(toml::Value::Array(shapes)) = key.get_mut("shape") {
        for shape in shapes.iter_mut().filter_map(toml::Value::as_table_mut) {
            let emits = shape.remove("emission").is_some();
            shape.remove("emission_scale");
            shape.remove("two_sided");
            shape.insert("emits".into(), toml::Value::Boolean(emits));
        }
    }
    let names = file.materials.keys().cloned().map(toml::Value::String);
    key.insert("material names".into(), toml::Value::Array(names.collect()));
    key.insert(
        "base".into(),
        toml::Value::String(base.display().to_string()),
    );
    toml::Value::Table(key).to_string()
}

struct Loader {
    scene_file: PathBuf,
    base: PathBuf,
    /// Images decoded so far, shared by every material that uses them.
    textures: RefCell<TextureCache>,
    /// OBJ and glTF files read so far: instances of one file read it once.
    assets: RefCell<HashMap<PathBuf, Rc<Asset>>>,
    warnings: RefCell<Vec<String>>,
    /// Cut-outs of imported materials, by scene material index.
    cutouts: RefCell<HashMap<u32, Cutout>>,
    single_sided: RefCell<std::collections::HashSet<u32>>,
    /// Keys set by the command line, and the flag that set each.
    overridden: RefCell<Vec<(&'static str, &'static str)>>,
    /// Bytes of meshes counted against the memory budget: they are gone
    /// once the scene is built.
    meshes_held: Cell<u64>,
}

/// Where an asset's materials went in the scene's list, per asset file.
type AssetMaterialSlots = HashMap<(PathBuf, usize), u32>;

impl Loader {
    fn new(scene_file: PathBuf, base: PathBuf) -> Self {
        Self {
            scene_file,
            base,
            textures: RefCell::default(),
            assets: RefCell::default(),
            warnings: RefCell::default(),
            cutouts: RefCell::default(),
            single_sided: RefCell::default(),
            overridden: RefCell::default(),
            meshes_held: Cell::new(0),
        }
    }

    /// An error naming the scene file; a key that the command line set is
    /// named with its flag.
    fn error(&self, message: impl Into<String>) -> SceneError {
        let mut message = message.into();
        for (key, flag) in self.overridden.borrow().iter() {
            if message.contains(&format!("`{key}`")) {
                message = format!("{message} (set by {flag})");
            }
        }
        SceneError {
            file: self.scene_file.clone(),
            message,
        }
    }

    /// A file the scene names (`key`), relative to the scene file's folder.
    /// One that is not there is an error that shows where it was looked
    /// for, so that a path written relative to the wrong folder is plain.
    fn input_file(&self, rel: &Path, key: &str) -> Result<PathBuf, SceneError> {
        let path = self.base.join(rel);
        if path.exists() {
            return Ok(path);
        }
        let folder = if self.base.as_os_str().is_empty() {
            Path::new(".")
        } else {
            self.base.as_path()
        };
        Err(self.error(if rel.is_absolute() {
            format!("`{key}`: {} does not exist", rel.display())
        } else {
            format!(
                "`{key}`: {} does not exist (looked for {}: relative paths start at the scene \
                 file's folder, {})",
                rel.display(),
                path.display(),
                folder.display()
            )
        }))
    }

    fn warn(&self, message: impl Into<String>) {
        self.warnings.borrow_mut().push(message.into());
    }

    /// Loads the scene, tallying what its inputs hold against the memory
    /// budget; the scene keeps the bytes of its images.
    fn load(
        &self,
        text: &str,
        overrides: &Overrides,
        previous: Option<&Loaded>,
    ) -> Result<Loaded, SceneError> {
        let (loaded, held) =
            crate::memory::tallying(None, || self.load_scene(text, overrides, previous));
        let mut loaded = loaded?;
        loaded.scene.image_bytes = held.saturating_sub(self.meshes_held.get());
        Ok(loaded)
    }

    fn load_scene(
        &self,
        text: &str,
        overrides: &Overrides,
        previous: Option<&Loaded>,
    ) -> Result<Loaded, SceneError> {
        let value = toml::Value::Table(
            toml::from_str(text).map_err(|e| self.error(with_suggestion(e.to_string())))?,
        );
        if let Some((key, v)) = first_non_finite(&value, "") {
            return Err(self.error(if v.is_finite() {
                format!(
                    "`{key}` = {v:e} is beyond single precision (±{:e}), which prism computes in",
                    f32::MAX
                )
            } else {
                format!("`{key}` is not a finite number; numbers in a scene must be finite")
            }));
        }
        let mut file: SceneFile = toml::from_str(text)
            .map_err(|e| self.error(with_suggestion(in_typed_table(text, e.to_string()))))?;
        let mut set = Vec::new();
        let dropped = overrides.apply(&mut file, &mut set);
        *self.overridden.borrow_mut() = set;
        let dropped = dropped.map_err(|e| self.error(e))?;
        // The file's parameters for its own integrator do not apply to the
        // one the command line chose.
        for key in dropped {
            self.warn(format!(
                "`integrator.{key}` does not apply to `{}` (chosen by --integrator): ignored",
                file.integrator.kind().name()
            ));
        }

        self.add_measured_materials(&mut file)?;
        let film = self.film(&file)?;
        let integrator = self.integrator(&mut file)?;
        let camera = self.camera(&file, &film)?;
        // What the integrator's loop cannot do with this camera and film
        // is refused now, naming the file, rather than when rendering.
        integrator
            .as_integrate()
            .check(&camera, &film, &RenderOptions::new(&film))
            .map_err(|e| self.error(e.to_string()))?;

        let mut material_index = BTreeMap::new();
        let mut materials = Vec::new();
        for (name, spec) in &file.materials {
            let m = self.material(name, spec, &file)?;
            material_index.insert(name.clone(), materials.len() as u32);
            materials.push(m);
        }
        // Only camera paths follow fluorescence: refused now, naming the file.
        if materials.iter().any(Material::is_fluorescent) && !integrator.handles_fluorescence() {
            return Err(
                self.error(crate::drive::RenderError::Fluorescence(integrator.name()).to_string())
            );
        }
        let default_material = materials.len() as u32;
        materials.push(Material::Diffuse {
            reflectance: Spectrum::Constant(0.5).into(),
        });
        let key = shapes_key(&value, &file, &self.base);
        // The BVH build's transient memory, where it runs this time.
        let (built, build_bytes, reused) = match previous.filter(|p| p.shapes.key == key) {
            Some(p) => {
                crate::input::record(&p.shapes.inputs);
                (p.shapes.clone(), 0, true)
            }
            None => {
                let built =
                    self.build_shapes(key, &file, &material_index, &materials, default_material)?;
                let bytes = built.build_bytes;
                (Arc::new(built), bytes, false)
            }
        };
        materials.extend(built.asset_materials.iter().cloned());
        // Imported assets give media per metre (glTF's unit): per scene unit.
        let units = self.units(&file)?;
        for m in &mut materials[default_material as usize + 1..] {
            m.scale_medium(units);
        }
        let lights = self.lights(&file)?;
        let world_medium = match &file.medium {
            Some(spec) => Some(self.medium(spec, &file, "medium")?),
            None => None,
        };
        // Decoders' buffers (textures, maps) on top of what was held then,
        // or what is held now and the BVH build's.
        let load_peak = crate::memory::peak().max(crate::memory::held() + build_bytes);
        let scene = Scene::assemble(
            camera,
            materials,
            built.geometry.clone(),
            self.surface_lights(&built, reused, &file)?,
            lights,
        )
        .with_world_medium(world_medium)
        .with_cutouts(built.cutouts.clone())
        .with_single_sided(&built.single_sided);
        if scene.lights.is_empty() {
            self.warn(
                "the scene has no light (no shape with `emission`, no [[light]], no [environment]) \
                 or none that emits: the image will be black",
            );
        }
        let mut warnings = built.warnings.clone();
        warnings.append(&mut self.textures.borrow_mut().warnings.split_off(0));
        warnings.append(&mut self.warnings.take());
        Ok(Loaded {
            scene,
            settings: RenderSettings { integrator, film },
            report: LoadReport {
                warnings,
                inputs: Vec::new(),
                peak_bytes: load_peak,
            },
            shapes: built,
        })
    }

    /// The emitting surfaces of the built geometry; where the geometry is
    /// shared with an earlier load, with this file's emission (edited
    /// since, maybe).
    fn surface_lights(
        &self,
        built: &BuiltShapes,
        reused: bool,
        file: &SceneFile,
    ) -> Result<Vec<crate::light::Light>, SceneError> {
        if !reused {
            return Ok(built.geometry.surface_lights().to_vec());
        }
        let emission: Result<Vec<_>, _> = (file.shapes.iter().enumerate())
            .map(|(i, shape)| self.shape_emission(i, shape, file))
            .collect();
        Ok(built.geometry.surface_lights_with(&emission?))
    }

    /// Reads the shapes' meshes and builds the geometry: the BVH, and
    /// the materials the assets define (after `materials`).
    fn build_shapes(
        &self,
        key: String,
        file: &SceneFile,
        material_index: &BTreeMap<String, u32>,
        materials: &[Material],
        default_material: u32,
    ) -> Result<BuiltShapes, SceneError> {
        let warned = self.warnings.borrow().len();
        let textures_warned = self.textures.borrow().warnings.len();
        let (shapes, inputs) = crate::input::recording(|| {
            let mut all = materials.to_vec();
            let shapes = self.shapes(file, material_index, &mut all, default_material)?;
            Ok::<_, SceneError>((shapes, all.split_off(materials.len())))
        });
        crate::input::record(&inputs);
        let ((shapes, spheres), asset_materials) = shapes?;
        let triangles: u64 = shapes.iter().map(|s| s.mesh.indices.len() as u64).sum();
        let build = triangles * crate::scene::BUILD_BYTES_PER_TRIANGLE;
        crate::memory::check(
            &format!("building the scene's {triangles} triangles"),
            build,
        )
        .map_err(|e| self.error(e))?;
        // The shapes' warnings go with them, to be said again on reuse.
        let mut warnings = self.warnings.borrow_mut().split_off(warned);
        warnings.extend(
            self.textures
                .borrow_mut()
                .warnings
                .split_off(textures_warned),
        );
        Ok(BuiltShapes {
            key,
            geometry: Arc::new(SceneGeometry::build(shapes, spheres)),
            asset_materials,
            cutouts: self.cutouts.take(),
            single_sided: self.single_sided.take(),
            warnings,
            inputs,
            build_bytes: build,
        })
    }
}

fn list<'a>(names: impl Iterator<Item = &'a String>) -> String {
    let v: Vec<&str> = names.map(String::as_str).collect();
    if v.is_empty() {
        "none".into()
    } else {
        v.join(", ")
    }
}

/// The dotted key of the first number in a TOML value that is NaN,
/// infinite, or finite but infinite in single precision (1e39), with it.
fn first_non_finite(v: &toml::Value, key: &str) -> Option<(String, f64)> {
    match v {
        toml::Value::Float(f) if !(f.abs() <= f32::MAX as f64) => Some((key.to_string(), *f)),
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
