//! prism._native: the Rust half of the Python package `prism` (python/prism).
//! It loads scenes (a file, TOML text, or a dict turned into TOML text),
//! renders them with the GIL released, and hands the film over as numpy
//! arrays. The Python half adds the friendly API: keyword arguments,
//! progress bars, `Scene.with_updates`, colour-science objects.

mod convert;
mod image;
mod scene;

use pyo3::prelude::*;

/// The CPU features this build of the module uses that the running CPU
/// lacks, as a bit mask over `prism::cpu::features()` (bit k: feature k).
/// `prism/__init__.py` asks it through ctypes before it imports the module:
/// the module is compiled for x86-64-v3 and would stop at its first AVX2
/// instruction with SIGILL, and this answer takes only CPUID and integer
/// code, checked under QEMU's Sandy Bridge (python/tests/test_cpu.py).
#[no_mangle]
pub extern "C" fn prism_cpu_lacks() -> u32 {
    let features = prism::cpu::features();
    let mut mask = 0;
    for (k, feature) in features.iter().enumerate() {
        // Opaque to the optimiser, so the loop stays scalar: vectorised, it
        // would use the AVX2 it is here to look for.
        if std::hint::black_box(feature).missing() {
            mask |= 1 << k;
        }
    }
    mask
}

/// The name of feature `k` of `prism_cpu_lacks`' mask, as
/// `target_feature` spells it: its UTF-8 bytes, their count in `len`; null
/// past the last feature.
///
/// # Safety
/// `len` is null or points to a `usize` the caller owns.
#[no_mangle]
pub unsafe extern "C" fn prism_cpu_feature_name(k: u32, len: *mut usize) -> *const u8 {
    let Some(feature) = prism::cpu::features().get(k as usize).copied() else {
        return std::ptr::null();
    };
    if !len.is_null() {
        // SAFETY: the caller passes a pointer to a usize it owns.
        unsafe { *len = feature.name.len() };
    }
    feature.name.as_ptr()
}

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
