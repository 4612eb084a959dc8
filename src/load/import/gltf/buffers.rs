//! Buffers and image bytes: GLB chunks, base64 data URIs and external
//! files, read so that errors name the file.

use std::path::Path;

use base64::Engine;

/// The bytes of a `data:` URI, or of a file relative to the asset.
pub(super) fn read_uri(uri: &str, base: &Path) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (_, data) = rest
            .split_once(";base64,")
            .ok_or("a data URI that is not base64")?;
        return base64::engine::general_purpose::STANDARD
            .decode(data)
            .map_err(|e| format!("bad base64 data: {e}"));
    }
    let path = base.join(percent_decode(uri));
    crate::input::read(&path).map_err(|e| format!("{}: {e}", path.display()))
}

/// URIs in glTF are percent-encoded (spaces are %20).
pub(super) fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            if let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

pub(super) fn load_buffers(gltf: &mut gltf::Gltf, base: &Path) -> Result<Vec<Vec<u8>>, String> {
    // The binary chunk moves over (a copy would fault in as many pages
    // again: 280 MB for a 10M-triangle mesh); a second buffer naming it
    // copies the first.
    let mut blob = gltf.blob.take();
    let mut bin_buffer: Option<usize> = None;
    let mut buffers = Vec::new();
    for buffer in gltf.buffers() {
        let i = buffer.index();
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => match (blob.take(), bin_buffer) {
                (Some(data), _) => {
                    bin_buffer = Some(buffers.len());
                    data
                }
                (None, Some(first)) => Vec::clone(&buffers[first]),
                (None, None) => {
                    return Err(format!(
                        "buffer {i} refers to a GLB binary chunk the file does not have"
                    ))
                }
            },
            gltf::buffer::Source::Uri(uri) => {
                read_uri(uri, base).map_err(|e| format!("buffer {i}: {e}"))?
            }
        };
        if data.len() < buffer.length() {
            return Err(format!(
                "buffer {i} holds {} bytes but declares {} (truncated file?)",
                data.len(),
                buffer.length()
            ));
        }
        buffers.push(data);
    }
    Ok(buffers)
}
