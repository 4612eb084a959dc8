//! A primitive's vertex attributes and indices as prism reads them, from
//! either source glTF has:
//! - accessors, with any component type KHR_mesh_quantization allows
//!   (normalised integers map to [0, 1] or [-1, 1], others convert as
//!   written; sparse accessors included);
//! - a KHR_draco_mesh_compression stream, decoded by draco-core.

use gltf::accessor::{DataType, Item, Iter};

/// Where a primitive's attributes come from.
pub(super) enum Source<'a> {
    Accessors(&'a [Vec<u8>]),
    Draco(Box<DracoPrimitive>),
}

/// A decoded Draco stream and the extension's map from glTF attribute
/// names to the stream's attribute ids.
pub(super) struct DracoPrimitive {
    mesh: draco_core::Mesh,
    ids: gltf::json::Value,
}

impl Source<'_> {
    /// The elements of `semantic` as rows of `N` floats; None if the
    /// primitive lacks it or its data cannot be read.
    pub(super) fn rows<const N: usize>(
        &self,
        p: &gltf::Primitive,
        semantic: &gltf::Semantic,
    ) -> Option<Vec<[f32; N]>>
    where
        [f32; N]: Item,
        [i8; N]: Item,
        [u8; N]: Item,
        [i16; N]: Item,
        [u16; N]: Item,
        [u32; N]: Item,
    {
        let accessor = p.get(semantic)?;
        let buffers = match self {
            Source::Accessors(buffers) => buffers,
            Source::Draco(d) => return d.rows(&semantic.to_string(), &accessor),
        };
        // Widened to f32 by glTF's rules for normalised integers (the
        // signed ones clamp at −1).
        fn widen<T: Item + Copy, const N: usize>(
            a: &gltf::Accessor,
            buffers: &[Vec<u8>],
            f: impl Fn(T) -> f32,
        ) -> Option<Vec<[f32; N]>>
        where
            [T; N]: Item,
        {
            let get = |b: gltf::Buffer| buffers.get(b.index()).map(Vec::as_slice);
            Some(
                Iter::<[T; N]>::new(a.clone(), get)?
                    .map(|e| e.map(&f))
                    .collect(),
            )
        }
        let a = &accessor;
        match (a.data_type(), a.normalized()) {
            (DataType::F32, _) => widen::<f32, N>(a, buffers, |x| x),
            (DataType::I8, true) => widen::<i8, N>(a, buffers, |x| (x as f32 / 127.0).max(-1.0)),
            (DataType::U8, true) => widen::<u8, N>(a, buffers, |x| x as f32 / 255.0),
            (DataType::I16, true) => {
                widen::<i16, N>(a, buffers, |x| (x as f32 / 32767.0).max(-1.0))
            }
            (DataType::U16, true) => widen::<u16, N>(a, buffers, |x| x as f32 / 65535.0),
            (DataType::I8, false) => widen::<i8, N>(a, buffers, |x| x as f32),
            (DataType::U8, false) => widen::<u8, N>(a, buffers, |x| x as f32),
            (DataType::I16, false) => widen::<i16, N>(a, buffers, |x| x as f32),
            (DataType::U16, false) => widen::<u16, N>(a, buffers, |x| x as f32),
            (DataType::U32, _) => widen::<u32, N>(a, buffers, |x| x as f32),
        }
    }

    /// The triangle list's indices (None without an index accessor).
    pub(super) fn indices(&self, p: &gltf::Primitive) -> Option<Vec<u32>> {
        match self {
            Source::Accessors(buffers) => {
                let reader = p.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
                Some(reader.read_indices()?.into_u32().collect())
            }
            Source::Draco(d) => Some(d.mesh.faces().iter().flat_map(|f| f.map(|i| i.0)).collect()),
        }
    }
}

impl DracoPrimitive {
    /// Decodes the primitive's `KHR_draco_mesh_compression` stream, within
    /// what the memory budget leaves.
    pub(super) fn decode(
        extension: &gltf::json::Value,
        document: &gltf::Document,
        buffers: &[Vec<u8>],
    ) -> Result<Self, String> {
        let fail = |why: &str| format!("KHR_draco_mesh_compression: {why}");
        let view_index = extension
            .get("bufferView")
            .and_then(|v| v.as_u64())
            .ok_or_else(|| fail("no bufferView"))? as usize;
        let view = document
            .views()
            .nth(view_index)
            .ok_or_else(|| fail(&format!("buffer view {view_index} does not exist")))?;
        let data = buffers
            .get(view.buffer().index())
            .and_then(|b| b.get(view.offset()..view.offset().checked_add(view.length())?))
            .ok_or_else(|| fail(&format!("buffer view {view_index} lies outside its buffer")))?;
        let ids = extension
            .get("attributes")
            .filter(|a| a.is_object())
            .cloned()
            .ok_or_else(|| fail("no attributes"))?;
        let (limit, _) = crate::memory::limit();
        let left = limit.saturating_sub(crate::memory::held());
        let limits = draco_core::DecodeLimits::default().with_max_decoded_bytes(left);
        let mut stream = draco_core::DecoderBuffer::new(data).with_limits(limits);
        let mut mesh = draco_core::Mesh::new();
        draco_core::MeshDecoder::new()
            .decode(&mut stream, &mut mesh)
            .map_err(|e| fail(&format!("the Draco stream cannot be decoded ({e})")))?;
        let points = mesh.num_points() as u32;
        if let Some(f) = mesh
            .faces()
            .iter()
            .find(|f| f.iter().any(|i| i.0 >= points))
        {
            return Err(fail(&format!(
                "a decoded face {:?} names a point beyond the {points} decoded",
                f.map(|i| i.0)
            )));
        }
        Ok(Self { mesh, ids })
    }

    /// The decoded attribute glTF calls `name`, as rows of `N` floats
    /// (normalised as its accessor says).
    fn rows<const N: usize>(&self, name: &str, accessor: &gltf::Accessor) -> Option<Vec<[f32; N]>> {
        let id = self.ids.get(name)?.as_u64()?;
        let attribute = self.mesh.attribute_by_unique_id(u32::try_from(id).ok()?)?;
        let points = self.mesh.num_points();
        let values = attribute.read_f32s(points, N);
        use draco_core::DataType as D;
        let scale = match attribute.data_type() {
            _ if !accessor.normalized() => 1.0,
            D::Int8 => 1.0 / 127.0,
            D::Uint8 => 1.0 / 255.0,
            D::Int16 => 1.0 / 32767.0,
            D::Uint16 => 1.0 / 65535.0,
            _ => 1.0,
        };
        // Normalised signed integers clamp at −1, as accessors' do.
        let widen = |v: f32| {
            if scale == 1.0 {
                v
            } else {
                (v * scale).max(-1.0)
            }
        };
        Some(
            values
                .chunks_exact(N)
                .map(|c| std::array::from_fn(|i| widen(c[i])))
                .collect(),
        )
    }
}
