//! The command line's jobs as library calls: render a scene to files, merge
//! partial renders, describe an EXR. `main.rs` parses flags and calls these.

mod info;
mod interrupt;
mod merge;
mod render;
mod spectrum;
mod tev;

use std::ffi::OsStr;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};

pub use info::describe;
pub use interrupt::{Interrupts, Reaction};
pub use merge::{merge_files, MergeJob};
pub use render::{
    render_files, spectral_attributes, write_set, RenderJob, RenderOutcome, ATTR_INTERRUPTED,
    ATTR_WHITE_BALANCE, ATTR_XYZ_TO_RGB,
};
pub use spectrum::{describe_spectrum, SpectrumQuery};

/// Where NAME.exr and NAME.png go: `output` (extension dropped) or next to
/// the scene.
pub fn output_stem(scene: &Path, output: Option<PathBuf>) -> PathBuf {
    let named_like_scene = || PathBuf::from(scene.file_stem().unwrap_or(OsStr::new("render")));
    match output {
        // A folder (`-o out/`, `-o .`): the files go in it, named like the scene.
        Some(o)
            if o.is_dir()
                || o.as_os_str()
                    .to_string_lossy()
                    .ends_with(['/', std::path::MAIN_SEPARATOR]) =>
        {
            o.join(named_like_scene())
        }
        Some(o) => match o.extension().and_then(|e| e.to_str()) {
            Some("exr" | "png") => o.with_extension(""),
            _ => o,
        },
        None => scene.with_extension(""),
    }
}

/// `stem` + "." + `ext`, keeping any dots already in the stem (`out.part3`).
pub fn suffixed(stem: &Path, ext: &str) -> PathBuf {
    let mut s = stem.as_os_str().to_owned();
    s.push(".");
    s.push(ext);
    PathBuf::from(s)
}

/// The folder the files of `stem` go in ("." for a bare name).
fn output_dir(stem: &Path) -> PathBuf {
    match stem.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Temporary files of earlier renders to `stem` (`.NAME.partial-PID.exr`,
/// `.png`, `.spectral.exr`, `.preview.png`, a retired `.spectral.…retired`)
/// whose process is gone (killed before it could
/// clean up): removed where the process table can be read (/proc), else
/// only named. Returns each with whether it was removed.
pub fn stale_temporaries(stem: &Path) -> Vec<(PathBuf, bool)> {
    let Some(name) = stem.file_name().map(|n| n.to_string_lossy().to_string()) else {
        return Vec::new();
    };
    let dir = output_dir(stem);
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return Vec::new();
    };
    let can_tell = Path::new("/proc/self").exists();
    let mut found = Vec::new();
    for entry in entries.flatten() {
        let file = entry.file_name().to_string_lossy().to_string();
        let Some(pid) = temporary_pid(&file, &name) else {
            continue;
        };
        if pid == std::process::id() {
            continue;
        }
        let path = dir.join(&file);
        if !can_tell {
            found.push((path, false));
        } else if !Path::new(&format!("/proc/{pid}")).exists() {
            let removed = std::fs::remove_file(&path).is_ok();
            found.push((path, removed));
        }
    }
    found.sort();
    found
}

/// The process id in `file` if it is a temporary name of one of the files
/// of the render named `name` (see `film::output`'s temporary names).
fn temporary_pid(file: &str, name: &str) -> Option<u32> {
    let rest = file.strip_prefix('.')?.strip_prefix(name)?;
    let rest = rest
        .strip_prefix(".spectral")
        .or_else(|| rest.strip_prefix(".preview"))
        .unwrap_or(rest);
    let (pid, ext) = rest.strip_prefix(".partial-")?.split_once('.')?;
    matches!(ext, "exr" | "png" | "retired").then_some(())?;
    pid.parse().ok()
}

/// Fails early, before any rendering, if the output folder cannot take files.
pub fn check_writable(stem: &Path) -> Result<()> {
    // The longest name written is the spectral EXR's temporary one
    // (`.NAME.partial-PID.spectral.exr`): refuse names that file systems
    // cannot hold before rendering, not after.
    let name = stem.file_name().map_or(0, |n| n.len());
    let longest = name + ".partial-4294967295.spectral.exr".len() + 1;
    if longest > 255 {
        bail!(
            "output name {} is too long: with its suffixes it would exceed the 255 bytes a file name may have",
            stem.display()
        );
    }
    let dir = output_dir(stem);
    if !dir.is_dir() {
        bail!("output folder {} does not exist", dir.display());
    }
    let probe = dir.join(format!(".prism-write-test-{}", std::process::id()));
    std::fs::write(&probe, b"")
        .with_context(|| format!("cannot write to output folder {}", dir.display()))?;
    let _ = std::fs::remove_file(probe);
    Ok(())
}
