#!/usr/bin/env python3
"""Writes tests/data/assets/: small, licence-clean glTF and OBJ files with
what exporters really write, one for each case the importer must handle
(tests/assets.rs loads them). Deterministic: re-running changes nothing.

    python3 tools/gen_asset_cases.py           # standard library only
    python3 tools/gen_asset_cases.py --draco   # also sphere_draco.gltf
                                               # (needs `pip install DracoPy numpy`)

The Draco file is made by Google's encoder (DracoPy wraps it), so the test
that decodes it with prism's decoder (draco-core) checks one against the
other.
"""

import base64
import json
import math
import struct
import sys
from pathlib import Path

from gen_assets import png, sphere

OUT = Path(__file__).resolve().parent.parent / "tests" / "data" / "assets"


def bmp(width, height, pixel):
    """A 24-bit BMP (rows bottom-up, BGR, padded to 4 bytes)."""
    row_bytes = (3 * width + 3) & ~3
    data = b""
    for y in reversed(range(height)):
        row = b"".join(bytes(reversed(pixel(x, y))) for x in range(width))
        data += row + b"\x00" * (row_bytes - len(row))
    header = struct.pack("<2sIHHI", b"BM", 54 + len(data), 0, 0, 54)
    info = struct.pack("<IiiHHIIiiII", 40, width, height, 1, 24, 0, len(data), 2835, 2835, 0, 0)
    return header + info + data


def tga(width, height, pixel):
    """An uncompressed 24-bit TGA, rows top-down (descriptor bit 5)."""
    header = struct.pack("<BBBHHBHHHHBB", 0, 0, 2, 0, 0, 0, 0, 0, width, height, 24, 0x20)
    data = b"".join(bytes(reversed(pixel(x, y))) for y in range(height) for x in range(width))
    return header + data


class Gltf:
    """A .gltf with one embedded (base64) buffer."""

    def __init__(self):
        self.bin = bytearray()
        self.views, self.accessors = [], []

    def view(self, data, stride=None):
        while len(self.bin) % 4:
            self.bin += b"\x00"
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if stride:
            v["byteStride"] = stride
        self.views.append(v)
        self.bin += data
        return len(self.views) - 1

    def accessor(self, view, component, count, kind, normalized=False, bounds=None):
        a = {"bufferView": view, "componentType": component, "count": count, "type": kind}
        if normalized:
            a["normalized"] = True
        if bounds:
            a["min"], a["max"] = bounds
        self.accessors.append(a)
        return len(self.accessors) - 1

    def floats(self, rows, kind):
        flat = [c for r in rows for c in r]
        view = self.view(struct.pack(f"<{len(flat)}f", *flat))
        bounds = None
        if kind == "VEC3":
            bounds = ([min(r[i] for r in rows) for i in range(3)], [max(r[i] for r in rows) for i in range(3)])
        return self.accessor(view, 5126, len(rows), kind, bounds=bounds)

    def packed(self, rows, fmt, component, kind, normalized, stride, bounds=None):
        """Integer rows, each padded to `stride` bytes (attributes start on
        4-byte boundaries)."""
        data = b""
        for r in rows:
            e = struct.pack("<" + fmt * len(r), *r)
            data += e + b"\x00" * (stride - len(e))
        view = self.view(data, stride)
        return self.accessor(view, component, len(rows), kind, normalized, bounds)

    def indices(self, idx):
        view = self.view(struct.pack(f"<{len(idx)}H", *idx))
        return self.accessor(view, 5123, len(idx), "SCALAR")

    def image(self, data):
        return self.view(data)

    def write(self, path, doc):
        doc.setdefault("asset", {"version": "2.0", "generator": "prism tools/gen_asset_cases.py"})
        doc["bufferViews"] = self.views
        doc["accessors"] = self.accessors
        data = bytes(self.bin)
        doc["buffers"] = [
            {
                "byteLength": len(data),
                "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode(),
            }
        ]
        path.write_text(json.dumps(doc, indent=1) + "\n")


def one_mesh(primitive, material=None, node=None, extensions=None):
    doc = {
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [dict(node or {}, mesh=0)],
        "meshes": [{"name": "mesh", "primitives": [primitive]}],
        "materials": [material or {"name": "plain"}],
    }
    if extensions:
        doc["extensionsUsed"] = extensions
    return doc


def float_sphere(g):
    pos, nor, uv, idx = sphere(12, 24)
    return {
        "attributes": {
            "POSITION": g.floats(pos, "VEC3"),
            "NORMAL": g.floats(nor, "VEC3"),
            "TEXCOORD_0": g.floats(uv, "VEC2"),
        },
        "indices": g.indices(idx),
        "material": 0,
    }


def write_spheres():
    g = Gltf()
    g.write(OUT / "sphere_float.gltf", one_mesh(float_sphere(g)))

    # What gltfpack writes: positions as unsigned shorts dequantised by the
    # node's transform, normals as normalised bytes, uvs as normalised
    # unsigned shorts.
    pos, nor, uv, idx = sphere(12, 24)
    q = [tuple(round((c + 1) / 2 * 65535) for c in p) for p in pos]
    qn = [tuple(max(-127, min(127, round(c * 127))) for c in n) for n in nor]
    quv = [tuple(round(c * 65535) for c in t) for t in uv]
    g = Gltf()
    primitive = {
        "attributes": {
            "POSITION": g.packed(q, "H", 5123, "VEC3", False, 8, ([0, 0, 0], [65535] * 3)),
            "NORMAL": g.packed(qn, "b", 5120, "VEC3", True, 4),
            "TEXCOORD_0": g.packed(quv, "H", 5123, "VEC2", True, 4),
        },
        "indices": g.indices(idx),
        "material": 0,
    }
    node = {"translation": [-1, -1, -1], "scale": [2 / 65535] * 3}
    doc = one_mesh(primitive, node=node, extensions=["KHR_mesh_quantization"])
    doc["extensionsRequired"] = ["KHR_mesh_quantization"]
    g.write(OUT / "sphere_quantized.gltf", doc)


def write_draco_sphere():
    import DracoPy
    import numpy as np

    pos, nor, uv, idx = sphere(12, 24)
    stream = DracoPy.encode(
        np.array(pos, dtype=np.float32),
        np.array(idx, dtype=np.uint32).reshape(-1, 3),
        quantization_bits=16,
        compression_level=7,
        tex_coord=np.array(uv, dtype=np.float64),
        normals=np.array(nor, dtype=np.float64),
    )
    g = Gltf()
    view = g.view(stream)
    n = len(pos)
    primitive = {
        "attributes": {
            "POSITION": g.accessor(None, 5126, n, "VEC3", bounds=([-1, -1, -1], [1, 1, 1])),
            "NORMAL": g.accessor(None, 5126, n, "VEC3"),
            "TEXCOORD_0": g.accessor(None, 5126, n, "VEC2"),
        },
        "indices": g.accessor(None, 5125, len(idx), "SCALAR"),
        "material": 0,
        "extensions": {
            "KHR_draco_mesh_compression": {
                "bufferView": view,
                # The unique ids DracoPy 2.2 gives (DracoPy.decode lists
                # them): texture coordinates, normals, then positions.
                "attributes": {"POSITION": 2, "TEXCOORD_0": 0, "NORMAL": 1},
            }
        },
    }
    for a in g.accessors:
        if a["bufferView"] is None:
            del a["bufferView"]
    doc = one_mesh(primitive, extensions=["KHR_draco_mesh_compression"])
    doc["extensionsRequired"] = ["KHR_draco_mesh_compression"]
    g.write(OUT / "sphere_draco.gltf", doc)


def quad(g, uv1=None):
    """A unit quad in z = 0 facing +z, uvs over [0, 1]²; `uv1` a second set."""
    pos = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]
    attrs = {
        "POSITION": g.floats(pos, "VEC3"),
        "NORMAL": g.floats([(0, 0, 1)] * 4, "VEC3"),
        "TEXCOORD_0": g.floats([(0, 1), (1, 1), (1, 0), (0, 0)], "VEC2"),
    }
    if uv1:
        attrs["TEXCOORD_1"] = g.floats(uv1, "VEC2")
    return {"attributes": attrs, "indices": g.indices([0, 1, 2, 0, 2, 3]), "material": 0}


def write_required_extensions():
    # Every material extension prism maps, required.
    g = Gltf()
    mapped = [
        "KHR_materials_sheen",
        "KHR_materials_specular",
        "KHR_materials_clearcoat",
        "KHR_materials_iridescence",
        "KHR_materials_dispersion",
        "KHR_materials_transmission",
        "KHR_materials_volume",
        "KHR_materials_ior",
        "KHR_materials_emissive_strength",
        "KHR_texture_transform",
    ]
    material = {
        "name": "layered",
        "extensions": {
            "KHR_materials_sheen": {"sheenColorFactor": [0.5, 0.4, 0.3], "sheenRoughnessFactor": 0.5},
            "KHR_materials_specular": {"specularFactor": 0.8},
            "KHR_materials_clearcoat": {"clearcoatFactor": 0.5},
            "KHR_materials_iridescence": {"iridescenceFactor": 1.0},
            "KHR_materials_ior": {"ior": 1.4},
        },
    }
    doc = one_mesh(quad(g), material, extensions=mapped)
    doc["extensionsRequired"] = mapped
    g.write(OUT / "requires_mapped.gltf", doc)

    g = Gltf()
    doc = one_mesh(quad(g), extensions=["EXT_meshopt_compression", "KHR_materials_unlit"])
    doc["extensionsRequired"] = ["KHR_materials_sheen", "EXT_meshopt_compression", "KHR_materials_unlit"]
    g.write(OUT / "requires_meshopt.gltf", doc)


def write_glass_roughness():
    # Clear glass as exporters write it: no roughnessFactor (so 1), the
    # roughness in the metallic-roughness texture's green channel: 0 on the
    # left texel, 1 on the right.
    g = Gltf()
    image = g.image(png(2, 1, lambda x, y: (0, 255 * x, 0)))
    material = {
        "name": "glass",
        "pbrMetallicRoughness": {"metallicFactor": 0.0, "metallicRoughnessTexture": {"index": 0}},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}},
    }
    doc = one_mesh(quad(g), material, extensions=["KHR_materials_transmission"])
    doc["images"] = [{"bufferView": image, "mimeType": "image/png"}]
    doc["samplers"] = [{"magFilter": 9728, "minFilter": 9728}]
    doc["textures"] = [{"source": 0, "sampler": 0}]
    g.write(OUT / "glass_roughness_texture.gltf", doc)


def write_texture_sets_and_transforms():
    # Material 0 reads every texture through TEXCOORD_1 (the quad's second
    # set maps it to the image's right half); its normalTexture and its
    # sheen colour texture carry KHR_texture_transform.
    g = Gltf()
    image = g.image(png(2, 1, lambda x, y: ((40, 200, 90) if x else (250, 10, 10))))
    normal = g.image(png(1, 1, lambda x, y: (128, 128, 255)))
    transform = {"KHR_texture_transform": {"offset": [0.5, 0.0], "scale": [0.5, 1.0]}}
    material = {
        "name": "second_set",
        "pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 1}},
        "normalTexture": {"index": 1, "texCoord": 1, "extensions": transform},
        "extensions": {
            "KHR_materials_sheen": {
                "sheenColorFactor": [1, 1, 1],
                "sheenColorTexture": {"index": 0, "texCoord": 1, "extensions": transform},
            }
        },
    }
    uv1 = [(0.75, 0.5)] * 4
    doc = one_mesh(quad(g, uv1), material, extensions=["KHR_texture_transform", "KHR_materials_sheen"])
    doc["images"] = [
        {"bufferView": image, "mimeType": "image/png"},
        {"bufferView": normal, "mimeType": "image/png"},
    ]
    doc["samplers"] = [{"magFilter": 9728, "minFilter": 9728}]
    doc["textures"] = [{"source": 0, "sampler": 0}, {"source": 1, "sampler": 0}]
    g.write(OUT / "texture_sets.gltf", doc)


def write_single_sided():
    # NegativeScaleTest in miniature: four quads of the quad mesh (facing
    # +z) seen from +z. Top left: as made. Top right: turned about y, its
    # back to the camera. Bottom left: mirrored by a negative scale, whose
    # front still faces +z (glTF reads a negative determinant's winding as
    # clockwise). Bottom right: turned, double-sided. Single-sided, the
    # camera sees all but the top right.
    g = Gltf()
    primitive = quad(g)
    turned = [0, 1, 0, 0]
    doc = {
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": [
            {"mesh": 0, "translation": [-1.5, 0, 0]},
            {"mesh": 0, "translation": [1.5, 0, 0], "rotation": turned},
            {"mesh": 0, "translation": [-1.5, -3, 0], "scale": [-1, 1, 1]},
            {"mesh": 1, "translation": [1.5, -3, 0], "rotation": turned},
        ],
        "meshes": [
            {"name": "single", "primitives": [primitive]},
            {"name": "double", "primitives": [dict(primitive, material=1)]},
        ],
        "materials": [
            {"name": "single_sided", "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.2, 0.2, 1], "metallicFactor": 0}},
            {
                "name": "double_sided",
                "doubleSided": True,
                "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.2, 0.2, 1], "metallicFactor": 0},
            },
        ],
    }
    g.write(OUT / "single_sided.gltf", doc)


def write_obj_cases():
    brick = lambda x, y: (200, 60, 40)
    tile = lambda x, y: (30, 90, 210)
    (OUT / "brick.bmp").write_bytes(bmp(3, 2, brick))
    (OUT / "tile.tga").write_bytes(tga(2, 3, tile))
    # What Maya's exporter writes (illum 4, Ni 1.00 everywhere), and the
    # other illumination models.
    (OUT / "illum.mtl").write_text(
        "# Maya-style: illum 4 and Ni 1.00 on an opaque textured material\n"
        "newmtl maya_brick\nillum 4\nKd 0.00 0.00 0.00\nKa 0.00 0.00 0.00\nTf 1.00 1.00 1.00\n"
        "map_Kd -s 1 1 1 brick.bmp\nNi 1.00\nKs 0.00 0.00 0.00\n\n"
        "newmtl maya_tile\nillum 4\nKd 0.50 0.50 0.50\nNi 1.00\nmap_Kd tile.tga\n\n"
        "newmtl fresnel_mirror\nillum 5\nKd 0.1 0.1 0.1\nKs 0.9 0.9 0.9\nNs 1000\n\n"
        "newmtl mirror_without_ks\nillum 3\nKd 0.7 0.6 0.5\n\n"
        "newmtl refraction\nillum 7\nKd 0 0 0\nNi 1.6\n\n"
        "newmtl glass_index_one\nillum 6\nNi 1.0\n\n"
        "newmtl shadow_matte\nillum 10\nKd 0.5 0.5 0.5\n"
    )
    faces = ""
    names = ["maya_brick", "maya_tile", "fresnel_mirror", "mirror_without_ks", "refraction", "glass_index_one", "shadow_matte"]
    verts = ""
    for k, name in enumerate(names):
        x = 3 * k
        verts += f"v {x} 0 0\nv {x + 1} 0 0\nv {x + 1} 1 0\nv {x} 1 0\n"
        faces += f"usemtl {name}\nf {4 * k + 1}/1 {4 * k + 2}/2 {4 * k + 3}/3 {4 * k + 4}/4\n"
    (OUT / "illum.obj").write_text(
        "mtllib illum.mtl\n" + verts + "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n" + faces
    )

    # Two libraries on one line, the second with an escaped space in its
    # name, and in a folder of its own (its textures are relative to it).
    (OUT / "libraries").mkdir(exist_ok=True)
    (OUT / "first.mtl").write_text("newmtl red\nKd 0.8 0.1 0.1\n")
    (OUT / "libraries" / "second lib.mtl").write_text("newmtl textured\nKd 1 1 1\nmap_Kd brick.bmp\n")
    (OUT / "libraries" / "brick.bmp").write_bytes(bmp(1, 1, lambda x, y: (10, 220, 10)))
    (OUT / "libraries.obj").write_text(
        "mtllib first.mtl libraries/second\\ lib.mtl\n"
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 3 0 0\nv 4 0 0\nv 4 1 0\nv 3 1 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
        "usemtl red\nf 1/1 2/2 3/3 4/4\nusemtl textured\nf 5/1 6/2 7/3 8/4\n"
    )

    # Faces naming `vn` lines the file does not have (the first two exist).
    (OUT / "missing_normals.obj").write_text(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 0.5 1\n"
        "vn 0 0 1\nvn 0 0 1\n"
        "f 1//1 2//2 5//7\nf 2//3 3//4 5//8\nf 3//5 4//6 5//9\nf 4//1 1//2 5//1\n"
    )


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    write_spheres()
    write_required_extensions()
    write_glass_roughness()
    write_texture_sets_and_transforms()
    write_single_sided()
    write_obj_cases()
    if "--draco" in sys.argv:
        write_draco_sphere()


if __name__ == "__main__":
    main()
