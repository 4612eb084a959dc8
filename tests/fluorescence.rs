//! Fluorescent materials: what the loader refuses (with file and key), the
//! integrators that refuse them, and properties of the transport that need
//! no reference (the colour-science check, tools/tests/test_fluorescence.py,
//! compares renders with the total radiance factor computed by numpy).

use std::path::Path;

use prism::drive::{RenderError, RenderOptions};
use prism::integrator::{Integrator, IntegratorKind, IntegratorSpec};
use prism::load::{load, load_str};
use prism::render::{render, RenderSettings};

use crate::common::{render_film, scene};

/// A patch lit from every direction by `light`, `fluorescence` being the
/// material's keys beside its reflectance.
fn patch(light: &str, fluorescence: &str) -> String {
    format!(
        r#"
        [camera]
        position = [0, 0, -1]
        look_at = [0, 0, 0]
        fov = 40

        [film]
        resolution = [8, 8]
        spp = 64

        [integrator]
        max_depth = 1

        [[shape]]
        type = "sphere"
        radius = 50
        flip_normals = true
        emission = {light}

        [materials.patch]
        type = "fluorescent"
        reflectance = 0.2
        {fluorescence}

        [[shape]]
        type = "quad"
        vertices = [[-2, -2, 0], [-2, 2, 0], [2, 2, 0], [2, -2, 0]]
        material = "patch"
        "#
    )
}

/// Absorbs at 380-440 nm, emits a band around 520 nm.
const BRIGHTENER: &str = r#"
    excitation = [[370, 0], [380, 0.7], [440, 0.7], [450, 0]]
    emission = [[490, 0], [520, 1], [550, 0]]
    quantum_yield = 0.9
"#;

fn error(text: &str) -> String {
    match load_str(text, Path::new(env!("CARGO_MANIFEST_DIR"))) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn bad_fluorescence_is_refused_naming_the_key() {
    let cases = [
        ("", "`excitation`, `emission`, `quantum_yield` missing"),
        (
            "excitation = 0.5\nemission = 1",
            "`quantum_yield` missing",
        ),
        (
            "donaldson = \"m.csv\"\nquantum_yield = 0.5",
            "not both",
        ),
        (
            &BRIGHTENER.replace("0.9", "1.2"),
            "`materials.patch.quantum_yield` must lie in [0, 1]",
        ),
        (
            &BRIGHTENER.replace("0.7", "1.5"),
            "`materials.patch.excitation`: a reflectance must lie in [0, 1]",
        ),
        (
            "excitation = 0.5\nemission = [[300, 0], [350, 1]]\nquantum_yield = 1",
            "`materials.patch.emission` is zero over 360-830 nm",
        ),
        (
            "excitation = [[700, 0], [710, 1], [720, 0]]\nemission = [[400, 0], [410, 1], [420, 0]]\nquantum_yield = 1",
            "zero everywhere",
        ),
    ];
    for (keys, expected) in cases {
        let e = error(&patch("\"D65\"", keys));
        assert!(e.contains(expected), "{keys}: {e}");
    }
}

#[test]
fn a_surface_that_sends_back_more_than_it_receives_is_refused() {
    // Reflectance 0.2 plus 0.9 of the light absorbed at 380-440 nm, nearly
    // all of it re-emitted: 1.0 of it and more.
    let keys = BRIGHTENER.replace("0.7", "1.0").replace("0.9", "1.0");
    let e = error(&patch("\"D65\"", &keys));
    assert!(
        e.contains("materials.patch") && e.contains("more than all of it"),
        "{e}"
    );
}

#[test]
fn donaldson_files_are_checked_naming_file_and_value() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    let run = |csv: &str| -> String {
        std::fs::write(dir.path().join("m.csv"), csv).unwrap();
        std::fs::write(&scene, patch("\"D65\"", "donaldson = \"m.csv\"")).unwrap();
        match load(&scene) {
            Ok(_) => "loaded".into(),
            Err(e) => e.to_string(),
        }
    };
    let e = run("400,0.1,0.2\n410,0.1,0.2\n");
    assert!(e.contains("m.csv") && e.contains("header"), "{e}");
    let e = run("ex,500,blue\n400,0.1,0.2\n410,0.1,0.2\n");
    assert!(e.contains("`blue` is not an emission wavelength"), "{e}");
    let e = run("ex,500,510\n400,0.001,-0.002\n410,0.001,0.002\n");
    assert!(
        e.contains("excitation 400 nm, emission 510 nm is negative"),
        "{e}"
    );
    let e = run("ex,510,500\n400,0.001,0.002\n410,0.001,0.002\n");
    assert!(e.contains("increasing"), "{e}");
    let e = run("ex,500,510\n400,0.001,0.002,0.3\n410,0.001,0.002,0.3\n");
    assert!(e.contains("names 2 emission wavelengths"), "{e}");
    assert_eq!(
        run("ex,500,510\n400,0.001,0.002\n410,0.001,0.002\n"),
        "loaded"
    );
}

#[test]
fn only_the_path_tracer_renders_fluorescence() {
    let text = patch("\"D65\"", BRIGHTENER);
    for &kind in IntegratorKind::ALL {
        let with = text.replace(
            "max_depth = 1",
            &format!("max_depth = 1\ntype = \"{}\"", kind.name()),
        );
        let loaded = load_str(&with, Path::new(env!("CARGO_MANIFEST_DIR")));
        if kind == IntegratorKind::Path {
            assert!(loaded.is_ok());
            continue;
        }
        let e = loaded.err().unwrap().to_string();
        assert!(e.contains("fluorescent") && e.contains(kind.name()), "{e}");
        // Settings changed after loading are refused by `render` too.
        let loaded = scene(&text);
        let settings = RenderSettings {
            integrator: Integrator::from_spec(&IntegratorSpec::of(kind)).unwrap(),
            ..loaded.settings.clone()
        };
        let refused = render(
            &loaded.scene,
            &settings,
            &RenderOptions::new(&settings.film),
        );
        assert!(matches!(refused, Err(RenderError::Fluorescence(_))));
    }
}

/// Under a lamp that emits only at 380-440 nm the reflected light is
/// violet; what the surface sends at 490-550 nm comes only from
/// fluorescence, and the film bins it there: the wavelengths the camera
/// saw, not where the light was absorbed. Its luminance is that of the
/// re-emitted band under the lamp, which a non-fluorescent twin lacks.
#[test]
fn light_absorbed_in_violet_comes_back_green_at_the_film() {
    let lamp = "[[375, 0], [380, 1], [440, 1], [445, 0]]";
    let spectral = "spectral_range = [360, 830]\nspectral_buckets = 47";
    let fluorescent =
        scene(&patch(lamp, BRIGHTENER).replace("spp = 64", &format!("spp = 64\n{spectral}")));
    let film = render_film(&fluorescent, 2);
    let twin = scene(
        &patch(lamp, "")
            .replace("\"fluorescent\"", "\"diffuse\"")
            .replace("spp = 64", &format!("spp = 64\n{spectral}")),
    );
    let plain = render_film(&twin, 2);
    let band = |f: &prism::film::Film, lo: f32, hi: f32| -> f64 {
        let mut sum = 0.0;
        for y in 0..8 {
            for x in 0..8 {
                let s = f.spectrum(x, y);
                for (k, v) in s.iter().enumerate() {
                    let centre = 360.0 + 10.0 * k as f32 + 5.0;
                    if (lo..hi).contains(&centre) {
                        sum += *v as f64;
                    }
                }
            }
        }
        sum / 64.0
    };
    // Green appears only with fluorescence; violet is the same reflectance.
    assert_eq!(band(&plain, 480.0, 560.0), 0.0);
    assert!(
        band(&film, 480.0, 560.0) > 0.05,
        "{}",
        band(&film, 480.0, 560.0)
    );
    let (v_fl, v_plain) = (band(&film, 380.0, 440.0), band(&plain, 380.0, 440.0));
    assert!(
        (v_fl - v_plain).abs() < 0.1 * v_plain,
        "violet {v_fl} against {v_plain}"
    );
    // The same image for any thread count.
    let one = render_film(&fluorescent, 1);
    for y in 0..8 {
        for x in 0..8 {
            assert_eq!(one.sums(x, y), film.sums(x, y));
        }
    }
}
