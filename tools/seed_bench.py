#!/usr/bin/env python3
"""Variance × CPU of scene variants over several seeds, alternated.

    python3 tools/seed_bench.py --reference REF.exr --spp 16 --seeds 1,2,3,4 \
        [--resolution 200x200] [--threads 2] [--prism BIN] SCENE [SCENE ...]

Renders every SCENE at --spp for each seed (`prism render --seed`), the
scenes taking turns seed by seed so that load on a shared machine falls on
all alike, and scores each render against REF with prism's relMSE
(src/bench.rs: ε = 0.01, all pixels). Prints every run (relMSE, CPU
seconds of the whole `prism render`, user + system; it writes no spectral
EXR, whose writing would add the same time to every scene and pull their
ratios towards 1: before 2026-12-04 it did) and per scene the mean
relMSE, the mean CPU and their product, the figure to compare at equal CPU
time. One seed's relMSE is one draw of a heavy-tailed error: `prism bench`
renders one seed a rung, so its ratios swing more than the mean over seeds.
The mean relMSE comes with its standard error over the seeds, and each
scene after the first with the first's variance × CPU over its own and a
90% interval for that ratio (the seeds resampled with replacement, the
same draws for every scene: their renders share a seed). On the glass of
water the ratio 8.6 from 24 seeds spans 7.5–10.1.

Needs numpy and OpenEXR (tools/bench-requirements.txt); not part of the
test suite.
"""

import argparse
import resource
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from caustics_bench import read_exr, rel_mse

ROOT = Path(__file__).resolve().parent.parent


def render(prism, scene, spp, seed, args, out):
    """CPU seconds of one render of `scene` into `out`."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    command = [prism, "render", str(scene), "--spp", str(spp), "--seed", str(seed),
               "--threads", str(args.threads), "--no-spectral", "-q", "-o", str(out)]
    if args.resolution:
        command += ["--resolution", args.resolution]
    subprocess.run(command, check=True, capture_output=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("scenes", nargs="+", type=Path)
    parser.add_argument("--reference", required=True, type=Path)
    parser.add_argument("--spp", type=int, default=16)
    parser.add_argument("--seeds", default="1,2,3,4")
    parser.add_argument("--resolution")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--prism", default=str(ROOT / "target/release/prism"))
    args = parser.parse_args()
    reference = read_exr(args.reference)
    seeds = [int(s) for s in args.seeds.split(",")]
    runs = {scene: [] for scene in args.scenes}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in seeds:
            for k, scene in enumerate(args.scenes):
                out = Path(tmp) / f"{k}.exr"
                cpu = render(args.prism, scene, args.spp, seed, args, out)
                image = read_exr(out)
                if image.shape != reference.shape:
                    raise SystemExit(f"{scene}: image {image.shape} against reference {reference.shape}")
                error = rel_mse(image, reference, np.ones(reference.shape[:2], dtype=bool))
                runs[scene].append((error, cpu))
                print(f"{scene} seed {seed}: relMSE {error:.4e}, {cpu:.2f} CPU-s", flush=True)
    for line in summary_lines(runs):
        print(line)


def summarise(runs, draws=4000, seed=0):
    """Per scene (`runs`: name → one (relMSE, CPU) per seed, the seeds in
    the same order for every scene): mean relMSE, its standard error, mean
    CPU, their product and, against the first scene, the first's product
    over this one's with its 5th and 95th percentiles over bootstrap
    draws of the seeds."""
    scores = {name: np.array(s, dtype=float) for name, s in runs.items()}
    n = len(next(iter(scores.values())))
    if any(len(s) != n for s in scores.values()):
        raise ValueError("every scene needs a score for every seed")
    picks = np.random.default_rng(seed).integers(0, n, size=(draws, n))

    def products(s):
        means = s[picks].mean(axis=1)
        return means[:, 0] * means[:, 1]

    first = next(iter(scores.values()))
    out = {}
    for name, s in scores.items():
        error, cpu = s.mean(axis=0)
        stderr = s[:, 0].std(ddof=1) / np.sqrt(n) if n > 1 else float("nan")
        ratio = first[:, 0].mean() * first[:, 1].mean() / (error * cpu)
        low, high = np.percentile(products(first) / products(s), [5, 95])
        out[name] = dict(rel_mse=error, stderr=stderr, cpu=cpu, product=error * cpu,
                         ratio=ratio, low=low, high=high)
    return out


def summary_lines(runs):
    names = list(runs)
    lines = []
    for k, (name, r) in enumerate(summarise(runs).items()):
        line = (f"{name}: mean relMSE {r['rel_mse']:.4e} ± {r['stderr']:.1e} × {r['cpu']:.2f} CPU-s"
                f" = {r['product']:.4f}")
        if k > 0:
            line += (f"; {names[0]} over this: {r['ratio']:.2f}"
                     f" (90%: {r['low']:.2f}–{r['high']:.2f})")
        lines.append(line)
    return lines


if __name__ == "__main__":
    main()
