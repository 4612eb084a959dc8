//! Reading input files (scenes, meshes, material libraries, textures,
//! buffers, spectra, environment maps) one way: only regular files, and
//! none above a size limit. A FIFO would block a read forever, /dev/zero
//! would fill memory: they are refused before they are opened.

use std::io::Read;
use std::path::Path;

/// The largest input file read (8 GiB).
pub const MAX_INPUT_BYTES: u64 = 8 << 30;

/// The bytes of the regular file at `path`; the error says why not
/// ("cannot read: …").
pub fn read(path: &Path) -> Result<Vec<u8>, String> {
    let meta = std::fs::metadata(path).map_err(|e| format!("cannot read: {e}"))?;
    if !meta.is_file() {
        let what = if meta.is_dir() {
            "a folder"
        } else {
            "not a regular file (a pipe, socket or device)"
        };
        return Err(format!("cannot read: it is {what}"));
    }
    if meta.len() > MAX_INPUT_BYTES {
        return Err(format!(
            "cannot read: {} bytes, above the {} GiB limit on input files",
            meta.len(),
            MAX_INPUT_BYTES >> 30
        ));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_INPUT_BYTES + 1).read_to_end(&mut bytes))
        .map_err(|e| format!("cannot read: {e}"))?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(format!(
            "cannot read: it grew above the {} GiB limit on input files while being read",
            MAX_INPUT_BYTES >> 30
        ));
    }
    Ok(bytes)
}

/// `read` as UTF-8 text.
pub fn read_to_string(path: &Path) -> Result<String, String> {
    String::from_utf8(read(path)?).map_err(|_| "cannot read: it is not UTF-8 text".to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn special_files_and_folders_are_refused_without_blocking() {
        let e = read(Path::new("/dev/zero")).unwrap_err();
        assert!(e.contains("not a regular file"), "{e}");
        let e = read(Path::new("/")).unwrap_err();
        assert!(e.contains("folder"), "{e}");
        let dir = std::env::temp_dir().join(format!("prism-fifo-{}", std::process::id()));
        let made = std::process::Command::new("mkfifo").arg(&dir).status();
        if made.is_ok_and(|s| s.success()) {
            let e = read(&dir).unwrap_err();
            let _ = std::fs::remove_file(&dir);
            assert!(e.contains("not a regular file"), "{e}");
        }
    }
}
