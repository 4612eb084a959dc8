"""The ColorChecker under D65, A and F11, rendered by prism and computed by
colour-science: ΔE2000 of every patch.

prism renders scenes/colorchecker.toml (the 24 BabelColor Average patches lit
from every direction, one bounce) under each illuminant; colour-science
integrates each patch's reflectance times the illuminant with the CIE 1931
observer. Both normalise the illuminant to luminance 1, so the two XYZ are
the same quantity and compare in CIELAB with the illuminant's white.

    python python/examples/colorchecker_illuminants.py [spp]
"""

import sys
import warnings
from pathlib import Path

import numpy as np

import prism
from checker import patch_centres, patch_mean

warnings.filterwarnings("ignore")  # colour-science's optional-dependency notes
import colour  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
ILLUMINANTS = ["D65", "A", "FL11"]  # F11, by colour-science's and prism's name


def main(spp: int = 64) -> float:
    scene = prism.load(ROOT / "scenes" / "colorchecker.toml", resolution=(150, 100))
    doc = scene.to_dict()
    width, height = scene.resolution
    centres = list(patch_centres(doc, width, height).values())
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    checker = list(colour.SDS_COLOURCHECKERS["BabelColor Average"].items())
    worst = 0.0
    for name in ILLUMINANTS:
        # The light is the first shape, a sphere around everything.
        lit = scene.with_updates({"shape[0].emission": name})
        image = prism.render(lit, spp=spp, progress=False)
        # prism interpolates tables linearly: so does the reference (the
        # default, Sprague, rings around FL11's lines).
        illuminant = colour.SDS_ILLUMINANTS[name].copy().interpolate(
            colour.SpectralShape(360, 830, 1), interpolator=colour.LinearInterpolator)
        white = colour.XYZ_to_xy(colour.sd_to_XYZ(illuminant, cmfs) / 100)
        errors = []
        for centre, (_, sd) in zip(centres, checker):
            rendered = patch_mean(image.xyz, centre)
            reflectance = sd.copy().align(colour.SpectralShape(360, 830, 1),
                                          interpolator=colour.LinearInterpolator)
            expected = colour.sd_to_XYZ(reflectance, cmfs, illuminant, method="Integration") / 100
            errors.append(colour.delta_E(colour.XYZ_to_Lab(rendered, white),
                                         colour.XYZ_to_Lab(expected, white), method="CIE 2000"))
        errors = np.array(errors)
        print(f"{name:5s} ΔE2000 mean {errors.mean():.3f}, max {errors.max():.3f} "
              f"({image.metadata['seconds']:.2f} s at {spp} spp)")
        worst = max(worst, float(errors.max()))
    return worst


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 64)
