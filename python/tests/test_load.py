"""Loading scenes from Python: files, dicts and text give the same scene;
errors are the command line's; with_updates shares what it can."""

import pathlib
import tomllib

import numpy as np
import pytest

import prism
from conftest import ROOT

CORNELL = ROOT / "scenes" / "cornell-box.toml"


def test_a_file_its_dict_and_its_text_render_the_same_pixels():
    from_file = prism.load(CORNELL, resolution=(32, 24))
    doc = tomllib.loads(CORNELL.read_text())
    from_dict = prism.load(doc, base_dir=CORNELL.parent, resolution=(32, 24))
    from_text = prism.load(CORNELL.read_text(), base_dir=CORNELL.parent, resolution=(32, 24))
    images = [prism.render(s, spp=4, progress=False) for s in (from_file, from_dict, from_text)]
    for image in images[1:]:
        assert np.array_equal(image.spectral, images[0].spectral)
        assert np.array_equal(image.xyz, images[0].xyz)


def test_relative_paths_of_a_dict_start_at_base_dir(tmp_path):
    doc = tomllib.loads((ROOT / "scenes" / "prism.toml").read_text())
    scene = prism.load(doc, base_dir=ROOT / "scenes", resolution=(16, 16))
    assert scene.triangle_count > 0
    with pytest.raises(prism.SceneError, match="does not exist"):
        prism.load(doc, base_dir=tmp_path)


def test_scene_errors_are_value_errors_with_the_command_lines_message(tmp_path, cli):
    bad = tmp_path / "bad.toml"
    bad.write_text(CORNELL.read_text().replace("[film]", "[film]\nresolutoin = [4, 4]", 1))
    with pytest.raises(prism.SceneError) as caught:
        prism.load(bad)
    assert isinstance(caught.value, ValueError)
    message = str(caught.value)
    assert str(bad) in message and "resolutoin" in message and "did you mean `resolution`" in message
    # The command line says the same.
    assert message in cli("render", bad, "-o", tmp_path / "x", check=False).stderr


def test_a_dict_error_names_the_key():
    doc = tomllib.loads(CORNELL.read_text())
    doc["materials"]["red"]["reflectance"] = {1, 2}
    with pytest.raises(prism.SceneError, match=r"materials\.red\.reflectance"):
        prism.load(doc, base_dir=CORNELL.parent)


def test_overrides_pass_the_files_checks():
    with pytest.raises(prism.SceneError, match="resolution"):
        prism.load(CORNELL, resolution=(0, 10))
    with pytest.raises(TypeError, match="unknown override 'spp'"):
        prism.load(CORNELL, spp=4)
    assert prism.load(CORNELL, integrator="bdpt").integrator == "bdpt"
    # Pairs as TOML writes them (lists) or as arrays do too.
    assert prism.load(CORNELL, resolution=[40, 30]).resolution == (40, 30)
    assert prism.load(CORNELL, resolution=np.array([40, 30])).resolution == (40, 30)


def test_with_updates_shares_the_geometry_when_only_materials_change(cornell):
    red = cornell.with_updates({"materials.red.reflectance": 0.1})
    assert cornell.shares_geometry(red)
    moved = cornell.with_updates({"camera.focal_length": 30})
    assert cornell.shares_geometry(moved)
    reshaped = cornell.with_updates({"shape[0].material": "green"})
    assert not cornell.shares_geometry(reshaped)


def test_an_edit_of_a_shapes_emission_shares_the_geometry_and_renders_as_a_load(cornell):
    doc = cornell.to_dict()
    lamp = next(i for i, s in enumerate(doc["shape"]) if "emission" in s)
    updates = {f"shape[{lamp}].emission": "A", f"shape[{lamp}].emission_scale": 3.0}
    relit = cornell.with_updates(updates)
    assert cornell.shares_geometry(relit)
    doc["shape"][lamp].update({"emission": "A", "emission_scale": 3.0})
    loaded = prism.load(doc, base_dir=CORNELL.parent, resolution=cornell.resolution)
    a = prism.render(relit, spp=4, progress=False).spectral
    assert np.array_equal(a, prism.render(loaded, spp=4, progress=False).spectral)
    assert not np.array_equal(a, prism.render(cornell, spp=4, progress=False).spectral)
    # A shape that starts or stops emitting changes the geometry's lights.
    dark = cornell.with_updates({f"shape[{lamp}].emission": None})
    assert not cornell.shares_geometry(dark)


def test_with_updates_renders_as_a_scene_loaded_with_the_change(cornell):
    updated = cornell.with_updates({"materials.red.reflectance": {"rgb": [0.2, 0.7, 0.2]}})
    doc = cornell.to_dict()
    doc["materials"]["red"]["reflectance"] = {"rgb": [0.2, 0.7, 0.2]}
    loaded = prism.load(doc, base_dir=CORNELL.parent, resolution=cornell.resolution)
    a = prism.render(updated, spp=4, progress=False)
    b = prism.render(loaded, spp=4, progress=False)
    assert np.array_equal(a.spectral, b.spectral)
    before = prism.render(cornell, spp=4, progress=False)
    assert not np.array_equal(a.spectral, before.spectral)


def test_spectra_as_numpy_pairs_and_colour_distributions_are_tables(cornell):
    import colour

    wl = np.array([400.0, 500.0, 600.0, 700.0])
    values = np.array([0.1, 0.3, 0.6, 0.8])
    table = cornell.with_updates({"materials.red.reflectance": np.column_stack([wl, values]).tolist()})
    pair = cornell.with_updates({"materials.red.reflectance": (wl, values)})
    sd = cornell.with_updates({"materials.red.reflectance": colour.SpectralDistribution(values, wl)})
    images = [prism.render(s, spp=2, progress=False).spectral for s in (table, pair, sd)]
    assert np.array_equal(images[0], images[1]) and np.array_equal(images[0], images[2])


def test_spectrum_gives_the_scenes_values():
    import colour

    wl, d65 = prism.spectrum("D65")
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(colour.SpectralShape(360, 830, 1))
    # Illuminants are normalised to luminance 1, that of radiance 1 at
    # every wavelength: ∫ S ȳ dλ = ∫ ȳ dλ.
    y = np.trapezoid(d65 * cmfs.values[:, 1], wl) / np.trapezoid(cmfs.values[:, 1], wl)
    assert y == pytest.approx(1.0, rel=2e-3)
    wl, v = prism.spectrum([[400, 0.2], [700, 0.8]], wavelengths=[400, 550, 700], role="reflectance")
    assert np.allclose(v, [0.2, 0.5, 0.8])
    with pytest.raises(prism.SceneError, match="illuminant, not a reflectance"):
        prism.spectrum("D65", role="reflectance")


def test_everything_public_has_a_docstring():
    import inspect

    missing = []
    for name in prism.__all__:
        obj = getattr(prism, name)
        if not isinstance(obj, str) and not (obj.__doc__ or "").strip():
            missing.append(name)
        if inspect.isclass(obj) and obj.__module__ == "prism":
            for member, value in vars(obj).items():
                if member.startswith("_") and member != "__init__":
                    continue
                target = value.fget if isinstance(value, property) else value
                if callable(target) and not (target.__doc__ or "").strip():
                    missing.append(f"{name}.{member}")
    assert not missing, missing
    assert (pathlib.Path(prism.__file__).parent / "_native.pyi").exists()
    assert (pathlib.Path(prism.__file__).parent / "py.typed").exists()
