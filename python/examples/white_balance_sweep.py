"""A white-balance sweep: the ColorChecker lit by a 3200 K blackbody,
balanced for colour temperatures from 2400 K to 8000 K. The grey patches
come out neutral (equal R, G, B) when the balance matches the light.

It renders once: a white balance changes only how the film's XYZ becomes
RGB. Each balance is a `with_updates` of the film (nothing is built again),
whose `xyz_to_rgb` matrix turns the one render's XYZ into that balance's
RGB, as a render under it would (checked for one balance).

    python python/examples/white_balance_sweep.py
"""

from pathlib import Path

import numpy as np

import prism
from checker import patch_centres, patch_mean

ROOT = Path(__file__).resolve().parents[2]
LIGHT_KELVIN = 3200
TEMPERATURES = [2400, 2800, 3200, 3600, 4500, 5500, 6500, 8000]
GREY = "patch22"  # neutral 5


def neutral_cast(rgb: np.ndarray) -> float:
    """How far from grey: the largest departure of r, g, b chromaticity from 1/3."""
    c = rgb / rgb.sum()
    return float(np.abs(c - 1 / 3).max())


def main(spp: int = 8) -> dict:
    base = prism.load(ROOT / "scenes" / "colorchecker.toml", resolution=(150, 100))
    lit = base.with_updates({"shape[0].emission": {"blackbody": LIGHT_KELVIN}})
    image = prism.render(lit, spp=spp, progress=False)
    grey_xyz = patch_mean(image.xyz, patch_centres(lit.to_dict(), *lit.resolution)[GREY])
    casts = {}
    for kelvin in TEMPERATURES:
        balanced = lit.with_updates({"film.white_balance": {"temperature": kelvin}})
        rgb = balanced.xyz_to_rgb @ grey_xyz
        casts[kelvin] = neutral_cast(rgb)
        print(f"balance {kelvin:5d} K: grey patch RGB {np.round(rgb, 4)}, cast {casts[kelvin]:.4f}")
    # The matrix is the one a render under that balance uses.
    balanced = lit.with_updates({"film.white_balance": {"temperature": 6500}})
    rendered = prism.render(balanced, spp=spp, progress=False).rgb
    assert np.allclose(rendered, image.xyz @ balanced.xyz_to_rgb.T, rtol=1e-4, atol=1e-6)
    best = min(casts, key=casts.get)
    print(f"most neutral at {best} K (the light is {LIGHT_KELVIN} K)")
    return casts


if __name__ == "__main__":
    main()
