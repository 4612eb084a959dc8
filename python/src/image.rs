//! A rendered (or read) image as numpy arrays, and its files.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{Mat3, Vec3};
use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use prism::film::display::parse_matrix;
use prism::film::spectral_exr::{self, SpectralImage, ATTR_COLOUR_SPACE, SAMPLE_COUNT};
use prism::film::{Film, FilmSettings};
use prism::job::{spectral_attributes, write_set, ATTR_INTERRUPTED, ATTR_XYZ_TO_RGB};
use prism::load::Loaded;
use prism::render::{RenderOptions, RenderStats, Stop};

use crate::RenderError;

/// What the arrays come from: a film just rendered, or a file read back.
enum Source {
    Rendered {
        film: Box<Film>,
        settings: Box<FilmSettings>,
        stats: RenderStats,
    },
    Read {
        image: Box<SpectralImage>,
        path: PathBuf,
    },
}

#[pyclass(frozen, module = "prism._native")]
pub struct NativeImage {
    source: Source,
    /// The spectral EXR's header attributes (what `save` writes, what
    /// `read` found).
    attributes: Vec<(String, String)>,
}

impl NativeImage {
    pub fn rendered(
        film: Film,
        scene_name: &Path,
        loaded: &Loaded,
        options: &RenderOptions,
        stats: RenderStats,
    ) -> Self {
        let attributes = spectral_attributes(
            &scene_name.display().to_string(),
            &loaded.report.content_hash(),
            &loaded.settings,
            options,
            &stats,
        )
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
        Self {
            source: Source::Rendered {
                film: Box::new(film),
                settings: Box::new(loaded.settings.film.clone()),
                stats,
            },
            attributes,
        }
    }

    fn size(&self) -> (usize, usize) {
        match &self.source {
            Source::Rendered { film, .. } => (film.width as usize, film.height as usize),
            Source::Read { image, .. } => (image.width, image.height),
        }
    }

    fn attribute(&self, key: &str) -> Option<&str> {
        self.attributes
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// A file's R, G, B planes as H×W×3 floats.
    fn read_rgb(image: &SpectralImage) -> Option<Vec<f32>> {
        let [r, g, b] = ["R", "G", "B"].map(|c| image.other.get(c));
        let (r, g, b) = (r?, g?, b?);
        Some((0..r.len()).flat_map(|i| [r[i], g[i], b[i]]).collect())
    }
}

fn array3<'py>(
    py: Python<'py>,
    data: Vec<f32>,
    h: usize,
    w: usize,
    c: usize,
) -> PyResult<Bound<'py, PyAny>> {
    // The vector becomes the array's buffer: no copy.
    Ok(data.into_pyarray(py).reshape([h, w, c])?.into_any())
}

#[pymethods]
impl NativeImage {
    #[getter]
    fn width(&self) -> usize {
        self.size().0
    }

    #[getter]
    fn height(&self) -> usize {
        self.size().1
    }

    /// Mean CIE XYZ of every pixel (the film's observer), H×W×3 float32;
    /// None for a file that does not say how its RGB was made.
    #[getter]
    fn xyz<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let (w, h) = self.size();
        match &self.source {
            Source::Rendered { film, .. } => Ok(Some(array3(py, film.xyz_image(), h, w, 3)?)),
            Source::Read { image, .. } => {
                let Some(m) = self.attribute(ATTR_XYZ_TO_RGB).and_then(parse_matrix) else {
                    return Ok(None);
                };
                let Some(rgb) = Self::read_rgb(image) else {
                    return Ok(None);
                };
                let inverse: Mat3 = m.inverse();
                let xyz: Vec<f32> = rgb
                    .chunks_exact(3)
                    .flat_map(|c| (inverse * Vec3::from_slice(c)).to_array())
                    .collect();
                Ok(Some(array3(py, xyz, h, w, 3)?))
            }
        }
    }

    /// Linear RGB in the film's colour space (white balance applied), as
    /// NAME.exr holds it, H×W×3 float32.
    #[getter]
    fn rgb<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let (w, h) = self.size();
        let rgb = match &self.source {
            Source::Rendered { film, settings, .. } => Some(
                film.rgb(&settings.colour)
                    .iter()
                    .flat_map(|c| c.to_array())
                    .collect(),
            ),
            Source::Read { image, .. } => Self::read_rgb(image),
        };
        rgb.map(|v| array3(py, v, h, w, 3)).transpose()
    }

    /// Mean spectral radiance of each bucket (per nm), H×W×B float32.
    #[getter]
    fn spectral<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let (w, h) = self.size();
        match &self.source {
            Source::Rendered { film, .. } => {
                let b = film.layout.count as usize;
                Ok(Some(array3(py, film.spectral_cube(), h, w, b)?))
            }
            Source::Read { image, .. } => {
                let b = image.spectral.len();
                if b == 0 {
                    return Ok(None);
                }
                let mut cube = vec![0.0f32; w * h * b];
                for (k, plane) in image.spectral.iter().enumerate() {
                    for (i, v) in plane.iter().enumerate() {
                        cube[i * b + k] = *v;
                    }
                }
                Ok(Some(array3(py, cube, h, w, b)?))
            }
        }
    }

    /// The buckets' centre wavelengths in nm.
    #[getter]
    fn wavelengths(&self) -> Vec<f64> {
        match &self.source {
            Source::Rendered { film, .. } => (0..film.layout.count)
                .map(|b| f64::from(film.layout.centre(b)))
                .collect(),
            Source::Read { image, .. } => image.wavelengths.clone(),
        }
    }

    /// The buckets' edges in nm (one more than the buckets).
    #[getter]
    fn bucket_edges(&self) -> Vec<f64> {
        match &self.source {
            Source::Rendered { film, .. } => {
                let l = film.layout;
                (0..=l.count)
                    .map(|i| f64::from(l.min) + f64::from(l.width()) * f64::from(i))
                    .collect()
            }
            Source::Read { image, .. } => {
                // Equal buckets, as prism writes them: edges halfway.
                let c = &image.wavelengths;
                if c.len() < 2 {
                    return c.clone();
                }
                let half = (c[1] - c[0]) / 2.0;
                c.iter()
                    .map(|x| x - half)
                    .chain(std::iter::once(c[c.len() - 1] + half))
                    .collect()
            }
        }
    }

    /// Samples each pixel took, H×W uint64.
    #[getter]
    fn sample_count<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let (w, h) = self.size();
        let counts: Option<Vec<u64>> = match &self.source {
            Source::Rendered { film, .. } => Some(
                (0..h as u32)
                    .flat_map(|y| (0..w as u32).map(move |x| (x, y)))
                    .map(|(x, y)| film.sums(x, y).samples)
                    .collect(),
            ),
            Source::Read { image, .. } => image
                .other
                .get(SAMPLE_COUNT)
                .map(|c| c.iter().map(|&v| v as u64).collect()),
        };
        counts
            .map(|c| Ok(c.into_pyarray(py).reshape([h, w])?.into_any()))
            .transpose()
    }

    /// The AOVs the film traced: albedo (RGB in the film's space), normal
    /// (world space) as H×W×3, depth as H×W.
    #[getter]
    fn aovs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        let (w, h) = self.size();
        let Source::Rendered { film, settings, .. } = &self.source else {
            return Ok(d);
        };
        let aovs = settings.aovs;
        if !aovs.traced() {
            return Ok(d);
        }
        let pixels = || (0..h as u32).flat_map(|y| (0..w as u32).map(move |x| (x, y)));
        let values: Vec<(Vec3, Vec3, f32)> = pixels()
            .map(|(x, y)| film.aov(x, y).unwrap_or_default())
            .collect();
        if aovs.albedo {
            let v = values
                .iter()
                .flat_map(|a| settings.colour.rgb(a.0).to_array())
                .collect();
            d.set_item("albedo", array3(py, v, h, w, 3)?)?;
        }
        if aovs.normal {
            let v = values.iter().flat_map(|a| a.1.to_array()).collect();
            d.set_item("normal", array3(py, v, h, w, 3)?)?;
        }
        if aovs.depth {
            let v: Vec<f32> = values.iter().map(|a| a.2).collect();
            d.set_item("depth", v.into_pyarray(py).reshape([h, w])?)?;
        }
        Ok(d)
    }

    /// The spectral EXR's header attributes (prismSeed, prismSamples, ...).
    #[getter]
    fn attributes(&self) -> BTreeMap<String, String> {
        self.attributes.iter().cloned().collect()
    }

    /// How the render went: samples, rays, seconds, why it stopped.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        match &self.source {
            Source::Rendered { stats, .. } => {
                d.set_item("samples", stats.samples)?;
                d.set_item("spp", stats.spp)?;
                d.set_item("rays", stats.rays)?;
                d.set_item("seconds", stats.elapsed.as_secs_f64())?;
                d.set_item("non_finite", stats.non_finite)?;
                d.set_item("estimated_rel_mse", stats.estimated_rel_mse)?;
                d.set_item(
                    "stop",
                    match stats.stop {
                        Stop::Complete => "complete",
                        Stop::Interrupted => "interrupted",
                        Stop::TimeBudget => "time budget",
                        Stop::ErrorTarget => "error target",
                    },
                )?;
            }
            Source::Read { path, .. } => {
                d.set_item("file", path.clone())?;
            }
        }
        Ok(d)
    }

    /// Whether the render stopped before every sample was taken.
    #[getter]
    fn interrupted(&self) -> bool {
        match &self.source {
            Source::Rendered { stats, .. } => stats.stop != Stop::Complete,
            Source::Read { .. } => self.attribute(ATTR_INTERRUPTED).is_some(),
        }
    }

    #[getter]
    fn colour_space(&self) -> Option<String> {
        match &self.source {
            Source::Rendered { settings, .. } => Some(settings.colour.space.name().to_string()),
            Source::Read { .. } => self.attribute(ATTR_COLOUR_SPACE).map(str::to_string),
        }
    }

    /// Writes STEM.exr, STEM.png and STEM.spectral.exr (as the film asks),
    /// as one set, byte for byte what `prism render` writes for this render.
    fn save(&self, py: Python<'_>, stem: PathBuf) -> PyResult<()> {
        let Source::Rendered { film, settings, .. } = &self.source else {
            return Err(RenderError::new_err(
                "an image read from a file is not saved again: its files are there to copy",
            ));
        };
        prism::job::check_writable(&stem).map_err(|e| RenderError::new_err(format!("{e:#}")))?;
        let attributes: Vec<(&str, String)> = self
            .attributes
            .iter()
            .map(|(k, v)| (k.as_str(), v.clone()))
            .collect();
        py.detach(|| write_set(&stem, settings, film, &attributes))
            .map_err(|e| RenderError::new_err(format!("{e:#}")))
    }
}

/// Reads a prism EXR or spectral EXR (or any Fichet 2021 spectral EXR).
#[pyfunction]
pub fn read(py: Python<'_>, path: PathBuf) -> PyResult<NativeImage> {
    let image = py
        .detach(|| spectral_exr::read(&path))
        .map_err(|e| RenderError::new_err(format!("{e:#}")))?;
    let attributes = image
        .attributes
        .iter()
        .map(|(k, v)| (k.clone(), v.clone()))
        .collect();
    Ok(NativeImage {
        source: Source::Read {
            image: Box::new(image),
            path,
        },
        attributes,
    })
}
