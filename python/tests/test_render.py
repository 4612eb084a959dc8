"""Rendering from Python: arrays against the files, the files against the
command line's, the spectral cube against XYZ, interrupts and errors."""

import filecmp
import os
import signal
import threading

import numpy as np
import OpenEXR
import pytest

import prism
from conftest import ROOT

CORNELL = ROOT / "scenes" / "cornell-box.toml"


@pytest.fixture(scope="module")
def image(cornell):
    # Uniform: every pixel's 8 samples, which the metadata tests read.
    return prism.render(cornell, spp=8, adaptive=False, progress=False)


def test_save_writes_what_the_command_line_writes_byte_for_byte(tmp_path, cli):
    scene = prism.load(CORNELL, resolution=(48, 32))
    prism.render(scene, spp=8, threads=2, progress=False).save(tmp_path / "py")
    cli("render", CORNELL, "--resolution", "48x32", "--spp", "8", "-o", tmp_path / "cli", "-q")
    for ext in ("exr", "png", "spectral.exr"):
        assert filecmp.cmp(tmp_path / f"py.{ext}", tmp_path / f"cli.{ext}", shallow=False), ext


def exr_channels(path):
    with OpenEXR.File(str(path), separate_channels=True) as f:
        return {name: c.pixels for name, c in f.channels().items()}


def test_the_arrays_are_the_files_pixels(image, tmp_path):
    image.save(tmp_path / "a")
    rgb = exr_channels(tmp_path / "a.exr")
    assert np.array_equal(np.stack([rgb[c] for c in "RGB"], axis=-1), image.rgb)
    spectral = exr_channels(tmp_path / "a.spectral.exr")
    names = sorted((n for n in spectral if n.startswith("S0.")), key=lambda n: float(n[3:-2].replace(",", ".")))
    cube = np.stack([spectral[n] for n in names], axis=-1)
    assert np.array_equal(cube, image.spectral)
    assert np.array_equal(spectral["sampleCount"], image.sample_count.astype(np.float32))
    back = prism.read(tmp_path / "a.spectral.exr")
    assert np.array_equal(back.spectral, image.spectral)
    # Channel names carry the centres to 1e-6 nm.
    assert np.allclose(back.wavelengths, image.wavelengths, rtol=0, atol=1e-6)
    # XYZ comes back through the inverse of the RGB matrix (float32 rounding).
    assert np.allclose(back.xyz, image.xyz, rtol=1e-5, atol=1e-6)
    assert back.metadata["seed"] == image.metadata["seed"]
    plain = prism.read(tmp_path / "a.exr")
    assert np.array_equal(plain.rgb, image.rgb) and plain.spectral is None
    # NAME.exr records its XYZ -> RGB matrix too.
    assert np.allclose(plain.xyz, image.xyz, rtol=1e-5, atol=1e-6)
    with pytest.raises(prism.RenderError, match="not saved again"):
        back.save(tmp_path / "b")


def test_shapes_dtypes_and_metadata(image, cornell):
    h, w = 32, 48
    assert image.xyz.shape == (h, w, 3) and image.xyz.dtype == np.float32
    assert image.rgb.shape == (h, w, 3)
    assert image.spectral.shape == (h, w, len(image.wavelengths))
    assert len(image.bucket_edges) == len(image.wavelengths) + 1
    assert np.allclose((image.bucket_edges[1:] + image.bucket_edges[:-1]) / 2, image.wavelengths)
    assert (image.sample_count == 8).all()
    m = image.metadata
    assert (m["integrator"], m["seed"], m["samples"], m["spp"]) == ("path", 0, (0, 8), 8)
    assert m["colour_space"] == cornell.colour_space and m["scene_hash"] == cornell.content_hash
    assert not image.interrupted and m["stop"] == "complete"
    assert np.allclose(image.rgb, image.xyz @ cornell.xyz_to_rgb.T, rtol=1e-5, atol=1e-7)


def test_the_spectral_cube_integrates_to_xyz(cornell):
    """XYZ is ∫ L·CMF dλ / ∫ ȳ dλ (radiance 1 at every wavelength has Y = 1),
    scored per sample at its wavelengths; Σ over buckets of mean radiance ×
    ∫ CMF over the bucket approximates it. Over the image the two differ by
    the CMFs' and the spectrum's variation within a 10 nm bucket and the
    light outside 380-780 nm (measured 0.1%, and at 512 spp too: a bias,
    not noise); per pixel, also by where in its buckets a pixel's few
    wavelengths fell (noise: 1.1% of Z at 64 spp, 0.3% at 512)."""
    import colour

    image = prism.render(cornell, spp=64, progress=False)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(colour.SpectralShape(360, 830, 1))
    y_integral = np.trapezoid(cmfs.values[:, 1], cmfs.wavelengths)

    def bucket_integral(lo, hi, k):
        return np.interp(np.linspace(lo, hi, 101), cmfs.wavelengths, cmfs.values[:, k]).mean() * (hi - lo)

    edges = image.bucket_edges
    weights = np.array([[bucket_integral(lo, hi, k) for k in range(3)] for lo, hi in zip(edges[:-1], edges[1:])])
    integrated = (image.spectral @ (weights / y_integral)).reshape(-1, 3)
    xyz = image.xyz.reshape(-1, 3)
    mean = xyz.mean(axis=0)
    assert (np.abs(integrated.mean(axis=0) - mean) < 0.005 * mean).all()
    assert (np.abs(integrated - xyz).mean(axis=0) < 0.03 * mean).all()


def test_aovs_are_arrays(cornell):
    scene = cornell.with_updates({"film.aovs": ["albedo", "normal", "depth"]})
    aovs = prism.render(scene, spp=2, progress=False).aovs
    assert aovs["albedo"].shape == (32, 48, 3) and aovs["depth"].shape == (32, 48)
    lengths = np.linalg.norm(aovs["normal"], axis=-1)
    assert np.allclose(lengths[lengths > 0], 1, atol=1e-4)


def test_ctrl_c_returns_the_image_with_even_samples(cornell):
    sent = []

    def interrupt(fraction, info):
        if not sent and info["done"] > 0:
            sent.append(info["done"])
            os.kill(os.getpid(), signal.SIGINT)

    image = prism.render(cornell, spp=1 << 20, adaptive=False, progress=interrupt)
    assert image.interrupted and image.metadata["stop"] == "interrupted"
    counts = image.sample_count
    assert counts.min() == counts.max() > 0
    assert image.metadata["spp"] == counts[0, 0]


def test_a_time_budget_stops_after_the_pass_under_way(cornell):
    image = prism.render(cornell, spp=1 << 20, time=0.2, adaptive=False, progress=False)
    assert image.interrupted and image.metadata["stop"] == "time budget"
    assert image.sample_count.min() == image.sample_count.max()


def test_progress_is_called_with_fractions_up_to_one(cornell):
    seen = []
    prism.render(cornell, spp=4, progress=lambda f, info: seen.append((f, info["done"], info["total"])))
    assert seen and all(0 <= f <= 1 for f, _, _ in seen)
    assert seen[-1][0] == 1.0 and seen[-1][1] == seen[-1][2]
    # Adaptive by default: the counts average the 4 samples asked for.
    assert abs(seen[-1][2] - 48 * 32 * 4) <= 48 * 32 * 0.05


def test_an_error_in_the_progress_callback_stops_the_render_and_is_raised(cornell):
    def fail(fraction, info):
        raise ArithmeticError("from the callback")

    with pytest.raises(ArithmeticError, match="from the callback"):
        prism.render(cornell, spp=1 << 20, progress=fail)


def test_rendering_releases_the_gil(cornell):
    ticks = []
    stop = threading.Event()

    def tick():
        while not stop.is_set():
            ticks.append(1)
            stop.wait(0.001)

    t = threading.Thread(target=tick)
    t.start()
    before = len(ticks)
    prism.render(cornell, spp=64, threads=1, progress=False)
    during = len(ticks) - before
    stop.set()
    t.join()
    assert during > 10


def test_render_errors(cornell):
    with pytest.raises(prism.RenderError, match="threads must be at least 1"):
        prism.render(cornell, threads=0, progress=False)
    with pytest.raises(prism.RenderError, match="adaptive sampling"):
        prism.render(cornell, integrator="bdpt", adaptive=True, progress=False)
    with pytest.raises(prism.RenderError, match="adaptive sampling spreads"):
        prism.render(cornell, adaptive=True, samples=range(0, 8), progress=False)
    # Adaptive by default, but not towards an error target (which says so).
    with pytest.warns(UserWarning, match="uniform sampling: an error target"):
        image = prism.render(cornell, spp=8, target_error=1e-9, progress=False)
    assert image.sample_count.min() == image.sample_count.max() == 8


def test_render_overrides_and_sample_ranges_merge_exactly(cornell):
    small = prism.render(cornell, spp=2, resolution=(24, 16), progress=False)
    assert small.rgb.shape == (16, 24, 3)
    whole = prism.render(cornell, spp=4, adaptive=False, progress=False)
    # Parts of a render sample uniformly, and say so.
    with pytest.warns(UserWarning, match="uniform sampling: this is a part of a render"):
        first = prism.render(cornell, samples=range(0, 2), progress=False)
    second = prism.render(cornell, samples=(2, 4), adaptive=False, progress=False)
    merged = (first.spectral + second.spectral) / 2
    assert np.allclose(merged, whole.spectral, rtol=1e-5, atol=1e-6)


def test_to_colour_gives_colour_science_objects(image):
    import colour

    sd = image.to_colour(pixel=(10, 20))
    assert isinstance(sd, colour.SpectralDistribution)
    assert np.allclose(sd.values, image.spectral[20, 10])
    msds = image.to_colour(pixels=[(1, 2), (3, 4)])
    assert isinstance(msds, colour.MultiSpectralDistributions) and msds.values.shape[1] == 2
