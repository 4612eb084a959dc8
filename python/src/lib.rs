//! prism._native: the Rust half of the Python package `prism` (python/prism).
//! It loads scenes (a file, TOML text, or a dict turned into TOML text),
//! renders them with the GIL released, and hands the film over as numpy
//! arrays. The Python half adds the friendly API: keyword arguments,
//! progress bars, `Scene.with_updates`, colour-science objects.

mod convert;
mod image;
mod scene;

use pyo3::prelude::*;

pyo3::create_exception!(
    prism,
    SceneError,
    pyo3::exceptions::PyValueError,
    "A scene that cannot be loaded: the message names the file (or <dict>), the key and what is wrong, as the command line says it."
);
pyo3::create_exception!(
    prism,
    RenderError,
    pyo3::exceptions::PyRuntimeError,
    "A render that cannot run as asked (threads, region, an integrator that cannot honour an option), or output that cannot be written."
);

#[pymodule]
#[pyo3(name = "_native")]
fn prism_native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add("RenderError", m.py().get_type::<RenderError>())?;
    m.add_class::<scene::NativeScene>()?;
    m.add_class::<image::NativeImage>()?;
    m.add_function(wrap_pyfunction!(scene::load_file, m)?)?;
    m.add_function(wrap_pyfunction!(scene::load_text, m)?)?;
    m.add_function(wrap_pyfunction!(scene::render, m)?)?;
    m.add_function(wrap_pyfunction!(scene::spectrum_values, m)?)?;
    m.add_function(wrap_pyfunction!(image::read, m)?)?;
    m.add_function(wrap_pyfunction!(convert::to_toml, m)?)?;
    m.add_function(wrap_pyfunction!(convert::parse_toml, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
