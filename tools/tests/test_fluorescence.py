"""Fluorescent materials against the total radiance factor computed with
numpy straight from the Donaldson matrix.

- A flat patch lit from every direction by D65, A and a narrow violet lamp
  (max_depth 1): its radiance at each wavelength is r(λ) E(λ) + ∫ D(λx, λ)
  E(λx) dλx, so its XYZ is that integrated with the CIE 1931 CMFs. The
  matrix is given as a CSV (interpolated bilinearly, as prism documents)
  and as excitation, emission and quantum yield (D = Q a(λx) λx e(λ) /
  ∫ e λ dλ for λ ≥ λx).
- Inside a closed fluorescent sphere that emits E: the radiance is the
  Neumann series E + K E + K² E + ..., with K the bounce operator L ↦ r L +
  ∫ D(λx, ·) L(λx) dλx: two bounces (max_depth 2, fluorescent light falling
  on a second fluorescent surface) and all of them ((I − K)⁻¹ E, energy
  conservation over every bounce).

Everything is evaluated at the centres of 1 nm cells (prism holds the
matrix on the same cells). Each image is uniform, so its pixels are
independent estimates of one XYZ: the tolerance is 5 standard errors of
their mean, plus 2e-4 relative for the midpoint rule.
"""
import pathlib

import numpy as np

import colour_check  # noqa: F401  (silences colour-science's warnings)
import colour

ROOT = pathlib.Path(__file__).resolve().parents[2]
CELLS = np.arange(360, 830) + 0.5
CMFS = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
CMF = np.stack([np.interp(CELLS, CMFS.wavelengths, CMFS.values[:, k], left=0, right=0) for k in range(3)], -1)

# The test's matrix: excited around 450 nm, emitting around 520 nm, none
# below the exciting wavelength (per nm of excitation), on a 10 nm grid.
EXCITATION_ROWS = np.arange(360, 561, 10.0)
EMISSION_COLUMNS = np.arange(400, 701, 10.0)
REFLECTANCE = [[360, 0.3], [830, 0.9]]
VIOLET = [[395, 0.0], [400, 1.0], [410, 1.0], [415, 0.0]]


def matrix_values():
    x, m = np.meshgrid(EXCITATION_ROWS, EMISSION_COLUMNS, indexing="ij")
    d = 0.004 * np.exp(-(((x - 450) / 30) ** 2)) * np.exp(-(((m - 520) / 25) ** 2))
    return np.where(m >= x, d, 0.0)


def write_matrix(path):
    lines = ["excitation\\emission," + ",".join(f"{m:g}" for m in EMISSION_COLUMNS)]
    for x, row in zip(EXCITATION_ROWS, matrix_values()):
        lines.append(f"{x:g}," + ",".join(f"{v:.9g}" for v in row))
    path.write_text("\n".join(lines) + "\n")


def bilinear_matrix():
    """D on CELLS x CELLS (excitation, emission): the file's grid interpolated, zero outside it."""
    values = matrix_values()
    along_emission = np.stack([np.interp(CELLS, EMISSION_COLUMNS, row, left=0, right=0) for row in values])
    d = np.stack([np.interp(CELLS, EXCITATION_ROWS, col, left=0, right=0) for col in along_emission.T], axis=1)
    return d


def triplet_matrix(q=0.8):
    a = np.interp(CELLS, [380, 420, 460, 480], [0, 0.6, 0.6, 0])
    e = np.exp(-(((CELLS - 530) / 20) ** 2))
    x, m = np.meshgrid(CELLS, CELLS, indexing="ij")
    d = q * a[:, None] * x * e[None, :] / np.sum(e * CELLS)
    return np.where(m >= x, d, 0.0)


TRIPLET = """excitation = [[380, 0], [420, 0.6], [460, 0.6], [480, 0]]
emission = { file = "emission.csv" }
quantum_yield = 0.8"""


def table(path):
    rows = [line.split(",") for line in (ROOT / "spectra" / path).read_text().splitlines() if line[:1].isdigit()]
    values = np.array(rows, dtype=np.float64)
    return np.interp(CELLS, values[:, 0], values[:, 1], left=0, right=0)


def luminance_one(spd):
    """An illuminant scaled as prism scales named ones: Y = 1 under CIE 1931."""
    return spd / (spd @ CMF[:, 1] / CMF[:, 1].sum())


# Each lamp with the samples per pixel its error bars need: few paths
# from a green wavelength find the violet lamp's narrow band.
ILLUMINANTS = {
    '"D65"': (luminance_one(table("cie_d65.csv")), 64),
    '"A"': (luminance_one(table("cie_a.csv")), 64),
    str(VIOLET): (np.interp(CELLS, *np.array(VIOLET).T, left=0, right=0), 256),
}


def bounce(d, r, light):
    """K L: what a fluorescent Lambertian surface sends back under uniform radiance L."""
    return r * light + light @ d


def xyz(spectrum):
    return spectrum @ CMF / CMF[:, 1].sum()


def setup(tmp_path, form):
    write_matrix(tmp_path / "matrix.csv")
    e = np.exp(-(((np.arange(360, 831) - 530) / 20) ** 2))
    (tmp_path / "emission.csv").write_text("".join(f"{l},{v:.9g}\n" for l, v in zip(range(360, 831), e)))
    if form == "matrix":
        return 'donaldson = "matrix.csv"', bilinear_matrix()
    return TRIPLET, triplet_matrix()


def render_xyz(prism, tmp_path, scene, spp):
    path = tmp_path / "scene.toml"
    path.write_text(scene)
    prism("render", path, "-q", "-o", tmp_path / "out", "--spp", spp, "--seed", "5")
    pixels = colour_check.read_rgb_exr(tmp_path / "out.exr").reshape(-1, 3)
    return pixels.mean(axis=0), pixels.std(axis=0, ddof=1) / np.sqrt(len(pixels))


def assert_agrees(got, error, expected, what):
    tolerance = 5 * error + 2e-4 * np.abs(expected)
    assert np.all(np.abs(got - expected) < tolerance), f"{what}: {got} +- {error}, expected {expected}"
    # The test can fail: its error bars are far tighter than the fluorescent part.
    assert np.all(error < 0.01 * np.abs(expected) + 1e-6), f"{what}: error bars {error} too wide"


PATCH = """
[camera]
position = [0, 0, -1]
look_at = [0, 0, 0]
fov = 40

[film]
resolution = [24, 24]
colour_space = "xyz"

[integrator]
max_depth = 1

[[shape]]
type = "sphere"
radius = 50
flip_normals = true
emission = {light}

[materials.patch]
type = "fluorescent"
reflectance = {reflectance}
{fluorescence}

[[shape]]
type = "quad"
vertices = [[-2, -2, 0], [-2, 2, 0], [2, 2, 0], [2, -2, 0]]
material = "patch"
"""


def test_flat_patch_under_three_lamps_matches_the_total_radiance_factor(prism, tmp_path):
    r = np.interp(CELLS, *np.array(REFLECTANCE).T)
    for form in ["matrix", "triplet"]:
        keys, d = setup(tmp_path, form)
        for light, (e, spp) in ILLUMINANTS.items():
            scene = PATCH.format(light=light, reflectance=REFLECTANCE, fluorescence=keys)
            got, error = render_xyz(prism, tmp_path, scene, spp)
            expected = xyz(bounce(d, r, e))
            assert_agrees(got, error, expected, f"{form} under {light}")
            # The fluorescent part is what the check is about: it must be
            # well outside the error bars (from 2% of Y under A to most of
            # it under the violet lamp).
            assert abs(xyz(e @ d)[1]) > 10 * error[1], f"{form} under {light}: fluorescence too faint to test"


FURNACE = """
[camera]
position = [0.1, -0.2, 0.05]
look_at = [0, 0, 1]
fov = 100

[film]
resolution = [16, 16]
colour_space = "xyz"

[integrator]
max_depth = {depth}

[materials.wall]
type = "fluorescent"
reflectance = {reflectance}
{fluorescence}

[[shape]]
type = "sphere"
radius = 1
tessellate = true
segments = 24
smooth = false
flip_normals = true
material = "wall"
emission = {{ blackbody = 6500, scale = 0.25 }}
"""


def test_fluorescent_light_on_fluorescent_walls_follows_the_neumann_series(prism, tmp_path):
    keys, d = setup(tmp_path, "matrix")
    r = np.interp(CELLS, *np.array(REFLECTANCE).T)
    kelvin = 6500
    planck = colour.colorimetry.planck_law(CELLS * 1e-9, kelvin)
    e = 0.25 * luminance_one(planck)
    # Two bounces: emission, fluorescent light, and that light on the
    # fluorescent wall again.
    two = e + bounce(d, r, e) + bounce(d, r, bounce(d, r, e))
    # Every bounce: (I - K)^-1 E.
    k = np.diag(r) + d.T
    every = np.linalg.solve(np.eye(len(CELLS)) - k, e)
    # The second bounce's fluorescence must matter at the test's precision:
    # the same without it (only reflected the second time).
    without = e + bounce(d, r, e) + r * bounce(d, r, e)
    for depth, spectrum, spp in [(2, two, 64), (100000, every, 64)]:
        scene = FURNACE.format(depth=depth, reflectance=REFLECTANCE, fluorescence=keys)
        got, error = render_xyz(prism, tmp_path, scene, spp)
        assert_agrees(got, error, xyz(spectrum), f"max_depth {depth}")
        if depth == 2:
            assert np.abs(xyz(two) - xyz(without)).max() > 10 * error.max()
