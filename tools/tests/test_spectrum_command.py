"""`prism spectrum` against colour-science: the chromaticity of lamps and
daylight (colour-science's own SPDs, integrated by numpy with its CMFs),
CCT and Duv by colour-science's Ohno 2013, and a reflectance's CIELAB
under an illuminant."""
import re

import numpy as np

import colour_check  # noqa: F401  (silences colour-science's warnings)
import colour

GRID = np.arange(360, 831)
CMFS = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
CMF = np.stack([np.interp(GRID, CMFS.wavelengths, CMFS.values[:, k], left=0, right=0) for k in range(3)], -1)


def report(prism, *args):
    out = prism("spectrum", *args).stdout
    numbers = {}
    for key in ["XYZ", "xy", "u'v'", "CIELAB"]:
        m = re.search(rf"^{re.escape(key)}: (.*)$", out, re.M)
        if m:
            numbers[key] = np.array([float(v) for v in re.findall(r"-?\d+\.\d+(?:e-?\d+)?", m.group(1))])
    m = re.search(r"CCT: ([\d.]+) K, Duv ([-+][\d.]+)", out)
    if m:
        numbers["CCT"] = np.array([float(m.group(1)), float(m.group(2))])
    return numbers, out


def xyz_of(sd):
    values = np.interp(GRID, sd.wavelengths, sd.values, left=0, right=0)
    return values @ CMF


def test_lamps_and_daylight_match_colour_science(prism):
    cases = {name: colour.SDS_ILLUMINANTS[name] for name in ["D65", "A", "LED-B3", "LED-V1", "FL3.4", "HP1", "FL11"]}
    cases["{ daylight = 5500 }"] = colour.sd_CIE_illuminant_D_series(colour.temperature.CCT_to_xy_CIE_D(5500))
    cases["{ daylight = 12000 }"] = colour.sd_CIE_illuminant_D_series(colour.temperature.CCT_to_xy_CIE_D(12000))
    for arg, sd in cases.items():
        got, out = report(prism, arg)
        xyz = xyz_of(sd)
        xy = xyz[:2] / xyz.sum()
        assert np.abs(got["xy"] - xy).max() < 2e-5, (arg, got["xy"], xy)
        u, v = colour.xy_to_UCS_uv(xy)
        assert np.abs(got["u'v'"] - [u, 1.5 * v]).max() < 2e-5, (arg, out)
        cct, duv = colour.uv_to_CCT(np.array([u, v]), method="Ohno 2013")
        if abs(duv) <= 0.05:
            assert abs(got["CCT"][0] - cct) < 0.5 and abs(got["CCT"][1] - duv) < 2e-5, (arg, got["CCT"], cct, duv)
        # Built-in illuminants are scaled to Y = 1.
        assert abs(got["XYZ"][1] - 1.0) < 1e-5, (arg, out)


def test_a_reflectance_under_an_illuminant_gives_its_cielab(prism):
    path = "spectra/colorchecker/13_blue.csv"
    got, out = report(prism, path, "--under", "D50")
    rows = np.array([line.split(",") for line in open(path).read().splitlines() if line[:1].isdigit()], dtype=float)
    r = np.interp(GRID, rows[:, 0], rows[:, 1], left=0, right=0)
    d50 = colour.SDS_ILLUMINANTS["D50"]
    e = np.interp(GRID, d50.wavelengths, d50.values, left=0, right=0)
    white = e @ CMF
    xyz = (r * e) @ CMF * 100 / white[1]
    lab = colour.XYZ_to_Lab(xyz / 100, colour.XYZ_to_xy(white))
    assert np.abs(got["XYZ"] - xyz).max() < 2e-3, (got["XYZ"], xyz)
    assert np.abs(got["CIELAB"] - lab).max() < 2e-3, (got["CIELAB"], lab)
    assert "CCT" not in got, out


def test_cgats_and_spdx_files_read_as_colour_science_reads_their_data(prism, tmp_path):
    """A ColorChecker measured as i1Profiler writes it (CGATS.17, percent,
    380-730 nm in 10 nm): each sample is a column named by SAMPLE_NAME, and
    its CIELAB under D65 is colour-science's. An IES TM-27 file of LED-B3
    has LED-B3's chromaticity."""
    checker = colour.SDS_COLOURCHECKERS["BabelColor Average"]
    bands = np.arange(380, 731, 10)
    names = list(checker)[:6]
    lines = ["CGATS.17", 'ORIGINATOR "test"', "BEGIN_DATA_FORMAT",
             "SAMPLE_ID SAMPLE_NAME " + " ".join(f"SPECTRAL_NM{b}" for b in bands), "END_DATA_FORMAT",
             f"NUMBER_OF_SETS {len(names)}", "BEGIN_DATA"]
    for i, name in enumerate(names):
        values = " ".join(f"{100 * checker[name][b]:.4f}" for b in bands)
        lines.append(f'{i + 1} "{name}" {values}')
    lines.append("END_DATA")
    cgats = tmp_path / "checker.txt"
    cgats.write_text("\n".join(lines) + "\n")
    d65 = colour.SDS_ILLUMINANTS["D65"]
    e = np.interp(GRID, d65.wavelengths, d65.values, left=0, right=0)
    white = e @ CMF
    for name in names:
        got, out = report(prism, cgats, "--column", name, "--under", "D65")
        r = np.interp(GRID, bands, [checker[name][b] for b in bands], left=0, right=0)
        lab = colour.XYZ_to_Lab((r * e) @ CMF / white[1], colour.XYZ_to_xy(white))
        assert np.abs(got["CIELAB"] - lab).max() < 2e-3, (name, got["CIELAB"], lab)

    led = colour.SDS_ILLUMINANTS["LED-B3"]
    spdx = tmp_path / "led.spdx"
    data = "\n".join(f'<SpectralData wavelength="{w:g}">{v:.6g}</SpectralData>' for w, v in zip(led.wavelengths, led.values))
    spdx.write_text('<?xml version="1.0"?>\n<IESTM2714 xmlns="iestm2714" version="1.0">\n<Header><Manufacturer>test</Manufacturer></Header>\n'
                    f"<SpectralDistribution><SpectralQuantity>relative</SpectralQuantity>\n{data}\n</SpectralDistribution></IESTM2714>\n")
    got, out = report(prism, spdx)
    xyz = xyz_of(led)
    assert np.abs(got["xy"] - xyz[:2] / xyz.sum()).max() < 2e-5, out
