//! Every integration test of prism, one module a file, in one test crate:
//! the release build links it once (the whole-program optimisation takes
//! about a minute a binary), and it shares every compiled crate with the
//! render command's `cargo build --release`. Run one file's tests with
//! `cargo test --release --test suite -- bdpt::`.

mod common;

mod aov;
mod assets;
mod bdpt;
mod bsdf;
mod camera;
mod cli;
mod colorimetry;
mod delta_lights;
mod direct_lighting;
mod dispersion;
mod docs;
mod environment_map;
mod farm;
mod fluorescence;
mod furnace;
mod fuzz;
mod hard_cases;
mod hostile_round3;
mod import;
mod light_tracer;
mod lights;
mod media;
mod medium_boundary;
mod merge;
mod packet;
mod path_caustics;
mod progressive;
mod sampling;
mod scene_errors;
mod settings;
mod shapes;
mod sky;
mod spectral_exr;
mod spheres;
mod splitting;
mod sppm;
mod strategies_agree;
mod stream;
mod structure;
mod tev;
