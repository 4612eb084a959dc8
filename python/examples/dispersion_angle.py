"""The dispersion of an N-SF11 wedge measured from prism's spectral image,
against Snell's law with Schott's Sellmeier coefficients.

The camera looks through a thin glass wedge (10° apex) at a far, narrow
emitting strip. Each wavelength is bent by its own angle, so each spectral
bucket sees the strip at its own column. The example finds that column in
every bucket (the intensity-weighted centroid), and predicts it by tracing
the camera ray of each column through the two faces with Snell's law and
n(λ) from the Sellmeier equation, finding where it meets the strip.

    python python/examples/dispersion_angle.py
"""

import math
import tempfile
from pathlib import Path

import numpy as np

import prism

# Schott N-SF11: n² = 1 + Σ B·λ² / (λ² − C), λ in µm.
SELLMEIER_B = (1.73759695, 0.313747346, 1.89878101)
SELLMEIER_C = (0.013188707, 0.0623068142, 155.23629)

APEX = math.radians(10.0)   # the wedge's angle between its faces
FRONT_Z = 1.0               # the front face: the plane z = 1
THICKNESS = 0.1             # along the camera's axis
STRIP_Z = 2000.0            # the strip: far, narrow, tall
WIDTH, HEIGHT = 480, 6
FOV_V = 0.025               # degrees; horizontally 2°


def sellmeier(nm: np.ndarray) -> np.ndarray:
    l2 = (np.asarray(nm) / 1000.0) ** 2
    return np.sqrt(1 + sum(b * l2 / (l2 - c) for b, c in zip(SELLMEIER_B, SELLMEIER_C)))


def back_face_normal() -> np.ndarray:
    """Outward normal of the back face z = FRONT_Z + THICKNESS + x·tan(APEX)."""
    n = np.array([-math.tan(APEX), 0.0, 1.0])
    return n / np.linalg.norm(n)


def refract(d: np.ndarray, n: np.ndarray, eta: float) -> np.ndarray:
    """Snell's law: d (unit) through a surface of unit normal n facing d's
    side, with eta = n_from / n_to."""
    cos_i = -np.dot(n, d)
    sin2_t = eta * eta * (1 - cos_i * cos_i)
    return eta * d + (eta * cos_i - math.sqrt(1 - sin2_t)) * n


def camera_ray(column: float) -> np.ndarray:
    """The unit direction of the camera ray through `column` (continuous,
    pixel centres at .5) in the middle row."""
    tan_h = math.tan(math.radians(FOV_V) / 2) * WIDTH / HEIGHT
    s = (2 * column / WIDTH - 1) * tan_h
    d = np.array([-s, 0.0, 1.0])  # camera right is -x (looking along +z, up +y)
    return d / np.linalg.norm(d)


def deviation(column: float, target_x: float) -> float:
    """Degrees between the camera ray through `column` and the direction
    light leaves the wedge in to reach the strip (far: its direction)."""
    d = camera_ray(column)
    return math.degrees(math.atan2(target_x, STRIP_Z) - math.atan2(d[0], d[2]))


def strip_x(column: float, n_glass: float) -> float:
    """Where the camera ray through `column` meets the strip's plane, after
    both faces."""
    d = camera_ray(column)
    p = d * (FRONT_Z / d[2])
    d = refract(d, np.array([0.0, 0.0, -1.0]), 1.0 / n_glass)
    nb = back_face_normal()
    # The back face: nb · (q − q0) = 0 with q0 = (0, 0, FRONT_Z + THICKNESS).
    q0 = np.array([0.0, 0.0, FRONT_Z + THICKNESS])
    p = p + d * (np.dot(nb, q0 - p) / np.dot(nb, d))
    d = refract(d, -nb, n_glass)
    p = p + d * ((STRIP_Z - p[2]) / d[2])
    return float(p[0])


def predicted_column(n_glass: float, target_x: float) -> float:
    """The column whose ray meets the strip (bisection: x falls with column)."""
    lo, hi = 0.0, float(WIDTH)
    for _ in range(60):
        mid = (lo + hi) / 2
        if strip_x(mid, n_glass) > target_x:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2


def wedge_obj(path: Path) -> None:
    """A closed glass wedge, 1 × 1 across, faces wound outwards."""
    t = math.tan(APEX)
    z_back = lambda x: FRONT_Z + THICKNESS + x * t  # noqa: E731
    v = [(-.5, -.5, FRONT_Z), (.5, -.5, FRONT_Z), (.5, .5, FRONT_Z), (-.5, .5, FRONT_Z),
         (-.5, -.5, z_back(-.5)), (.5, -.5, z_back(.5)), (.5, .5, z_back(.5)), (-.5, .5, z_back(-.5))]
    faces = [(1, 4, 3, 2), (5, 6, 7, 8), (1, 2, 6, 5), (4, 8, 7, 3), (1, 5, 8, 4), (2, 3, 7, 6)]
    lines = [f"v {x} {y} {z}" for x, y, z in v] + ["f " + " ".join(map(str, f)) for f in faces]
    path.write_text("\n".join(lines) + "\n")


def main(spp: int = 1024) -> float:
    # The strip sits where 550 nm light through the middle column goes.
    target_x = strip_x(WIDTH / 2, float(sellmeier(550.0)))
    with tempfile.TemporaryDirectory() as folder:
        wedge_obj(Path(folder) / "wedge.obj")
        scene = prism.load({
            "camera": {"position": [0, 0, 0], "look_at": [0, 0, 1], "fov": FOV_V},
            "film": {"resolution": [WIDTH, HEIGHT], "spectral_range": [420, 700],
                     "spectral_buckets": 28},
            "integrator": {"max_depth": 8},
            "materials": {"sf11": {"type": "dielectric", "ior": "N-SF11"}},
            "shape": [
                {"type": "obj", "file": "wedge.obj", "material": "sf11"},
                # Wound to face the camera (emission leaves the front).
                {"type": "quad", "emission": "E",
                 "vertices": [[target_x - 0.02, 500, STRIP_Z], [target_x + 0.02, 500, STRIP_Z],
                              [target_x + 0.02, -500, STRIP_Z], [target_x - 0.02, -500, STRIP_Z]]},
            ],
        }, base_dir=folder)
        image = prism.render(scene, spp=spp, progress=False)
    profile = image.spectral.sum(axis=0)        # W × B: each bucket's light by column
    columns = np.arange(WIDTH) + 0.5
    errors = []
    print(" λ (nm)   n(λ)     column: measured   Snell     deviation (°): measured  Snell    error (px)")
    for b, nm in enumerate(image.wavelengths):
        weights = profile[:, b]
        measured = float((weights * columns).sum() / weights.sum())
        n = float(sellmeier(nm))
        predicted = predicted_column(n, target_x)
        errors.append(measured - predicted)
        print(f"{nm:7.1f}  {n:.5f}  {measured:17.2f}  {predicted:8.2f}  "
              f"{deviation(measured, target_x):24.4f}  {deviation(predicted, target_x):7.4f}  "
              f"{measured - predicted:+9.3f}")
    errors = np.array(errors)
    spread = predicted_column(float(sellmeier(image.wavelengths[0])), target_x) - \
        predicted_column(float(sellmeier(image.wavelengths[-1])), target_x)
    print(f"the spectrum spans {abs(spread):.1f} px; measured − Snell: RMS {np.sqrt((errors ** 2).mean()):.3f} px, "
          f"max {np.abs(errors).max():.3f} px ({np.abs(errors).max() * 2.0 / WIDTH * 3600:.1f} arcsec)")
    return float(np.abs(errors).max())


if __name__ == "__main__":
    main()
