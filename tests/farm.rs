//! The render-farm recipes in tools/farm run as documented: GNU parallel
//! with several local processes, and the Slurm array task script driven by
//! the variables Slurm would set. Both merge to the single render.

use std::path::Path;
use std::process::Command;

use prism::film::spectral_exr::{self, SAMPLE_COUNT};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

fn run(cmd: &mut Command) {
    let out = cmd
        .current_dir(ROOT)
        .env("PRISM", env!("CARGO_BIN_EXE_prism"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{cmd:?}: {}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A small copy of the Cornell Box scene (the farm scripts take the scene's own resolution).
fn small_scene(dir: &Path) -> String {
    let text = std::fs::read_to_string(Path::new(ROOT).join("scenes/cornell-box.toml"))
        .unwrap()
        .replace("resolution = [512, 512]", "resolution = [32, 32]")
        .replace("\"../spectra/", &format!("\"{ROOT}/spectra/"))
        .replace("\"cornell/", &format!("\"{ROOT}/scenes/cornell/"));
    let path = dir.join("small.toml");
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

fn assert_matches_single(dir: &Path, scene: &str, merged: &Path, spp: u32) {
    let single = dir.join("single");
    run(Command::new(env!("CARGO_BIN_EXE_prism"))
        .args([
            "render",
            scene,
            "-q",
            "--uniform",
            "--spp",
            &spp.to_string(),
            "-o",
        ])
        .arg(&single));
    let a = spectral_exr::read(&single.with_extension("spectral.exr")).unwrap();
    let b = spectral_exr::read(&merged.with_extension("spectral.exr")).unwrap();
    assert_eq!(a.other[SAMPLE_COUNT], b.other[SAMPLE_COUNT]);
    for (pa, pb) in a.spectral.iter().zip(&b.spectral) {
        for (x, y) in pa.iter().zip(pb) {
            assert!((x - y).abs() <= 1e-5 * x.abs().max(y.abs()), "{x} vs {y}");
        }
    }
}

#[test]
fn gnu_parallel_flavour() {
    if Command::new("parallel").arg("--version").output().is_err() {
        // CI installs GNU parallel (.ci/run); there this test must run.
        assert!(
            std::env::var_os("CI").is_none(),
            "GNU parallel is missing on CI"
        );
        eprintln!("skipped: GNU parallel is not installed (apt-get install parallel)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = small_scene(dir.path());
    let out = dir.path().join("farm/cbox");
    run(Command::new("bash").args([
        "tools/farm/render-parallel.sh",
        &scene,
        out.to_str().unwrap(),
        "12",
        "4",
        "-j",
        "3",
    ]));
    assert!(dir.path().join("farm/cbox.part3.spectral.exr").exists());
    assert!(dir.path().join("farm/cbox.png").exists());
    assert_matches_single(dir.path(), &scene, &out, 12);
}

#[test]
fn slurm_array_task_script() {
    let dir = tempfile::tempdir().unwrap();
    let scene = small_scene(dir.path());
    let out = dir.path().join("cbox");
    for task in 0..3 {
        run(Command::new("bash")
            .arg("tools/farm/slurm-array.sbatch")
            .env("SCENE", &scene)
            .env("OUT", &out)
            .env("SPP", "10")
            .env("SLURM_ARRAY_TASK_ID", task.to_string())
            .env("SLURM_ARRAY_TASK_COUNT", "3")
            .env("SLURM_CPUS_PER_TASK", "1"));
    }
    let parts: Vec<String> = (0..3)
        .map(|i| format!("{}.part{i}.spectral.exr", out.display()))
        .collect();
    run(Command::new(env!("CARGO_BIN_EXE_prism"))
        .args(["merge", "-o"])
        .arg(&out)
        .args(&parts));
    let merged = spectral_exr::read(&out.with_extension("spectral.exr")).unwrap();
    assert_eq!(merged.attributes["prismSampleRange"], "0..10");
    assert_matches_single(dir.path(), &scene, &out, 10);
    // The submit script at least parses.
    run(Command::new("bash").args(["-n", "tools/farm/slurm-submit.sh"]));
}
