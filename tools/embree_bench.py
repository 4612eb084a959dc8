#!/usr/bin/env python3
"""Embree (PyPI `embreex`) on exactly the rays of prism's criterion bench.

    PRISM_BENCH_DUMP=target/bench-rays cargo bench --bench rays -- terrain
    python3 tools/embree_bench.py target/bench-rays

The bench writes the ~1M-triangle terrain and its 65536 coherent camera
rays and 65536 incoherent rays; this traces them with Embree's single-ray
closest-hit queries (`EmbreeScene.run`, one thread) and prints rays/s, the
best of several runs, and how many rays hit (to check both see the same).
"""

import sys
import time
from pathlib import Path

import numpy as np
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh


def main(directory):
    d = Path(directory)
    vertices = np.fromfile(d / "terrain_vertices.f32", dtype=np.float32).reshape(-1, 3)
    indices = np.fromfile(d / "terrain_indices.u32", dtype=np.uint32).reshape(-1, 3)
    t0 = time.perf_counter()
    scene = rtcs.EmbreeScene()
    TriangleMesh(scene, vertices, indices)
    # The first query commits the scene and builds the BVH.
    scene.run(np.zeros((1, 3), np.float32), np.ones((1, 3), np.float32))
    build = time.perf_counter() - t0
    print(f"embree: {len(indices)} triangles, BVH built in {build:.2f} s")
    for name in ["coherent", "incoherent"]:
        rays = np.fromfile(d / f"rays_{name}.f32", dtype=np.float32).reshape(-1, 6)
        origins = np.ascontiguousarray(rays[:, :3])
        dirs = np.ascontiguousarray(rays[:, 3:])
        best = float("inf")
        for _ in range(7):
            t = time.perf_counter()
            prim = scene.run(origins, dirs)
            best = min(best, time.perf_counter() - t)
        hits = int((np.asarray(prim) >= 0).sum())
        print(f"embree {name}: {len(rays) / best / 1e6:.2f} M rays/s ({hits} of {len(rays)} hit)")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "target/bench-rays")
