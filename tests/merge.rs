//! Splitting a render by sample range and by region, then merging, gives the
//! single render of all the samples (up to float32 rounding of the stored
//! means); parts that do not belong together are refused.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use prism::film::spectral_exr::{self, SpectralImage, SAMPLE_COUNT};

fn prism(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_prism"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap()
}

fn ok(args: &[&str]) {
    let out = prism(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

const SCENE: &str = "scenes/cornell-box.toml";

fn render(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let stem = dir.join(name);
    let mut args = vec![
        "render",
        SCENE,
        "-q",
        "--resolution",
        "40x24",
        "-o",
        stem.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    ok(&args);
    stem.with_extension("spectral.exr")
}

/// Largest difference between two images: spectral values relative to
/// themselves, RGB relative to the pixel's largest component (R, G and B mix
/// XYZ with negative weights, so a component near zero carries the rounding
/// of its larger neighbours).
fn max_relative_difference(a: &SpectralImage, b: &SpectralImage) -> f64 {
    let mut worst = 0.0f64;
    for (pa, pb) in a.spectral.iter().zip(&b.spectral) {
        for (x, y) in pa.iter().zip(pb) {
            let (x, y) = (*x as f64, *y as f64);
            if x != y {
                worst = worst.max((x - y).abs() / x.abs().max(y.abs()));
            }
        }
    }
    for i in 0..a.width * a.height {
        let scale = ["R", "G", "B"]
            .iter()
            .map(|c| a.other[*c][i].abs())
            .fold(0.0f32, f32::max) as f64;
        for c in ["R", "G", "B"] {
            let (x, y) = (a.other[c][i] as f64, b.other[c][i] as f64);
            if x != y {
                worst = worst.max((x - y).abs() / scale);
            }
        }
    }
    worst
}

#[test]
fn merged_sample_ranges_and_tiles_equal_the_single_render() {
    let dir = tempfile::tempdir().unwrap();
    let single =
        spectral_exr::read(&render(dir.path(), "single", &["--spp", "8", "--uniform"])).unwrap();

    let parts = [
        render(dir.path(), "a", &["--samples", "0..3"]),
        render(dir.path(), "b", &["--samples", "3..8"]),
    ];
    let merged = dir.path().join("merged");
    let mut args = vec!["merge", "-o", merged.to_str().unwrap()];
    args.extend(parts.iter().map(|p| p.to_str().unwrap()));
    ok(&args);
    let merged = spectral_exr::read(&merged.with_extension("spectral.exr")).unwrap();
    assert_eq!(merged.attributes["prismSampleRange"], "0..8");
    assert_eq!(merged.other[SAMPLE_COUNT], single.other[SAMPLE_COUNT]);
    let d = max_relative_difference(&merged, &single);
    eprintln!("sample ranges merged: max relative difference {d:e}");
    // Float32 rounding: the film sums buckets in f32 and the files store
    // means; a few ulps (ε = 6e-8) per value, never more than 1e-5.
    assert!(d < 1e-5, "merged differs from the single render by {d}");

    // Four tiles times two sample ranges: eight parts.
    let mut tiles = Vec::new();
    for (k, tile) in ["0,0,20,12", "20,0,40,12", "0,12,20,24", "20,12,40,24"]
        .iter()
        .enumerate()
    {
        for (j, range) in ["0..5", "5..8"].iter().enumerate() {
            tiles.push(render(
                dir.path(),
                &format!("t{k}{j}"),
                &["--tile", tile, "--samples", range],
            ));
        }
    }
    let merged_tiles = dir.path().join("tiles");
    let mut args = vec!["merge", "-o", merged_tiles.to_str().unwrap()];
    args.extend(tiles.iter().map(|p| p.to_str().unwrap()));
    ok(&args);
    let merged_tiles = spectral_exr::read(&merged_tiles.with_extension("spectral.exr")).unwrap();
    assert_eq!(merged_tiles.other[SAMPLE_COUNT], single.other[SAMPLE_COUNT]);
    let d = max_relative_difference(&merged_tiles, &single);
    eprintln!("tiles merged: max relative difference {d:e}");
    assert!(
        d < 1e-5,
        "merged tiles differ from the single render by {d}"
    );
    // The merged RGB image and PNG exist too.
    assert!(dir.path().join("tiles.exr").exists() && dir.path().join("tiles.png").exists());
}

#[test]
fn parts_that_do_not_belong_together_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let a = render(dir.path(), "a", &["--samples", "0..4"]);
    let overlapping = render(dir.path(), "b", &["--samples", "2..6"]);
    let other_seed = render(dir.path(), "c", &["--samples", "4..6", "--seed", "9"]);
    let other_layout = render(
        dir.path(),
        "d",
        &["--samples", "4..6", "--spectral-buckets", "20"],
    );
    let other_size = dir.path().join("e");
    ok(&[
        "render",
        SCENE,
        "-q",
        "--resolution",
        "20x12",
        "--samples",
        "4..6",
        "-o",
        other_size.to_str().unwrap(),
    ]);
    let other_size = other_size.with_extension("spectral.exr");
    let rgb_only = dir.path().join("a.exr");
    for (part, expect) in [
        (&overlapping, "overlap"),
        (&other_seed, "seeds"),
        (&other_layout, "spectral layouts"),
        (&other_size, "resolutions"),
        (&rgb_only, "not a partial render"),
    ] {
        let out = prism(&[
            "merge",
            "-o",
            dir.path().join("m").to_str().unwrap(),
            a.to_str().unwrap(),
            part.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(err.contains(expect), "expected `{expect}` in: {err}");
    }
}

#[test]
fn splatting_parts_merge_exactly_and_regions_are_refused() {
    for kind in ["light", "bdpt"] {
        parts_merge(kind);
        region_refused(kind);
    }
}

/// Photon mapping's iterations are independent estimates (each with its
/// own radius, fixed by its index): iteration ranges merge exactly.
#[test]
fn photon_mapped_iteration_ranges_merge_exactly() {
    parts_merge("sppm");
}

fn parts_merge(kind: &str) {
    // Splats land anywhere, yet each part's pixels are its splat sums over
    // its own sample count: sample ranges still merge to the single render.
    let dir = tempfile::tempdir().unwrap();
    let light = ["--integrator", kind];
    let single = spectral_exr::read(&render(
        dir.path(),
        "single",
        &[&light[..], &["--spp", "6"]].concat(),
    ))
    .unwrap();
    let parts = [
        render(
            dir.path(),
            "a",
            &[&light[..], &["--samples", "0..2"]].concat(),
        ),
        render(
            dir.path(),
            "b",
            &[&light[..], &["--samples", "2..6"]].concat(),
        ),
    ];
    let merged = dir.path().join("merged");
    let mut args = vec!["merge", "-o", merged.to_str().unwrap()];
    args.extend(parts.iter().map(|p| p.to_str().unwrap()));
    ok(&args);
    let merged = spectral_exr::read(&merged.with_extension("spectral.exr")).unwrap();
    assert_eq!(merged.attributes["prismIntegrator"], kind);
    let d = max_relative_difference(&merged, &single);
    eprintln!("{kind}: sample ranges merged: max relative difference {d:e}");
    assert!(d < 1e-5, "merged differs from the single render by {d}");
}

/// A region of a splatting render is not the region's light: refused.
fn region_refused(kind: &str) {
    let dir = tempfile::tempdir().unwrap();
    let out = prism(&[
        "render",
        SCENE,
        "-q",
        "--integrator",
        kind,
        "--tile",
        "0,0,8,8",
        "-o",
        dir.path().join("tile").to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("not a region"), "{err}");
}

/// A merge writes the PNG and the EXR as the render would: the parts carry
/// their colour space, display, gamut and bit depth.
#[test]
fn merged_parts_keep_their_colour_space_and_display() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(
        &scene,
        "[camera]\nposition = [0, 1, -4]\nlook_at = [0, 0.5, 0]\n\
         [film]\nresolution = [24, 16]\nspp = 16\ncolour_space = \"acescg\"\n\
         display = \"display-p3\"\npng_bits = 16\ngamut = \"map\"\nwhite_balance = \"A\"\n\
         [materials.red]\ntype = \"diffuse\"\nreflectance = { rgb = [0.9, 0.1, 0.05] }\n\
         [[shape]]\ntype = \"quad\"\nvertices = [[-3, 0, -3], [-3, 0, 3], [3, 0, 3], [3, 0, -3]]\nmaterial = \"red\"\n\
         [[shape]]\ntype = \"sphere\"\ncenter = [0, 3, 0]\nradius = 0.5\nemission = \"A\"\n",
    )
    .unwrap();
    let scene = scene.to_str().unwrap();
    let stem = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    ok(&["render", scene, "-q", "--uniform", "-o", &stem("whole")]);
    for (name, range) in [("a", "0..7"), ("b", "7..16")] {
        ok(&["render", scene, "-q", "-o", &stem(name), "--samples", range]);
    }
    ok(&[
        "merge",
        &format!("{}.spectral.exr", stem("a")),
        &format!("{}.spectral.exr", stem("b")),
        "-o",
        &stem("merged"),
    ]);
    let png = |name: &str| {
        let path = format!("{}.png", stem(name));
        let bytes = std::fs::read(&path).unwrap();
        let at = bytes.windows(4).position(|w| w == b"cICP").unwrap();
        assert_eq!(&bytes[at + 4..at + 8], &[12, 13, 0, 1], "{path}");
        image::open(&path).unwrap().to_rgb16().into_raw()
    };
    let (whole, merged) = (png("whole"), png("merged"));
    // The merge goes through the float32 RGB of the parts: a level at most.
    let worst = whole
        .iter()
        .zip(&merged)
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap();
    assert!(worst <= 2, "16-bit levels apart: {worst}");
    for name in ["whole", "merged"] {
        let exr = spectral_exr::read(Path::new(&format!("{}.spectral.exr", stem(name)))).unwrap();
        assert_eq!(exr.attributes["prismColourSpace"], "acescg");
    }
}

#[test]
fn a_merge_that_leaves_pixels_uncovered_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let part = render(dir.path(), "left", &["--tile", "0,0,20,24", "--spp", "2"]);
    let out = prism(&[
        "merge",
        part.to_str().unwrap(),
        "-o",
        dir.path().join("m").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("480 of 960 pixels are in no part"), "{err}");
    assert!(err.contains("merged 1 part ("), "{err}");
}

#[test]
fn a_part_whose_samples_lie_outside_its_claimed_region_is_refused() {
    // A tile copied and forged to claim the other half, where its samples
    // are not: merged with the original, the left half would count its
    // samples twice. The per-pixel sample counts give it away.
    let dir = tempfile::tempdir().unwrap();
    let left = render(
        dir.path(),
        "left",
        &["--samples", "0..4", "--tile", "0,0,20,24"],
    );
    let mut forged = spectral_exr::read(&left).unwrap();
    forged.attributes.insert(
        prism::merge::ATTR_REGION.to_string(),
        "20,0,40,24".to_string(),
    );
    let forged_path = dir.path().join("forged.spectral.exr");
    spectral_exr::write_image(forged, &forged_path).unwrap();
    let out = prism(&[
        "merge",
        "-o",
        dir.path().join("m").to_str().unwrap(),
        left.to_str().unwrap(),
        forged_path.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("outside the part's region"), "{err}");
}

#[test]
fn parts_rendered_before_and_after_a_loaded_file_changed_are_refused() {
    // The scene file is the same; the spectrum file it loads is not.
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("lamp.toml");
    std::fs::write(
        &scene,
        "[camera]\nposition = [0, 0, -3]\nlook_at = [0, 0, 0]\n[film]\nresolution = [8, 8]\n\
         [[shape]]\ntype = \"sphere\"\nradius = 1\nemission = { file = \"lamp.csv\" }\n",
    )
    .unwrap();
    let part = |name: &str, samples: &str| {
        let stem = dir.path().join(name);
        ok(&[
            "render",
            scene.to_str().unwrap(),
            "-q",
            "--samples",
            samples,
            "-o",
            stem.to_str().unwrap(),
        ]);
        stem.with_extension("spectral.exr")
    };
    std::fs::write(dir.path().join("lamp.csv"), "400,1\n700,1\n").unwrap();
    let a = part("a", "0..2");
    let same = part("same", "2..4");
    std::fs::write(dir.path().join("lamp.csv"), "400,1\n700,2\n").unwrap();
    let b = part("b", "4..6");
    let merged = dir.path().join("m");
    ok(&[
        "merge",
        "-o",
        merged.to_str().unwrap(),
        a.to_str().unwrap(),
        same.to_str().unwrap(),
    ]);
    let out = prism(&[
        "merge",
        "-o",
        merged.to_str().unwrap(),
        a.to_str().unwrap(),
        b.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("different scenes"), "{err}");
}
