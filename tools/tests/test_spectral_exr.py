"""prism's spectral EXR, read by independent readers and integrated by
colour-science, gives the same colours as prism's own RGB output."""
import numpy as np
import OpenEXR

import colour_check


def test_spectral_exr_matches_the_rgb_output(prism, tmp_path):
    out = tmp_path / "cbox"
    # 1 nm buckets over the whole sampled range, so the spectral file holds
    # all the light the RGB output was computed from.
    prism("render", "scenes/cornell-box.toml", "-q", "-o", out, "--resolution", "96x96",
          "--spp", "64", "--spectral-range", "360,830", "--spectral-buckets", "470")
    spectral, rgb = f"{out}.spectral.exr", f"{out}.exr"

    # The layout as the OpenEXR package sees it.
    with OpenEXR.File(spectral, separate_channels=True) as f:
        header, channels = f.header(), f.channels()
        assert header["spectralLayoutVersion"] == "1.0"
        assert header["emissiveUnits"] == "W.m^-2.sr^-1"
        names = [n for n in channels if n.startswith("S0.")]
        assert len(names) == 470 and "S0.550,500000nm" in names
        assert {"R", "G", "B"} <= set(channels)

    result = colour_check.compare(spectral, rgb)
    print(result)
    # The two differ only where the CMFs are evaluated: at each sampled
    # wavelength (RGB) or at its 1 nm bucket's centre (spectral), a relative
    # perturbation of about |x'(λ)|/x · 0.3 nm per wavelength sample that
    # averages out over the 256 wavelengths of a pixel. Measured at 64 spp:
    # mean 0.05, max 0.48 over pixels no brighter than the white.
    assert result["mean_dE2000"] < 0.1
    assert result["max_dE2000"] < 1.0
    assert result["bright_max_rel_xyz"] < 0.02


def test_coarse_buckets_are_read_in_wavelength_order(prism, tmp_path):
    out = tmp_path / "coarse"
    prism("render", "scenes/cornell-box.toml", "-q", "-o", out, "--resolution", "16x16", "--spp", "4")
    import colour

    wavelengths, values = colour.read_spectral_image_Fichet2021(f"{out}.spectral.exr")["S0"]
    np.testing.assert_allclose(wavelengths, np.arange(385, 780, 10))
    assert values.shape == (16, 16, 40)
    assert np.isfinite(values).all() and (values >= 0).all() and values.max() > 0


def test_colour_check_gives_a_verdict(prism, tmp_path):
    import pathlib
    import subprocess
    import sys

    tool = pathlib.Path(__file__).resolve().parents[1] / "colour_check.py"
    a, b = tmp_path / "a", tmp_path / "b"
    # Default 10 nm buckets: the per-pixel differences reach dE 5 and more,
    # and the verdict still passes on the mean, scaled to the bucket width.
    prism("render", "scenes/cornell-box.toml", "-q", "-o", a, "--resolution", "48x48", "--spp", "16")
    prism("render", "scenes/colorchecker.toml", "-q", "-o", b, "--resolution", "48x48", "--spp", "16")
    ok = subprocess.run([sys.executable, tool, f"{a}.spectral.exr", f"{a}.exr"], capture_output=True, text=True)
    assert ok.returncode == 0 and "PASS" in ok.stdout, ok.stdout + ok.stderr
    bad = subprocess.run([sys.executable, tool, f"{a}.spectral.exr", f"{b}.exr"], capture_output=True, text=True)
    assert bad.returncode == 1 and "FAIL" in bad.stdout, bad.stdout + bad.stderr


def test_info_reads_the_reflective_layout(prism, tmp_path):
    """A reflectance image in Fichet's reflective layout (T. channels), as
    colour-science reads it: `prism info` lists its channels as spectral."""
    import colour

    path = tmp_path / "reflectance.exr"
    wavelengths = [450.0, 550.0, 650.0]
    channels = {"T." + f"{w:.6f}".replace(".", ",") + "nm": np.full((2, 3), 0.1 * (k + 1), np.float32)
                for k, w in enumerate(wavelengths)}
    header = {"spectralLayoutVersion": "1.0", "compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, channels) as f:
        f.write(str(path))
    read_wavelengths, values = colour.read_spectral_image_Fichet2021(str(path))["T"]
    np.testing.assert_allclose(read_wavelengths, wavelengths)
    assert values.shape == (2, 3, 3)

    report = prism("info", path).stdout
    assert "spectral (reflective T): 3 channels, centres 450.000-650.000 nm" in report, report
    assert "no spectral channels" not in report
    assert "550.000      0.200000      0.200000      0.200000" in report, report
