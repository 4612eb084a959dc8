//! prism: a spectral, physically based path tracer.
//!
//! Data flows one way: a TOML scene file is read by [`load`] into an
//! immutable [`scene::Scene`] and the [`render::RenderSettings`] it asks
//! for; [`render::render`] hands the job to the [`integrator`], whose loop
//! (its own, or a shared one of [`drive`]) accumulates into a
//! [`film::Film`], which [`film::output`] writes as EXR and PNG. The
//! library is usable without the command-line front end. The modules'
//! layers are listed in ARCHITECTURE.md (and checked by tests/layers.rs).

// `!(x > 0.0)` is deliberate throughout: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bench;
pub mod camera;
pub mod cpu;
pub mod drive;
pub mod film;
pub mod geometry;
pub mod input;
pub mod integrator;
pub mod job;
pub mod light;
pub mod load;
pub mod material;
pub mod medium;
pub mod memory;
pub mod merge;
pub mod render;
pub mod sampler;
pub mod scene;
pub mod schema;
pub mod spectrum;
#[cfg(test)]
mod test_random;
pub mod texture;
