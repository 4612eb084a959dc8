"""tools/gen_meshes.py: the shipped meshes are what it writes, and the
turned ones (the glass, the water) carry normals that lie on their faces'
side, smooth around the axis and sharp at the profile's corners."""
import math

import numpy as np

import gen_meshes
from conftest import ROOT

SEGMENTS = 96
CUP = gen_meshes.TUMBLER


def test_shipped_meshes_are_what_the_generator_writes(tmp_path, monkeypatch):
    monkeypatch.setattr(gen_meshes, "OUT", tmp_path)
    gen_meshes.main()
    written = sorted(p.name for p in tmp_path.glob("*.obj"))
    assert "glass.obj" in written and "water.obj" in written
    for name in written:
        shipped = (ROOT / "scenes" / "meshes" / name).read_text()
        assert shipped == (tmp_path / name).read_text(), f"{name}: run tools/gen_meshes.py"


def test_turned_normals_follow_the_faces():
    v, faces, normals = gen_meshes.lathe(CUP, SEGMENTS)
    v, normals = np.array(v), np.array(normals)
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-12)
    # Half a segment's turn: the most a corner's normal may lean from its
    # face's, on a wall; on the flat rim and bottoms it is the face's own.
    half_turn = math.cos(math.pi / SEGMENTS) - 1e-9
    walls = 0
    for face in faces:
        corners = [v[i] for i, _ in face]
        # A quad's diagonals, or a triangle's two edges (the caps' fans).
        n = np.cross(corners[2] - corners[0], corners[-1] - corners[1])
        assert np.linalg.norm(n) > 1e-6, "no degenerate faces"
        n /= np.linalg.norm(n)
        cosines = [normals[k] @ n for _, k in face]
        assert min(cosines) > half_turn, (face, cosines)
        if abs(n[1]) < 1e-9:
            walls += 1
            # Radial on a wall: smooth around the axis, not the facet's.
            assert max(cosines) < 1.0 - 1e-9
    assert walls == 2 * SEGMENTS  # the outer and the inner wall
    # The bottom, the rim and the inner bottom; nothing along the axis.
    assert len(faces) == 5 * SEGMENTS


def test_the_rim_is_a_sharp_edge():
    v, faces, normals = gen_meshes.lathe(CUP, SEGMENTS)
    rim_outer = CUP.index((1.0, 2.5))  # the corner of the outer wall and the rim
    by_vertex = {}
    for face in faces:
        for i, k in face:
            by_vertex.setdefault(i, set()).add(tuple(np.round(normals[k], 9)))
    # Its vertices take the wall's normal (radial) in one band and the
    # rim's (up) in the next.
    for s in range(SEGMENTS):
        seen = by_vertex[s * len(CUP) + rim_outer]
        assert (0.0, 1.0, 0.0) in seen
        assert any(abs(n[1]) < 1e-9 for n in seen)
