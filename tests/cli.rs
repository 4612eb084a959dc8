//! The command line end to end: renders write readable images, bad input
//! exits non-zero with a message and no panic, and renders are reproducible.

use std::path::Path;
use std::process::Command;

use crate::common;

fn prism() -> Command {
    Command::new(env!("CARGO_BIN_EXE_prism"))
}

pub(crate) const SCENE: &str = r#"
[camera]
position = [0, 1, -4]
look_at = [0, 0.5, 0]

[film]
resolution = [24, 16]
spp = 4

[[shape]]
type = "quad"
vertices = [[-5, 0, -5], [-5, 0, 5], [5, 0, 5], [5, 0, -5]]

[[shape]]
type = "sphere"
center = [0, 3, 0]
radius = 0.5
emission = "D65"
emission_scale = 10
"#;

#[test]
fn render_writes_exr_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("tiny.toml");
    std::fs::write(&scene, SCENE).unwrap();
    succeed(
        prism()
            .args(["render", "--quiet", "--threads", "2"])
            .arg(&scene),
    );
    let png = image::open(dir.path().join("tiny.png")).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (24, 16));
    assert!(png.pixels().any(|p| p.0 != [0, 0, 0]), "the image is black");
    let exr = exr::prelude::read_first_rgba_layer_from_file(
        dir.path().join("tiny.exr"),
        |res, _| vec![[0f32; 3]; res.width() * res.height()],
        |px: &mut Vec<[f32; 3]>, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * 24 + pos.x()] = [r, g, b]
        },
    )
    .unwrap();
    let pixels = &exr.layer_data.channel_data.pixels;
    assert!(pixels
        .iter()
        .all(|p| p.iter().all(|v| v.is_finite() && *v >= -1e-3)));
    // No temporary files are left behind.
    let names = file_names(dir.path());
    assert!(names.iter().all(|n| !n.contains("partial")), "{names:?}");
}

#[test]
fn output_option_and_determinism_across_threads() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    // 200×150: several 64² EXR tiles, which the exr crate compresses in
    // parallel (once written in the order they finished).
    for (threads, name) in [("1", "one"), ("2", "two")] {
        succeed(
            prism()
                .args([
                    "render",
                    "-q",
                    "--threads",
                    threads,
                    "--resolution",
                    "200x150",
                    "--spp",
                    "1",
                    "-o",
                ])
                .arg(dir.path().join(format!("{name}.png")))
                .arg(&scene),
        );
    }
    for ext in ["exr", "spectral.exr", "png"] {
        let a = std::fs::read(dir.path().join(format!("one.{ext}"))).unwrap();
        let b = std::fs::read(dir.path().join(format!("two.{ext}"))).unwrap();
        assert!(
            a == b,
            "the same scene and seed gave different .{ext} bytes with 1 and 2 threads"
        );
    }
}

/// The names of the files in `dir`, in no particular order.
fn file_names(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into())
        .collect()
}

fn succeed(cmd: &mut Command) {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn failing(args: &[&str], cwd: &Path) -> String {
    let out = prism().args(args).current_dir(cwd).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    err
}

#[test]
fn bad_input_exits_with_a_message() {
    let dir = tempfile::tempdir().unwrap();
    let err = failing(&["render", "missing.toml"], dir.path());
    assert!(
        err.contains("missing.toml") && err.contains("cannot read"),
        "{err}"
    );
    std::fs::write(dir.path().join("bad.toml"), "[camera\n").unwrap();
    let err = failing(&["render", "bad.toml"], dir.path());
    assert!(err.contains("bad.toml") && err.contains("line 1"), "{err}");
    std::fs::write(dir.path().join("ok.toml"), SCENE).unwrap();
    let err = failing(
        &["render", "ok.toml", "-o", "no/such/folder/out"],
        dir.path(),
    );
    assert!(err.contains("does not exist"), "{err}");
    let err = failing(&["render", "ok.toml", "--spp", "0"], dir.path());
    assert!(err.contains("--spp"), "{err}");
}

#[test]
fn sigterm_writes_the_samples_done_so_far() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("long.toml");
    // Far more samples than a second allows.
    std::fs::write(&scene, SCENE.replace("spp = 4", "spp = 1000000")).unwrap();
    let child = prism()
        .args(["render", "--threads", "2", "-q", "--uniform"])
        .arg(&scene)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(1500));
    let status = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(
        err.contains("interrupted after the pass under way: every pixel has"),
        "{err}"
    );
    let png = image::open(dir.path().join("long.png")).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (24, 16));
    assert!(png.pixels().any(|p| p.0 != [0, 0, 0]));
    let img = prism::film::spectral_exr::read(&dir.path().join("long.spectral.exr")).unwrap();
    assert_eq!(img.attributes["prismInterrupted"], "true");
    // Whole passes: every pixel has the same samples.
    let counts = &img.other["sampleCount"];
    assert!(
        counts
            .iter()
            .all(|c| *c == counts[0] && (1.0..1_000_000.0).contains(c)),
        "{:?}",
        &counts[..4]
    );
    let names = file_names(dir.path());
    assert!(names.iter().all(|n| !n.contains("partial")), "{names:?}");
}

#[test]
fn interrupts_while_writing_let_the_files_finish_as_one_set() {
    use std::io::BufRead;
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("big.toml"), SCENE).unwrap();
    // 512² with 400 buckets: writing takes a second or more.
    let mut child = prism()
        .args([
            "render",
            "big.toml",
            "--spp",
            "1",
            "--resolution",
            "512x512",
        ])
        .args(["--spectral-buckets", "400", "--threads", "2"])
        .current_dir(dir.path())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut err = String::new();
    let mut lines = std::io::BufReader::new(child.stderr.take().unwrap()).lines();
    for line in lines.by_ref() {
        let line = line.unwrap();
        err += &line;
        err += "\n";
        if line.starts_with("rendered ") {
            break;
        }
    }
    // Two interrupts as the writing begins: once, the second one exited
    // with "exiting without writing" and left a half-written file.
    for _ in 0..2 {
        let pid = child.id() as libc::pid_t;
        // SAFETY: kill only sends a signal to our child.
        assert_eq!(unsafe { libc::kill(pid, libc::SIGTERM) }, 0);
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    for line in lines {
        err += &line.unwrap();
        err += "\n";
    }
    let status = child.wait().unwrap();
    assert!(!err.contains("without writing"), "{err}");
    assert_eq!(status.code(), Some(0), "{err}");
    let names = file_names(dir.path());
    assert!(names.iter().all(|n| !n.contains("partial")), "{names:?}");
    let img = prism::film::spectral_exr::read(&dir.path().join("big.spectral.exr")).unwrap();
    assert_eq!((img.width, img.spectral.len()), (512, 400));
    assert!(image::open(dir.path().join("big.png")).is_ok());
    assert!(dir.path().join("big.exr").exists());
}

#[test]
fn resource_failures_and_command_line_values_are_errors_not_panics() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ok.toml"), SCENE).unwrap();
    // 5000 threads under a 4 GiB address space: the pool cannot start.
    let out = Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 4000000; exec {} render ok.toml -q --threads 5000 --spp 1 --resolution 8x8",
            env!("CARGO_BIN_EXE_prism")
        ))
        .current_dir(dir.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("cannot start 5000 worker threads"), "{err}");
    // Overrides are checked like the file's values, naming the flag.
    let err = failing(
        &["render", "ok.toml", "--spectral-range", "300,900"],
        dir.path(),
    );
    assert!(err.contains("--spectral-range"), "{err}");
    let err = failing(&["render", "ok.toml", "--exposure", "NaN"], dir.path());
    assert!(err.contains("exposure"), "{err}");
    // A part without its R channel: merge refuses it.
    succeed(
        prism()
            .args([
                "render",
                "ok.toml",
                "-q",
                "--uniform",
                "--spp",
                "1",
                "--resolution",
                "8x8",
                "-o",
                "part",
            ])
            .current_dir(dir.path()),
    );
    let part = dir.path().join("part.spectral.exr");
    let mut img = prism::film::spectral_exr::read(&part).unwrap();
    img.other.remove("R");
    prism::film::spectral_exr::write_image(img, &part).unwrap();
    let err = failing(&["merge", "part.spectral.exr", "-o", "merged"], dir.path());
    assert!(err.contains("no `R` channel"), "{err}");
}

#[test]
fn an_output_folder_gets_files_named_like_the_scene_and_long_names_are_refused_first() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    // `-o DIR/` and `-o .` (from inside the folder).
    succeed(
        prism()
            .args(["render", "-q", "-o"])
            .arg(format!("{}/", out.display()))
            .arg(&scene),
    );
    succeed(
        prism()
            .args(["render", "-q", "-o", "."])
            .arg(&scene)
            .current_dir(&out),
    );
    let mut names = file_names(&out);
    names.sort();
    assert_eq!(names, ["s.exr", "s.png", "s.spectral.exr"]);
    // A name that cannot hold its suffixes fails before rendering, and
    // writes nothing.
    let long = "x".repeat(240);
    let err = failing(&["render", "-q", "-o", &long, "../s.toml"], &out);
    assert!(err.contains("too long"), "{err}");
    assert_eq!(std::fs::read_dir(&out).unwrap().count(), 3);
}

#[test]
fn a_failed_write_leaves_the_earlier_set_whole_and_no_temporary_files() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    succeed(
        prism()
            .args(["render", "-q", "-o", "out"])
            .arg(&scene)
            .current_dir(dir.path()),
    );
    let before = std::fs::read(dir.path().join("out.exr")).unwrap();
    // The spectral EXR's name is taken by a folder: the new set cannot be
    // completed, so none of it may replace the old files.
    std::fs::remove_file(dir.path().join("out.spectral.exr")).unwrap();
    std::fs::create_dir(dir.path().join("out.spectral.exr")).unwrap();
    let err = failing(
        &["render", "-q", "--seed", "7", "-o", "out", "s.toml"],
        dir.path(),
    );
    assert!(err.contains("out.spectral.exr"), "{err}");
    assert_eq!(
        std::fs::read(dir.path().join("out.exr")).unwrap(),
        before,
        "the old .exr stays"
    );
    let names = file_names(dir.path());
    assert!(names.iter().all(|n| !n.contains("partial")), "{names:?}");
}

#[test]
fn temporary_files_of_a_killed_render_are_cleaned_up_by_the_next_one() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    // What a SIGKILL during the write phase leaves (a process id no
    // running process has), and an unrelated file that looks alike.
    let stale = [
        ".out.partial-999999999.exr",
        ".out.spectral.partial-999999999.exr",
        ".out.preview.partial-999999999.png",
        ".out.spectral.partial-999999999.retired",
    ];
    for name in stale {
        std::fs::write(dir.path().join(name), b"half a file").unwrap();
    }
    std::fs::write(dir.path().join(".other.partial-999999999.exr"), b"not ours").unwrap();
    let out = prism()
        .args(["render", "-q", "-o", "out", "s.toml"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    if std::path::Path::new("/proc/self").exists() {
        for name in stale {
            assert!(!dir.path().join(name).exists(), "{name} left");
            assert!(err.contains(name), "{err}");
        }
    }
    assert!(dir.path().join(".other.partial-999999999.exr").exists());
}

#[test]
fn memory_bombs_are_refused_before_allocation() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // A 23000² texture declared in 57 bytes.
    std::fs::write(
        d.join("bomb.png"),
        common::assets::forged_png(23000, 23000, 2, 8, 0),
    )
    .unwrap();
    let textured = SCENE.replace(
        "[[shape]]\ntype = \"quad\"",
        "[materials.t]\ntype = \"diffuse\"\ntexture = \"bomb.png\"\n\n[[shape]]\nmaterial = \"t\"\ntype = \"quad\"",
    );
    std::fs::write(d.join("textured.toml"), textured).unwrap();
    let err = failing(&["--max-memory", "1G", "render", "textured.toml"], d);
    assert!(
        err.contains("bomb.png: the decoded image (23000x23000 texels) would need")
            && err.contains("more than the memory budget (--max-memory) of 1.00 GiB"),
        "{err}"
    );
    // Twelve spheres of 4096 segments (0.4 GiB of mesh each).
    let mut spheres = SCENE.to_string();
    for i in 0..12 {
        spheres += &format!(
            "[[shape]]\ntype = \"sphere\"\ncenter = [{i}, 0, 0]\nradius = 0.1\ntessellate = true\nsegments = 4096\n"
        );
    }
    std::fs::write(d.join("spheres.toml"), spheres).unwrap();
    let err = failing(&["--max-memory", "1G", "render", "spheres.toml"], d);
    assert!(
        err.contains("(4096 segments) would need") && err.contains("already loaded"),
        "{err}"
    );
    // A film and its output buffers beyond the budget; then a render whose
    // film fits but whose estimate does not, with the estimate's parts named.
    std::fs::write(d.join("ok.toml"), SCENE).unwrap();
    for (resolution, buckets, expect) in [
        (
            "2048x2048",
            "40",
            &["the film (2048x2048 pixels, 40 spectral buckets) would need"][..],
        ),
        (
            "512x512",
            "4",
            &["the render would need", "film", "writing"][..],
        ),
    ] {
        let err = failing(
            &[
                "--max-memory",
                "64M",
                "render",
                "ok.toml",
                "--resolution",
                resolution,
            ]
            .into_iter()
            .chain(["--spectral-buckets", buckets])
            .collect::<Vec<_>>(),
            d,
        );
        assert!(expect.iter().all(|e| err.contains(e)), "{err}");
    }
    // An EXR whose header declares 32768² pixels: `info` and `merge` refuse
    // it from the header.
    succeed(
        prism()
            .args(["render", "ok.toml", "-q", "--spp", "1", "-o", "part"])
            .current_dir(d),
    );
    let path = d.join("part.spectral.exr");
    let mut bytes = std::fs::read(&path).unwrap();
    let key = b"dataWindow\0box2i\0";
    let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len() + 4;
    for (k, v) in [0i32, 0, 32767, 32767].iter().enumerate() {
        bytes[at + 4 * k..at + 4 * k + 4].copy_from_slice(&v.to_le_bytes());
    }
    std::fs::write(&path, bytes).unwrap();
    for args in [
        vec!["--max-memory", "1G", "info", "part.spectral.exr"],
        vec![
            "--max-memory",
            "1G",
            "merge",
            "part.spectral.exr",
            "-o",
            "m",
        ],
    ] {
        let err = failing(&args, d);
        assert!(
            err.contains("part.spectral.exr: its pixels (1073741824 declared")
                && err.contains("more than the memory budget"),
            "{err}"
        );
    }
}

/// A CPU older than the build's target (x86-64-v3), the binary run under
/// QEMU as a Nehalem (SSE4.2, no AVX): where the release build embeds its
/// baseline build (build.rs) it runs that, else it says what the CPU lacks
/// and exits with status 1, never SIGILL. `.ci/run` installs `qemu-user`;
/// without it the test says so and passes, as it cannot emulate the old
/// CPU.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[test]
fn an_older_cpu_runs_the_baseline_build_or_is_told_what_it_lacks() {
    let nehalem = |binary: &str, args: &[&str]| {
        Command::new("qemu-x86_64")
            .args(["-cpu", "Nehalem", binary])
            .args(args)
            .output()
    };
    let Ok(out) = nehalem(env!("CARGO_BIN_EXE_prism"), &["--version"]) else {
        eprintln!("qemu-x86_64 not found: the old-CPU check is not exercised here");
        return;
    };
    let stderr = String::from_utf8_lossy(&out.stderr);
    if prism::cpu::BASELINE_EMBEDDED {
        assert!(out.status.success(), "{stderr}");
        assert!(String::from_utf8_lossy(&out.stdout).starts_with("prism "));
    } else {
        assert_eq!(out.status.code(), Some(1), "{stderr}");
        assert!(stderr.contains("this CPU lacks"), "{stderr}");
        assert!(stderr.contains("avx2"), "{stderr}");
        assert!(stderr.contains("target-cpu=native"), "{stderr}");
    }
    // The same binary on a CPU that has the features runs.
    succeed(Command::new("qemu-x86_64").args([
        "-cpu",
        "Haswell",
        env!("CARGO_BIN_EXE_prism"),
        "--version",
    ]));
    // QEMU runs what the binary executes on the host CPU, so the embedded
    // build itself is rendered with as a Nehalem.
    #[cfg(prism_baseline_embedded)]
    {
        let dir = tempfile::tempdir().unwrap();
        let scene = dir.path().join("s.toml");
        std::fs::write(&scene, SCENE).unwrap();
        let scene = scene.to_str().unwrap();
        let out = nehalem(env!("PRISM_BASELINE_BINARY"), &["render", scene]).unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
        assert!(stderr.contains("(x86-64 code)"), "{stderr}");
        assert!(dir.path().join("s.exr").exists());
    }
}

/// `PRISM_BASELINE=1` runs the embedded baseline x86-64 build (the one a
/// CPU without AVX2 runs): it renders the same image, bit for bit (Rust
/// fuses no multiply-adds, so the wider instructions change no result). A
/// value other than 0 or 1 is refused with a message.
#[cfg(prism_baseline_embedded)]
#[test]
fn the_baseline_build_renders_the_same_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let mut images = Vec::new();
    for (baseline, code) in [("0", "(x86-64-v3 code)"), ("1", "(x86-64 code)")] {
        let stem = dir.path().join(format!("b{baseline}"));
        let out = prism()
            .env("PRISM_BASELINE", baseline)
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(&stem)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{stderr}");
        assert!(stderr.contains(code), "{stderr}");
        images.push(std::fs::read(stem.with_extension("exr")).unwrap());
    }
    assert!(images[0] == images[1], "the two builds' images differ");
    refuses_environment_value("PRISM_BASELINE", &scene);
}

/// A render with `var=yes` in its environment is refused with a message
/// that names the variable and its value.
fn refuses_environment_value(var: &str, scene: &Path) {
    let out = prism()
        .env(var, "yes")
        .arg("render")
        .arg(scene)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains(&format!("{var}=\"yes\" is neither 0 nor 1")),
        "{stderr}"
    );
}

/// `PRISM_AVX512=0` keeps the ray packets to AVX2's eight lanes where the
/// CPU has AVX-512: the Cornell Box (which the packet core renders) comes
/// out the same, bit for bit, with sixteen lanes and with eight (each lane
/// does the single ray's operations). A value other than 0 or 1 is
/// refused with a message.
#[test]
fn sixteen_ray_packets_render_what_eight_do() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-box.toml");
    let mut images = Vec::new();
    for avx512 in ["0", "1"] {
        let stem = dir.path().join(format!("w{avx512}"));
        succeed(
            prism()
                .env("PRISM_AVX512", avx512)
                .args([
                    "render",
                    "--quiet",
                    "--resolution",
                    "48x48",
                    "--spp",
                    "8",
                    "--uniform",
                ])
                .arg(&scene)
                .arg("-o")
                .arg(&stem),
        );
        images.push(std::fs::read(stem.with_extension("exr")).unwrap());
    }
    assert!(
        images[0] == images[1],
        "eight- and sixteen-ray packets' images differ"
    );
    refuses_environment_value("PRISM_AVX512", &scene);
}

#[test]
fn the_profile_guided_build_trains_on_renders_that_run() {
    // tools/pgo-build.sh renders every line of tools/pgo-training.txt with
    // its instrumented binary: a scene renamed or an option changed would
    // stop that build minutes in. Each line here, at 16x16 and 1 spp.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let list = std::fs::read_to_string(root.join("tools/pgo-training.txt")).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut renders = 0;
    for line in list.lines().map(str::trim) {
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let mut words = line.split_whitespace();
        let scene = root.join(format!("scenes/{}.toml", words.next().unwrap()));
        assert!(scene.is_file(), "{line}: no {}", scene.display());
        let output = dir.path().join(renders.to_string());
        let mut args = vec![
            "render".to_string(),
            scene.display().to_string(),
            "-o".to_string(),
            output.display().to_string(),
        ];
        while let Some(word) = words.next() {
            let small = match word {
                "--resolution" => "16x16",
                "--spp" => "1",
                _ => {
                    args.push(word.to_string());
                    continue;
                }
            };
            assert!(words.next().is_some(), "{line}: {word} without a value");
            args.extend([word.to_string(), small.to_string()]);
        }
        for (option, small) in [("--resolution", "16x16"), ("--spp", "1")] {
            if !args.iter().any(|a| a == option) {
                args.extend([option.to_string(), small.to_string()]);
            }
        }
        succeed(prism().args(&args));
        assert!(output.with_extension("exr").is_file(), "{line}: no image");
        renders += 1;
    }
    assert!(renders >= 10, "only {renders} training renders");
}
