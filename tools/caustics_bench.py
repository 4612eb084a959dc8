#!/usr/bin/env python3
"""Speed against error for caustics: prism's integrators side by side.

    python3 tools/caustics_bench.py SCENE --reference REF.exr [--threads 2]
        [--integrators path,light,bdpt,sppm] [--seconds 60] [--out DIR]

1. For each integrator, `prism bench SCENE --integrator K` renders a ladder
   of sample counts (doubling up to about --seconds of wall time each,
   alternating the integrators rung by rung so that load on a shared
   machine falls on all alike) and scores each rung against REF: relMSE
   as prism computes it (ε = 0.01), over the pixels whose reference
   luminance is at most --exclude-above (a light seen directly, such as
   the sun's disc, would otherwise weigh more than the whole picture).
2. Writes DIR/caustics.csv (every rung), DIR/caustics.png (relMSE against
   CPU time, log-log) and DIR/equal-time.png (each integrator's rung
   nearest to the equal CPU time, side by side, labelled with its relMSE),
   and prints each integrator's relMSE at equal CPU time (log-log
   interpolation), its ratio to path's and its mean against REF's.

REF should be an unbiased render far longer than any rung (e.g. the light
tracer at many samples: `prism render SCENE --integrator light --spp 8192`);
its own noise puts a floor under every curve, printed as an estimate.

Needs numpy, matplotlib, OpenEXR and Pillow (tools/bench-requirements.txt);
not part of the test suite.
"""

import argparse
import csv
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def read_exr(path):
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        ch = f.channels()
        if "RGB" in ch:
            return np.asarray(ch["RGB"].pixels, dtype=np.float64)
        return np.stack([np.asarray(ch[c].pixels, dtype=np.float64) for c in "RGB"], -1)


REL_MSE_EPSILON = 0.01
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])


def rel_mse(image, reference, keep):
    """prism's relMSE (src/bench.rs) over the pixels `keep`."""
    d = (image - reference) ** 2 / (reference**2 + REL_MSE_EPSILON)
    return float(d[keep].mean())


def rungs(prism, scene, kind, spp, reference, threads, out, resolution):
    """Renders one rung; returns its CSV row."""
    args = [
        str(prism), "bench", str(scene), "--integrator", kind, "--spp", str(spp),
        "--reference", str(reference), "--threads", str(threads), "-o", str(out),
    ]
    if resolution:
        args += ["--resolution", resolution]
    subprocess.run(args, check=True, stderr=subprocess.DEVNULL)
    rows = list(csv.DictReader(open(out / f"prism-{kind}.csv")))
    return rows[-1]


def srgb_png(rgb, exposure):
    from PIL import Image

    x = np.clip(rgb * 2.0**exposure, 0, 1)
    x = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return Image.fromarray((x * 255 + 0.5).astype(np.uint8))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("--reference", required=True)
    ap.add_argument("--integrators", default="path,light,bdpt,sppm")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--seconds", type=float, default=60.0, help="stop a ladder past this wall time")
    ap.add_argument("--resolution", default=None)
    ap.add_argument("--exposure", type=float, default=0.0, help="exposure (stops) of the side-by-side PNG")
    ap.add_argument("--exclude-above", type=float, default=math.inf,
                    help="leave out pixels whose reference luminance is above this")
    ap.add_argument("--out", default="bench-caustics")
    ap.add_argument("--prism", default=str(ROOT / "target" / "release" / "prism"))
    a = ap.parse_args()
    # The plots need matplotlib and Pillow: say so before minutes of
    # rendering, not after (pip install -r tools/bench-requirements.txt).
    for module in ("matplotlib", "PIL"):
        try:
            __import__(module)
        except ImportError:
            sys.exit(f"caustics_bench.py needs {module}: pip install -r tools/bench-requirements.txt")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    kinds = a.integrators.split(",")
    reference = read_exr(a.reference)
    keep = reference @ LUMINANCE <= a.exclude_above
    print(f"relMSE over {keep.sum()} of {keep.size} pixels", flush=True)

    # Ladders of doubling sample counts, alternated rung by rung.
    results = {k: [] for k in kinds}
    spp = {k: 1 for k in kinds}
    live = set(kinds)
    while live:
        for k in kinds:
            if k not in live:
                continue
            row = rungs(a.prism, a.scene, k, spp[k], a.reference, a.threads, out, a.resolution)
            row["spp"] = spp[k]
            (out / f"{k}-{spp[k]}.exr").write_bytes(Path(row["image"]).read_bytes())
            image = read_exr(out / f"{k}-{spp[k]}.exr")
            row["rel_mse"] = rel_mse(image, reference, keep)
            row["mean"] = float((image[keep] @ LUMINANCE).mean() / (reference[keep] @ LUMINANCE).mean())
            results[k].append(row)
            wall = float(row["wall_s"])
            print(f"{k:13s} {spp[k]:>7} spp {wall:8.2f} s wall {float(row['cpu_s']):8.2f} s CPU  relMSE {row['rel_mse']:.3e}  mean/ref {row['mean']:.4f}", flush=True)
            if 2 * wall > a.seconds:
                live.discard(k)
            spp[k] *= 2

    with open(out / "caustics.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["integrator", "spp", "wall_s", "cpu_s", "rel_mse", "mean_over_reference"])
        for k in kinds:
            for r in results[k]:
                w.writerow([k, r["spp"], r["wall_s"], r["cpu_s"], r["rel_mse"], r["mean"]])

    # relMSE at the longest CPU time every integrator reached (log-log
    # interpolation).
    t_eq = min(float(results[k][-1]["cpu_s"]) for k in kinds)

    def at(k, t):
        ts = np.log([float(r["cpu_s"]) for r in results[k]])
        es = np.log([float(r["rel_mse"]) for r in results[k]])
        return float(np.exp(np.interp(math.log(t), ts, es)))

    print(f"\nrelMSE at equal CPU time {t_eq:.1f} s ({a.threads} threads):")
    base = at("path", t_eq) if "path" in kinds else None
    for k in kinds:
        e = at(k, t_eq)
        ratio = f"  path / {k} = {base / e:.1f}×" if base else ""
        print(f"  {k:13s} {e:.3e}{ratio}  mean/ref at the last rung {results[k][-1]['mean']:.4f}")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    for k in kinds:
        ax.loglog([float(r["cpu_s"]) for r in results[k]], [float(r["rel_mse"]) for r in results[k]], "o-", label=k)
    ax.set_xlabel(f"CPU time (s, {a.threads} threads)")
    ax.set_ylabel("relMSE against the reference")
    ax.set_title(Path(a.scene).name)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "caustics.png", dpi=110)

    # Side by side: each integrator's rung nearest (in log time) to t_eq.
    from PIL import Image, ImageDraw

    tiles = []
    for k in kinds:
        r = min(results[k], key=lambda r: abs(math.log(float(r["cpu_s"]) / t_eq)))
        img = srgb_png(read_exr(out / f"{k}-{r['spp']}.exr"), a.exposure)
        lines = [f"{k}, {r['spp']} spp", f"{float(r['cpu_s']):.1f} CPU-s, relMSE {r['rel_mse']:.2g}"]
        draw = ImageDraw.Draw(img)
        draw.rectangle((0, 0, 6 * max(map(len, lines)) + 8, 26), fill=(0, 0, 0))
        draw.text((4, 2), "\n".join(lines), fill=(255, 255, 255))
        tiles.append(img)
    w, h = tiles[0].size
    sheet = Image.new("RGB", (w * len(tiles), h))
    for i, t in enumerate(tiles):
        sheet.paste(t, (i * w, 0))
    sheet.save(out / "equal-time.png")
    print(f"wrote {out / 'caustics.csv'}, {out / 'caustics.png'}, {out / 'equal-time.png'}")


if __name__ == "__main__":
    sys.exit(main())
