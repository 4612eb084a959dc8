#!/usr/bin/env python3
"""Speed against error, prism side by side with Mitsuba 3.

    python3 tools/bench.py [--spp 1,2,...] [--reference-spp 4096] [--threads 2] [--out bench]

1. `prism bench` renders the ladder (load excluded from the timings) and
   the reference (prism at --reference-spp, rendered once and cached).
2. Mitsuba 3 renders the same Cornell Box (geometry from scenes/cornell/*.obj,
   the measured spectra from spectra/, the same camera, box filter, max depth
   and Russian roulette start) at the same ladder on the same number of
   threads, timed the same way, in each variant of `--variants`:
   `scalar_spectral` (the default) and `llvm_ad_spectral`, its fastest CPU
   variant, which JIT-compiles its kernels: a first render (not part of the
   ladder) compiles them, and its time is reported apart. The LLVM variant
   needs libLLVM (Debian 12: `apt-get install libllvm19`; this script sets
   DRJIT_LIBLLVM_PATH to it when that file exists). `--llvm-width 8` has
   its kernels compiled 8 lanes wide (AVX2) where the CPU offers 16
   (AVX-512): what its vectors, not its algorithms, are worth.
3. Both renderers' rungs are scored against the same reference: relMSE
   (as prism computes it) and HDR-FLIP (flip-evaluator).
4. Writes OUT/convergence.csv and OUT/convergence.png (log-log error against
   wall time) and prints the time each needs for equal relMSE.

`--check` first checks that both renderers converge to the same image:
K independent renders each, mean radiance per wall with its standard error,
and the z-score of the difference per wall and channel.

Needs the packages of tools/bench-requirements.txt (mitsuba, numpy,
matplotlib, flip-evaluator, OpenEXR); not part of the test suite.
"""

import argparse
import csv
import math
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import peer_scenes

ROOT = Path(__file__).resolve().parent.parent
CORNELL = ["floor", "ceiling", "back", "short", "tall", "red", "green", "light"]

# Image-space boxes (x0, y0, x1, y1) on the 512² Cornell Box view, inside
# each surface and away from edges and shadows' penumbrae.
REGIONS = {
    "light": (225, 68, 290, 76),
    "ceiling": (150, 10, 360, 40),
    "left wall (red)": (20, 150, 60, 350),
    "right wall (green)": (452, 150, 492, 350),
    "back wall": (270, 150, 380, 260),
    "floor": (150, 470, 360, 500),
    "tall block front": (160, 260, 230, 380),
    "short block front": (250, 350, 330, 420),
}


def cpu_seconds():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def read_exr(path):
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        channels = f.channels()
        if "RGB" in channels:
            return np.asarray(channels["RGB"].pixels, dtype=np.float32)
        return np.stack([np.asarray(channels[c].pixels, dtype=np.float32) for c in "RGB"], axis=-1)


def rel_mse(image, reference, eps=1e-2):
    """As prism's src/bench.rs: mean over pixels and channels of (x-r)²/(r²+ε)."""
    image = image.astype(np.float64)
    reference = reference.astype(np.float64)
    return float(np.mean((image - reference) ** 2 / (reference**2 + eps)))


def flip_error(image, reference):
    import flip_evaluator as flip

    _, mean, _ = flip.evaluate(reference.astype(np.float32), image.astype(np.float32), "HDR")
    return float(mean)


LIBLLVM = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"


def cornell_dict(mi, width=512, height=512, max_depth=16, rr_depth=3):
    """The Cornell Box of scenes/cornell-box.toml for Mitsuba 3."""
    return {
        "type": "scene",
        "integrator": peer_scenes.path_integrator(max_depth, rr_depth),
        "sensor": peer_scenes.perspective(mi, **peer_scenes.CORNELL_CAMERA, width=width, height=height),
        **peer_scenes.cornell_shapes(CORNELL),
    }


class Target:
    """What a run compares: prism's scene file, the same scene for Mitsuba
    (`build(mi)` gives its dict), the image size and the check's regions."""

    def __init__(self, name, work):
        self.name = name
        if name == "cornell-box":
            self.prism_scene = ROOT / "scenes/cornell-box.toml"
            self.width, self.height = 512, 512
            self.build = cornell_dict
            self.regions = REGIONS
            self.title = "Cornell Box 512²"
        else:
            peer = peer_scenes.SCENES[name]
            self.prism_scene = peer_scenes.write_prism_scene(peer, work)
            self.width, self.height = peer.width, peer.height
            self.build = lambda mi: peer.mitsuba_dict(mi, work)
            self.regions = peer.regions
            self.title = f"{name} {peer.width}×{peer.height} ({peer.description})"


class Mitsuba:
    """A target's scene in Mitsuba 3, in one variant."""

    def __init__(self, threads, variant="scalar_spectral", build=cornell_dict, llvm_width=None):
        if variant.startswith("llvm") and "DRJIT_LIBLLVM_PATH" not in os.environ and os.path.exists(LIBLLVM):
            os.environ["DRJIT_LIBLLVM_PATH"] = LIBLLVM
        import drjit as dr
        import mitsuba as mi

        mi.set_variant(variant)
        dr.set_thread_count(threads)
        self.mi = mi
        self.variant = variant
        self.name = f"mitsuba3-{variant}"
        if llvm_width and variant.startswith("llvm"):
            set_llvm_vector_width(dr, llvm_width)
            self.name += f"-{llvm_width}wide"
        scene = build(mi)
        t0 = time.perf_counter()
        self.scene = mi.load_dict(scene)
        self.load_s = time.perf_counter() - t0

    def render(self, spp, seed):
        """Renders; returns (image HxWx3, wall seconds, CPU seconds)."""
        # Variants share one module: select this one's before each render.
        self.mi.set_variant(self.variant)
        c0, w0 = cpu_seconds(), time.perf_counter()
        image = np.array(self.mi.render(self.scene, spp=spp, seed=seed))
        return image, time.perf_counter() - w0, cpu_seconds() - c0


def set_llvm_vector_width(dr, width):
    """Has Dr.Jit's LLVM backend compile kernels `width` lanes wide: 8 as
    AVX2 (Haswell's features), 16 as the host CPU has them (AVX-512 where
    present). Dr.Jit's Python module does not expose this, so it goes
    through the C++ symbol of libdrjit-core (`jit_llvm_set_target`); it
    must come before the first kernel is compiled, once per process."""
    import ctypes

    core = ctypes.CDLL(os.path.join(os.path.dirname(dr.__file__), "libdrjit-core.so"))
    set_target = core._Z19jit_llvm_set_targetPKcS0_j
    set_target.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint]
    cpu = core._Z19jit_llvm_target_cpuv
    cpu.restype = ctypes.c_char_p
    features = core._Z24jit_llvm_target_featuresv
    features.restype = ctypes.c_char_p
    width_now = core._Z21jit_llvm_vector_widthv
    width_now.restype = ctypes.c_uint
    if width == 8:
        set_target(b"haswell", b"+avx,+avx2,+fma,+f16c,+sse4.2", 8)
    elif width != width_now():
        set_target(cpu(), features(), width)
    if width_now() != width:
        raise SystemExit(f"Dr.Jit's LLVM backend refused {width} lanes (it has {width_now()})")


PRISM = None  # set by --prism


def prism_bin():
    if PRISM:
        return PRISM
    path = ROOT / "target/release/prism"
    if not path.exists():
        subprocess.run(["cargo", "build", "--release", "--quiet"], cwd=ROOT, check=True)
    return str(path)


def run_prism(args, out, ladder):
    """`prism bench` for these rungs; returns its CSV rows."""
    cmd = [
        prism_bin(),
        "bench",
        str(args.target.prism_scene),
        "--spp",
        ",".join(map(str, ladder)),
        "--reference-spp",
        str(args.reference_spp),
        "--threads",
        str(args.threads),
        "--out",
        str(out),
    ]
    if args.split:
        cmd += ["--split", str(args.split)]
    if args.uniform:
        cmd += ["--uniform"]
    subprocess.run(cmd, check=True)
    return list(csv.DictReader(open(out / "prism.csv")))


def check_convergence(args, out):
    """Both renderers, K independent renders each: per-region means agree?"""
    k, spp, target = args.check_renders, args.check_spp, args.target
    mit = Mitsuba(args.threads, build=target.build)
    means = {"prism": [], "mitsuba": []}
    for i in range(k):
        image, _, _ = mit.render(spp, seed=1000 + i)
        means["mitsuba"].append(region_means(image, target.regions))
        stem = out / f"check-prism-{i}"
        subprocess.run(
            [prism_bin(), "render", str(target.prism_scene), "--spp", str(spp),
             "--seed", str(1000 + i), "--threads", str(args.threads), "--no-spectral", "-q", "-o", str(stem)],
            check=True,
        )
        means["prism"].append(region_means(read_exr(stem.with_suffix(".exr")), target.regions))
    worst = 0.0
    lines = ["region,channel,prism,prism_se,mitsuba,mitsuba_se,ratio,z"]
    luminance = np.array([0.2126, 0.7152, 0.0722])
    for r in target.regions:
        for c, channel in enumerate(["R", "G", "B", "Y"]):
            pick = (lambda v: v @ luminance) if channel == "Y" else (lambda v, c=c: v[c])
            p = np.array([pick(m[r]) for m in means["prism"]])
            m = np.array([pick(m[r]) for m in means["mitsuba"]])
            sp, sm = p.std(ddof=1) / math.sqrt(k), m.std(ddof=1) / math.sqrt(k)
            z = abs(p.mean() - m.mean()) / math.hypot(sp, sm)
            worst = max(worst, z)
            lines.append(
                f"{r},{channel},{p.mean():.6f},{sp:.6f},{m.mean():.6f},{sm:.6f},{p.mean() / m.mean():.5f},{z:.2f}"
            )
    (out / "convergence-check.csv").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"largest |z| over {len(target.regions)} regions × R, G, B, Y: {worst:.2f}")
    if target.name == "cornell-box":
        emission_only_check(args, out)
    return worst


def emission_only_check(args, out):
    """The light seen directly, nothing else (max depth 0): both renderers
    against the 1 nm CIE 1931 integral of its spectrum with the IEC sRGB
    matrix, which isolates the colour pipeline from light transport."""
    text = (ROOT / "scenes/cornell-box.toml").read_text().replace("max_depth = 16", "max_depth = 0")
    scene = out / "cornell-emission-only.toml"
    scene.write_text(text.replace('"../spectra/', f'"{ROOT}/spectra/').replace('"cornell/', f'"{ROOT}/scenes/cornell/'))
    stem = out / "emission-only-prism"
    subprocess.run([prism_bin(), "render", str(scene), "--spp", "64", "--threads", str(args.threads),
                    "--no-spectral", "-q", "-o", str(stem)], check=True)
    x0, y0, x1, y1 = REGIONS["light"]
    prism = read_exr(stem.with_suffix(".exr"))[y0:y1, x0:x1].reshape(-1, 3).mean(axis=0)
    mitsuba = Mitsuba(args.threads, build=lambda mi: cornell_dict(mi, max_depth=0)).render(64, 7)[0][y0:y1, x0:x1].reshape(-1, 3).mean(axis=0)
    print(f"light, emission only: prism {prism}, mitsuba {mitsuba}")
    print("  (the CIE 1931 1 nm integral with the IEC matrix gives [20.7177 10.8564 2.7708])")


def region_means(image, regions):
    return {r: image[y0:y1, x0:x1].reshape(-1, 3).mean(axis=0) for r, (x0, y0, x1, y1) in regions.items()}


def equal_error_time(rows, target, clock="wall_s"):
    """Time (`clock`: wall_s or cpu_s) at which a ladder reaches relMSE `target` (log-log interpolation)."""
    pts = sorted((float(r[clock]), float(r["rel_mse"])) for r in rows)
    for (t0, e0), (t1, e1) in zip(pts, pts[1:]):
        if e0 >= target >= e1:
            f = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0)))
    # Outside the ladder: extrapolate along error ∝ 1/time from the nearest end.
    t, e = pts[-1] if target < pts[-1][1] else pts[0]
    return t * e / target


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--spp", default="1,2,4,8,16,32,64,128,256")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default=str(ROOT / "bench"))
    ap.add_argument("--scene", default="cornell-box", choices=["cornell-box", *peer_scenes.SCENES],
                    help="the Cornell Box, or a scene of tools/peer_scenes.py (glass, environment map, textures)")
    ap.add_argument("--check", action="store_true", help="check both converge to the same image first")
    ap.add_argument("--check-renders", type=int, default=6)
    ap.add_argument("--check-spp", type=int, default=64)
    ap.add_argument("--check-only", action="store_true", help="only the convergence check")
    ap.add_argument("--no-mitsuba", action="store_true")
    ap.add_argument("--variants", default="scalar_spectral",
                    help="Mitsuba variants, comma-separated (scalar_spectral, llvm_ad_spectral)")
    ap.add_argument("--llvm-width", type=int, choices=[4, 8, 16],
                    help="lanes of Mitsuba's LLVM kernels (default: the widest the CPU has; 8 = AVX2)")
    ap.add_argument("--prism", help="the prism binary (default: target/release/prism, built if missing)")
    ap.add_argument("--split", type=int, help="prism's path splitting (integrator.split) for the ladder")
    ap.add_argument("--uniform", action="store_true",
                    help="the same samples in every pixel of prism's rungs (default: as `prism render`, the scene's film.sampling)")
    args = ap.parse_args()
    global PRISM
    PRISM = args.prism
    args.spp = [int(s) for s in args.spp.split(",")]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    args.target = target = Target(args.scene, out / "scene")

    if args.check or args.check_only:
        worst = check_convergence(args, out)
        if args.check_only:
            return 0 if worst < 4.5 else 1

    # The reference (prism at --reference-spp) is rendered once and cached.
    run_prism(args, out, [1])
    size = f"{target.width}x{target.height}"
    reference_path = sorted(out.glob(f"reference-*-{size}-{args.reference_spp}spp.exr"), key=os.path.getmtime)[-1]
    reference = read_exr(reference_path)
    peers = [] if args.no_mitsuba else [
        Mitsuba(args.threads, v, target.build, args.llvm_width) for v in args.variants.split(",")
    ]
    for mit in peers:
        print(f"{mit.name}: scene loaded in {mit.load_s:.3f} s", flush=True)
        if mit.variant.startswith(("llvm", "cuda")):
            # The first render compiles the kernels: timed apart, not in the ladder.
            _, wall, cpu = mit.render(args.spp[0], seed=10_000)
            print(f"{mit.name}: first (compiling) render at {args.spp[0]} spp: {wall:.3f} s wall, {cpu:.3f} s CPU",
                  flush=True)
    # The Cornell Box's renderers agree within their noise (--check), and
    # both are scored against prism's reference. On the other scenes they
    # differ by up to half a percent in places (environment map lookups,
    # RGB upsampling), which would put a floor under Mitsuba's error: there
    # each is scored against its own reference.
    mitsuba_reference = reference
    if peers and target.name != "cornell-box":
        fastest = next((m for m in peers if m.variant.startswith("llvm")), peers[0])
        mitsuba_reference = own_reference(fastest, out, args.reference_spp)
    # Rungs alternate between the renderers, so that drifts in the machine's
    # speed hit both alike.
    rows = []
    for i, spp in enumerate(args.spp):
        for r in run_prism(args, out, [spp]):
            rows.append({**r, "flip": flip_error(read_exr(r["image"]), reference)})
        for mit in peers:
            import mitsuba as mi

            image, wall, cpu = mit.render(spp, seed=i + 1)
            path = out / f"{mit.name}-{spp}spp.exr"
            mi.Bitmap(image).write(str(path))
            e = rel_mse(image, mitsuba_reference)
            rows.append(
                {
                    "renderer": mit.name,
                    "scene": target.name,
                    "spp": spp,
                    "wall_s": f"{wall:.6f}",
                    "cpu_s": f"{cpu:.6f}",
                    "load_s": f"{mit.load_s:.6f}",
                    "rel_mse": f"{e:.6e}",
                    "image": str(path),
                    "flip": flip_error(image, mitsuba_reference),
                }
            )
            print(f"{mit.name} {spp:>6} spp: {wall:8.3f} s wall, {cpu:8.3f} s CPU, relMSE {e:.3e}", flush=True)

    fields = ["renderer", "scene", "spp", "wall_s", "cpu_s", "load_s", "rel_mse", "flip", "image"]
    with open(out / "convergence.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    print(f"wrote {out / 'convergence.csv'}")
    plot(rows, out / "convergence.png", args)
    summarise(rows)


def own_reference(mit, out, spp):
    """Mitsuba's reference of the target at `spp` (rendered once, cached)."""
    import mitsuba as mi

    path = out / f"{mit.name}-reference-{spp}spp.exr"
    if not path.exists():
        print(f"{mit.name}: rendering its reference at {spp} spp", flush=True)
        image, wall, _ = mit.render(spp, seed=999_999)
        mi.Bitmap(image).write(str(path))
        print(f"{mit.name}: reference in {wall:.1f} s", flush=True)
    return read_exr(path)


def plot(rows, path, args):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for name in sorted({r["renderer"] for r in rows}):
        rs = [r for r in rows if r["renderer"] == name]
        t = [float(r["wall_s"]) for r in rs]
        axes[0].loglog(t, [float(r["rel_mse"]) for r in rs], "o-", label=name)
        axes[1].loglog(t, [float(r["flip"]) for r in rs], "o-", label=name)
        for r in rs:
            axes[0].annotate(str(r["spp"]), (float(r["wall_s"]), float(r["rel_mse"])), fontsize=6,
                             textcoords="offset points", xytext=(3, 3))
    axes[0].set_ylabel("relMSE (ε = 0.01)")
    axes[1].set_ylabel("HDR-FLIP (mean)")
    for ax in axes:
        ax.set_xlabel(f"wall time, s ({args.threads} threads, scene load excluded)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend()
    fig.suptitle(f"{args.target.title}, error against a {args.reference_spp} spp reference")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


def summarise(rows):
    prism = [r for r in rows if r["renderer"] == "prism"]
    for name in sorted({r["renderer"] for r in rows} - {"prism"}):
        print(f"time to equal relMSE (prism / {name}), wall and CPU:")
        for r in (r for r in rows if r["renderer"] == name):
            target = float(r["rel_mse"])
            tp = equal_error_time(prism, target, "wall_s")
            cp = equal_error_time(prism, target, "cpu_s")
            print(f"  relMSE {target:.3e}: {name} {float(r['wall_s']):.2f} s ({float(r['cpu_s']):.2f} CPU-s), "
                  f"prism {tp:.2f} s ({cp:.2f} CPU-s), ratio {tp / float(r['wall_s']):.3f} wall, "
                  f"{cp / float(r['cpu_s']):.3f} CPU")


if __name__ == "__main__":
    sys.exit(main())
