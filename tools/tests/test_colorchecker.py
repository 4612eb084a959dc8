"""The ColorChecker under D65: each rendered patch must have the colour that
colour-science computes for its reflectance (sd_to_XYZ with D65 -> Lab and
sRGB). scenes/colorchecker.toml lights every patch with uniform D65 from the
whole hemisphere and max_depth = 1, so a patch's radiance is exactly its
reflectance times D65 (luminance 1): the same quantity colour-science
integrates."""
import math
import pathlib
import tomllib
import warnings

import numpy as np

import colour_check

warnings.filterwarnings("ignore")
import colour  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]


def patch_centres(scene):
    """Raster position of every quad's centre (the camera looks along +z)."""
    cam, film = scene["camera"], scene["film"]
    w, h = film["resolution"]
    tan = math.tan(math.radians(cam["fov"]) / 2)
    eye = np.array(cam["position"], dtype=float)
    centres = []
    for shape in scene["shape"]:
        if shape["type"] != "quad":
            continue
        c = np.mean(np.array(shape["vertices"], dtype=float), axis=0) - eye
        # Camera right is -x for forward +z and up +y.
        sx, sy = -c[0] / c[2], c[1] / c[2]
        centres.append(((sx / (tan * w / h) + 1) * w / 2, (1 - sy / tan) * h / 2, shape["material"]))
    return centres


def test_colorchecker_patches_match_colour_science(prism, tmp_path):
    scene_path = ROOT / "scenes" / "colorchecker.toml"
    scene = tomllib.loads(scene_path.read_text())
    out = tmp_path / "checker"
    prism("render", scene_path, "-q", "-o", out, "--spp", "64")
    rgb = colour_check.read_rgb_exr(f"{out}.exr")

    d65 = colour.SDS_ILLUMINANTS["D65"]
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    white = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    checker = list(colour.SDS_COLOURCHECKERS["BabelColor Average"].items())
    centres = patch_centres(scene)
    assert len(centres) == 24
    errors = []
    for (x, y, material), (name, sd) in zip(centres, checker):
        # The middle of the patch: 20 x 20 pixels of a 40-pixel patch.
        block = rgb[int(y) - 10:int(y) + 10, int(x) - 10:int(x) + 10]
        xyz_render = colour.sRGB_to_XYZ(block.reshape(-1, 3).mean(axis=0), apply_cctf_decoding=False)
        reflectance = sd.copy().align(colour.SpectralShape(360, 830, 5))
        xyz_expected = colour.sd_to_XYZ(reflectance, cmfs, d65, method="Integration") / 100
        de = colour.delta_E(colour.XYZ_to_Lab(xyz_render, white), colour.XYZ_to_Lab(xyz_expected, white), method="CIE 2000")
        errors.append(de)
        srgb_expected = colour.XYZ_to_sRGB(xyz_expected)
        srgb_render = colour.XYZ_to_sRGB(xyz_render)
        print(f"{material} {name:15s} dE2000 {de:.3f}  sRGB {np.round(srgb_render, 4)} expected {np.round(srgb_expected, 4)}")
    errors = np.array(errors)
    print(f"mean dE2000 {errors.mean():.3f}, max {errors.max():.3f}")
    # Monte Carlo noise of a 400-pixel, 64 spp average is a few tenths of a
    # percent in luminance (~0.1 dE); the rest is how the two integrate the
    # 5 nm tables (prism: linear between points, sampled; colour-science:
    # its interpolation to 1 nm). A wrong CMF, matrix, white or
    # normalisation costs several dE.
    assert errors.mean() < 0.5
    assert errors.max() < 1.0
