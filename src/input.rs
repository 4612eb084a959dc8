//! Reading input files (scenes, meshes, material libraries, textures,
//! buffers, spectra, environment maps) one way: only regular files, and
//! none above a size limit. A FIFO would block a read forever, /dev/zero
//! would fill memory: they are refused before they are opened.

use std::cell::RefCell;
use std::io::Read;
use std::path::{Path, PathBuf};

/// The largest input file read (8 GiB).
pub const MAX_INPUT_BYTES: u64 = 8 << 30;

thread_local! {
    /// While `recording`: every file read, with a hash of its bytes.
    static READ: RefCell<Option<Vec<(PathBuf, u64)>>> = const { RefCell::new(None) };
}

/// Runs `f`, returning with its result every file it read through
/// [`read`] and a hash of each one's bytes (what a scene depends on).
pub fn recording<T>(f: impl FnOnce() -> T) -> (T, Vec<(PathBuf, u64)>) {
    let outer = READ.with(|r| r.borrow_mut().replace(Vec::new()));
    let result = f();
    let files = READ
        .with(|r| std::mem::replace(&mut *r.borrow_mut(), outer))
        .unwrap_or_default();
    (result, files)
}

/// Adds `files` to the files read, as if read now (what a scene reused
/// from an earlier load depends on).
pub fn record(files: &[(PathBuf, u64)]) {
    READ.with(|r| {
        if let Some(read) = r.borrow_mut().as_mut() {
            read.extend_from_slice(files);
        }
    });
}

/// Inputs bigger than this hash as blocks of it, on every thread.
const HASH_BLOCK: usize = 64 << 20;

/// A 64-bit FNV-1a over 8-byte words (then the tail): quick on big meshes.
/// Bigger than a block, the hash is that of the blocks' hashes, made in
/// parallel (a 1.1 GB OBJ took 0.35 s on one thread).
pub fn content_hash(bytes: &[u8]) -> u64 {
    use rayon::prelude::*;
    if bytes.len() <= HASH_BLOCK {
        return fnv_words(bytes);
    }
    let blocks: Vec<u64> = bytes.par_chunks(HASH_BLOCK).map(fnv_words).collect();
    let joined: Vec<u8> = blocks.iter().flat_map(|h| h.to_le_bytes()).collect();
    fnv_words(&joined) ^ bytes.len() as u64
}

fn fnv_words(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut words = bytes.chunks_exact(8);
    for w in &mut words {
        h ^= u64::from_le_bytes(w.try_into().expect("eight bytes"));
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    for b in words.remainder() {
        h ^= u64::from(*b);
        h = h.wrapping_mul(0x0000_0100_0000_01b3);
    }
    h ^ bytes.len() as u64
}

/// The size of the regular file at `path`, if it is one within the size
/// limit; the error says why not ("cannot read: …"). Opening anything else
/// could block (a FIFO) or never end (a device).
pub fn regular_file_size(path: &Path) -> Result<u64, String> {
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
    Ok(meta.len())
}

/// The bytes of the regular file at `path`; the error says why not
/// ("cannot read: …").
pub fn read(path: &Path) -> Result<Vec<u8>, String> {
    read_sized(path, regular_file_size(path)?)
}

/// `read` of a regular file of `size` bytes (as `regular_file_size` found).
fn read_sized(path: &Path, size: u64) -> Result<Vec<u8>, String> {
    // The bytes are held while they are decoded: a file larger than the
    // budget (a sparse one reads as zeros) is refused before it is read.
    crate::memory::check("reading the file", size)?;
    let mut bytes = Vec::with_capacity(size as usize);
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_INPUT_BYTES + 1).read_to_end(&mut bytes))
        .map_err(|e| format!("cannot read: {e}"))?;
    if bytes.len() as u64 > MAX_INPUT_BYTES {
        return Err(format!(
            "cannot read: it grew above the {} GiB limit on input files while being read",
            MAX_INPUT_BYTES >> 30
        ));
    }
    record_read(path, &bytes);
    Ok(bytes)
}

/// Counts `path` among the files read while `recording`, with a hash of
/// its bytes.
fn record_read(path: &Path, bytes: &[u8]) {
    READ.with(|r| {
        if let Some(files) = r.borrow_mut().as_mut() {
            files.push((path.to_path_buf(), content_hash(bytes)));
        }
    });
}

/// Files at least this big are mapped rather than read by [`read_mapped`].
const MAP_AT_LEAST: u64 = 64 << 20;

/// A file's bytes, mapped (big files) or read.
pub enum FileBytes {
    Mapped(memmap2::Mmap),
    Read(Vec<u8>),
}

impl std::ops::Deref for FileBytes {
    type Target = [u8];

    fn deref(&self) -> &[u8] {
        match self {
            FileBytes::Mapped(map) => map,
            FileBytes::Read(bytes) => bytes,
        }
    }
}

/// `read`, except that big files are mapped: their pages are the page
/// cache's, neither copied nor zeroed first (on a 1.1 GB OBJ, 0.8 s of a
/// 2-thread load), and faulted in by the threads that parse them.
pub fn read_mapped(path: &Path) -> Result<FileBytes, String> {
    let size = regular_file_size(path)?;
    if size < MAP_AT_LEAST {
        return read_sized(path, size).map(FileBytes::Read);
    }
    crate::memory::check("reading the file", size)?;
    let file = std::fs::File::open(path).map_err(|e| format!("cannot read: {e}"))?;
    // SAFETY: the map is read-only and lives as long as the bytes are
    // used. A file shortened by another program while it is mapped would
    // fault on the lost pages (as it would for any program that maps its
    // inputs, such as ripgrep); prism never writes its inputs.
    let map = unsafe { memmap2::Mmap::map(&file) }.map_err(|e| format!("cannot read: {e}"))?;
    record_read(path, &map);
    Ok(FileBytes::Mapped(map))
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
