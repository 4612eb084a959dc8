#!/usr/bin/env python3
"""Writes the demo assets of scenes/assets/: a textured OBJ/MTL room, a
glTF binary (.glb) with a textured floor, a transmissive dispersive glass
sphere, a gold sphere, an emissive panel and a camera, and an HDR studio
environment map (studio.hdr: softboxes in a dim room, made here, so free
of any licence). Standard library only; the output is deterministic, so
re-running it changes nothing.

    python3 tools/gen_assets.py
    python3 tools/gen_assets.py --terrain DIR   # 1M-triangle OBJ + GLB + scene, for load timing
    python3 tools/gen_assets.py --terrain DIR 2237   # the same with 10M triangles
"""

import json
import math
import struct
import zlib
from pathlib import Path

OUT = Path(__file__).resolve().parent.parent / "scenes" / "assets"


def png(width, height, pixel):
    """An RGB PNG; pixel(x, y) returns (r, g, b) bytes."""
    rows = b"".join(
        b"\x00" + bytes(c for x in range(width) for c in pixel(x, y)) for y in range(height)
    )

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(rows, 9))
        + chunk(b"IEND", b"")
    )


def rgbe(rgb):
    """A linear RGB radiance as Radiance RGBE bytes."""
    m = max(rgb)
    if m < 1e-32:
        return bytes((0, 0, 0, 0))
    e = math.frexp(m)[1]
    f = 256.0 / 2.0**e
    return bytes(min(255, int(c * f)) for c in rgb) + bytes((e + 128,))


def studio(u, v):
    """Radiance of the studio map at map coordinates (u, v) in [0, 1]²: the
    map's convention (README, [environment]): azimuth 0 (u = 0.5) looks
    along +z, u grows towards +x, v = 0 is the zenith."""
    azimuth = (u - 0.5) * 360.0
    elevation = 90.0 - v * 180.0
    if elevation < 0.0:
        # The room's floor, dark and warm.
        return (0.05, 0.045, 0.04)
    # Walls: brighter towards the horizon.
    base = 0.12 + 0.18 * (1.0 - elevation / 90.0)
    rgb = [base * 1.0, base * 0.97, base * 0.92]

    def box(az, el, half_az, half_el):
        d = (azimuth - az + 180.0) % 360.0 - 180.0
        return abs(d) < half_az and abs(elevation - el) < half_el

    if box(35.0, 35.0, 14.0, 10.0):  # warm key softbox, front right
        rgb = [14.0, 12.5, 10.5]
    elif box(-60.0, 22.0, 11.0, 14.0):  # cool fill, left
        rgb = [2.0, 2.6, 3.4]
    elif box(180.0, 30.0, 4.0, 20.0):  # rim strip behind
        rgb = [7.0, 7.0, 7.0]
    elif elevation > 75.0:  # a ceiling light
        rgb = [3.0, 3.0, 3.0]
    return tuple(rgb)


def hdr(width, height, radiance):
    """An uncompressed Radiance HDR (RGBE) image; radiance(u, v) → RGB."""
    header = f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n".encode()
    body = b"".join(
        rgbe(radiance((x + 0.5) / width, (y + 0.5) / height))
        for y in range(height)
        for x in range(width)
    )
    return header + body


def checker(x, y, n=8, a=(230, 230, 225), b=(40, 60, 90)):
    return a if ((x * n // 256) + (y * n // 256)) % 2 == 0 else b


def bricks(x, y):
    row = y // 32
    offset = 32 if row % 2 else 0
    mortar = y % 32 < 3 or (x + offset) % 64 < 3
    if mortar:
        return (200, 195, 185)
    shade = ((x + offset) // 64 * 37 + row * 91) % 40
    return (150 + shade, 60 + shade // 2, 40)


def sphere(rings=24, segments=48):
    """Positions, normals, uvs (v down) and indices of a unit UV sphere."""
    pos, nor, uv, idx = [], [], [], []
    for r in range(rings + 1):
        theta = math.pi * r / rings
        for s in range(segments + 1):
            phi = 2 * math.pi * s / segments
            n = (math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi))
            pos.append(n)
            nor.append(n)
            uv.append((s / segments, r / rings))
    for r in range(rings):
        for s in range(segments):
            a = r * (segments + 1) + s
            b, c, d = a + 1, a + segments + 1, a + segments + 2
            if r != 0:
                idx += [a, c, b]
            if r != rings - 1:
                idx += [b, c, d]
    return pos, nor, uv, idx


def quad(size):
    h = size / 2
    pos = [(-h, 0, h), (h, 0, h), (h, 0, -h), (-h, 0, -h)]
    nor = [(0, 1, 0)] * 4
    uv = [(0, 4), (4, 4), (4, 0), (0, 0)]  # repeats the texture 4 times
    return pos, nor, uv, [0, 1, 2, 0, 2, 3]


class Glb:
    def __init__(self):
        self.bin = bytearray()
        self.views, self.accessors = [], []

    def view(self, data):
        while len(self.bin) % 4:
            self.bin += b"\x00"
        self.views.append({"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)})
        self.bin += data
        return len(self.views) - 1

    def floats(self, rows, kind):
        flat = [c for r in rows for c in r]
        view = self.view(struct.pack(f"<{len(flat)}f", *flat))
        acc = {"bufferView": view, "componentType": 5126, "count": len(rows), "type": kind}
        if kind == "VEC3":
            acc["min"] = [min(r[i] for r in rows) for i in range(3)]
            acc["max"] = [max(r[i] for r in rows) for i in range(3)]
        self.accessors.append(acc)
        return len(self.accessors) - 1

    def indices(self, idx):
        view = self.view(struct.pack(f"<{len(idx)}I", *idx))
        self.accessors.append(
            {"bufferView": view, "componentType": 5125, "count": len(idx), "type": "SCALAR"}
        )
        return len(self.accessors) - 1

    def mesh(self, name, geometry, material):
        pos, nor, uv, idx = geometry
        attrs = {
            "POSITION": self.floats(pos, "VEC3"),
            "NORMAL": self.floats(nor, "VEC3"),
            "TEXCOORD_0": self.floats(uv, "VEC2"),
        }
        return {"name": name, "primitives": [{"attributes": attrs, "indices": self.indices(idx), "material": material}]}

    def write(self, path, doc):
        doc["bufferViews"] = self.views
        doc["accessors"] = self.accessors
        doc["buffers"] = [{"byteLength": len(self.bin)}]
        text = json.dumps(doc, separators=(",", ":")).encode()
        text += b" " * (-len(text) % 4)
        data = bytes(self.bin) + b"\x00" * (-len(self.bin) % 4)
        total = 12 + 8 + len(text) + 8 + len(data)
        out = struct.pack("<4sII", b"glTF", 2, total)
        out += struct.pack("<II", len(text), 0x4E4F534A) + text
        out += struct.pack("<II", len(data), 0x004E4942) + data
        path.write_bytes(out)


def write_glb():
    g = Glb()
    floor_png = g.view(png(256, 256, checker))
    meshes = [
        g.mesh("floor", quad(8.0), 0),
        g.mesh("sphere", sphere(), 1),
        g.mesh("ball", sphere(), 2),
        g.mesh("panel", quad(1.0), 3),
    ]
    doc = {
        "asset": {"version": "2.0", "generator": "prism tools/gen_assets.py"},
        "extensionsUsed": [
            "KHR_materials_transmission",
            "KHR_materials_ior",
            "KHR_materials_dispersion",
            "KHR_materials_emissive_strength",
        ],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3, 4]}],
        "nodes": [
            {"name": "floor", "mesh": 0},
            {"name": "glass sphere", "mesh": 1, "translation": [-0.9, 0.8, 0], "scale": [0.8, 0.8, 0.8]},
            {"name": "gold ball", "mesh": 2, "translation": [1.0, 0.6, -0.6], "scale": [0.6, 0.6, 0.6]},
            # The panel faces down: a 180° turn about x (quaternion x, y, z, w).
            {"name": "light", "mesh": 3, "translation": [0.5, 3.5, 0.5], "rotation": [1, 0, 0, 0], "scale": [2, 1, 2]},
            {
                "name": "camera",
                "camera": 0,
                # Looking down 10° towards the spheres from (0, 1.6, 5).
                "translation": [0, 1.6, 5],
                "rotation": [-math.sin(math.radians(5)), 0, 0, math.cos(math.radians(5))],
            },
        ],
        "cameras": [{"name": "view", "type": "perspective", "perspective": {"yfov": 0.6, "znear": 0.1}}],
        "meshes": meshes,
        "images": [{"bufferView": floor_png, "mimeType": "image/png"}],
        "samplers": [{"wrapS": 10497, "wrapT": 10497}],
        "textures": [{"source": 0, "sampler": 0}],
        "materials": [
            {
                "name": "tiles",
                "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0, "roughnessFactor": 0.5},
            },
            {
                "name": "glass",
                "pbrMetallicRoughness": {"metallicFactor": 0, "roughnessFactor": 0},
                "extensions": {
                    "KHR_materials_transmission": {"transmissionFactor": 1},
                    "KHR_materials_ior": {"ior": 1.6},
                    "KHR_materials_dispersion": {"dispersion": 0.6},
                },
            },
            {
                "name": "gold",
                "pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.76, 0.33, 1], "metallicFactor": 1, "roughnessFactor": 0.25},
            },
            {
                "name": "lamp",
                "emissiveFactor": [1, 0.95, 0.85],
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 12}},
                "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0},
            },
        ],
    }
    g.write(OUT / "spheres.glb", doc)


def write_layers_glb():
    """Spheres with the glTF extension layers prism maps: thin films
    (KHR_materials_iridescence: an oil film on a dark base, an anodised metal),
    a clear coat over red plastic, a tinted specular and velvet (KHR_materials_clearcoat,
    KHR_materials_specular, KHR_materials_sheen), on a grey floor under a panel light."""
    g = Glb()
    ball = sphere(32, 64)

    def swirl(x, y):
        # Film thickness in green: bands that wander like oil on water.
        u, v = x / 128.0, y / 128.0
        t = 0.5 + 0.5 * math.sin(9 * u + 4 * math.sin(7 * v) + 3 * math.sin(5 * u * v))
        return (0, int(255 * t), 0)

    film_png = g.view(png(128, 128, swirl))
    meshes = [g.mesh("floor", quad(10.0), 0), g.mesh("panel", quad(1.0), 1)]
    materials = [
        {"name": "floor", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0, "roughnessFactor": 0.8}},
        {
            "name": "lamp",
            "emissiveFactor": [1, 1, 1],
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 10}},
            "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0},
        },
    ]
    balls = [
        # A film shows colours where its index differs from the base's on both
        # sides: oil (1.45) on glTF's default base (1.5) is nearly index-matched
        # and reads as black glass. A film of 1.33 on it has the contrast of
        # oil on water (0.06 against 0.04) and, thin (250-550 nm: first and
        # second orders), the vivid bands of a puddle's oil slick.
        ("oil film", {"baseColorFactor": [0.02, 0.02, 0.025, 1], "metallicFactor": 0, "roughnessFactor": 0.05},
         {"KHR_materials_iridescence": {"iridescenceFactor": 1, "iridescenceIor": 1.33, "iridescenceThicknessMinimum": 250,
                                        "iridescenceThicknessMaximum": 550, "iridescenceThicknessTexture": {"index": 0}}}),
        ("anodised titanium", {"baseColorFactor": [0.55, 0.52, 0.5, 1], "metallicFactor": 1, "roughnessFactor": 0.2},
         {"KHR_materials_iridescence": {"iridescenceFactor": 1, "iridescenceIor": 2.0, "iridescenceThicknessMaximum": 260}}),
        ("clear-coated red", {"baseColorFactor": [0.6, 0.04, 0.03, 1], "metallicFactor": 0, "roughnessFactor": 0.6},
         {"KHR_materials_clearcoat": {"clearcoatFactor": 1, "clearcoatRoughnessFactor": 0.05}}),
        ("tinted specular", {"baseColorFactor": [0.05, 0.1, 0.3, 1], "metallicFactor": 0, "roughnessFactor": 0.3},
         {"KHR_materials_specular": {"specularFactor": 1, "specularColorFactor": [1.0, 0.8, 0.3]}}),
        ("velvet", {"baseColorFactor": [0.25, 0.02, 0.08, 1], "metallicFactor": 0, "roughnessFactor": 0.9},
         {"KHR_materials_sheen": {"sheenColorFactor": [1.0, 0.55, 0.7], "sheenRoughnessFactor": 0.4}}),
    ]
    nodes = [{"name": "floor", "mesh": 0},
             {"name": "light", "mesh": 1, "translation": [0, 4, 1], "rotation": [1, 0, 0, 0], "scale": [4, 1, 2]}]
    for i, (name, pbr, ext) in enumerate(balls):
        materials.append({"name": name, "pbrMetallicRoughness": pbr, "extensions": ext})
        meshes.append(g.mesh(name, ball, len(materials) - 1))
        nodes.append({"name": name, "mesh": len(meshes) - 1, "translation": [-2.4 + 1.2 * i, 0.5, 0], "scale": [0.5, 0.5, 0.5]})
    nodes.append({
        "name": "camera", "camera": 0, "translation": [0, 1.5, 5.5],
        "rotation": [-math.sin(math.radians(6)), 0, 0, math.cos(math.radians(6))],
    })
    doc = {
        "asset": {"version": "2.0", "generator": "prism tools/gen_assets.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_materials_iridescence",
                           "KHR_materials_clearcoat", "KHR_materials_specular", "KHR_materials_sheen"],
        "scene": 0,
        "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes,
        "cameras": [{"name": "view", "type": "perspective", "perspective": {"yfov": 0.55, "znear": 0.1}}],
        "meshes": meshes,
        "materials": materials,
        "images": [{"bufferView": film_png, "mimeType": "image/png"}],
        "samplers": [{"wrapS": 10497, "wrapT": 10497}],
        "textures": [{"source": 0, "sampler": 0}],
    }
    g.write(OUT / "layers.glb", doc)


OBJ = """# A room made of quads, n-gons and per-face materials (tools/gen_assets.py)
mtllib room.mtl
o floor
v -2 0 -2
v 2 0 -2
v 2 0 2
v -2 0 2
vt 0 0
vt 3 0
vt 3 3
vt 0 3
vn 0 1 0
usemtl tiles
f -4/-4/-1 -1/-1/-1 -2/-2/-1 -3/-3/-1
o back_wall
v -2 0 -2
v -2 3 -2
v 2 3 -2
v 2 0 -2
vt 0 0
vt 0 1.5
vt 2 1.5
vt 2 0
usemtl brick
f 5/5 8/8 7/7 6/6
o lamp
v -0.6 2.99 -0.4
v 0.6 2.99 -0.4
v 0.8 2.99 0.3
v 0 2.99 0.8
v -0.8 2.99 0.3
usemtl lamp
f 9 10 11 12 13
o block
v -1.2 0 -0.6
v -0.4 0 -0.6
v -0.4 0 0.2
v -1.2 0 0.2
v -1.2 0.8 -0.6
v -0.4 0.8 -0.6
v -0.4 0.8 0.2
v -1.2 0.8 0.2
usemtl glossy
f 18 21 20 19
f 14 18 19 15
f 15 19 20 16
f 16 20 21 17
f 17 21 18 14
"""

MTL = """# Materials for room.obj (tools/gen_assets.py)
newmtl tiles
Kd 1 1 1
map_Kd tiles.png

newmtl brick
Kd 1 1 1
map_Kd bricks.png

newmtl lamp
Kd 0 0 0
Ke 8 7.6 6.8

newmtl glossy
illum 2
Kd 0.1 0.35 0.2
Ks 0.5 0.5 0.5
Ns 400
Ni 1.5
"""


def write_obj():
    (OUT / "room.obj").write_text(OBJ)
    (OUT / "room.mtl").write_text(MTL)
    (OUT / "tiles.png").write_bytes(png(128, 128, lambda x, y: checker(x * 2, y * 2, 4)))
    (OUT / "bricks.png").write_bytes(png(256, 128, bricks))


def write_terrain(out, n=708):
    """A height-field grid of 2·(n−1)² ≈ 1M triangles with normals and
    texture coordinates, as OBJ and as GLB, and a scene that loads each."""
    out.mkdir(parents=True, exist_ok=True)
    pos, nor, uv, idx = [], [], [], []
    for j in range(n):
        for i in range(n):
            x, z = i / (n - 1) * 2 - 1, j / (n - 1) * 2 - 1
            h = 0.1 * math.sin(7 * x) * math.cos(5 * z)
            dx, dz = 0.7 * math.cos(7 * x) * math.cos(5 * z), -0.5 * math.sin(7 * x) * math.sin(5 * z)
            l = math.sqrt(dx * dx + 1 + dz * dz)
            pos.append((x, h, z))
            nor.append((-dx / l, 1 / l, -dz / l))
            uv.append((i / (n - 1), j / (n - 1)))
    for j in range(n - 1):
        for i in range(n - 1):
            a = j * n + i
            idx += [a, a + n, a + 1, a + 1, a + n, a + n + 1]
    with open(out / "terrain.obj", "w") as f:
        f.writelines(f"v {p[0]:.6f} {p[1]:.6f} {p[2]:.6f}\n" for p in pos)
        f.writelines(f"vn {v[0]:.6f} {v[1]:.6f} {v[2]:.6f}\n" for v in nor)
        f.writelines(f"vt {t[0]:.6f} {1 - t[1]:.6f}\n" for t in uv)
        for k in range(0, len(idx), 3):
            a, b, c = (i + 1 for i in idx[k : k + 3])
            f.write(f"f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}\n")
    g = Glb()
    mesh = g.mesh("terrain", (pos, nor, uv, idx), 0)
    g.write(
        out / "terrain.glb",
        {
            "asset": {"version": "2.0"},
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [mesh],
            "materials": [{"pbrMetallicRoughness": {"metallicFactor": 0}}],
        },
    )
    for kind, ext in (("obj", "obj"), ("gltf", "glb")):
        (out / f"terrain-{ext}.toml").write_text(
            "[camera]\nposition = [0, 2, 2]\nlook_at = [0, 0, 0]\n[film]\nresolution = [64, 64]\nspp = 1\n"
            f'[[shape]]\ntype = "{kind}"\nfile = "terrain.{ext}"\n'
            '[[shape]]\ntype = "sphere"\ncenter = [0, 3, 0]\nradius = 0.5\nemission = 5\n'
        )
    print(f"wrote {out}: {len(idx) // 3} triangles")


if __name__ == "__main__":
    import sys

    if len(sys.argv) in (3, 4) and sys.argv[1] == "--terrain":
        write_terrain(Path(sys.argv[2]), *map(int, sys.argv[3:]))
    else:
        OUT.mkdir(parents=True, exist_ok=True)
        write_glb()
        write_layers_glb()
        write_obj()
        (OUT / "studio.hdr").write_bytes(hdr(512, 256, studio))
        print(f"wrote {OUT}")
