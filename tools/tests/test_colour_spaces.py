"""Output colour spaces, observers, white balance and display output,
with colour-science as the oracle.

- Every space and observer: the ColorChecker's patches (strategy "bsdf",
  so each sample is exactly reflectance x D65 and only the wavelength
  sampling is random) are within dE2000 0.1 of colour-science's XYZ under
  that observer taken to the space by its XYZ_to_RGB (Bradford); and every
  pixel is colour-science's conversion of the same render's raw XYZ.
- The EXRs carry the space's chromaticities.
- A white balance renders its illuminant neutral (exactly: colour-science's
  transform of the raw render).
- Gamut mapping keeps the OKLab hue of spectral colours; per-channel
  clipping does not.
- The PNG is tagged (cICP) and 16-bit where asked.
"""
import pathlib
import re
import struct

import numpy as np
import OpenEXR
import OpenImageIO as oiio
import pytest

import colour_check  # noqa: F401  (silences colour-science's warnings)
import colour

ROOT = pathlib.Path(__file__).resolve().parents[2]
SPACES = {
    "srgb-linear": "sRGB",
    "rec2020-linear": "ITU-R BT.2020",
    "display-p3-linear": "Display P3",
    "acescg": "ACEScg",
    "aces2065-1": "ACES2065-1",
    "xyz": None,
}
OBSERVERS = {
    "cie1931-2": "CIE 1931 2 Degree Standard Observer",
    "cie1964-10": "CIE 1964 10 Degree Standard Observer",
    "cie2015-2": "CIE 2015 2 Degree Standard Observer",
    "cie2015-10": "CIE 2015 10 Degree Standard Observer",
}
GRID = np.arange(360, 831)


def cmfs(observer):
    """The observer's CMFs on prism's 1 nm grid (zero where undefined)."""
    c = colour.MSDS_CMFS[OBSERVERS[observer]]
    return np.stack([np.interp(GRID, c.wavelengths, c.values[:, k], left=0, right=0) for k in range(3)], axis=-1)


def xyz_of(values, observer):
    """XYZ of a spectrum on GRID, normalised as prism's film (a constant 1 has Y = 1)."""
    c = cmfs(observer)
    return values @ c / c[:, 1].sum()


def spd(sd):
    return np.interp(GRID, sd.wavelengths, sd.values)


def table(path):
    """A spectrum CSV of spectra/ (written by tools/gen_tables.py from colour-science) on GRID."""
    rows = [line.split(",") for line in (ROOT / "spectra" / path).read_text().splitlines() if line[:1].isdigit()]
    values = np.array(rows, dtype=np.float64)
    return np.interp(GRID, values[:, 0], values[:, 1])


# prism's D65: colour-science's D-series at the historical CCT, 1 nm.
D65 = table("cie_d65.csv")
D65_1931_LUMINANCE = xyz_of(D65, "cie1931-2")[1]


def render_white_xy(observer):
    """The white prism adapts from: the D65 spectrum under the observer (under
    CIE 1931 too, so that D65 renders neutral in every observer)."""
    return colour.XYZ_to_xy(xyz_of(D65, observer))


def colourspace(space):
    """colour-science's space with its matrices derived from the primaries
    and white, as prism derives them (sRGB's own is IEC 61966-2-1's
    4-digit rounding of it)."""
    cs = colour.RGB_COLOURSPACES[SPACES[space]].copy()
    cs.use_derived_matrix_RGB_to_XYZ = True
    cs.use_derived_matrix_XYZ_to_RGB = True
    return cs


def to_space(xyz, space, source_xy):
    if SPACES[space] is None:
        return xyz
    return colour.XYZ_to_RGB(xyz, colourspace(space), illuminant=source_xy, chromatic_adaptation_transform="Bradford")


def from_space(rgb, space):
    """RGB of a space back to XYZ under the space's own white (no adaptation)."""
    if SPACES[space] is None:
        return rgb
    cs = colourspace(space)
    return colour.RGB_to_XYZ(rgb, cs, illuminant=cs.whitepoint, chromatic_adaptation_transform=None)


def space_white(space):
    return np.array([1 / 3, 1 / 3]) if SPACES[space] is None else colour.RGB_COLOURSPACES[SPACES[space]].whitepoint


def checker_scene(tmp_path, film_keys, name):
    """scenes/colorchecker.toml at 150 x 100 with extra [film] keys, written to tmp_path."""
    text = (ROOT / "scenes" / "colorchecker.toml").read_text()
    text = text.replace('"../spectra/', f'"{ROOT}/spectra/')
    text = text.replace("resolution = [300, 200]", "resolution = [150, 100]\n" + film_keys)
    text = text.replace("max_depth = 1", 'max_depth = 1\nstrategy = "bsdf"')
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def render(prism, scene, out, spp="64"):
    prism("render", scene, "-q", "-o", out, "--spp", spp, "--seed", "3")
    return colour_check.read_rgb_exr(f"{out}.exr")


def patch_means(rgb):
    """Mean RGB of the middle 8 x 8 pixels of each of the 24 patches (6 x 4 grid)."""
    import tomllib

    from test_colorchecker import patch_centres

    scene = tomllib.loads((ROOT / "scenes" / "colorchecker.toml").read_text())
    scene["film"]["resolution"] = [150, 100]
    out = []
    for x, y, _ in patch_centres(scene):
        out.append(rgb[int(y) - 4:int(y) + 4, int(x) - 4:int(x) + 4].reshape(-1, 3).mean(axis=0))
    return np.array(out)


def expected_patch_xyz(observer):
    checker = colour.SDS_COLOURCHECKERS["BabelColor Average"]
    out = []
    for sd in checker.values():
        # As tools/gen_colorchecker.py writes the scene's patches: aligned
        # to 5 nm by colour-science, linear in between.
        sd = sd.copy().align(colour.SpectralShape(360, 830, 5))
        refl = np.interp(GRID, sd.wavelengths, sd.values)
        # The scene's D65 is normalised to luminance 1 under CIE 1931.
        out.append(xyz_of(refl * D65 / D65_1931_LUMINANCE, observer))
    return np.array(out)


@pytest.mark.parametrize("observer", list(OBSERVERS))
def test_every_space_matches_colour_science(prism, tmp_path, observer):
    source = render_white_xy(observer)
    # Few samples suffice to compare transforms: the same seed gives the
    # same samples, so every pixel of a space's render must be
    # colour-science's conversion of the raw XYZ render.
    raw_keys = f'observer = "{observer}"\ncolour_space = "xyz"'
    raw = render(prism, checker_scene(tmp_path, raw_keys, "raw"), tmp_path / "raw", "4")
    for space in SPACES:
        keys = f'observer = "{observer}"\ncolour_space = "{space}"'
        rgb = render(prism, checker_scene(tmp_path, keys, space), tmp_path / space, "4")
        converted = to_space(raw, space, source)
        scale = np.abs(converted).max()
        assert np.abs(rgb - converted).max() < 1e-5 * scale, f"{space}: pixels differ from colour-science's XYZ_to_RGB"
    # The patches against colour-science's integral, in every space's own
    # Lab: with 1 024 spp (65 536 samples a patch) the wavelength sampling
    # noise is ~0.003 dE (at 64 spp the white patch alone strays to 0.13).
    raw = render(prism, checker_scene(tmp_path, raw_keys, "raw"), tmp_path / "raw", "1024")
    got_xyz, want_xyz = patch_means(raw), expected_patch_xyz(observer)
    for space in SPACES:
        got = from_space(to_space(got_xyz, space, source), space)
        want = from_space(to_space(want_xyz, space, source), space)
        white = space_white(space)
        de = colour.delta_E(colour.XYZ_to_Lab(got, white), colour.XYZ_to_Lab(want, white), method="CIE 2000")
        print(f"{observer} {space}: dE2000 mean {de.mean():.4f} max {de.max():.4f}")
        assert de.max() < 0.1, f"{observer} {space}: dE2000 {de.max():.3f}"


def test_exrs_carry_the_space_chromaticities(prism, tmp_path):
    for space, name in SPACES.items():
        out = tmp_path / space
        prism("render", checker_scene(tmp_path, f'colour_space = "{space}"', space), "-q", "-o", out, "--spp", "1")
        for path in [f"{out}.exr", f"{out}.spectral.exr"]:
            with OpenEXR.File(path) as f:
                c = np.array(f.header()["chromaticities"], dtype=np.float64).reshape(4, 2)
            if name is None:
                want = np.array([[1, 0], [0, 1], [0, 0], [1 / 3, 1 / 3]])
            else:
                cs = colour.RGB_COLOURSPACES[name]
                want = np.vstack([cs.primaries, cs.whitepoint])
            assert np.abs(c - want).max() < 1e-6, f"{space} {path}: {c}"


@pytest.mark.parametrize("balance,spectrum", [('"A"', "A"), ("{ temperature = 3200 }", 3200)])
def test_white_balance_renders_its_illuminant_neutral(prism, tmp_path, balance, spectrum):
    scene = """
[camera]
position = [0, 0, -3]
look_at = [0, 0, 0]
fov = 30
[film]
resolution = [16, 16]
spp = 64
{film}
[[shape]]
type = "quad"
vertices = [[-2, -2, 0], [-2, 2, 0], [2, 2, 0], [2, -2, 0]]
emission = {emission}
"""
    emission = '"A"' if spectrum == "A" else "{ blackbody = 3200 }"
    raw_path, wb_path = tmp_path / "raw.toml", tmp_path / "wb.toml"
    raw_path.write_text(scene.format(film='colour_space = "xyz"', emission=emission))
    wb_path.write_text(scene.format(film=f"white_balance = {balance}", emission=emission))
    raw = render(prism, raw_path, tmp_path / "raw")
    balanced = render(prism, wb_path, tmp_path / "wb")
    if spectrum == "A":
        illuminant = table("cie_a.csv")  # colour-science's formula at 1 nm, as prism embeds it
    else:
        illuminant = spd(colour.sd_blackbody(3200, colour.SpectralShape(360, 830, 1)))
    source = colour.XYZ_to_xy(xyz_of(illuminant, "cie1931-2"))
    want = to_space(raw, "srgb-linear", source)
    # prism evaluates Planck's law in single precision: its white is 3e-5 off.
    tolerance = 1e-5 if spectrum == "A" else 5e-5
    assert np.abs(balanced - want).max() < tolerance * np.abs(want).max()
    # colour-science's own transform of the illuminant's exact XYZ is neutral...
    white = to_space(xyz_of(illuminant, "cie1931-2"), "srgb-linear", source)
    assert np.ptp(white) < 1e-4 * white.max(), white
    # ...and so is the render, to its wavelength-sampling noise.
    mean = balanced.reshape(-1, 3).mean(axis=0)
    assert np.ptp(mean) < 5e-3 * mean.max(), mean


def png_chunks(path):
    data = pathlib.Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    at, chunks = 8, {}
    while at < len(data):
        (n,) = struct.unpack(">I", data[at:at + 4])
        chunks.setdefault(data[at + 4:at + 8].decode(), data[at + 8:at + 8 + n])
        at += 12 + n
    return chunks


def test_pngs_are_tagged_and_16_bit_where_asked(prism, tmp_path):
    for display, primaries in [("srgb", 1), ("display-p3", 12)]:
        keys = f'display = "{display}"\npng_bits = 16'
        out = tmp_path / display
        prism("render", checker_scene(tmp_path, keys, display), "-q", "-o", out, "--spp", "1")
        chunks = png_chunks(f"{out}.png")
        assert chunks["cICP"] == bytes([primaries, 13, 0, 1]), chunks["cICP"]
        assert chunks["IHDR"][8] == 16
        assert ("sRGB" in chunks) == (display == "srgb")
        assert ("iCCP" in chunks) == (display == "display-p3")


def test_display_p3_pngs_carry_an_icc_profile_that_little_cms_reads_as_p3(prism, tmp_path):
    """For viewers that ignore cICP: the iCCP profile, read by littleCMS
    (Pillow's ImageCms), takes Display P3 pixels to the same sRGB values as
    colour-science's Display P3 -> sRGB conversion (within 8-bit rounding)."""
    import io

    from PIL import Image, ImageCms

    out = tmp_path / "p3"
    prism("render", checker_scene(tmp_path, 'display = "display-p3"', "p3"), "-q", "-o", out, "--spp", "1")
    profile = Image.open(f"{out}.png").info["icc_profile"]
    p3 = ImageCms.ImageCmsProfile(io.BytesIO(profile))
    assert "Display P3" in ImageCms.getProfileDescription(p3)
    # In-gamut colours of both spaces, and saturated P3 ones that clip.
    codes = np.array([[[200, 30, 40], [30, 180, 60], [40, 60, 190], [128, 128, 128], [250, 240, 10], [255, 255, 255]]], np.uint8)
    src = Image.fromarray(codes, "RGB")
    srgb = ImageCms.createProfile("sRGB")
    converted = np.asarray(ImageCms.profileToProfile(src, p3, srgb, renderingIntent=ImageCms.Intent.RELATIVE_COLORIMETRIC), np.float64)
    expected = colour.RGB_to_RGB(codes / 255.0, "Display P3", "sRGB", apply_cctf_decoding=True, apply_cctf_encoding=True)
    expected = np.clip(expected, 0, 1) * 255
    assert np.abs(converted - expected).max() < 2.5, (converted, expected)


LINES = [450, 475, 500, 520, 540, 560, 580, 600, 630]


def line_scene(tmp_path, gamut):
    """One quad per narrow spectral line (Gaussian, 6 nm wide), side by side."""
    shapes = []
    for i, nm in enumerate(LINES):
        table = ", ".join(f"[{w}, {np.exp(-0.5 * ((w - nm) / 6) ** 2):.6g}]" for w in range(nm - 30, nm + 31, 2))
        x0 = -4.5 + i
        shapes.append(
            f'[[shape]]\ntype = "quad"\nvertices = [[{x0 + 1}, -0.5, 0], [{x0}, -0.5, 0], [{x0}, 0.5, 0], [{x0 + 1}, 0.5, 0]]\n'
            f"emission = {{ scale = 0.6, constant = 1 }}\n".replace("{ scale = 0.6, constant = 1 }", f"[{table}]")
        )
    text = f"""
[camera]
position = [0, 0, -10]
look_at = [0, 0, 0]
fov = 12
[film]
resolution = [180, 40]
spp = 256
png_bits = 16
gamut = "{gamut}"
exposure = -1.5
""" + "\n".join(shapes)
    path = tmp_path / f"lines-{gamut}.toml"
    path.write_text(text)
    return path


def oklab_of_linear_srgb(rgb):
    return colour.XYZ_to_Oklab(colour.RGB_to_XYZ(rgb, "sRGB", illuminant=np.array([0.3127, 0.3290]), chromatic_adaptation_transform=None))


def hue_offsets(prism, tmp_path, gamut):
    """Per line: how far the PNG's OKLab (a, b) lies from the line's hue
    (from the EXR of the same render, before any clipping)."""
    out = tmp_path / f"lines-{gamut}"
    prism("render", line_scene(tmp_path, gamut), "-q", "-o", out, "--seed", "5")
    linear = colour_check.read_rgb_exr(f"{out}.exr") * 2.0 ** -1.5
    png = oiio.ImageInput.open(f"{out}.png")
    encoded = png.read_image(format=oiio.UINT16).astype(np.float64) / 65535.0
    png.close()
    shown = colour.models.eotf_sRGB(encoded)
    offsets = []
    for i in range(len(LINES)):
        x = int((i + 0.5) * 180 / len(LINES))
        block = (slice(15, 25), slice(x - 4, x + 4))
        want = oklab_of_linear_srgb(linear[block].reshape(-1, 3))
        got = oklab_of_linear_srgb(shown[block].reshape(-1, 3))
        hue = want[:, 1:] / np.linalg.norm(want[:, 1:], axis=-1, keepdims=True)
        ab = got[:, 1:]
        off_line = ab - hue * np.sum(ab * hue, axis=-1, keepdims=True)
        offsets.append(np.linalg.norm(off_line, axis=-1).max())
    return np.array(offsets)


def test_gamut_mapping_keeps_the_hue_of_spectral_lines(prism, tmp_path):
    mapped = hue_offsets(prism, tmp_path, "map")
    clipped = hue_offsets(prism, tmp_path, "clip")
    print("hue offset (OKLab a, b) mapped:", np.round(mapped, 4), "clipped:", np.round(clipped, 4))
    # CSS Color 4 stops once clipping moves the colour less than a JND of
    # 0.02 in OKLab from a colour of the original lightness and hue, so the
    # result lies within 0.02 of the hue line; 16-bit quantisation adds ~1e-5.
    assert mapped.max() < 0.021, mapped
    # Per-channel clipping turns spectral greens and cyans far off their hue.
    assert clipped.max() > 0.05, clipped


@pytest.mark.parametrize("observer,space,balance,recorded", [
    ("cie1931-2", "srgb-linear", None, "none"),
    ("cie1964-10", "xyz", None, "none"),
    ("cie2015-10", "acescg", '"A"', "A"),
    ("cie1931-2", "xyz", "{ temperature = 3200 }", "3200 K"),
])
def test_files_say_which_observer_white_balance_and_neutral(prism, tmp_path, observer, space, balance, recorded):
    """NAME.exr and NAME.spectral.exr record the observer, the white
    balance and OpenEXR's adoptedNeutral: the chromaticity their R, G, B
    render neutral (the space's white; raw XYZ: D65 under the observer, or
    E after a white balance)."""
    keys = f'observer = "{observer}"\ncolour_space = "{space}"'
    if balance:
        keys += f"\nwhite_balance = {balance}"
    render(prism, checker_scene(tmp_path, keys, "s"), tmp_path / "s", "1")
    if space == "xyz":
        neutral = np.array([1 / 3, 1 / 3]) if balance else render_white_xy(observer)
    else:
        neutral = colour.RGB_COLOURSPACES[SPACES[space]].whitepoint
    for path in [tmp_path / "s.exr", tmp_path / "s.spectral.exr"]:
        with OpenEXR.File(str(path)) as f:
            header = dict(f.header())
        assert header["prismObserver"] == observer, path
        assert header["prismWhiteBalance"] == recorded, path
        assert header["prismColourSpace"] == space, path
        assert np.abs(np.array(header["adoptedNeutral"]) - neutral).max() < 1e-5, (path, header["adoptedNeutral"], neutral)
