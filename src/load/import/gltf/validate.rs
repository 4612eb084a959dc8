//! What the gltf crate leaves unchecked, checked before it reads: the
//! element types the specification allows, accessor layouts within their
//! buffers, and the document's indices.

use super::describe;

/// The element types the specification (with KHR_mesh_quantization) allows
/// for the vertex attributes prism reads, and a stride that holds an
/// element.
pub(super) fn check_accessor(a: &gltf::Accessor, semantic: &gltf::Semantic) -> Result<(), String> {
    use gltf::accessor::{DataType, Dimensions};
    use DataType::{F32, I16, I8, U16, U8};
    let (dims, types, normalized): (Dimensions, &[DataType], bool) = match semantic {
        gltf::Semantic::Positions => (Dimensions::Vec3, &[F32, I8, U8, I16, U16], false),
        // Integer directions must be normalised.
        gltf::Semantic::Normals => (Dimensions::Vec3, &[F32, I8, I16], true),
        gltf::Semantic::Tangents => (Dimensions::Vec4, &[F32, I8, I16], true),
        _ => (Dimensions::Vec2, &[F32, I8, U8, I16, U16], false),
    };
    let integer = a.data_type() != F32;
    if a.dimensions() != dims
        || !types.contains(&a.data_type())
        || (normalized && integer && !a.normalized())
    {
        return Err(format!(
            "{} accessor {} holds {}{:?} of {:?}, which the specification does not allow",
            semantic.to_string(),
            a.index(),
            if integer && a.normalized() {
                "normalised "
            } else {
                ""
            },
            a.dimensions(),
            a.data_type()
        ));
    }
    Ok(())
}

pub(super) fn check_index_accessor(a: &gltf::Accessor) -> Result<(), String> {
    use gltf::accessor::{DataType, Dimensions};
    if a.dimensions() != Dimensions::Scalar
        || ![DataType::U8, DataType::U16, DataType::U32].contains(&a.data_type())
    {
        return Err(format!(
            "index accessor {} holds {:?} of {:?}, not unsigned integer scalars",
            a.index(),
            a.dimensions(),
            a.data_type()
        ));
    }
    Ok(())
}

/// Elements an accessor without a buffer view (all zeros but its sparse
/// values) may declare: its count is not bounded by any data in the file.
const MAX_VIEWLESS_COUNT: usize = 1 << 26;

/// An accessor's elements inside their buffer view and the view inside its
/// buffer, in checked arithmetic: the crate's reader computes these ends
/// unchecked and trusts the stride.
pub(super) fn check_layout(
    a: &gltf::Accessor,
    name: &str,
    buffers: &[Vec<u8>],
) -> Result<(), String> {
    let fail = |why: String| format!("{name} accessor {}: {why}", a.index());
    let size = a.size();
    if a.count() == 0 {
        return Err(fail("count is 0".into()));
    }
    match (a.view(), a.sparse()) {
        (Some(view), _) => check_span(&view, a.offset(), a.count(), size, buffers).map_err(fail)?,
        (None, Some(_)) if a.count() > MAX_VIEWLESS_COUNT => {
            return Err(fail(format!(
                "{} elements without a buffer view (at most {MAX_VIEWLESS_COUNT})",
                a.count()
            )))
        }
        (None, _) => {}
    }
    if let Some(sparse) = a.sparse() {
        let n = sparse.count();
        if n == 0 || n > a.count() {
            return Err(fail(format!(
                "sparse count {n} is not within 1..={}",
                a.count()
            )));
        }
        let (indices, values) = (sparse.indices(), sparse.values());
        let index_size = indices.index_type().size();
        check_span(&indices.view(), indices.offset(), n, index_size, buffers)
            .map_err(|e| fail(format!("sparse indices: {e}")))?;
        check_span(&values.view(), values.offset(), n, size, buffers)
            .map_err(|e| fail(format!("sparse values: {e}")))?;
    }
    Ok(())
}

/// `count` elements of `size` bytes from `offset` in a buffer view.
pub(super) fn check_span(
    view: &gltf::buffer::View,
    offset: usize,
    count: usize,
    size: usize,
    buffers: &[Vec<u8>],
) -> Result<(), String> {
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "byteStride {stride} is smaller than an element ({size} bytes)"
        ));
    }
    let buffer_len = buffers.get(view.buffer().index()).map_or(0, Vec::len);
    let view_end = view.offset().checked_add(view.length());
    if view_end.is_none_or(|end| end > buffer_len) {
        return Err(format!(
            "buffer view {} lies outside its buffer",
            view.index()
        ));
    }
    let end = stride
        .checked_mul(count - 1)
        .and_then(|x| x.checked_add(size))
        .and_then(|x| x.checked_add(offset));
    if end.is_none_or(|end| end > view.length()) {
        return Err(format!(
            "its data lies outside buffer view {}",
            view.index()
        ));
    }
    Ok(())
}

/// The gltf crate's validation, with what it leaves out. Its own check
/// that a primitive's POSITION accessor has bounds indexes the accessor
/// before the index is checked, so the index is checked first. Then rules
/// of the specification that it does not check but whose breach makes its
/// accessors panic: an image in a buffer view needs a MIME type, an image
/// needs a source, a camera needs the projection its type names.
pub(super) fn validate(json: &gltf::json::Root) -> Result<(), String> {
    use gltf::json::mesh::Semantic;
    use gltf::json::validation::{Checked, Validate};
    for (m, mesh) in json.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            if let Some(a) = primitive
                .attributes
                .get(&Checked::Valid(Semantic::Positions))
            {
                if a.value() >= json.accessors.len() {
                    return Err(format!(
                        "invalid glTF: meshes[{m}].primitives[{p}].attributes.POSITION: \
                         accessor {} does not exist",
                        a.value()
                    ));
                }
            }
        }
    }
    check_required_extensions(&json.extensions_required)?;
    // The crate judges extensionsRequired by the features compiled into
    // it; prism judges it by what it maps (above).
    let mut errors = Vec::new();
    // Draco-compressed primitives' accessors have no buffer view: their
    // data is in the stream.
    let draco = json
        .extensions_used
        .iter()
        .any(|e| e == "KHR_draco_mesh_compression");
    json.validate(json, gltf::json::Path::new, &mut |path, error| {
        let path = path();
        let p = path.as_str();
        let viewless = draco && p.starts_with("accessors[") && p.ends_with("].bufferView");
        if !p.starts_with("extensionsRequired") && !viewless {
            errors.push((path, error))
        }
    });
    if !errors.is_empty() {
        return Err(describe(gltf::Error::Validation(errors)));
    }
    for (i, image) in json.images.iter().enumerate() {
        match (&image.buffer_view, &image.uri) {
            (Some(_), _) if image.mime_type.is_none() => {
                return Err(format!(
                    "invalid glTF: images[{i}] lies in a buffer view but has no mimeType"
                ))
            }
            (None, None) => {
                return Err(format!(
                    "invalid glTF: images[{i}] has neither a uri nor a bufferView"
                ))
            }
            _ => {}
        }
    }
    for (i, camera) in json.cameras.iter().enumerate() {
        use gltf::json::camera::Type;
        let present = match camera.type_ {
            gltf::json::validation::Checked::Valid(Type::Perspective) => {
                camera.perspective.is_some()
            }
            gltf::json::validation::Checked::Valid(Type::Orthographic) => {
                camera.orthographic.is_some()
            }
            gltf::json::validation::Checked::Invalid => true, // already refused
        };
        if !present {
            return Err(format!(
                "invalid glTF: cameras[{i}] has no object for its type"
            ));
        }
    }
    Ok(())
}

/// Refuses a file that requires an extension prism cannot honour, naming
/// it; extensions prism maps or decodes pass.
fn check_required_extensions(required: &[String]) -> Result<(), String> {
    let unsupported: Vec<&str> = required
        .iter()
        .map(String::as_str)
        .filter(|e| !super::supports(e))
        .collect();
    if unsupported.is_empty() {
        return Ok(());
    }
    let why = |e: &str| match e {
        "EXT_meshopt_compression" => {
            " (meshoptimizer-compressed buffers: decompress with `gltfpack -noq` or \
             `gltf-transform copy`)"
        }
        "KHR_texture_basisu" | "EXT_texture_webp" | "EXT_texture_avif" => {
            " (a texture format prism does not decode)"
        }
        _ => "",
    };
    let list: Vec<String> = unsupported
        .iter()
        .map(|e| format!("{e}{}", why(e)))
        .collect();
    Err(format!(
        "the file requires {} that prism does not support: {}",
        if list.len() == 1 {
            "an extension"
        } else {
            "extensions"
        },
        list.join(", ")
    ))
}
