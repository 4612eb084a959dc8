#!/usr/bin/env python3
"""Where a render's noise is: the per-pixel variance of independent seeds.

    python3 tools/noise_map.py SCENE --reference REF.exr [--seeds 12]
        [--spp 16] [--resolution WxH] [--integrator K] [--threads 2]
        [--region NAME:X0,Y0,X1,Y1 ...] [--compare DIR] [--out DIR]

1. Renders SCENE once per seed (`prism render --seed S`), the same sample
   count each, so that the images are independent estimates.
2. Per pixel, the variance over the seeds, divided as prism's relMSE
   divides (by the reference's square + 0.01, REF being a long render of
   the same scene at the same size): the relMSE a render of those samples
   owes to noise, pixel by pixel. Its mean is the image's.
3. Prints that mean, the share of it held by the noisiest 1% / 5% / 20% of
   pixels, and each --region's share beside its share of the pixels
   (boxes in pixels, end exclusive); writes DIR/noise.png (the map,
   brighter where noisier, square-root scaled to its 99.5th percentile)
   and DIR/noise.npy (the map).
4. With --compare DIR (an earlier run's --out, of the same scene and
   size), also compare.png in this run's --out: the reference's PNG
   (REF's name with .png, which `prism render` writes beside it), that
   run's map and this run's, both on that run's scale, each shown twice
   its size. The figures of docs/integrators.md ("Where the noise left
   is") are made so: the path tracer's run first, then `path_caustics`'
   compared to it.

A benchmark helper; its figure is tested (tools/tests/test_noise_map.py),
the renders are not. Needs numpy, OpenEXR and Pillow
(tools/bench-requirements.txt).
"""

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np

from caustics_bench import REL_MSE_EPSILON, read_exr

ROOT = Path(__file__).resolve().parent.parent


def region(text):
    name, _, box = text.partition(":")
    try:
        x0, y0, x1, y1 = (int(v) for v in box.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--region {text!r}: expected NAME:X0,Y0,X1,Y1")
    return name, (x0, y0, x1, y1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--reference", required=True, type=Path)
    ap.add_argument("--seeds", type=int, default=12)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--resolution")
    ap.add_argument("--integrator")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--region", type=region, action="append", default=[])
    ap.add_argument("--compare", type=Path, help="an earlier run's --out: a figure of both maps on its scale")
    ap.add_argument("--out", type=Path, default=Path("noise-map"))
    ap.add_argument("--prism", default=str(ROOT / "target/release/prism"))
    args = ap.parse_args()
    if args.seeds < 2:
        sys.exit("--seeds: at least 2 (a variance needs two)")

    if args.compare:
        # Before the renders: what the figure needs must be there.
        reference_png = args.reference.with_suffix(".png")
        if not reference_png.exists():
            sys.exit(f"--compare: {reference_png} is missing (prism render writes it beside the EXR)")
        if not (args.compare / "noise.npy").exists():
            sys.exit(f"--compare: {args.compare / 'noise.npy'} is missing (an earlier run's --out holds it)")
        other = np.load(args.compare / "noise.npy")

    args.out.mkdir(parents=True, exist_ok=True)
    images = []
    for seed in range(1, args.seeds + 1):
        out = args.out / f"seed-{seed}.exr"
        cmd = [args.prism, "render", args.scene, "--spp", str(args.spp), "--seed", str(seed),
               "--threads", str(args.threads), "--uniform", "-q", "-o", str(out)]
        if args.resolution:
            cmd += ["--resolution", args.resolution]
        if args.integrator:
            cmd += ["--integrator", args.integrator]
        subprocess.run(cmd, check=True)
        images.append(read_exr(out))
    reference = read_exr(args.reference)
    stack = np.stack(images)
    if stack.shape[1:] != reference.shape:
        sys.exit(f"the reference is {reference.shape[1]}x{reference.shape[0]}, "
                 f"the renders {stack.shape[2]}x{stack.shape[1]}")
    noise = (stack.var(0, ddof=1) / (reference**2 + REL_MSE_EPSILON)).mean(-1)
    total = noise.sum()
    print(f"relMSE owed to noise at {args.spp} spp: {noise.mean():.3e} "
          f"({args.seeds} seeds; mean against the reference {stack.mean() / reference.mean():.4f})")
    ranked = np.sort(noise.ravel())[::-1]
    shares = np.cumsum(ranked) / total
    for top in (0.01, 0.05, 0.20):
        print(f"  noisiest {top:.0%} of pixels: {shares[int(top * ranked.size) - 1]:.0%} of it")
    for name, (x0, y0, x1, y1) in args.region:
        box = noise[y0:y1, x0:x1]
        print(f"  {name}: {box.sum() / total:.0%} of it on {box.size / noise.size:.0%} of the pixels")

    from PIL import Image

    Image.fromarray(shown(noise, np.percentile(noise, 99.5))).save(args.out / "noise.png")
    np.save(args.out / "noise.npy", noise)
    if args.compare:
        if other.shape != noise.shape:
            sys.exit(f"--compare: {args.compare} holds a {other.shape[1]}x{other.shape[0]} map, "
                     f"this run {noise.shape[1]}x{noise.shape[0]}")
        picture = np.asarray(Image.open(reference_png).convert("RGB"))
        Image.fromarray(side_by_side(picture, other, noise)).save(args.out / "compare.png")


def shown(noise, scale):
    """A map as 8-bit grey: square-root scaled, `scale` and above white."""
    if not scale > 0:
        return np.zeros(noise.shape, np.uint8)
    return (np.sqrt(np.clip(noise / scale, 0.0, 1.0)) * 255).astype(np.uint8)


def side_by_side(picture, first, second, zoom=2):
    """The picture (H×W×3, 8-bit) and two maps on the first's scale (its
    99.5th percentile), left to right, each `zoom` times its size."""
    scale = np.percentile(first, 99.5)
    panels = [picture] + [np.repeat(shown(m, scale)[..., None], 3, axis=2) for m in (first, second)]
    row = np.concatenate(panels, axis=1)
    return row.repeat(zoom, axis=0).repeat(zoom, axis=1)


if __name__ == "__main__":
    main()
