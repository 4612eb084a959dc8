"""Reads a spectral EXR back and plots one pixel's spectrum with matplotlib
(written to a PNG): the Cornell Box's red wall, next to the spectrum of the
same pixel in the render that made the file.

    python python/examples/plot_spectrum.py [out.png]
"""

import sys
import tempfile
from pathlib import Path

import numpy as np

import prism

ROOT = Path(__file__).resolve().parents[2]


def main(out: str = "out/red-wall-spectrum.png") -> tuple:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scene = prism.load(ROOT / "scenes" / "cornell-box.toml", resolution=(96, 96))
    rendered = prism.render(scene, spp=16, progress=False)
    with tempfile.TemporaryDirectory() as folder:
        rendered.save(Path(folder) / "cornell")
        image = prism.read(Path(folder) / "cornell.spectral.exr")
    x, y = 8, 48  # on the red (left) wall
    spectrum = image.spectral[y, x]
    assert np.array_equal(spectrum, rendered.spectral[y, x])
    edges = image.bucket_edges
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.stairs(spectrum, edges, label=f"pixel ({x}, {y})")
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("spectral radiance (per nm)")
    ax.set_title("Cornell Box, red wall")
    ax.legend()
    fig.tight_layout()
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    print(f"wrote {out}: {len(spectrum)} buckets, {edges[0]:.0f}–{edges[-1]:.0f} nm, "
          f"peak at {image.wavelengths[int(np.argmax(spectrum))]:.0f} nm")
    return image.wavelengths, spectrum


if __name__ == "__main__":
    main(*sys.argv[1:])
