"""The renderer's embedded colorimetric tables agree with colour-science."""
import pathlib
import re
import subprocess
import sys
import warnings

import numpy as np
import pytest

warnings.filterwarnings("ignore")
import colour  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[2]
SPECTRA = ROOT / "spectra"


def read_csv(name):
    rows = [
        line.split(",")
        for line in (SPECTRA / name).read_text().splitlines()
        if line and not line.startswith("#")
    ]
    return np.array([[float(v) for v in row] for row in rows[1:]])


def test_cmfs_match_cie_1931():
    table = read_csv("cie_1931_2deg.csv")
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(colour.SpectralShape(360, 830, 1))
    assert table.shape == (471, 4)
    np.testing.assert_allclose(table[:, 0], cmfs.wavelengths)
    np.testing.assert_allclose(table[:, 1:], cmfs.values, rtol=1e-9, atol=1e-12)
    assert abs(table[:, 2].sum() - 106.856917) < 1e-5


@pytest.mark.parametrize("name,sd", [
    ("cie_d65.csv", lambda: colour.sd_CIE_illuminant_D_series(colour.temperature.CCT_to_xy_CIE_D(6500 * 1.4388 / 1.4380))),
    ("cie_a.csv", lambda: colour.sd_CIE_standard_illuminant_A(colour.SpectralShape(300, 830, 1))),
])
def test_illuminants_match(name, sd):
    table = read_csv(name)
    sd = sd()
    np.testing.assert_allclose(table[:, 1], [sd[w] for w in table[:, 0]], rtol=1e-9)


def test_lamps_and_the_d_series_basis_match():
    header = next(line for line in (SPECTRA / "cie_lamps.csv").read_text().splitlines() if not line.startswith("#"))
    lamps = read_csv("cie_lamps.csv")
    names = header.split(",")[1:]
    assert {"FL2", "FL7", "FL11", "FL3.15", "HP5", "LED-B3", "LED-V2"} <= set(names)
    for k, name in enumerate(names):
        sd = colour.SDS_ILLUMINANTS[name]
        np.testing.assert_allclose(lamps[:, k + 1], [sd[w] for w in lamps[:, 0]], rtol=1e-9, err_msg=name)
    basis = read_csv("cie_d_series_basis.csv")
    functions = colour.colorimetry.SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES
    for k, name in enumerate(["S0", "S1", "S2"]):
        np.testing.assert_allclose(basis[:, k + 1], [functions[name][w] for w in basis[:, 0]], rtol=1e-9, atol=1e-12)


def test_d65_white_point_through_the_tables():
    cmfs = read_csv("cie_1931_2deg.csv")
    d65 = read_csv("cie_d65.csv")
    e = np.interp(cmfs[:, 0], d65[:, 0], d65[:, 1])
    xyz = (cmfs[:, 1:] * e[:, None]).sum(axis=0)
    xyz /= xyz[1]
    ref = colour.sd_to_XYZ(
        colour.sd_CIE_illuminant_D_series(colour.temperature.CCT_to_xy_CIE_D(6500 * 1.4388 / 1.4380)).align(colour.SpectralShape(360, 830, 1)),
        method="Integration",
    ) / 100
    # colour interpolates the 10 nm D-series table over the range it is
    # aligned to (300-830 nm for the committed table, 360-830 nm here): the
    # white points differ by ~2e-6.
    np.testing.assert_allclose(xyz, ref / ref[1], atol=1e-5)
    np.testing.assert_allclose(xyz, [0.95047, 1.0, 1.08883], atol=1e-5)


def test_xyz_to_srgb_matrix_is_derived_from_the_primaries():
    source = (ROOT / "src/spectrum/cie.rs").read_text()
    block = source[source.index("pub const XYZ_TO_SRGB"):]
    block = block[: block.index("]);")]
    numbers = [float(v.replace("_", "")) for v in re.findall(r"-?\d+\.[\d_]+", block)]
    # glam matrices are column-major: the source lists the columns.
    matrix = np.array(numbers).reshape(3, 3).T
    srgb = colour.RGB_COLOURSPACES["sRGB"].copy()
    srgb.use_derived_matrix_XYZ_to_RGB = True
    np.testing.assert_allclose(matrix, srgb.matrix_XYZ_to_RGB, atol=1e-6)
    # Within IEC 61966-2-1's 4-digit rounding, which colour.XYZ_to_sRGB uses.
    xyz = np.array([0.3, 0.4, 0.5])
    np.testing.assert_allclose(
        colour.XYZ_to_sRGB(xyz, apply_cctf_encoding=False), matrix @ xyz, atol=3e-4
    )


def test_regenerating_the_tables_reproduces_the_committed_files(tmp_path):
    script = ROOT / "tools/gen_tables.py"
    subprocess.run([sys.executable, str(script), str(tmp_path)], check=True, capture_output=True)
    generated = {p.name: p.read_bytes() for p in tmp_path.glob("cie_*.csv")}
    committed = {p.name: p.read_bytes() for p in SPECTRA.glob("cie_*.csv")}
    assert generated and generated == committed
