"""tools/gen_cave.py writes a closed-in cave that prism loads and renders
the same with and without streams of paths."""
import subprocess
import sys

import numpy as np

from conftest import ROOT


def read_obj(path):
    v, f = [], []
    for line in path.read_text().splitlines():
        kind, *rest = line.split()
        (v if kind == "v" else f).append([float(x) if kind == "v" else int(x) - 1 for x in rest])
    return np.array(v), np.array(f)


def normals(v, f):
    return np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])


def test_cave_faces_inwards_and_renders_the_same_streamed(tmp_path, prism):
    n = 12
    subprocess.run([sys.executable, str(ROOT / "tools" / "gen_cave.py"), str(tmp_path), "--n", str(n)], check=True)
    floor_v, floor_f = read_obj(tmp_path / "floor.obj")
    ceiling_v, ceiling_f = read_obj(tmp_path / "ceiling.obj")
    assert len(floor_f) == len(ceiling_f) == 2 * (n - 1) ** 2
    # The floor faces up, the ceiling down, into the cave between them.
    assert (normals(floor_v, floor_f)[:, 1] > 0).all()
    assert (normals(ceiling_v, ceiling_f)[:, 1] < 0).all()
    assert floor_v[:, 1].max() < ceiling_v[:, 1].min()
    outputs = []
    for mode in ("never", "always"):
        out = tmp_path / mode
        prism("render", tmp_path / "cave.toml", "--resolution", "24x16", "--spp", "4",
              "--stream", mode, "-q", "-o", out)
        outputs.append((out.with_suffix(".exr")).read_bytes())
    assert outputs[0] == outputs[1]
