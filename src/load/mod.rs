//! Scene file → the runtime [`Scene`], the [`RenderSettings`] the file
//! asks for, and a [`LoadReport`]: parse, apply the command line's
//! overrides, validate, resolve names, spectra and files. Every failure
//! names the file and the key at fault. One submodule per part of the file;
//! `format` is the file's schema, `import` reads OBJ and glTF assets.

mod camera;
mod film;
pub mod format;
pub mod import;
mod lights;
mod materials;
mod media;
mod shapes;
mod spectra;
pub mod spectrum_spec;

use std::cell::{Cell, RefCell};
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::rc::Rc;

use crate::film::{Gamut, Tonemap};
use crate::integrator::{IntegratorKind, Strategy};
use crate::material::{Cutout, Material};
use crate::render::{RenderOptions, RenderSettings};
use crate::scene::Scene;
use crate::spectrum::Spectrum;
use format::SceneFile;
use import::{Asset, TextureCache};

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
    /// Writes the overrides into the parsed file; returns the keys they set
    /// with the flag that set each, for error messages.
    fn apply(&self, file: &mut SceneFile) -> Vec<(&'static str, &'static str)> {
        let mut set = Vec::new();
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
        if let Some(kind) = self.integrator {
            file.integrator.kind = kind;
        }
        if let Some(s) = self.strategy {
            file.integrator.strategy = Some(s);
            set.push(("integrator.strategy", "--strategy"));
        }
        if let Some(n) = self.split {
            file.integrator.split = Some(n);
            set.push(("integrator.split", "--split"));
        }
        set
    }
}

/// A loaded scene file: the scene, how the file asks for it to be
/// rendered, and what loading found.
pub struct Loaded {
    pub scene: Scene,
    pub settings: RenderSettings,
    pub report: LoadReport,
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
    let err = |message: String| SceneError {
        file: path.to_path_buf(),
        message,
    };
    if path.is_dir() {
        return Err(err("is a directory, not a scene file".into()));
    }
    let (scene, inputs) = crate::input::recording(|| {
        let text =
            crate::input::read_to_string(path).map_err(|e| err(format!("the scene file: {e}")))?;
        let base = path.parent().unwrap_or(Path::new("."));
        Loader::new(path.to_path_buf(), base.to_path_buf()).load(&text, overrides)
    });
    let mut loaded = scene?;
    loaded.report.inputs = inputs;
    Ok(loaded)
}

/// Loads a scene from TOML text; `base` is the folder relative paths start from.
pub fn load_str(text: &str, base: &Path) -> Result<Loaded, SceneError> {
    Loader::new(PathBuf::from("<scene>"), base.to_path_buf()).load(text, &Overrides::default())
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

    /// Rejects the keys given (`given`: name, present) that `allowed` does
    /// not list for this kind of table (`kind`, e.g. "a shape of type Quad").
    fn only_keys(
        &self,
        key: &str,
        kind: &str,
        given: &[(&str, bool)],
        allowed: &[&str],
    ) -> Result<(), SceneError> {
        match given
            .iter()
            .find(|(name, present)| *present && !allowed.contains(name))
        {
            Some((name, _)) => Err(self.error(format!("`{key}.{name}` does not apply to {kind}"))),
            None => Ok(()),
        }
    }

    fn warn(&self, message: impl Into<String>) {
        self.warnings.borrow_mut().push(message.into());
    }

    /// Loads the scene, tallying what its inputs hold against the memory
    /// budget; the scene keeps the bytes of its images.
    fn load(&self, text: &str, overrides: &Overrides) -> Result<Loaded, SceneError> {
        let (loaded, held) = crate::memory::tallying(None, || self.load_scene(text, overrides));
        let mut loaded = loaded?;
        loaded.scene.image_bytes = held.saturating_sub(self.meshes_held.get());
        Ok(loaded)
    }

    fn load_scene(&self, text: &str, overrides: &Overrides) -> Result<Loaded, SceneError> {
        let value: toml::Table =
            toml::from_str(text).map_err(|e| self.error(with_suggestion(e.to_string())))?;
        if let Some(key) = first_non_finite(&toml::Value::Table(value), "") {
            return Err(self.error(format!(
                "`{key}` is not a finite number; numbers in a scene must be finite"
            )));
        }
        let mut file: SceneFile = toml::from_str(text)
            .map_err(|e| self.error(with_suggestion(at_unknown_key(text, e.to_string()))))?;
        let file_kind = file.integrator.kind;
        *self.overridden.borrow_mut() = overrides.apply(&mut file);
        if file.integrator.kind != file_kind {
            // The file's parameters for its own integrator do not apply to
            // the one the command line chose.
            for key in file.integrator.drop_keys_of_others() {
                self.warn(format!(
                    "`integrator.{key}` does not apply to `{}` (chosen by --integrator): ignored",
                    file.integrator.kind.name()
                ));
            }
        }

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
        let default_material = materials.len() as u32;
        materials.push(Material::Diffuse {
            reflectance: Spectrum::Constant(0.5).into(),
        });
        let (shapes, spheres) =
            self.shapes(&file, &material_index, &mut materials, default_material)?;
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
        let triangles: u64 = shapes.iter().map(|s| s.mesh.indices.len() as u64).sum();
        let build = triangles * crate::scene::BUILD_BYTES_PER_TRIANGLE;
        crate::memory::check(
            &format!("building the scene's {triangles} triangles"),
            build,
        )
        .map_err(|e| self.error(e))?;
        let load_peak = crate::memory::held() + build;
        let scene = Scene::build(camera, materials, shapes, spheres, lights)
            .with_world_medium(world_medium)
            .with_cutouts(self.cutouts.take());
        if scene.lights.is_empty() {
            self.warn(
                "the scene has no light (no shape with `emission`, no [[light]], no [environment]) \
                 or none that emits: the image will be black",
            );
        }
        let mut warnings = self.textures.borrow_mut().warnings.split_off(0);
        warnings.append(&mut self.warnings.take());
        Ok(Loaded {
            scene,
            settings: RenderSettings { integrator, film },
            report: LoadReport {
                warnings,
                inputs: Vec::new(),
                peak_bytes: load_peak,
            },
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

/// Points the caret of "unknown field `x`" at the key. Tables read through
/// a tag (`type = "diffuse"`) lose their keys' places, and the toml crate
/// then points at the table's header: find the key below the header, in
/// the same table, and show that line instead.
fn at_unknown_key(text: &str, message: String) -> String {
    let Some(key) = message
        .split_once("unknown field `")
        .and_then(|(_, rest)| rest.split_once('`'))
        .map(|(key, _)| key.to_string())
    else {
        return message;
    };
    let Some(line) = message
        .strip_prefix("TOML parse error at line ")
        .and_then(|rest| rest.split_once(','))
        .and_then(|(n, _)| n.trim().parse::<usize>().ok())
    else {
        return message;
    };
    let lines: Vec<&str> = text.lines().collect();
    let Some(header) = lines.get(line.wrapping_sub(1)) else {
        return message;
    };
    if !header.trim_start().starts_with('[') {
        return message;
    }
    let found = lines
        .iter()
        .enumerate()
        .skip(line)
        .take_while(|(_, l)| !l.trim_start().starts_with('['))
        .find(|(_, l)| {
            l.split_once('=')
                .is_some_and(|(k, _)| k.trim().trim_matches('"') == key)
        });
    let Some((i, l)) = found else {
        return message;
    };
    let Some(rest) = message.split_once("unknown field").map(|(_, r)| r) else {
        return message;
    };
    let column = l.len() - l.trim_start().len();
    let number = (i + 1).to_string();
    let pad = " ".repeat(number.len());
    format!(
        "TOML parse error at line {}, column {}\n{pad} |\n{number} | {l}\n{pad} | {}{}\nunknown field{rest}",
        i + 1,
        column + 1,
        " ".repeat(column),
        "^".repeat(key.len()),
    )
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
pub(super) fn edit_distance(a: &str, b: &str) -> usize {
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
