//! The light tracer against the path tracer: the same image within error
//! bars, on the Cornell Box, on a scene of rough glass, rough metal and a
//! smoothly shaded sphere, on a floor whose shading normals lean off its
//! facets (where importance needs Veach's correction) and under delta
//! lights; and the same image for any number of threads.
//!
//! The 1/η'² of refraction is not visible here: with the camera and the
//! lights outside every dielectric, a path enters and leaves each medium and
//! the factors cancel (generalised reciprocity). tests/bsdf.rs checks the
//! adjoint BSDF directly, and tests/bdpt.rs a light inside glass.

use crate::common;

use common::agree::{assert_integrators_agree, cornell_box, DELTA_LIGHTS, GLASS_METAL_SHADING};

#[test]
fn light_tracer_matches_the_path_tracer_on_the_cornell_box() {
    assert_integrators_agree(&cornell_box(), "light", "Cornell Box");
}

#[test]
fn light_tracer_matches_the_path_tracer_through_glass_metal_and_shading_normals() {
    assert_integrators_agree(
        GLASS_METAL_SHADING,
        "light",
        "glass, metal and shading normals",
    );
}

#[test]
fn light_tracer_applies_the_shading_normal_correction() {
    // With the correction removed, this test fails (8σ off in the first
    // block).
    common::agree::assert_tilted_floor_agrees("light");
}

#[test]
fn light_tracer_matches_the_path_tracer_under_delta_lights() {
    assert_integrators_agree(DELTA_LIGHTS, "light", "point, spot and directional lights");
}

#[test]
fn splats_are_the_same_for_any_thread_count() {
    common::agree::assert_thread_count_invariant("light");
}
