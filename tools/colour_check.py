#!/usr/bin/env python3
"""Independent colorimetry checks of prism's output, built on colour-science.

    tools/.venv/bin/python tools/colour_check.py RENDER.spectral.exr RENDER.exr

reads the spectral EXR with colour-science's Fichet 2021 reader (through
OpenImageIO), integrates every pixel's spectrum against colour-science's CIE
1931 2 degree CMFs, converts with colour.XYZ_to_sRGB, and compares with the
renderer's own linear sRGB EXR (read through OpenEXR) pixel by pixel in
CIEDE2000. Prints the maximum and mean difference.
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


def spectral_exr_to_xyz(path):
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
    cmf = np.stack([np.interp(wavelengths, CMFS.wavelengths, CMFS.values[:, k], left=0, right=0) for k in range(3)], axis=-1)
    return np.einsum("hwn,nk->hwk", values.astype(np.float64) * delta, cmf) / Y_INTEGRAL


def delta_e_2000(xyz_a, xyz_b, white_y):
    """CIEDE2000 between two XYZ images, in Lab relative to D65 scaled to white_y."""
    lab_a = colour.XYZ_to_Lab(xyz_a / white_y, D65_XY)
    lab_b = colour.XYZ_to_Lab(xyz_b / white_y, D65_XY)
    return colour.delta_E(lab_a, lab_b, method="CIE 2000")


def compare(spectral_path, rgb_path):
    xyz_spectral = spectral_exr_to_xyz(spectral_path)
    rgb_spectral = colour.XYZ_to_sRGB(xyz_spectral, apply_cctf_encoding=False)
    rgb_prism = read_rgb_exr(rgb_path)
    xyz_prism = colour.sRGB_to_XYZ(rgb_prism, apply_cctf_decoding=False)
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


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    for k, v in compare(sys.argv[1], sys.argv[2]).items():
        print(f"{k}: {v:.6g}")
