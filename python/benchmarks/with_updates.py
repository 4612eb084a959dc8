"""How long Scene.with_updates takes against a load of the whole scene, on a
scene with a 1M-triangle mesh: one material's reflectance changed, the
lamp's emission, and the white balance. Prints the median of five of each, alternated.

    tools/.venv/bin/python python/benchmarks/with_updates.py [triangles]
"""

import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import prism


def grid_obj(path: Path, triangles: int) -> None:
    """A wavy height field of about `triangles` triangles."""
    n = int(np.sqrt(triangles / 2)) + 1
    u, v = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n))
    h = 0.05 * np.sin(9 * u) * np.cos(7 * v)
    verts = np.column_stack([u.ravel(), h.ravel(), v.ravel()])
    i = np.arange(n * n).reshape(n, n)[:-1, :-1].ravel()
    faces = np.concatenate(
        [np.column_stack([i, i + n, i + 1]), np.column_stack([i + 1, i + n, i + n + 1])]
    ) + 1
    with open(path, "w") as f:
        np.savetxt(f, verts, fmt="v %.6f %.6f %.6f")
        np.savetxt(f, faces, fmt="f %d %d %d")


SCENE = """
[camera]
position = [0, 2, 3]
look_at = [0, 0, 0]
[film]
resolution = [64, 48]
[materials.ground]
type = "diffuse"
reflectance = 0.5
[materials.patch]
type = "diffuse"
reflectance = { rgb = [0.8, 0.2, 0.1] }
[[shape]]
type = "obj"
file = "grid.obj"
material = "ground"
[[shape]]
type = "sphere"
center = [0, 0.4, 0]
radius = 0.3
material = "patch"
[[shape]]
type = "quad"
vertices = [[-1, 3, -1], [1, 3, -1], [1, 3, 1], [-1, 3, 1]]
emission = "D65"
"""


def timed(f):
    t = time.perf_counter()
    out = f()
    return time.perf_counter() - t, out


def main() -> None:
    triangles = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        grid_obj(d / "grid.obj", triangles)
        (d / "scene.toml").write_text(SCENE)
        scene = prism.load(d / "scene.toml")
        print(f"{scene.triangle_count} triangles")
        reflectance = (np.array([400.0, 550.0, 700.0]), np.array([0.1, 0.5, 0.9]))
        loads, updates, lamps, balances = [], [], [], []
        for _ in range(5):
            loads.append(timed(lambda: prism.load(d / "scene.toml"))[0])
            t, updated = timed(lambda: scene.with_updates({"materials.patch.reflectance": reflectance}))
            assert scene.shares_geometry(updated)
            updates.append(t)
            t, relit = timed(lambda: scene.with_updates({"shape[2].emission": "A"}))
            assert scene.shares_geometry(relit)
            lamps.append(t)
            balances.append(timed(lambda: scene.with_updates({"film.white_balance": "A"}))[0])
        load, update, lamp, balance = (statistics.median(x) for x in (loads, updates, lamps, balances))
        print(f"load of the scene: {load * 1e3:.1f} ms")
        print(f"with_updates, one reflectance: {update * 1e3:.2f} ms ({load / update:.0f}x faster)")
        print(f"with_updates, the lamp's emission: {lamp * 1e3:.2f} ms ({load / lamp:.0f}x faster)")
        print(f"with_updates, white balance: {balance * 1e3:.2f} ms ({load / balance:.0f}x faster)")


if __name__ == "__main__":
    main()
