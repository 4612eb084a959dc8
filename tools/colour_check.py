#!/usr/bin/env python3
"""Independent colorimetry checks of prism's output, built on colour-science.

    tools/colour-check RENDER.spectral.exr RENDER.exr

(which sets up tools/.venv first) reads the spectral EXR with
colour-science's Fichet 2021 reader (through OpenImageIO), integrates every
pixel's spectrum against colour-science's CMFs of the render's observer,
and compares with the renderer's own RGB EXR (read through OpenEXR, its
space taken from its `chromaticities`) pixel by pixel in CIEDE2000. Prints
the maximum and mean difference and a verdict.

The verdict is on the mean difference. The two routes differ only in where
the colour-matching functions are evaluated: at each sampled wavelength
(the RGB output) or at its bucket's centre (the spectral file). That moves
each wavelength sample by up to half a bucket, a perturbation proportional
to the bucket width w that averages out over a pixel's N wavelength samples
as 1/sqrt(N). Measured on the Cornell Box with 1 nm buckets at 64 spp: mean
dE2000 0.05; so the tolerance is 0.1 * (w / 1 nm) * sqrt(64 / spp), twice
that, scaled. (The maximum over pixels is heavy-tailed and only printed.)
Exit status: 0 pass, 1 fail.
"""
import sys
import warnings

import numpy as np

warnings.filterwarnings("ignore")
import colour  # noqa: E402
import OpenEXR  # noqa: E402

CMFS = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
# prism normalises XYZ so that a constant spectral radiance of 1 has Y = 1:
# Y = sum(ybar * L) / sum(ybar) over the 1 nm table from 360 to 830 nm.
Y_INTEGRAL = float(CMFS.copy().align(colour.SpectralShape(360, 830, 1)).values[:, 1].sum())
D65_XY = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]


def read_rgb_exr(path):
    """Linear sRGB (H, W, 3) of an RGB EXR, through the OpenEXR package."""
    with OpenEXR.File(str(path), separate_channels=True) as f:
        channels = f.channels()
        return np.stack([channels[c].pixels.astype(np.float64) for c in "RGB"], axis=-1)


def spectral_exr_to_xyz(path, observer="CIE 1931 2 Degree Standard Observer"):
    """XYZ (H, W, 3) of a spectral EXR: its buckets integrated against the CMFs.

    Each channel holds the mean spectral radiance over a bucket of width
    delta around its centre; the integral over the bucket is value * delta,
    weighted by the CMFs at the centre (exact for 1 nm buckets up to the CMFs'
    curvature).
    """
    components = colour.read_spectral_image_Fichet2021(str(path))
    wavelengths, values = components["S0"]
    wavelengths = np.asarray(wavelengths, dtype=np.float64)
    delta = np.gradient(wavelengths) if len(wavelengths) > 1 else np.array([1.0])
    cmfs = colour.MSDS_CMFS[observer]
    cmf = np.stack([np.interp(wavelengths, cmfs.wavelengths, cmfs.values[:, k], left=0, right=0) for k in range(3)], axis=-1)
    # prism's normalisation under this observer: sum of ybar over 360-830 nm at 1 nm.
    grid = np.arange(360, 831)
    y_integral = np.interp(grid, cmfs.wavelengths, cmfs.values[:, 1], left=0, right=0).sum()
    return np.einsum("hwn,nk->hwk", values.astype(np.float64) * delta, cmf) / y_integral


def delta_e_2000(xyz_a, xyz_b, white_y):
    """CIEDE2000 between two XYZ images, in Lab relative to D65 scaled to white_y."""
    lab_a = colour.XYZ_to_Lab(xyz_a / white_y, D65_XY)
    lab_b = colour.XYZ_to_Lab(xyz_b / white_y, D65_XY)
    return colour.delta_E(lab_a, lab_b, method="CIE 2000")


OBSERVERS = {
    "cie1931-2": "CIE 1931 2 Degree Standard Observer",
    "cie1964-10": "CIE 1964 10 Degree Standard Observer",
    "cie2015-2": "CIE 2015 2 Degree Standard Observer",
    "cie2015-10": "CIE 2015 10 Degree Standard Observer",
}


def rgb_to_xyz_matrix(rgb_path):
    """RGB → XYZ of an RGB EXR, from its chromaticities (sRGB when absent),
    derived from the primaries as prism derives it. Spaces whose white is
    not D65 are adapted by prism: refused here."""
    with OpenEXR.File(str(rgb_path)) as f:
        c = f.header().get("chromaticities")
    if c is None:
        c = (0.64, 0.33, 0.30, 0.60, 0.15, 0.06, 0.3127, 0.3290)
    c = np.array(c, dtype=np.float64).reshape(4, 2)
    if np.abs(c[3] - [0.3127, 0.3290]).max() > 1e-4 and np.abs(c[3] - [1 / 3, 1 / 3]).max() > 1e-4:
        sys.exit(f"{rgb_path}: white {c[3]} is not D65: render with a D65 colour space to compare")
    if np.abs(c[:3] - [[1, 0], [0, 1], [0, 0]]).max() < 1e-6:
        return np.eye(3)
    return colour.normalised_primary_matrix(c[:3], c[3])


def observer_of(spectral_path):
    with OpenEXR.File(str(spectral_path)) as f:
        return f.header().get("prismObserver", "cie1931-2")


def compare(spectral_path, rgb_path):
    observer = observer_of(spectral_path)
    xyz_spectral = spectral_exr_to_xyz(spectral_path, OBSERVERS[observer])
    to_xyz = rgb_to_xyz_matrix(rgb_path)
    rgb_spectral = xyz_spectral @ np.linalg.inv(to_xyz).T
    rgb_prism = read_rgb_exr(rgb_path)
    xyz_prism = rgb_prism @ to_xyz.T
    # Lab needs a white: take the 99th percentile luminance of the image.
    # Brighter pixels (lights) are beyond CIELAB's range; compare their XYZ
    # relative to their luminance instead.
    white_y = max(float(np.percentile(xyz_prism[..., 1], 99)), 1e-12)
    in_range = xyz_prism[..., 1] <= white_y
    de = delta_e_2000(xyz_spectral[in_range], xyz_prism[in_range], white_y)
    bright = ~in_range
    rel = np.abs(xyz_spectral[bright] - xyz_prism[bright]).max(axis=-1) / xyz_prism[bright][..., 1]
    return {
        "max_dE2000": float(de.max()),
        "mean_dE2000": float(de.mean()),
        "bright_max_rel_xyz": float(rel.max()) if rel.size else 0.0,
        "max_rgb_abs_diff": float(np.abs(rgb_spectral - rgb_prism).max()),
        "white_Y": white_y,
    }


def verdict(spectral_path, result):
    """(passed, explanation) for a comparison (see the module's text)."""
    wavelengths, _ = colour.read_spectral_image_Fichet2021(str(spectral_path))["S0"]
    width = float(np.median(np.diff(wavelengths))) if len(wavelengths) > 1 else 470.0
    with OpenEXR.File(str(spectral_path), separate_channels=True) as f:
        counts = f.channels()["sampleCount"].pixels
    spp = max(float(np.mean(counts)), 1.0)
    tolerance = 0.1 * width * np.sqrt(64.0 / spp)
    passed = result["mean_dE2000"] <= tolerance
    return passed, (
        f"mean dE2000 {result['mean_dE2000']:.3f} {'<=' if passed else '>'} {tolerance:.3f}, "
        f"the tolerance of {width:g} nm buckets at {spp:.0f} spp (0.1 x width/nm x sqrt(64/spp): "
        "the spectral file evaluates the CMFs at bucket centres, the RGB at each sampled wavelength)"
    )


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    result = compare(sys.argv[1], sys.argv[2])
    for k, v in result.items():
        print(f"{k}: {v:.6g}")
    passed, why = verdict(sys.argv[1], result)
    print(("PASS: " if passed else "FAIL: ") + why)
    sys.exit(0 if passed else 1)
