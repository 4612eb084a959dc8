#!/usr/bin/env python3
"""Embree (PyPI `embreex`) on exactly the rays of prism's criterion bench.

    PRISM_BENCH_DUMP=target/bench-rays cargo bench --bench rays -- terrain
    python3 tools/embree_bench.py target/bench-rays

The bench writes the ~1M-triangle terrain and its 65536 coherent camera
rays and 65536 incoherent rays; this traces them with Embree's single-ray
closest-hit queries (`EmbreeScene.run`, one thread) and prints rays/s, the
best and the median of several runs, and how many rays hit (to check both
see the same). Where criterion's samples of the bench's last run are there
(target/criterion), it prints prism's best and median beside them, per
iteration of a sample, so that the two are compared by the same statistic
(criterion's own figure is a mean, which a loaded machine pulls down).
"""

import json
import sys
import time
from pathlib import Path

import numpy as np
from embreex import rtcore_scene as rtcs
from embreex.mesh_construction import TriangleMesh

# Runs of each ray set: the best and the median are taken over them.
RUNS = 15
# The criterion benches (benches/rays.rs) that trace the same rays.
CRITERION_NAMES = {"coherent": "coherent camera rays", "incoherent": "incoherent rays"}


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
        seconds = []
        for _ in range(RUNS):
            t = time.perf_counter()
            prim = scene.run(origins, dirs)
            seconds.append(time.perf_counter() - t)
        hits = int((np.asarray(prim) >= 0).sum())
        best, median = len(rays) / min(seconds) / 1e6, len(rays) / float(np.median(seconds)) / 1e6
        print(f"embree {name}: {best:.2f} M rays/s best, {median:.2f} median ({hits} of {len(rays)} hit)")
        prism = prism_rates(d, CRITERION_NAMES[name], len(rays))
        if prism:
            p_best, p_median = prism
            print(f"prism  {name}: {p_best:.2f} M rays/s best, {p_median:.2f} median, one ray at a time "
                  f"(criterion's last run): {p_best / best:.0%} and {p_median / median:.0%} of Embree's")


def prism_rates(bench_dir, name, rays):
    """prism's best and median M rays/s over the samples of criterion's last
    run of the bench `name` (each sample's time per iteration), or None."""
    samples = bench_dir.parent / "criterion" / "terrain 1M triangles" / name / "new" / "sample.json"
    if not samples.exists():
        return None
    s = json.loads(samples.read_text())
    per_iteration = [t / i for t, i in zip(s["times"], s["iters"])]  # nanoseconds
    return rays / min(per_iteration) * 1e3, rays / float(np.median(per_iteration)) * 1e3


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "target/bench-rays")
