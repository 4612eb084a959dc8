"""The examples run and find what they claim."""

import pytest

import colorchecker_illuminants
import dispersion_angle
import plot_spectrum
import white_balance_sweep


def test_colorchecker_under_three_illuminants_matches_colour_science():
    # 64 spp over a 10 x 10 block: noise of a few tenths of ΔE2000 (most
    # under FL11's spikes); a wrong CMF, white or normalisation costs several.
    assert colorchecker_illuminants.main(64) < 1.0


def test_the_white_balance_sweep_is_neutral_at_the_lights_temperature():
    casts = white_balance_sweep.main()
    assert min(casts, key=casts.get) == white_balance_sweep.LIGHT_KELVIN
    assert casts[white_balance_sweep.LIGHT_KELVIN] < 0.02


def test_the_dispersion_follows_snell_and_sellmeier():
    # Each bucket's centroid is good to a few tenths of a pixel at 1024 spp;
    # the 28 buckets spread over 140 pixels, so a wrong index (another
    # glass, no dispersion) is off by tens of pixels.
    assert dispersion_angle.main() < 1.5


def test_plot_spectrum_writes_a_png(tmp_path):
    out = tmp_path / "spectrum.png"
    wavelengths, spectrum = plot_spectrum.main(str(out))
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # The red wall reflects long wavelengths.
    red, blue = (spectrum[(wavelengths > a) & (wavelengths < b)].mean() for a, b in ((600, 700), (400, 500)))
    assert red > 3 * blue


@pytest.mark.parametrize("module", [colorchecker_illuminants, dispersion_angle, plot_spectrum, white_balance_sweep])
def test_every_example_says_how_to_run_it(module):
    assert "python python/examples/" in module.__doc__
