"""Scenes beyond the Cornell Box, written for prism and for Mitsuba 3 alike,
for tools/bench.py's `--scene`: one with glass, one lit by an environment
map, one with image textures. Each is small enough for a ladder up to 256
spp in minutes, and uses only what both renderers model the same way:
diffuse surfaces with spectra, RGB reflectance or sRGB textures (both
upsample RGB by Jakob–Hanika), smooth glass of a constant index, an RGB
area light, an RGB environment map (both times D65).

    scene = peer_scenes.SCENES["cornell-glass"]
    toml = scene.prism_toml(work)      # text of a prism scene file
    d = scene.mitsuba_dict(mi, work)   # a dict for mi.load_dict

Mitsuba's BSDFs are one-sided: every surface here faces its viewers (the
OBJ windings are kept), and glass's outside index is 1 (Mitsuba's default is
air's 1.000277).
"""

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

ROOT = Path(__file__).resolve().parent.parent
ASSETS = ROOT / "scenes/assets"
CORNELL_WALLS = ["floor", "ceiling", "back", "red", "green", "light"]


def read_csv_spectrum(path):
    rows = []
    for line in Path(path).read_text().splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        parts = line.split(",")
        try:
            rows.append((float(parts[0]), float(parts[1])))
        except ValueError:
            continue  # header
    return rows


def perspective(mi, position, look_at, fov_y, width, height):
    return {
        "type": "perspective",
        "fov_axis": "y",
        "fov": fov_y,
        "to_world": mi.ScalarTransform4f().look_at(origin=position, target=look_at, up=[0, 1, 0]),
        "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"},
                 "pixel_format": "rgb"},
        "sampler": {"type": "independent", "sample_count": 1},
    }


def path_integrator(max_depth, rr_depth=3):
    # prism counts bounces; Mitsuba counts vertices (1 = emitters seen
    # directly): Mitsuba's depths are prism's + 1.
    return {"type": "path", "max_depth": max_depth + 1, "rr_depth": rr_depth + 1}


@dataclass
class PeerScene:
    """A scene for both renderers. What both must agree on to be compared
    fairly (camera, image size, path depth) is held here once; `prism_body`
    and `mitsuba_objects` write the rest, each in its renderer's terms."""

    name: str
    description: str
    width: int
    height: int
    max_depth: int
    # position, look_at and fov_y (vertical field of view, degrees).
    camera: dict
    prism_body: Callable[[Path], str]  # (meshes' folder) -> materials, lights and shapes
    mitsuba_objects: Callable  # (mi, meshes' folder) -> the scene dict's emitters and shapes
    # Image-space boxes (x0, y0, x1, y1) whose mean radiance both renderers
    # must agree on: inside surfaces, away from edges.
    regions: dict
    # Writes the meshes the scene needs into the folder it is given.
    meshes: Callable[[Path], object] = lambda work: None

    def prism_toml(self, work):
        c = self.camera
        return f"""# tools/peer_scenes.py: {self.description}
[camera]
position = {list(c["position"])}
look_at = {list(c["look_at"])}
fov = {c["fov_y"]}

[film]
resolution = [{self.width}, {self.height}]

[integrator]
max_depth = {self.max_depth}

{self.prism_body(Path(work))}"""

    def mitsuba_dict(self, mi, work):
        return {
            "type": "scene",
            "integrator": path_integrator(self.max_depth),
            "sensor": perspective(mi, **self.camera, width=self.width, height=self.height),
            **self.mitsuba_objects(mi, Path(work)),
        }


# --- The Cornell Box's walls and light with a glass sphere instead of the blocks.

GLASS_CENTRE, GLASS_RADIUS = (278.0, 110.0, 270.0), 110.0
# scenes/cornell-box.toml's camera: a 35 mm lens on 25 mm of film.
CORNELL_CAMERA = dict(position=[278, 273, -800], look_at=[278, 273, 0], fov_y=math.degrees(2 * math.atan(12.5 / 35)))


def cornell_spectra():
    """The measured Cornell Box spectra (spectra/cornell_*.csv) for Mitsuba."""
    return {n: {"type": "spectrum", "value": read_csv_spectrum(ROOT / f"spectra/cornell_{n}.csv")}
            for n in ["white", "red", "green", "light"]}


def cornell_shapes(parts):
    """scenes/cornell/PART.obj for each of `parts` as Mitsuba shapes: diffuse
    with the measured spectra, the light emitting its spectrum."""
    spectra = cornell_spectra()
    shapes = {}
    for part in parts:
        material = part if part in ("red", "green") else "white"
        shape = {"type": "obj", "filename": str(ROOT / f"scenes/cornell/{part}.obj"), "face_normals": True,
                 "bsdf": {"type": "diffuse", "reflectance": spectra[material]}}
        if part == "light":
            shape["emitter"] = {"type": "area", "radiance": spectra["light"]}
        shapes[part] = shape
    return shapes


def cornell_glass_body(work):
    walls = "\n".join(
        f'[[shape]]\ntype = "obj"\nfile = "{ROOT}/scenes/cornell/{p}.obj"\n'
        f'material = "{p if p in ("red", "green") else "white"}"\n'
        + ("emission = \"light\"\n" if p == "light" else "")
        for p in CORNELL_WALLS
    )
    return f"""[spectra]
white = {{ file = "{ROOT}/spectra/cornell_white.csv" }}
red = {{ file = "{ROOT}/spectra/cornell_red.csv" }}
green = {{ file = "{ROOT}/spectra/cornell_green.csv" }}
light = {{ file = "{ROOT}/spectra/cornell_light.csv" }}

[materials.white]
type = "diffuse"
reflectance = "white"

[materials.red]
type = "diffuse"
reflectance = "red"

[materials.green]
type = "diffuse"
reflectance = "green"

[materials.glass]
type = "dielectric"
ior = 1.5

{walls}
[[shape]]
type = "sphere"
center = {list(GLASS_CENTRE)}
radius = {GLASS_RADIUS}
material = "glass"
"""


def cornell_glass_mitsuba(mi, work):
    return {
        "glass": {"type": "sphere", "center": list(GLASS_CENTRE), "radius": GLASS_RADIUS,
                  "bsdf": {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}},
        **cornell_shapes(CORNELL_WALLS),
    }


# --- Two spheres (diffuse, glass) on a floor under the studio map.

STUDIO_CAMERA = dict(position=[0, 1.2, 3.6], look_at=[0, 0.45, 0], fov_y=32)


def studio_body(work):
    return f"""[environment]
file = "{ASSETS}/studio.hdr"

[materials.floor]
type = "diffuse"
reflectance = 0.5

[materials.matte]
type = "diffuse"
reflectance = 0.8

[materials.glass]
type = "dielectric"
ior = 1.5

[[shape]]
type = "quad"
vertices = [[-10, 0, -10], [-10, 0, 10], [10, 0, 10], [10, 0, -10]]
material = "floor"

[[shape]]
type = "sphere"
center = [-0.6, 0.5, 0]
radius = 0.5
material = "matte"

[[shape]]
type = "sphere"
center = [0.6, 0.5, 0]
radius = 0.5
material = "glass"
"""


def studio_mitsuba(mi, work):
    T = mi.ScalarTransform4f
    return {
        # prism's map: u = 0.5 looks along +z, u grows towards +x; Mitsuba's:
        # u = atan2(x, -z) / 2π. Mirroring x maps one onto the other.
        "sky": {"type": "envmap", "filename": str(ASSETS / "studio.hdr"), "to_world": T().scale([-1, 1, 1])},
        # A rectangle spans [-1, 1]² in xy facing +z: turned to face +y.
        "floor": {"type": "rectangle", "to_world": T().rotate([1, 0, 0], -90).scale(10),
                  "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.5, 0.5, 0.5]}}},
        "matte": {"type": "sphere", "center": [-0.6, 0.5, 0], "radius": 0.5,
                  "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.8, 0.8, 0.8]}}},
        "glass": {"type": "sphere", "center": [0.6, 0.5, 0], "radius": 0.5,
                  "bsdf": {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}},
    }


# --- The textured OBJ room of scenes/textured-obj.toml, its glossy block matte.

ROOM_CAMERA = dict(position=[0.6, 1.6, 4.2], look_at=[-0.3, 0.8, -1], fov_y=50)
BLOCK_RGB = [0.1, 0.35, 0.2]
LAMP_RGB = [8, 7.6, 6.8]


def room_objects():
    """room.obj's objects as {name: (positions, uvs, faces)}: faces are lists
    of (position index, uv index or None), indices from 0, windings kept."""
    objects, name = {}, None
    positions, uvs = [], []
    for line in (ASSETS / "room.obj").read_text().splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "o":
            name = parts[1]
            objects[name] = []
        elif parts[0] == "v":
            positions.append([float(x) for x in parts[1:4]])
        elif parts[0] == "vt":
            uvs.append([float(x) for x in parts[1:3]])
        elif parts[0] == "f":
            face = []
            for corner in parts[1:]:
                idx = corner.split("/")
                p = int(idx[0])
                p = p - 1 if p > 0 else len(positions) + p
                t = None
                if len(idx) > 1 and idx[1]:
                    t = int(idx[1])
                    t = t - 1 if t > 0 else len(uvs) + t
                face.append((p, t))
            objects[name].append(face)
    return {n: (positions, uvs, faces) for n, faces in objects.items()}


ROOM_PARTS = ("floor", "back_wall", "lamp", "block")


def room_obj_path(work, name):
    return Path(work) / f"room-{name}.obj"


def write_room_objs(work):
    """Each object of room.obj as its own OBJ of triangles (Mitsuba reads an
    OBJ as one shape of one material); returns {name: path}."""
    paths = {}
    for name, (positions, uvs, faces) in room_objects().items():
        lines, used_p, used_t = [], {}, {}
        for face in faces:
            for p, t in face:
                used_p.setdefault(p, len(used_p) + 1)
                if t is not None:
                    used_t.setdefault(t, len(used_t) + 1)
        lines += [f"v {' '.join(map(str, positions[p]))}" for p in used_p]
        lines += [f"vt {' '.join(map(str, uvs[t]))}" for t in used_t]
        for face in faces:
            corners = [f"{used_p[p]}/{used_t[t]}" if t is not None else str(used_p[p]) for p, t in face]
            lines += [f"f {corners[0]} {corners[k]} {corners[k + 1]}" for k in range(1, len(corners) - 1)]
        path = room_obj_path(work, name)
        path.write_text("\n".join(lines) + "\n")
        paths[name] = path
    return paths


def textured_room_body(work):
    return f"""[materials.tiles]
type = "diffuse"
reflectance = 1
texture = "{ASSETS}/tiles.png"

[materials.brick]
type = "diffuse"
reflectance = 1
texture = "{ASSETS}/bricks.png"

[materials.block]
type = "diffuse"
reflectance = {{ rgb = {BLOCK_RGB} }}

[materials.black]
type = "diffuse"
reflectance = 0

[[shape]]
type = "obj"
file = "{work}/room-floor.obj"
material = "tiles"

[[shape]]
type = "obj"
file = "{work}/room-back_wall.obj"
material = "brick"

[[shape]]
type = "obj"
file = "{work}/room-lamp.obj"
material = "black"
emission = {{ rgb = {LAMP_RGB} }}

[[shape]]
type = "obj"
file = "{work}/room-block.obj"
material = "block"
"""


def textured_room_mitsuba(mi, work):
    # The prism scene's `meshes` hook wrote them where the scene was written.
    paths = {name: room_obj_path(work, name) for name in ROOM_PARTS}
    if not all(p.exists() for p in paths.values()):
        paths = write_room_objs(work)

    def textured(png):
        return {"type": "diffuse", "reflectance": {"type": "bitmap", "filename": str(ASSETS / png)}}

    def shape(name, bsdf, **extra):
        return {"type": "obj", "filename": str(paths[name]), "face_normals": True, "bsdf": bsdf, **extra}

    black = {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0, 0, 0]}}
    return {
        "floor": shape("floor", textured("tiles.png")),
        "wall": shape("back_wall", textured("bricks.png")),
        "lamp": shape("lamp", black, emitter={"type": "area", "radiance": {"type": "rgb", "value": LAMP_RGB}}),
        "block": shape("block", {"type": "diffuse", "reflectance": {"type": "rgb", "value": BLOCK_RGB}}),
    }


SCENES = {
    s.name: s
    for s in [
        PeerScene("cornell-glass", "the Cornell Box's walls and light around a glass sphere", 256, 256, 16,
                  CORNELL_CAMERA, cornell_glass_body, cornell_glass_mitsuba,
                  {"ceiling": (80, 8, 170, 20), "red wall": (12, 80, 30, 170), "green wall": (226, 80, 244, 170),
                   "back wall": (60, 60, 100, 100), "sphere": (110, 150, 146, 186), "floor": (60, 236, 200, 248)}),
        PeerScene("studio", "a diffuse and a glass sphere on a floor under the studio map", 320, 180, 16,
                  STUDIO_CAMERA, studio_body, studio_mitsuba,
                  {"matte sphere": (95, 60, 125, 100), "glass sphere": (195, 60, 225, 100),
                   "floor front": (100, 160, 220, 175), "sky": (0, 0, 320, 12)}),
        PeerScene("textured-room", "scenes/textured-obj.toml's textured room, its glossy block matte", 320, 240, 12,
                  ROOM_CAMERA, textured_room_body, textured_room_mitsuba,
                  {"floor": (120, 200, 220, 235), "wall": (40, 40, 140, 100), "block": (60, 130, 100, 160)},
                  meshes=write_room_objs),
    ]
}


def write_prism_scene(scene, work):
    """Writes the prism scene file (and any meshes it needs) into `work`."""
    work = Path(work)
    work.mkdir(parents=True, exist_ok=True)
    scene.meshes(work)
    path = work / f"{scene.name}.toml"
    path.write_text(scene.prism_toml(work))
    return path
