//! Bad input, round 3: each case failed before its fix (a panic, a silent
//! non-finite image, an unending render, or files that were not one set)
//! and is refused or handled now.

use std::path::Path;
use std::process::{Command, Output};

use prism::light::LightSource;
use prism::load::load_str;

const CAMERA: &str = "[camera]\nposition = [0, 1, -4]\nlook_at = [0, 0.5, 0]\n";

fn prism(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_prism"))
        .args(args)
        .current_dir(cwd)
        .output()
        .unwrap()
}

/// `prism render` of the Cornell Box to `stem`, quietly, with `extra` flags.
fn render_cornell(stem: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "render",
        "scenes/cornell-box.toml",
        "-q",
        "-o",
        stem.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    prism(&args, Path::new(env!("CARGO_MANIFEST_DIR")))
}

fn refused(text: &str) -> String {
    match load_str(text, Path::new(env!("CARGO_MANIFEST_DIR"))) {
        Ok(_) => panic!("loaded:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Durations the clock cannot add to an instant, and an infinite log
/// interval, panicked (exit 101); they are a command-line error (exit 2).
#[test]
fn durations_beyond_the_clock_are_refused_not_a_panic() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.toml"), CAMERA).unwrap();
    for (flag, value) in [
        ("--time", "99999999999999999999h"),
        ("--time", "18446744073709551616s"),
        ("--log-every", "inf"),
        ("--log-every", "1e30"),
        ("--preview-every", "1e300"),
    ] {
        let out = prism(&["render", "s.toml", flag, value], dir.path());
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{flag} {value}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

/// A float that is finite in TOML (f64) but infinite as f32 was read as
/// infinity (`environment.rotate = 1e39` made NaN directions, dropped
/// silently).
#[test]
fn numbers_beyond_single_precision_are_refused_naming_the_key() {
    let e = refused(&format!(
        "{CAMERA}[environment]\nfile = \"scenes/assets/studio.hdr\"\nrotate = 1e39\n"
    ));
    assert!(
        e.contains("`environment.rotate`") && e.contains("beyond single precision"),
        "{e}"
    );
}

/// Environment emission escaped the 1e30 limit shapes and lights have.
#[test]
fn environment_emission_beyond_f32_is_refused() {
    for (keys, key) in [
        (
            "sky = { sun_elevation = 30, sun_scale = 1e38 }",
            "sun_scale",
        ),
        (
            "sky = { sun_elevation = 30, sky_scale = 1e38 }",
            "sky_scale",
        ),
        (
            "sky = { sun_elevation = 30 }\nscale = 1e25",
            "environment.scale",
        ),
    ] {
        let e = refused(&format!("{CAMERA}[environment]\n{keys}\n"));
        assert!(e.contains(key) && e.contains("f32"), "{keys}: {e}");
    }
    // A map whose brightest texel times the scale passes the limit.
    let dir = tempfile::tempdir().unwrap();
    let mut img = image::Rgb32FImage::new(4, 2);
    img.put_pixel(1, 1, image::Rgb([1e20, 1.0, 1.0]));
    img.save(dir.path().join("hot.hdr")).unwrap();
    let text = format!("{CAMERA}[environment]\nfile = \"hot.hdr\"\nscale = 1e12\n");
    let e = match load_str(&text, dir.path()) {
        Ok(_) => panic!("a map beyond f32 loaded"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("brightest texel") && e.contains("1e30"), "{e}");
    assert!(load_str(&text.replace("1e12", "1"), dir.path()).is_ok());
}

/// Unbounded work: 2³²−1 photons an iteration, or bounces, ran on and on.
#[test]
fn unbounded_work_is_refused_before_rendering() {
    for (keys, key) in [
        (
            "type = \"sppm\"\nphotons = 4294967295",
            "integrator.photons",
        ),
        ("max_depth = 4294967295", "integrator.max_depth"),
        (
            "type = \"bdpt\"\nmax_depth = 4294967295",
            "integrator.max_depth",
        ),
        ("type = \"sppm\"\nradius = 1e-30", "integrator.radius"),
        (
            "type = \"sppm\"\nspectral_radius = 1e-30",
            "integrator.spectral_radius",
        ),
    ] {
        let e = refused(&format!("{CAMERA}[integrator]\n{keys}\n"));
        assert!(e.contains(key), "{keys}: {e}");
    }
    let fine = format!("{CAMERA}[integrator]\nmax_depth = 131072\n");
    assert!(load_str(&fine, Path::new(".")).is_ok());
}

/// A spot light given by power with a cone of 0.01° had a solid angle of 0
/// in f32 and was dropped silently (then "no light" was warned, wrongly).
#[test]
fn a_spot_too_narrow_for_f32_is_refused_and_a_narrow_one_keeps_its_power() {
    let spot = |angle: f32| {
        format!(
            "{CAMERA}[[light]]\ntype = \"spot\"\nposition = [0, 2, 0]\nlook_at = [0, 0, 0]\n\
             power = 10\ncone_angle = {angle}\nfalloff_start = 0\n"
        )
    };
    let e = refused(&spot(0.01));
    assert!(
        e.contains("light[0].cone_angle") && e.contains("single precision"),
        "{e}"
    );
    // At 0.1° the power spread over the cone gives the closed-form
    // intensity: Φ / (2π(1 − (1 + cos θ)/2)) with θ = 0.1°.
    let loaded = load_str(&spot(0.1), Path::new(env!("CARGO_MANIFEST_DIR"))).unwrap();
    assert!(
        loaded.report.warnings.is_empty(),
        "{:?}",
        loaded.report.warnings
    );
    let theta = 0.1f64.to_radians();
    let expected = 10.0 / (2.0 * std::f64::consts::PI * (1.0 - (1.0 + theta.cos()) / 2.0));
    let intensity = loaded.scene.lights.get(0).spectrum().unwrap().eval(550.0) as f64;
    assert!(
        (intensity / expected - 1.0).abs() < 1e-3,
        "intensity {intensity}, expected {expected}"
    );
}

/// `--adaptive` parts held up to 16× their range's samples and merged with
/// exit 0, counting sample indices twice.
#[test]
fn adaptive_renders_are_not_parts() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let out = prism(
        &[
            "render",
            "scenes/cornell-box.toml",
            "--adaptive",
            "--samples",
            "0..4",
        ],
        root,
    );
    assert_eq!(
        out.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stem = dir.path().join("adaptive");
    let out = render_cornell(
        &stem,
        &["--adaptive", "--spp", "8", "--resolution", "24x16"],
    );
    assert!(out.status.success());
    let part = dir.path().join("part");
    let out = render_cornell(&part, &["--samples", "8..16", "--resolution", "24x16"]);
    assert!(out.status.success());
    let merged = dir.path().join("merged");
    let out = prism(
        &[
            "merge",
            stem.with_extension("spectral.exr").to_str().unwrap(),
            part.with_extension("spectral.exr").to_str().unwrap(),
            "-o",
            merged.to_str().unwrap(),
        ],
        root,
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("adaptive"), "{err}");
}

/// `prism merge` replaced its files one by one: with OUT.png a folder,
/// OUT.exr and OUT.spectral.exr were already replaced when it failed.
#[test]
fn a_merge_replaces_its_files_as_one_set_or_none() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let part = dir.path().join("part");
    let out = render_cornell(&part, &["--samples", "0..2", "--resolution", "24x16"]);
    assert!(out.status.success());
    let out_stem = dir.path().join("out");
    std::fs::write(out_stem.with_extension("exr"), b"old exr").unwrap();
    std::fs::write(out_stem.with_extension("spectral.exr"), b"old spectral").unwrap();
    std::fs::create_dir(out_stem.with_extension("png")).unwrap();
    let out = prism(
        &[
            "merge",
            part.with_extension("spectral.exr").to_str().unwrap(),
            "-o",
            out_stem.to_str().unwrap(),
        ],
        root,
    );
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(
        std::fs::read(out_stem.with_extension("exr")).unwrap(),
        b"old exr"
    );
    assert_eq!(
        std::fs::read(out_stem.with_extension("spectral.exr")).unwrap(),
        b"old spectral"
    );
    let hidden: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with('.'))
        .collect();
    assert!(hidden.is_empty(), "temporaries left: {hidden:?}");
}

/// `--no-spectral` over an earlier render left its NAME.spectral.exr beside
/// the new NAME.exr and NAME.png.
#[test]
fn no_spectral_over_an_earlier_render_takes_its_spectral_file_away() {
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("r");
    let render = |extra: &[&str]| {
        let out = render_cornell(
            &stem,
            &[&["--spp", "2", "--resolution", "24x16"], extra].concat(),
        );
        assert!(out.status.success());
    };
    render(&[]);
    assert!(stem.with_extension("spectral.exr").exists());
    render(&["--no-spectral"]);
    assert!(stem.with_extension("exr").exists() && stem.with_extension("png").exists());
    assert!(!stem.with_extension("spectral.exr").exists());
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    assert_eq!(left.len(), 2, "{left:?}");
}

/// The budget was MemAvailable or `--max-memory` alone: under `ulimit -v`
/// (RLIMIT_AS, as clusters set it) a render that fits the machine but not
/// the address space aborted in the allocator. The address space left is
/// part of the budget now, and the refusal names it.
#[test]
fn the_memory_budget_honours_the_address_space_limit() {
    let dir = tempfile::tempdir().unwrap();
    let scene = format!(
        "{CAMERA}[film]\nresolution = [3000, 3000]\n\
         [[shape]]\ntype = \"sphere\"\nradius = 1\nemission = 1\n"
    );
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    let out = Command::new("bash")
        .args([
            "-c",
            "ulimit -v 2097152 && exec \"$PRISM\" render s.toml -q -o out",
        ])
        .env("PRISM", env!("CARGO_BIN_EXE_prism"))
        .current_dir(dir.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("the film (3000x3000 pixels") && err.contains("ulimit -v"),
        "{err}"
    );
}

/// The address space a process reserves is what `ulimit -v` limits: a
/// scene that fit in memory aborted under the limit because the build
/// reserved twice its geometry's worth of address space it never touched
/// (vectors reserved for the BVH's worst case, grown by doubling). Now the
/// peak of the address space stays near the peak of memory used: 1.90 GB
/// against 0.97 GB used for this sphere before, 0.97 against 0.87 now
/// (malloc's per-thread arenas, 64 MiB each, limited to two).
#[test]
fn a_large_build_reserves_little_address_space_beyond_what_it_uses() {
    let dir = tempfile::tempdir().unwrap();
    let scene = format!(
        "{CAMERA}[film]
resolution = [32, 32]
spp = 1
         [[shape]]
type = \"sphere\"\nradius = 1\ntessellate = true\nsegments = 2048\n         [[shape]]\ntype = \"sphere\"\ncenter = [0, 3, 0]\nradius = 0.5\nemission = 1\n"
    );
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_prism"))
        .args(["render", "s.toml", "-q", "-o", "out", "--threads", "2"])
        .current_dir(dir.path())
        .spawn()
        .unwrap();
    let status = format!("/proc/{}/status", child.id());
    let kib = |text: &str, key: &str| -> u64 {
        let line = text.lines().find(|l| l.starts_with(key)).unwrap();
        line.split_whitespace().nth(1).unwrap().parse().unwrap()
    };
    // Both are peaks: the last reading before the process ends has them.
    let mut last = None;
    while child.try_wait().unwrap().is_none() {
        if let Ok(text) = std::fs::read_to_string(&status) {
            if text.contains("VmHWM") {
                last = Some((kib(&text, "VmPeak:"), kib(&text, "VmHWM:")));
            }
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let (peak, used) = last.expect("the render ran");
    assert!(
        peak < used + used * 35 / 100,
        "address space peak {peak} KiB against {used} KiB used"
    );
}

/// A file larger than the budget was read whole before any check (a
/// sparse file of gigabytes as an environment map aborted even under
/// `--max-memory`).
#[test]
fn an_input_file_larger_than_the_budget_is_refused_before_it_is_read() {
    let dir = tempfile::tempdir().unwrap();
    let map = std::fs::File::create(dir.path().join("sparse.hdr")).unwrap();
    map.set_len(3 << 30).unwrap(); // sparse: no disk used
    let scene = format!("{CAMERA}[environment]\nfile = \"sparse.hdr\"\n");
    std::fs::write(dir.path().join("s.toml"), scene).unwrap();
    let out = prism(
        &["--max-memory", "1G", "render", "s.toml", "-q", "-o", "out"],
        dir.path(),
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("sparse.hdr")
            && err.contains("reading the file")
            && err.contains("--max-memory"),
        "{err}"
    );
}

/// MTL values were used or dropped without a word (`d -1`, `Kd nan`,
/// `Ni -2`, `Ke 1e38`): each is a warning naming file, line, key and
/// material now, and an emission beyond f32 is an error.
#[test]
fn mtl_values_are_checked_naming_file_line_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";
    std::fs::write(dir.path().join("q.obj"), obj).unwrap();
    let scene = format!("{CAMERA}[[shape]]\ntype = \"obj\"\nfile = \"q.obj\"\n");
    let mtl = "newmtl a\nKd nan 0.5 0.5\nd -1\nNi -2\nKs 0.1 -3 0\nKe 2 2 2\n";
    std::fs::write(dir.path().join("m.mtl"), mtl).unwrap();
    let loaded = load_str(&scene, dir.path()).unwrap();
    let warnings = loaded.report.warnings.join("\n");
    for (line, key) in [(2, "Kd"), (3, "d"), (4, "Ni"), (5, "Ks")] {
        assert!(
            warnings.contains(&format!("m.mtl:{line}: `{key}` of material `a`")),
            "{key}: {warnings}"
        );
    }
    std::fs::write(dir.path().join("m.mtl"), "newmtl a\nKe 1e38 0 0\n").unwrap();
    let e = match load_str(&scene, dir.path()) {
        Ok(_) => panic!("an emission of 1e38 loaded"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains("m.mtl:2: `Ke` of material `a`") && e.contains("1e30"),
        "{e}"
    );
}

/// Concurrent renders to one name gave a mixed set (one render's EXR
/// beside the other's spectral EXR) in 1 of 6 trials: each set is moved
/// into place under the folder's lock now, so whichever comes last is
/// whole.
#[test]
fn concurrent_renders_to_one_name_leave_one_whole_set() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("same");
    for trial in 0..16 {
        let spawn = |seed: u32| {
            Command::new(env!("CARGO_BIN_EXE_prism"))
                .args([
                    "render",
                    "scenes/cornell-box.toml",
                    "--spp",
                    "1",
                    "--resolution",
                    "64x48",
                    "-q",
                ])
                .args([
                    "--seed",
                    &(seed + 100 * trial).to_string(),
                    "-o",
                    stem.to_str().unwrap(),
                ])
                .current_dir(root)
                .spawn()
                .unwrap()
        };
        let (mut a, mut b) = (spawn(1), spawn(2));
        assert!(a.wait().unwrap().success() && b.wait().unwrap().success());
        let spectral =
            prism::film::spectral_exr::read(&stem.with_extension("spectral.exr")).unwrap();
        let (_, _, rgb) = prism::film::output::read_rgb_exr(&stem.with_extension("exr")).unwrap();
        let same = rgb.iter().enumerate().all(|(i, c)| {
            [
                spectral.other["R"][i],
                spectral.other["G"][i],
                spectral.other["B"][i],
            ] == [c.x, c.y, c.z]
        });
        assert!(
            same,
            "trial {trial}: the EXR and the spectral EXR come from different renders"
        );
    }
}

/// With `--preview-every`, a SIGKILL left the new preview PNG beside the
/// old EXRs (a mixed set). The preview has a name of its own now: the
/// earlier set stays whole.
#[test]
fn a_killed_render_with_previews_leaves_the_earlier_set_whole() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let stem = dir.path().join("cb");
    let args = [
        "render",
        "scenes/cornell-box.toml",
        "-q",
        "--resolution",
        "64x48",
    ];
    let done = render_cornell(&stem, &["--resolution", "64x48", "--spp", "2"]);
    assert!(done.status.success());
    let earlier = std::fs::read(stem.with_extension("png")).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_prism"))
        .args(args)
        .args([
            "--spp",
            "1000000",
            "--preview-every",
            "0.1",
            "--seed",
            "9",
            "-o",
        ])
        .arg(&stem)
        .current_dir(root)
        .spawn()
        .unwrap();
    let preview = stem.with_extension("preview.png");
    let start = std::time::Instant::now();
    while !preview.exists() && start.elapsed().as_secs() < 30 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    assert!(preview.exists(), "no preview was written");
    assert_eq!(std::fs::read(stem.with_extension("png")).unwrap(), earlier);
}
