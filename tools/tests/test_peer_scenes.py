"""tools/peer_scenes.py: the scenes that tools/bench.py renders in prism and
Mitsuba 3 load in prism, and the room's OBJ, split per object for Mitsuba,
keeps every face and its winding (Mitsuba's surfaces are one-sided)."""
import numpy as np

import peer_scenes


def test_every_peer_scene_loads_and_renders_in_prism(tmp_path, prism):
    for scene in peer_scenes.SCENES.values():
        path = peer_scenes.write_prism_scene(scene, tmp_path)
        out = tmp_path / scene.name
        result = prism("render", path, "--resolution", "32x24", "--spp", "2", "--no-spectral", "-o", out)
        assert "triangles" in result.stderr + result.stdout
        assert out.with_suffix(".exr").exists()


def face_normal(positions, face):
    p = [np.array(positions[i]) for i, _ in face]
    # Newell's normal of the polygon: its winding's direction.
    return sum(np.cross(p[k], p[(k + 1) % len(p)]) for k in range(len(p)))


def read_triangles(path):
    v, tris = [], []
    for line in path.read_text().splitlines():
        kind, *rest = line.split()
        if kind == "v":
            v.append([float(x) for x in rest])
        elif kind == "f":
            tris.append([int(c.split("/")[0]) - 1 for c in rest])
    return np.array(v), tris


def test_room_objects_split_into_triangles_with_their_windings(tmp_path):
    objects = peer_scenes.room_objects()
    assert set(objects) == {"floor", "back_wall", "lamp", "block"}
    paths = peer_scenes.write_room_objs(tmp_path)
    for name, (positions, _, faces) in objects.items():
        v, tris = read_triangles(paths[name])
        # A polygon of n corners becomes n - 2 triangles.
        assert len(tris) == sum(len(f) - 2 for f in faces)
        normals = [face_normal(positions, f) for f in faces]
        k = 0
        for face, n in zip(faces, normals):
            for _ in range(len(face) - 2):
                t = tris[k]
                tn = np.cross(v[t[1]] - v[t[0]], v[t[2]] - v[t[0]])
                assert np.dot(tn, n) > 0, f"{name}: triangle {k} turned over"
                k += 1
    # The surfaces face the camera's side: the floor up, the wall forwards
    # (+z), the lamp down.
    up = face_normal(objects["floor"][0], objects["floor"][2][0])
    forwards = face_normal(objects["back_wall"][0], objects["back_wall"][2][0])
    down = face_normal(objects["lamp"][0], objects["lamp"][2][0])
    assert up[1] > 0 and forwards[2] > 0 and down[1] < 0
