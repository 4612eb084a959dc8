//! How renders spread their samples: uniformly unless the scene
//! (`film.sampling`) or the command line (`--adaptive`, `--uniform`) says;
//! where the scene asks for adaptive sampling, parts of a render and error
//! targets fall back to uniform sampling with a line that says so.

use std::path::Path;
use std::process::Command;

/// The command-line tests' scene (a floor under a lamp), larger and with
/// more samples: 16 a pixel leave the adaptive counts room to differ.
fn scene() -> String {
    crate::cli::SCENE
        .replace("resolution = [24, 16]", "resolution = [32, 24]")
        .replace("spp = 4", "spp = 16")
}

/// Renders `scene` (text) with `args` in a new folder; the stderr and the
/// per-pixel sample counts of the spectral EXR.
fn render(scene: &str, args: &[&str]) -> (String, Vec<f32>, bool) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.toml");
    std::fs::write(&path, scene).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_prism"))
        .args(["render", "-q", "--threads", "2", "-o"])
        .arg(dir.path().join("out"))
        .args(args)
        .arg(&path)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(out.status.success(), "{err}");
    let img = prism::film::spectral_exr::read(&dir.path().join("out.spectral.exr")).unwrap();
    let adaptive = img.attributes.contains_key(prism::merge::ATTR_ADAPTIVE);
    (err, img.other["sampleCount"].clone(), adaptive)
}

fn uniform(counts: &[f32], spp: f32) -> bool {
    counts.iter().all(|&c| c == spp)
}

fn with_film_key(key: &str) -> String {
    scene().replace("spp = 16", &format!("spp = 16\n{key}"))
}

const ADAPTIVE: &str = "sampling = \"adaptive\"";

#[test]
fn scenes_and_the_command_line_choose_adaptive_sampling() {
    let (err, counts, adaptive) = render(&scene(), &[]);
    assert!(!adaptive && uniform(&counts, 16.0), "{err}");
    assert!(!err.contains("uniform sampling"), "not a fallback: {err}");
    for (args, key) in [(&[][..], ADAPTIVE), (&["--adaptive"][..], "")] {
        let (err, counts, adaptive) = render(&with_film_key(key), args);
        assert!(adaptive && !uniform(&counts, 16.0), "{args:?} {key}: {err}");
        assert!(err.contains("adaptive: "), "{err}");
        let mean = counts.iter().sum::<f32>() / counts.len() as f32;
        assert!((mean - 16.0).abs() < 0.5, "mean {mean}");
    }
    // The command line wins over the scene file.
    for (args, key) in [
        (&["--uniform"][..], ADAPTIVE),
        (&[][..], "sampling = \"uniform\""),
    ] {
        let (err, counts, adaptive) = render(&with_film_key(key), args);
        assert!(!adaptive && uniform(&counts, 16.0), "{args:?} {key}: {err}");
    }
}

#[test]
fn parts_of_a_render_and_error_targets_sample_uniformly_and_say_so() {
    for args in [
        &["--samples", "0..16"][..],
        &["--tile", "0,0,16,24"],
        &["--target-error", "1e-12"],
    ] {
        let (err, counts, adaptive) = render(&with_film_key(ADAPTIVE), args);
        assert!(!adaptive, "{args:?}");
        assert!(err.contains("uniform sampling: "), "{args:?}: {err}");
        let taken: Vec<f32> = counts.iter().copied().filter(|&c| c > 0.0).collect();
        assert!(uniform(&taken, 16.0), "{args:?}");
    }
    // Asked for explicitly, adaptive sampling of a range is refused.
    let out = Command::new(env!("CARGO_BIN_EXE_prism"))
        .args(["render", "--adaptive", "--samples", "0..8", "x.toml"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
}

#[test]
fn other_integrators_sample_uniformly_and_say_so_where_the_scene_asks() {
    for kind in ["bdpt", "light", "sppm", "path_caustics"] {
        let (err, counts, adaptive) = render(&scene(), &["--integrator", kind]);
        assert!(!adaptive && uniform(&counts, 16.0), "{kind}: {err}");
        // The default is not a fallback: no line about it.
        assert!(!err.contains("uniform sampling"), "{kind}: {err}");
        // A scene that asks for adaptive sampling renders with them too.
        let (err, counts, adaptive) = render(&with_film_key(ADAPTIVE), &["--integrator", kind]);
        assert!(!adaptive && uniform(&counts, 16.0), "{kind}: {err}");
        assert!(err.contains("only the path tracer takes"), "{kind}: {err}");
    }
    let typo = with_film_key("sampling = \"adaptve\"");
    let loaded = prism::load::load_str(&typo, Path::new("."));
    let e = loaded
        .err()
        .expect("a misspelt value is refused")
        .to_string();
    assert!(e.contains("sampling") && e.contains("adaptive"), "{e}");
}
