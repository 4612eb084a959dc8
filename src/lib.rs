//! prism: a spectral, physically based path tracer.
//!
//! Data flows one way: a TOML scene file is read by [`scene::load`] into an
//! immutable [`scene::Scene`]; [`render`] drives the [`integrator`] over tiles
//! and accumulates into a [`film::Film`], which [`film::output`] writes as
//! EXR and PNG. The library is usable without the command-line front end.

// `!(x > 0.0)` is deliberate throughout: it also rejects NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bench;
pub mod camera;
pub mod cpu;
pub mod film;
pub mod geometry;
pub mod input;
pub mod integrator;
pub mod job;
pub mod light;
pub mod material;
pub mod medium;
pub mod memory;
pub mod merge;
pub mod render;
pub mod sampler;
pub mod scene;
pub mod spectrum;
pub mod texture;
