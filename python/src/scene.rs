//! Loading scenes and rendering them, for Python.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Duration, Instant};

use pyo3::exceptions::{PyKeyboardInterrupt, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use prism::film::{Gamut, Tonemap};
use prism::integrator::{IntegratorKind, Strategy};
use prism::load::{Loaded, Overrides};
use prism::render::ProgressCounts;

use crate::image::NativeImage;
use crate::{RenderError, SceneError};

/// A loaded scene: what it was loaded from (to load it again with other
/// values), and the loaded scene, shared by the scenes made from it.
#[pyclass(frozen, module = "prism._native")]
pub struct NativeScene {
    pub loaded: Arc<Loaded>,
    /// The scene's TOML text.
    text: Arc<String>,
    /// What errors name: the file, or <dict>, <text>.
    name: PathBuf,
    /// Where relative paths start.
    base: PathBuf,
    overrides: Overrides,
}

fn scene_error(e: prism::load::SceneError) -> PyErr {
    SceneError::new_err(e.to_string())
}

/// The command line's overrides from keyword arguments of the same names
/// (`resolution=(w, h)`, `integrator="bdpt"`, `spectral=False`, ...).
fn overrides_of(base: &Overrides, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Overrides> {
    let mut o = base.clone();
    let Some(kwargs) = kwargs else {
        return Ok(o);
    };
    fn named<T: serde::de::DeserializeOwned>(v: &Bound<'_, PyAny>, key: &str) -> PyResult<T> {
        let s: String = v.extract()?;
        toml::Value::String(s.clone())
            .try_into()
            .map_err(|_| SceneError::new_err(format!("`{key}`: unknown value {s:?}")))
    }
    for (k, v) in kwargs.iter() {
        let key: String = k.extract()?;
        if v.is_none() {
            continue;
        }
        match key.as_str() {
            "resolution" => o.resolution = Some(v.extract()?),
            "spectral_range" => {
                let (a, b): (f32, f32) = v.extract()?;
                o.spectral_range = Some([a, b]);
            }
            "spectral_buckets" => o.spectral_buckets = Some(v.extract()?),
            "spectral" => o.no_spectral = !v.extract::<bool>()?,
            "exposure" => o.exposure = Some(v.extract()?),
            "tonemap" => o.tonemap = Some(named::<Tonemap>(&v, "tonemap")?),
            "gamut" => o.gamut = Some(named::<Gamut>(&v, "gamut")?),
            "strategy" => o.strategy = Some(named::<Strategy>(&v, "strategy")?),
            "integrator" => o.integrator = Some(named::<IntegratorKind>(&v, "integrator")?),
            "split" => o.split = Some(v.extract()?),
            other => {
                return Err(PyTypeError::new_err(format!(
                    "unknown override {other:?}: resolution, integrator, spectral_range, \
                     spectral_buckets, spectral, exposure, tonemap, gamut, strategy, split \
                     (other values: Scene.with_updates)"
                )))
            }
        }
    }
    Ok(o)
}

/// Loads a scene file, as `prism render FILE` does.
#[pyfunction]
#[pyo3(signature = (path, **overrides))]
pub fn load_file(
    py: Python<'_>,
    path: PathBuf,
    overrides: Option<&Bound<'_, PyDict>>,
) -> PyResult<NativeScene> {
    let overrides = overrides_of(&Overrides::default(), overrides)?;
    // Read once: kept to load again with other values (`reload`).
    let text = prism::load::read_scene_file(&path).map_err(scene_error)?;
    let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
    let loaded = py
        .detach(|| prism::load::load_text(&text, &path, &base, &overrides, None))
        .map_err(scene_error)?;
    Ok(NativeScene {
        loaded: Arc::new(loaded),
        text: Arc::new(text),
        name: path,
        base,
        overrides,
    })
}

/// Loads a scene from TOML text that errors call `name`; relative paths
/// start at `base`. With `previous`, what the two share is not built again.
#[pyfunction]
#[pyo3(signature = (text, name, base, previous=None, **overrides))]
pub fn load_text(
    py: Python<'_>,
    text: String,
    name: PathBuf,
    base: PathBuf,
    previous: Option<&NativeScene>,
    overrides: Option<&Bound<'_, PyDict>>,
) -> PyResult<NativeScene> {
    let defaults = previous.map(|p| p.overrides.clone()).unwrap_or_default();
    let overrides = overrides_of(&defaults, overrides)?;
    let previous = previous.map(|p| p.loaded.clone());
    let loaded = py
        .detach(|| prism::load::load_text(&text, &name, &base, &overrides, previous.as_deref()))
        .map_err(scene_error)?;
    Ok(NativeScene {
        loaded: Arc::new(loaded),
        text: Arc::new(text),
        name,
        base,
        overrides,
    })
}

#[pymethods]
impl NativeScene {
    /// The same scene loaded with other overrides (a resolution, an
    /// integrator): its geometry is shared, not built again.
    #[pyo3(signature = (**overrides))]
    fn reload(&self, py: Python<'_>, overrides: Option<&Bound<'_, PyDict>>) -> PyResult<Self> {
        let overrides = overrides_of(&self.overrides, overrides)?;
        let loaded = py
            .detach(|| {
                prism::load::load_text(
                    &self.text,
                    &self.name,
                    &self.base,
                    &overrides,
                    Some(&self.loaded),
                )
            })
            .map_err(scene_error)?;
        Ok(NativeScene {
            loaded: Arc::new(loaded),
            text: self.text.clone(),
            name: self.name.clone(),
            base: self.base.clone(),
            overrides,
        })
    }

    #[getter]
    fn text(&self) -> &str {
        &self.text
    }

    #[getter]
    fn name(&self) -> PathBuf {
        self.name.clone()
    }

    #[getter]
    fn base(&self) -> PathBuf {
        self.base.clone()
    }

    #[getter]
    fn resolution(&self) -> (u32, u32) {
        let f = &self.loaded.settings.film;
        (f.width, f.height)
    }

    #[getter]
    fn spp(&self) -> u32 {
        self.loaded.settings.film.spp
    }

    #[getter]
    fn seed(&self) -> u64 {
        self.loaded.settings.film.seed
    }

    #[getter]
    fn integrator(&self) -> &'static str {
        self.loaded.settings.integrator.name()
    }

    #[getter]
    fn colour_space(&self) -> &'static str {
        self.loaded.settings.film.colour.space.name()
    }

    /// The film's XYZ → RGB matrix (colour space and white balance),
    /// row-major: `Image.rgb` is this times `Image.xyz`.
    #[getter]
    fn xyz_to_rgb(&self) -> [[f32; 3]; 3] {
        let m = self.loaded.settings.film.colour.matrix();
        [0, 1, 2].map(|r| m.row(r).to_array())
    }

    #[getter]
    fn observer(&self) -> &'static str {
        self.loaded.settings.film.observer.name()
    }

    #[getter]
    fn white_balance(&self) -> Option<String> {
        self.loaded.settings.film.white_balance.clone()
    }

    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.loaded.report.warnings.clone()
    }

    #[getter]
    fn inputs(&self) -> Vec<PathBuf> {
        self.loaded
            .report
            .inputs
            .iter()
            .map(|(p, _)| p.clone())
            .collect()
    }

    #[getter]
    fn content_hash(&self) -> String {
        self.loaded.report.content_hash()
    }

    #[getter]
    fn triangle_count(&self) -> usize {
        self.loaded.scene.triangle_count()
    }

    #[getter]
    fn light_count(&self) -> usize {
        self.loaded.scene.lights.len()
    }

    /// Whether `other` shares this scene's built geometry (no mesh was
    /// read and no BVH built to make it).
    fn shares_geometry(&self, other: &NativeScene) -> bool {
        Arc::ptr_eq(self.loaded.scene.geometry(), other.loaded.scene.geometry())
    }
}

/// How often the waiting thread looks at Ctrl-C and reports progress.
const POLL: Duration = Duration::from_millis(100);

/// Renders `scene`. The GIL is released while the workers run; this thread
/// wakes every 100 ms to take Ctrl-C (which stops the render after the
/// pass under way: the image comes back, marked interrupted) and to call
/// `progress(done, total, elapsed_seconds)`.
#[pyfunction]
#[pyo3(signature = (scene, spp=None, samples=None, seed=None, threads=None, time=None, target_error=None, adaptive=None, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn render(
    py: Python<'_>,
    scene: &NativeScene,
    spp: Option<u32>,
    samples: Option<(u32, u32)>,
    seed: Option<u64>,
    threads: Option<usize>,
    time: Option<f64>,
    target_error: Option<f64>,
    adaptive: Option<bool>,
    progress: Option<Bound<'_, PyAny>>,
) -> PyResult<NativeImage> {
    let settings = &scene.loaded.settings;
    let mut options = settings.options();
    if spp == Some(0) {
        return Err(RenderError::new_err("spp must be at least 1"));
    }
    if threads == Some(0) {
        return Err(RenderError::new_err("threads must be at least 1"));
    }
    if let Some(n) = spp {
        options.samples = 0..n;
    }
    if let Some((a, b)) = samples {
        if adaptive == Some(true) {
            // As the command line: a range is a part of a split render.
            return Err(RenderError::new_err(
                prism::render::RenderError::AdaptiveRange.to_string(),
            ));
        }
        if a >= b {
            return Err(RenderError::new_err(format!(
                "samples=({a}, {b}) is empty: give (first, end) with first < end"
            )));
        }
        options.samples = a..b;
    }
    if let Some(s) = seed {
        options.seed = s;
    }
    options.threads = threads;
    if let Some(t) = time {
        const YEAR: f64 = 365.25 * 86400.0;
        if !(t > 0.0 && t <= YEAR) {
            return Err(RenderError::new_err(
                "time must be a positive number of seconds, at most a year",
            ));
        }
        options.time_budget = Some(Duration::from_secs_f64(t));
    }
    if let Some(t) = target_error {
        if !(t > 0.0 && t.is_finite()) {
            return Err(RenderError::new_err(
                "target_error must be a positive relative MSE, such as 0.01",
            ));
        }
        options.target_error = Some(t);
    }
    // As the command line, with a warning where the scene's adaptive
    // sampling cannot be had.
    let (adaptive, why_uniform) =
        settings.adaptive_for(adaptive, samples.is_some(), target_error.is_some());
    if let Some(reason) = why_uniform {
        let category = py.get_type::<pyo3::exceptions::PyUserWarning>();
        let message = std::ffi::CString::new(reason).expect("no NUL in the reason");
        PyErr::warn(py, category.as_any(), &message, 2)?;
    }
    options.adaptive = adaptive;
    let counts = Arc::new(ProgressCounts::default());
    let cancel = Arc::new(AtomicBool::new(false));
    options.progress_counts = Some(counts.clone());
    options.cancel = Some(cancel.clone());

    let loaded = &scene.loaded;
    let done = (Mutex::new(false), Condvar::new());
    let start = Instant::now();
    let mut failure: Option<PyErr> = None;
    let result = std::thread::scope(|s| {
        let worker = s.spawn(|| {
            let r = prism::render::render(&loaded.scene, &loaded.settings, &options);
            *done.0.lock().unwrap_or_else(|e| e.into_inner()) = true;
            done.1.notify_all();
            r
        });
        loop {
            let finished = py.detach(|| {
                let guard = done.0.lock().unwrap_or_else(|e| e.into_inner());
                let (guard, _) = done
                    .1
                    .wait_timeout_while(guard, POLL, |d| !*d)
                    .unwrap_or_else(|e| e.into_inner());
                *guard
            });
            // Ctrl-C (KeyboardInterrupt, during the wait or the callback)
            // stops the render and keeps the image; another error from a
            // signal handler or the callback stops it and is raised.
            let mut errors = Vec::new();
            if let Err(e) = py.check_signals() {
                errors.push(e);
            }
            if let Some(f) = progress.as_ref().filter(|_| failure.is_none()) {
                let args = (counts.done(), counts.total(), start.elapsed().as_secs_f64());
                if let Err(e) = f.call1(args) {
                    errors.push(e);
                }
            }
            for e in errors {
                cancel.store(true, Ordering::Relaxed);
                if !e.is_instance_of::<PyKeyboardInterrupt>(py) {
                    failure.get_or_insert(e);
                }
            }
            if finished {
                break;
            }
        }
        worker.join()
    });
    if let Some(e) = failure {
        return Err(e);
    }
    let (film, stats) = match result {
        Ok(r) => r.map_err(|e| RenderError::new_err(e.to_string()))?,
        Err(_) => return Err(RenderError::new_err("the render panicked")),
    };
    Ok(NativeImage::rendered(
        film,
        &scene.name,
        &scene.loaded,
        &options,
        stats,
    ))
}

/// A spectrum as a scene writes one, evaluated at `wavelengths` (nm).
#[pyfunction]
#[pyo3(signature = (value, wavelengths, role="emission", base=None))]
pub fn spectrum_values(
    value: &Bound<'_, PyAny>,
    wavelengths: Vec<f32>,
    role: &str,
    base: Option<PathBuf>,
) -> PyResult<Vec<f32>> {
    let value = crate::convert::to_value(value, "spectrum")?;
    let base = base.unwrap_or_default();
    let s = prism::load::spectrum(value, role, &base, "spectrum").map_err(scene_error)?;
    Ok(wavelengths.iter().map(|&l| s.eval(l)).collect())
}
