//! AOVs (`film.aovs`): albedo, normal, depth and sample count as channels
//! of NAME.exr, from a first-hit ray of their own, so the image itself is
//! the same with or without them.

use crate::common;

use std::collections::HashMap;
use std::path::Path;
use std::process::Command;

/// A camera 3 units above a grey floor (reflectance 0.5) looking straight
/// down, a smooth glass sphere in view, lit from above.
const SCENE: &str = r#"
[camera]
position = [0, 3, 0]
look_at = [0, 0, 0.001]
fov = 40
[film]
resolution = [32, 32]
spp = 16
# Every pixel the same samples: the tolerances below are for 16.
sampling = "uniform"
aovs = ["albedo", "normal", "depth", "sample_count"]
[materials.floor]
type = "diffuse"
reflectance = 0.5
[materials.glass]
type = "dielectric"
ior = 1.5
[[shape]]
type = "quad"
vertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]
material = "floor"
[[shape]]
type = "sphere"
center = [0.6, 0.3, 0.6]
radius = 0.3
material = "glass"
[[shape]]
type = "sphere"
center = [0, 8, 0]
radius = 1
emission = 5
"#;

fn render(dir: &Path, name: &str, scene: &str) -> (usize, HashMap<String, Vec<f32>>) {
    let file = dir.join(format!("{name}.toml"));
    std::fs::write(&file, scene).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_prism"))
        .args(["render", "-q", "--no-spectral"])
        .arg(&file)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    common::exr_channels(&dir.join(format!("{name}.exr")))
}

#[test]
fn aovs_describe_the_first_hit_and_leave_the_image_alone() {
    let dir = tempfile::tempdir().unwrap();
    let (w, with) = render(dir.path(), "with", SCENE);
    let (_, without) = render(
        dir.path(),
        "without",
        &SCENE.replace(
            "aovs = [\"albedo\", \"normal\", \"depth\", \"sample_count\"]\n",
            "",
        ),
    );
    for c in ["R", "G", "B"] {
        assert_eq!(with[c], without[c], "channel {c}");
    }
    assert_eq!(without.len(), 3);
    let at = |c: &str, x: usize, y: usize| with[c][y * w + x];
    // The floor straight below: normal +y, depth 3, albedo 0.5 grey
    // (cosine-sampled Lambertian: every sample weighs exactly ρ; the
    // wavelengths' D65 integral adds a little noise).
    for (x, y) in [(15, 15), (16, 16)] {
        assert!((at("normal.Y", x, y) - 1.0).abs() < 1e-4);
        assert!(
            (at("depth.Z", x, y) - 3.0).abs() < 0.01,
            "{}",
            at("depth.Z", x, y)
        );
        for c in ["albedo.R", "albedo.G", "albedo.B"] {
            assert!((at(c, x, y) - 0.5).abs() < 0.02, "{c}: {}", at(c, x, y));
        }
    }
    // The glass sphere's nearest point, |centre − camera| − r = 2.830 − 0.3:
    // albedo ≈ 1 (reflection plus transmission).
    let depths = &with["depth.Z"];
    let (nearest, &depth) = depths
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .unwrap();
    assert!(
        (depth - 2.53).abs() < 0.02,
        "sphere nearest at depth {depth}"
    );
    let albedo = with["albedo.G"][nearest];
    assert!((albedo - 1.0).abs() < 0.05, "glass albedo {albedo}");
    assert!(with["sampleCount.Y"].iter().all(|&c| c == 16.0));
}

#[test]
fn unknown_aovs_are_errors() {
    let e = match prism::load::load_str(&SCENE.replace("\"depth\"", "\"motion\""), Path::new(".")) {
        Ok(_) => panic!("accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains("film.aovs") && e.contains("motion") && e.contains("sample_count"),
        "{e}"
    );
}
