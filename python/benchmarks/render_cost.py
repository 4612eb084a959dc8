"""What a render costs from Python against the same render from the command
line: load, render and write the three files, same scene, samples and
threads, alternated round by round. CPU seconds (user + system) beside wall
time; the median of each.

    tools/.venv/bin/python python/benchmarks/render_cost.py [rounds] [spp]

The command line's CPU is its process's (getrusage of children); Python's
is this process's, around prism.load, prism.render and Image.save (the
interpreter's start and numpy's import are not counted; the command line's
process start is, a few milliseconds).
"""

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import prism

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "scenes" / "cornell-box.toml"
BINARY = os.environ.get("PRISM_BIN", str(ROOT / "target" / "release" / "prism"))


def children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def own_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def cli(out: Path, spp: int) -> tuple:
    cpu, wall = children_cpu(), time.perf_counter()
    subprocess.run([BINARY, "render", str(SCENE), "--spp", str(spp), "--threads", "2", "-q",
                    "-o", str(out)], check=True, stderr=subprocess.DEVNULL)
    return children_cpu() - cpu, time.perf_counter() - wall


def python(out: Path, spp: int) -> tuple:
    cpu, wall = own_cpu(), time.perf_counter()
    scene = prism.load(SCENE)
    prism.render(scene, spp=spp, threads=2, progress=False).save(out)
    return own_cpu() - cpu, time.perf_counter() - wall


def main() -> None:
    rounds = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    spp = int(sys.argv[2]) if len(sys.argv) > 2 else 64
    runs = {"command line": [], "python": []}
    with tempfile.TemporaryDirectory() as d:
        python(Path(d) / "warm", 1)  # first-use costs (page cache, lazy imports)
        for i in range(rounds):
            order = [("command line", cli), ("python", python)]
            for name, f in order if i % 2 == 0 else order[::-1]:
                runs[name].append(f(Path(d) / name.replace(" ", "-"), spp))
    base = statistics.median(c for c, _ in runs["command line"])
    for name, r in runs.items():
        cpu = statistics.median(c for c, _ in r)
        wall = statistics.median(w for _, w in r)
        print(f"{name:13s} {cpu:7.2f} CPU-s  {wall:6.2f} s wall  ({100 * (cpu / base - 1):+.1f}% CPU)")


if __name__ == "__main__":
    main()
