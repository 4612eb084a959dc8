//! Small assets written by the tests themselves: glTF in its three forms
//! (external buffer, embedded base64, GLB), OBJ/MTL and PNG textures.
#![allow(dead_code)]

use std::path::Path;

use base64::Engine;

/// Binary data and accessors of a glTF file being assembled.
#[derive(Default)]
pub struct GltfBuilder {
    pub bin: Vec<u8>,
    views: Vec<String>,
    accessors: Vec<String>,
}

impl GltfBuilder {
    fn push_view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.views.push(format!(
            r#"{{"buffer":0,"byteOffset":{offset},"byteLength":{}}}"#,
            bytes.len()
        ));
        self.views.len() - 1
    }

    /// A float accessor of `kind` ("VEC2", "VEC3", "VEC4"), returning its index.
    pub fn floats(&mut self, data: &[f32], kind: &str) -> usize {
        let width = match kind {
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => 1,
        };
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.push_view(&bytes);
        let count = data.len() / width;
        // POSITION accessors need their bounds.
        let (mut min, mut max) = (vec![f32::INFINITY; width], vec![f32::NEG_INFINITY; width]);
        for c in data.chunks_exact(width) {
            for i in 0..width {
                min[i] = min[i].min(c[i]);
                max[i] = max[i].max(c[i]);
            }
        }
        let fmt = |v: &[f32]| {
            v.iter()
                .map(|x| format!("{x:?}"))
                .collect::<Vec<_>>()
                .join(",")
        };
        let bounds = if kind == "VEC3" && min.iter().all(|m| m.is_finite()) {
            format!(r#","min":[{}],"max":[{}]"#, fmt(&min), fmt(&max))
        } else {
            String::new()
        };
        self.accessors.push(format!(
            r#"{{"bufferView":{view},"componentType":5126,"count":{count},"type":"{kind}"{bounds}}}"#
        ));
        self.accessors.len() - 1
    }

    pub fn indices(&mut self, data: &[u16]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.push_view(&bytes);
        self.accessors.push(format!(
            r#"{{"bufferView":{view},"componentType":5123,"count":{},"type":"SCALAR"}}"#,
            data.len()
        ));
        self.accessors.len() - 1
    }

    /// An image stored in the binary buffer, returning its buffer view.
    pub fn image_view(&mut self, png: &[u8]) -> usize {
        self.push_view(png)
    }

    /// A sparse VEC2 float accessor over the base accessor's buffer view
    /// (`base_view`, `count` elements): the elements at `indices` replaced
    /// by `values`.
    pub fn sparse_vec2(
        &mut self,
        base_view: usize,
        count: usize,
        indices: &[u16],
        values: &[f32],
    ) -> usize {
        let i: Vec<u8> = indices.iter().flat_map(|v| v.to_le_bytes()).collect();
        let v: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let (iv, vv) = (self.push_view(&i), self.push_view(&v));
        self.accessors.push(format!(
            r#"{{"bufferView":{base_view},"componentType":5126,"count":{count},"type":"VEC2",
              "sparse":{{"count":{},"indices":{{"bufferView":{iv},"componentType":5123}},"values":{{"bufferView":{vv}}}}}}}"#,
            indices.len()
        ));
        self.accessors.len() - 1
    }

    /// The JSON document without "buffers" (the writers add it); `rest`
    /// holds the other top-level members ("meshes", "nodes", …).
    pub fn json(&self, rest: &str) -> String {
        format!(
            r#"{{"asset":{{"version":"2.0"}},"bufferViews":[{}],"accessors":[{}],{rest}}}"#,
            self.views.join(","),
            self.accessors.join(",")
        )
    }
}

fn with_buffer(json: &str, buffer: &str) -> String {
    let body = json.strip_suffix('}').unwrap();
    format!(r#"{body},"buffers":[{buffer}]}}"#)
}

/// `.gltf` + `.bin` side by side.
pub fn write_gltf_external(dir: &Path, name: &str, json: &str, bin: &[u8]) -> String {
    std::fs::write(dir.join(format!("{name}.bin")), bin).unwrap();
    let file = format!("{name}.gltf");
    let buffer = format!(r#"{{"byteLength":{},"uri":"{name}.bin"}}"#, bin.len());
    std::fs::write(dir.join(&file), with_buffer(json, &buffer)).unwrap();
    file
}

/// `.gltf` with the buffer embedded as a base64 data URI.
pub fn write_gltf_embedded(dir: &Path, name: &str, json: &str, bin: &[u8]) -> String {
    let data = base64::engine::general_purpose::STANDARD.encode(bin);
    let buffer = format!(
        r#"{{"byteLength":{},"uri":"data:application/octet-stream;base64,{data}"}}"#,
        bin.len()
    );
    let file = format!("{name}-embedded.gltf");
    std::fs::write(dir.join(&file), with_buffer(json, &buffer)).unwrap();
    file
}

/// Binary glTF: header, JSON chunk, BIN chunk.
pub fn glb_bytes(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut json = with_buffer(json, &format!(r#"{{"byteLength":{}}}"#, bin.len())).into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = bin.to_vec();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x4E4F_534Au32.to_le_bytes());
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x004E_4942u32.to_le_bytes());
    out.extend_from_slice(&bin);
    out
}

pub fn write_glb(dir: &Path, name: &str, json: &str, bin: &[u8]) -> String {
    let file = format!("{name}.glb");
    std::fs::write(dir.join(&file), glb_bytes(json, bin)).unwrap();
    file
}

/// PNG bytes of an RGBA8 image.
pub fn png(width: u32, height: u32, rgba: &[u8]) -> Vec<u8> {
    let image = image::RgbaImage::from_raw(width, height, rgba.to_vec()).unwrap();
    let mut out = std::io::Cursor::new(Vec::new());
    image.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// A PNG whose header declares `width` × `height` (colour type and bit
/// depth as given) with a little zlib data: a decompression bomb's shape.
pub fn forged_png(width: u32, height: u32, colour: u8, depth: u8, rows: usize) -> Vec<u8> {
    let data = zlib_stored(&vec![0u8; rows * 16]);
    let chunk = |kind: &[u8], body: &[u8]| {
        let mut c = (body.len() as u32).to_be_bytes().to_vec();
        c.extend_from_slice(kind);
        c.extend_from_slice(body);
        let crc = crc32(&c[4..]);
        c.extend_from_slice(&crc.to_be_bytes());
        c
    };
    let mut ihdr = width.to_be_bytes().to_vec();
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[depth, colour, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &ihdr));
    png.extend(chunk(b"IDAT", &data));
    png.extend(chunk(b"IEND", &[]));
    png
}

/// A zlib stream of stored (uncompressed) blocks.
pub fn zlib_stored(bytes: &[u8]) -> Vec<u8> {
    let mut out = vec![0x78, 0x01];
    let blocks: Vec<&[u8]> = bytes.chunks(65535).collect();
    for (i, b) in blocks.iter().enumerate() {
        out.push(u8::from(i + 1 == blocks.len()));
        out.extend_from_slice(&(b.len() as u16).to_le_bytes());
        out.extend_from_slice(&(!(b.len() as u16)).to_le_bytes());
        out.extend_from_slice(b);
    }
    if blocks.is_empty() {
        out.extend_from_slice(&[1, 0, 0, 0xff, 0xff]);
    }
    let (mut a, mut b) = (1u32, 0u32);
    for &x in bytes {
        a = (a + x as u32) % 65521;
        b = (b + a) % 65521;
    }
    out.extend_from_slice(&((b << 16) | a).to_be_bytes());
    out
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = 0xffff_ffffu32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 {
                0xedb8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// A quad from (-1, -1, 0) to (1, 1, 0) facing +z: positions, normals,
/// texture coordinates (v = 0 at the top, y = +1) and two triangles.
pub fn quad(b: &mut GltfBuilder, normals: bool) -> String {
    let p = b.floats(
        &[
            -1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0,
        ],
        "VEC3",
    );
    let t = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], "VEC2");
    let i = b.indices(&[0, 1, 2, 0, 2, 3]);
    let n = if normals {
        let n = b.floats(&[0.0, 0.0, 1.0].repeat(4), "VEC3");
        format!(r#","NORMAL":{n}"#)
    } else {
        String::new()
    };
    format!(r#"{{"attributes":{{"POSITION":{p},"TEXCOORD_0":{t}{n}}},"indices":{i}"#)
}
