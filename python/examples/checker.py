"""Where the ColorChecker's patches are in a render of scenes/colorchecker.toml
(shared by the examples that measure them)."""

import math

import numpy as np


def patch_centres(doc: dict, width: int, height: int) -> dict:
    """Raster (x, y) of every patch's centre, by material name, in the
    order of the scene's shapes (the camera looks along +z)."""
    cam = doc["camera"]
    tan = math.tan(math.radians(cam["fov"]) / 2)
    eye = np.array(cam["position"], dtype=float)
    centres = {}
    for shape in doc["shape"]:
        if shape["type"] != "quad":
            continue
        c = np.mean(np.array(shape["vertices"], dtype=float), axis=0) - eye
        sx, sy = -c[0] / c[2], c[1] / c[2]  # camera right is -x here
        centres[shape["material"]] = ((sx / (tan * width / height) + 1) * width / 2, (1 - sy / tan) * height / 2)
    return centres


def patch_mean(array: np.ndarray, centre: tuple, half: int = 5) -> np.ndarray:
    """The mean of a (2·half)² block of an H×W×C array around a centre."""
    x, y = int(centre[0]), int(centre[1])
    return array[y - half:y + half, x - half:x + half].reshape(-1, array.shape[-1]).mean(axis=0)
