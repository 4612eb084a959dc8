#!/usr/bin/env python3
"""A big-mesh benchmark scene: a cave of two bumpy terrains facing each other.

    python3 tools/gen_cave.py DIR [--n 708]

Writes DIR/floor.obj and DIR/ceiling.obj (2·(n−1)² triangles each: about
2 million at the default n = 708, a 116 MiB tree) and DIR/cave.toml, a
point light between them. Every bounce of a camera path lands on another
part of the mesh: incoherent rays through a tree that outgrows the caches,
the case `prism render --stream` is for (docs/performance.md, "Paths as a
stream"). The terrain is the one `cargo bench --bench rays` traces.
"""

import argparse
import math
from pathlib import Path

SCENE = """# A cave of two terrains (tools/gen_cave.py, n = {n}): {triangles} triangles.
[camera]
position = [0, 0.25, -0.95]
look_at = [0, 0.2, 0]
fov = 60

[film]
resolution = [256, 256]
spp = 16

[materials.rock]
type = "diffuse"
reflectance = 0.7

[[shape]]
type = "obj"
file = "floor.obj"
material = "rock"

[[shape]]
type = "obj"
file = "ceiling.obj"
material = "rock"

[[light]]
type = "point"
position = [0, 0.25, 0]
power = 50
"""


def height(x, z):
    return 0.05 * (math.sin(13 * x) * math.cos(11 * z) + 0.5 * math.sin(37 * x + 23 * z))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dir", type=Path)
    ap.add_argument("--n", type=int, default=708, help="vertices along a side of each terrain")
    args = ap.parse_args()
    n = args.n
    if n < 2:
        ap.error("--n: at least 2")
    args.dir.mkdir(parents=True, exist_ok=True)
    with open(args.dir / "floor.obj", "w") as floor, open(args.dir / "ceiling.obj", "w") as ceiling:
        for j in range(n):
            for i in range(n):
                x, z = 2 * i / (n - 1) - 1, 2 * j / (n - 1) - 1
                y = height(x, z)
                floor.write(f"v {x:.6f} {y:.6f} {z:.6f}\n")
                ceiling.write(f"v {x:.6f} {0.5 - y:.6f} {z:.6f}\n")
        for j in range(n - 1):
            for i in range(n - 1):
                a = j * n + i + 1
                floor.write(f"f {a} {a + n} {a + n + 1}\nf {a} {a + n + 1} {a + 1}\n")
                # Wound the other way: the ceiling faces down, into the cave.
                ceiling.write(f"f {a} {a + n + 1} {a + n}\nf {a} {a + 1} {a + n + 1}\n")
    triangles = 4 * (n - 1) ** 2
    (args.dir / "cave.toml").write_text(SCENE.format(n=n, triangles=triangles))
    print(f"wrote {args.dir}/cave.toml: {triangles} triangles")


if __name__ == "__main__":
    main()
