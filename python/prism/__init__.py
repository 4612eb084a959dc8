"""prism, a spectral physically based renderer, from Python.

Load a scene from a TOML file, TOML text or a dict of the same shape, render
it with the GIL released, and get the film as numpy arrays::

    import prism
    scene = prism.load("scenes/cornell-box.toml", resolution=(128, 128))
    image = prism.render(scene, spp=64)
    image.xyz          # H×W×3 float32, CIE XYZ of the film's observer
    image.spectral     # H×W×B float32, spectral radiance per nm
    image.save("out/cornell")   # .exr, .png, .spectral.exr as `prism render`

Change a scene without loading it again (what is unchanged is shared)::

    under_a = scene.with_updates({"film.white_balance": "A"})

Spectra can be given as numpy pairs ``(wavelengths, values)`` or as
colour-science ``SpectralDistribution`` objects anywhere a scene takes one.
"""

from __future__ import annotations

from ._cpu import refuse_an_unfit_cpu

# Before anything of the native module runs: on a CPU without AVX2 it
# would stop with SIGILL at its first instruction of x86-64-v3.
refuse_an_unfit_cpu()

import math
import os
import sys
import time as _time
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _native
from ._native import RenderError, SceneError, __version__

__all__ = [
    "Image",
    "RenderError",
    "Scene",
    "SceneError",
    "load",
    "read",
    "render",
    "spectrum",
    "__version__",
]

#: Keyword arguments of `load` and `Scene.with_overrides`, as the command
#: line's flags of the same names.
OVERRIDES = (
    "resolution",
    "integrator",
    "spectral_range",
    "spectral_buckets",
    "spectral",
    "exposure",
    "tonemap",
    "gamut",
    "strategy",
    "split",
)


def _is_spectral_distribution(value: Any) -> bool:
    """A colour-science SpectralDistribution (or anything shaped like one)."""
    return (
        not isinstance(value, (dict, list, tuple, str))
        and hasattr(value, "wavelengths")
        and hasattr(value, "values")
    )


def _spectrum_rows(wavelengths: Any, values: Any) -> list:
    wavelengths = np.asarray(wavelengths, dtype=np.float64).ravel()
    values = np.asarray(values, dtype=np.float64)
    if values.ndim != 1 or values.shape != wavelengths.shape:
        raise SceneError(
            f"a spectrum's wavelengths ({wavelengths.shape[0]}) and values "
            f"({values.shape}) must be two equal 1-D arrays"
        )
    return np.column_stack([wavelengths, values]).tolist()


def _normalise(value: Any) -> Any:
    """Turns the spectra of a scene dict into the table form TOML holds:
    ``(wavelengths, values)`` tuples of numpy arrays and colour-science
    distributions become ``[[nm, value], ...]``."""
    if isinstance(value, Mapping):
        return {k: _normalise(v) for k, v in value.items()}
    if (
        isinstance(value, tuple)
        and len(value) == 2
        and all(isinstance(x, np.ndarray) and x.ndim == 1 for x in value)
    ):
        return _spectrum_rows(value[0], value[1])
    if _is_spectral_distribution(value):
        return _spectrum_rows(value.wavelengths, value.values)
    if isinstance(value, (list, tuple)):
        return [_normalise(v) for v in value]
    return value


def _checked_overrides(overrides: Mapping[str, Any]) -> dict:
    """The overrides, with pairs given as lists or arrays made tuples."""
    unknown = sorted(set(overrides) - set(OVERRIDES))
    if unknown:
        raise TypeError(
            f"unknown override {unknown[0]!r}: the overrides are {', '.join(OVERRIDES)}; "
            "change other values with Scene.with_updates"
        )
    out = dict(overrides)
    for key in ("resolution", "spectral_range"):
        if out.get(key) is not None and not isinstance(out[key], tuple):
            out[key] = tuple(np.asarray(out[key]).tolist())
    return out


def _looks_like_toml(text: str) -> bool:
    return "\n" in text or "=" in text or text.lstrip().startswith("[")


def load(
    source: Union[str, os.PathLike, Mapping[str, Any]],
    *,
    base_dir: Union[str, os.PathLike, None] = None,
    **overrides: Any,
) -> "Scene":
    """Loads a scene.

    ``source`` is a path to a TOML scene file, a dict of the same shape
    (what ``tomllib.load`` returns: a file and its dict load the same
    scene), or TOML text. Relative asset paths start at the file's folder,
    or at ``base_dir`` (default: the working directory) for dicts and text.

    ``overrides`` are the command line's: ``resolution=(w, h)``,
    ``integrator="bdpt"``, ``spectral_range=(380, 780)``,
    ``spectral_buckets=40``, ``spectral=False``, ``exposure=1.0``,
    ``tonemap``, ``gamut``, ``strategy``, ``split``. They pass the same
    checks as the file's values.

    Raises `SceneError` (a ValueError) with the command line's message,
    naming the file, line and key at fault.
    """
    overrides = _checked_overrides(overrides)
    if isinstance(source, Mapping):
        text = _native.to_toml(_normalise(source))
        base = Path(base_dir) if base_dir is not None else Path.cwd()
        return Scene(_native.load_text(text, "<dict>", str(base), **overrides))
    if isinstance(source, str) and _looks_like_toml(source) and not os.path.exists(source):
        base = Path(base_dir) if base_dir is not None else Path.cwd()
        return Scene(_native.load_text(source, "<text>", str(base), **overrides))
    if isinstance(source, (str, os.PathLike)):
        if base_dir is not None:
            raise TypeError("base_dir is for dicts and text: a file's paths start at its folder")
        return Scene(_native.load_file(os.fspath(source), **overrides))
    raise TypeError(
        f"a scene is a path, a dict or TOML text, not a {type(source).__name__}"
    )


def _set_dotted(doc: dict, key: str, value: Any) -> None:
    """Sets ``doc[a][b]...`` for the key "a.b..." (``shape[2].material``
    indexes an array of tables). None removes the key."""
    parts: list = []
    for token in key.split("."):
        name, _, rest = token.partition("[")
        if name:
            parts.append(name)
        while rest:
            index, _, rest = rest.partition("]")
            try:
                parts.append(int(index))
            except ValueError:
                raise SceneError(f"`{key}`: [{index}] is not an index") from None
            rest = rest.lstrip("[")
    if not parts:
        raise SceneError("an update needs a key")
    node: Any = doc
    for i, part in enumerate(parts[:-1]):
        nxt = parts[i + 1]
        if isinstance(part, int):
            if not isinstance(node, list) or not -len(node) <= part < len(node):
                raise SceneError(f"`{key}`: there is no [{part}]")
            node = node[part]
        else:
            if not isinstance(node, dict):
                raise SceneError(f"`{key}`: `{part}` is not in a table")
            if part not in node:
                if isinstance(nxt, int):
                    raise SceneError(f"`{key}`: there is no `{part}` to index")
                node[part] = {}
            node = node[part]
    last = parts[-1]
    if isinstance(last, int):
        if not isinstance(node, list) or not -len(node) <= last < len(node):
            raise SceneError(f"`{key}`: there is no [{last}]")
        node[last] = value
    elif value is None:
        if isinstance(node, dict):
            node.pop(last, None)
    else:
        if not isinstance(node, dict):
            raise SceneError(f"`{key}`: `{last}` is not in a table")
        node[last] = value


class Scene:
    """A loaded scene. Scenes do not change: `with_updates` and
    `with_overrides` return new scenes that share what did not change
    (meshes and their BVH when the shapes are the same)."""

    def __init__(self, native: "_native.NativeScene"):
        """Made by `load`, `Scene.with_updates` and `Scene.with_overrides`."""
        self._native = native

    # What the scene is.
    @property
    def resolution(self) -> Tuple[int, int]:
        """The film's (width, height) in pixels."""
        return self._native.resolution

    @property
    def spp(self) -> int:
        """Samples per pixel the scene asks for (`film.spp`)."""
        return self._native.spp

    @property
    def seed(self) -> int:
        """The scene's seed (`film.seed`)."""
        return self._native.seed

    @property
    def integrator(self) -> str:
        """The integrator's name: path, bdpt, sppm, light, ..."""
        return self._native.integrator

    @property
    def colour_space(self) -> str:
        """The colour space of `Image.rgb` and the EXRs (`film.colour_space`)."""
        return self._native.colour_space

    @property
    def xyz_to_rgb(self) -> np.ndarray:
        """The 3×3 matrix from the film's XYZ to its RGB (colour space and
        white balance): ``image.rgb == image.xyz @ scene.xyz_to_rgb.T``."""
        return np.array(self._native.xyz_to_rgb, dtype=np.float64)

    @property
    def observer(self) -> str:
        """The colour-matching functions of `Image.xyz` (`film.observer`)."""
        return self._native.observer

    @property
    def white_balance(self) -> Optional[str]:
        """`film.white_balance` as written, or None."""
        return self._native.white_balance

    @property
    def warnings(self) -> list:
        """What loading warned about (the command line prints these)."""
        return list(self._native.warnings)

    @property
    def inputs(self) -> list:
        """Every file the scene was loaded from, the scene first."""
        return [Path(p) for p in self._native.inputs]

    @property
    def content_hash(self) -> str:
        """Identifies the scene and every file it read, by content."""
        return self._native.content_hash

    @property
    def triangle_count(self) -> int:
        """Triangles in the scene's BVH (degenerate ones dropped)."""
        return self._native.triangle_count

    @property
    def light_count(self) -> int:
        """Lights: one per emitting triangle or sphere, and every other light."""
        return self._native.light_count

    @property
    def path(self) -> Optional[Path]:
        """The scene file, or None for a scene from a dict or text."""
        name = str(self._native.name)
        return None if name.startswith("<") else Path(name)

    def to_dict(self) -> dict:
        """The scene as a dict (what ``tomllib.load`` gives for its TOML)."""
        return _native.parse_toml(self._native.text)

    def to_toml(self) -> str:
        """The scene's TOML text."""
        return self._native.text

    def shares_geometry(self, other: "Scene") -> bool:
        """Whether ``other`` uses this scene's built meshes and BVH."""
        return self._native.shares_geometry(other._native)

    def with_updates(self, updates: Optional[Mapping[str, Any]] = None, **more: Any) -> "Scene":
        """A scene with some values replaced, keyed by dotted paths:
        ``{"materials.patch.reflectance": (wl, values),
        "film.white_balance": "A", "shape[1].emission": "FL11"}``. A value
        of None removes the key. Keyword arguments are top-level keys.

        Only what changed is built again: when the shapes (``[[shape]]``,
        ``[spectra]``, ``units`` and the material names) are unchanged,
        meshes are not read again and the BVH is shared. Files on disk are
        not read again then: load the scene anew after editing a mesh.
        """
        doc = self.to_dict()
        for key, value in {**(updates or {}), **more}.items():
            _set_dotted(doc, key, _normalise(value))
        text = _native.to_toml(doc)
        native = self._native
        name = str(native.name)
        if not name.startswith("<"):
            name = f"<{name}, updated>"
        return Scene(_native.load_text(text, name, str(native.base), previous=native))

    def with_overrides(self, **overrides: Any) -> "Scene":
        """The scene loaded with other command-line overrides (see `load`);
        its geometry is shared."""
        return Scene(self._native.reload(**_checked_overrides(overrides)))

    def __repr__(self) -> str:
        w, h = self.resolution
        where = self.path or "<dict or text>"
        return (
            f"<prism.Scene {where}: {w}x{h}, {self.spp} spp, {self.integrator}, "
            f"{self.triangle_count} triangles, {self.light_count} lights>"
        )


class _ProgressBar:
    """A bar on stderr, drawn at most ten times a second (a line every
    five seconds where stderr is not a terminal)."""

    def __init__(self) -> None:
        self.tty = sys.stderr.isatty()
        self.last = 0.0
        self.drawn = False

    def __call__(self, done: int, total: int, elapsed: float) -> None:
        now = _time.monotonic()
        finished = total > 0 and done >= total
        if not finished and now - self.last < (0.1 if self.tty else 5.0):
            return
        self.last = now
        fraction = done / total if total else 0.0
        rate = done / elapsed if elapsed > 0 else 0.0
        eta = (total - done) / rate if rate > 0 else math.inf
        eta_text = f"{eta:.0f} s" if math.isfinite(eta) else "?"
        text = (
            f"{100 * fraction:5.1f}% {done}/{total} samples  "
            f"{rate / 1e6:.2f} M samples/s  {elapsed:.1f} s  ETA {eta_text}"
        )
        if self.tty:
            width = 30
            filled = int(width * fraction)
            sys.stderr.write(f"\r[{'#' * filled}{' ' * (width - filled)}] {text}")
        else:
            sys.stderr.write(f"progress: {text}\n")
        sys.stderr.flush()
        self.drawn = True

    def close(self) -> None:
        if self.drawn and self.tty:
            sys.stderr.write("\n")
            sys.stderr.flush()


def render(
    scene: Scene,
    spp: Optional[int] = None,
    integrator: Optional[str] = None,
    seed: Optional[int] = None,
    resolution: Optional[Tuple[int, int]] = None,
    threads: Optional[int] = None,
    time: Optional[float] = None,
    target_error: Optional[float] = None,
    samples: Union[range, Tuple[int, int], None] = None,
    adaptive: Optional[bool] = None,
    progress: Union[bool, Callable[[float, dict], Any]] = True,
) -> "Image":
    """Renders a scene and returns the `Image`.

    - ``spp``: samples per pixel (default: the scene's ``film.spp``);
      ``samples``: exactly these sample indices of every pixel, a
      ``range`` or ``(first, end)``, for renders split across machines.
    - ``integrator``, ``resolution``: as `load`'s overrides (the scene is
      loaded again with them; its geometry is shared).
    - ``seed``, ``threads`` (default: every core).
    - ``time``: stop after the pass during which this many seconds passed;
      ``target_error``: stop once the estimated relative MSE is below it.
    - ``adaptive``: spend the samples where a pilot finds the error high
      (True), or the same in every pixel (False). Default: the scene's
      ``film.sampling`` (uniform where it says nothing),
      except with ``samples`` (a part of a render) or ``target_error``,
      which sample uniformly and warn (``UserWarning``) that they do.
    - ``progress``: True (a bar on stderr), False, or a callable
      ``progress(fraction, info)`` with info's ``done``, ``total``,
      ``elapsed`` (seconds) and ``rate`` (samples a second).

    The GIL is released while rendering. Ctrl-C stops the render after the
    pass under way and returns the image with ``interrupted`` set; every
    pixel then has the same samples, as on the command line.
    Raises `RenderError` when the render cannot run as asked.
    """
    if not isinstance(scene, Scene):
        raise TypeError(f"render takes a prism.Scene (from prism.load), not a {type(scene).__name__}")
    reload = {k: v for k, v in (("integrator", integrator), ("resolution", resolution)) if v is not None}
    if reload:
        scene = scene.with_overrides(**reload)
    if isinstance(samples, range):
        if samples.step != 1:
            raise RenderError("samples must be a range with step 1")
        samples = (samples.start, samples.stop)
    elif samples is not None:
        samples = tuple(samples)
    bar = None
    callback = None
    if progress is True:
        bar = _ProgressBar()
        callback = bar
    elif callable(progress):
        user = progress

        def callback(done: int, total: int, elapsed: float) -> None:
            user(
                done / total if total else 0.0,
                {"done": done, "total": total, "elapsed": elapsed,
                 "rate": done / elapsed if elapsed > 0 else 0.0},
            )
    elif progress is not False and progress is not None:
        raise TypeError("progress is True, False or a callable(fraction, info)")
    try:
        native = _native.render(
            scene._native,
            spp=spp,
            samples=samples,
            seed=seed,
            threads=threads,
            time=time,
            target_error=target_error,
            adaptive=adaptive,
            progress=callback,
        )
    finally:
        if bar is not None:
            bar.close()
    return Image(native)


class Image:
    """A rendered image (or one read back with `read`), as numpy arrays.

    Arrays are made once, on first use, from a copy of the film.
    """

    def __init__(self, native: "_native.NativeImage"):
        """Made by `render` and `read`."""
        self._native = native
        self._cache: dict = {}

    def _array(self, name: str) -> Optional[np.ndarray]:
        if name not in self._cache:
            self._cache[name] = getattr(self._native, name)
        return self._cache[name]

    @property
    def xyz(self) -> Optional[np.ndarray]:
        """CIE XYZ of every pixel (the film's observer), H×W×3 float32."""
        return self._array("xyz")

    @property
    def rgb(self) -> Optional[np.ndarray]:
        """Linear RGB in the film's colour space with its white balance
        (what NAME.exr holds), H×W×3 float32."""
        return self._array("rgb")

    @property
    def spectral(self) -> Optional[np.ndarray]:
        """Mean spectral radiance of each bucket, per nm, H×W×B float32."""
        return self._array("spectral")

    @property
    def sample_count(self) -> Optional[np.ndarray]:
        """Samples each pixel took, H×W uint64."""
        return self._array("sample_count")

    @property
    def wavelengths(self) -> np.ndarray:
        """The buckets' centre wavelengths, nm."""
        return np.asarray(self._native.wavelengths)

    @property
    def bucket_edges(self) -> np.ndarray:
        """The buckets' edges, nm (one more than the buckets)."""
        return np.asarray(self._native.bucket_edges)

    @property
    def aovs(self) -> dict:
        """The film's AOVs by name (``film.aovs``): albedo, normal, depth."""
        if "aovs" not in self._cache:
            self._cache["aovs"] = dict(self._native.aovs)
        return self._cache["aovs"]

    @property
    def width(self) -> int:
        """Pixels across."""
        return self._native.width

    @property
    def height(self) -> int:
        """Pixels down."""
        return self._native.height

    @property
    def interrupted(self) -> bool:
        """True when the render stopped before every sample was taken
        (Ctrl-C, a time budget, an error target)."""
        return self._native.interrupted

    @property
    def metadata(self) -> dict:
        """What made the image: integrator, seed, samples (the sample
        indices, first and end), spp (samples every pixel has),
        samples_taken, colour_space, observer, white_balance, scene,
        scene_hash, interrupted, and for a render stop, seconds, rays,
        non_finite, estimated_rel_mse; the spectral EXR's header attributes
        under "attributes"."""
        a = self._native.attributes
        stats = dict(self._native.stats)
        first, _, end = a.get("prismSampleRange", "").partition("..")
        white = a.get("prismWhiteBalance")
        meta = {
            "integrator": a.get("prismIntegrator"),
            "seed": int(a["prismSeed"]) if "prismSeed" in a else None,
            "samples": (int(first), int(end)) if end else None,
            "spp": stats.pop("spp", None),
            "samples_taken": stats.pop("samples", None),
            "colour_space": self._native.colour_space,
            "observer": a.get("prismObserver"),
            "white_balance": None if white in (None, "none") else white,
            "scene": a.get("prismScene"),
            "scene_hash": a.get("prismSceneHash"),
            "interrupted": self.interrupted,
            "attributes": dict(a),
        }
        meta.update(stats)
        return meta

    def save(self, path: Union[str, os.PathLike]) -> None:
        """Writes PATH.exr, PATH.png and PATH.spectral.exr (as the film
        asks) as one set: byte for byte what `prism render` writes for the
        same render. A trailing .exr, .png or .spectral.exr is dropped."""
        stem = os.fspath(path)
        for ext in (".spectral.exr", ".exr", ".png"):
            if stem.endswith(ext):
                stem = stem[: -len(ext)]
                break
        self._native.save(stem)

    def to_colour(self, pixel: Optional[Tuple[int, int]] = None, pixels: Optional[Sequence[Tuple[int, int]]] = None):
        """The spectra as colour-science objects (colour-science must be
        installed): the image's mean spectrum, or ``pixel=(x, y)``'s, as a
        ``SpectralDistribution``; ``pixels=[(x, y), ...]`` as a
        ``MultiSpectralDistributions`` with a column per pixel."""
        try:
            import colour
        except ImportError as e:
            raise ImportError(
                "Image.to_colour needs colour-science: pip install colour-science"
            ) from e
        cube = self.spectral
        if cube is None:
            raise RenderError("the image has no spectral buckets")
        domain = self.wavelengths
        if pixels is not None:
            data = np.stack([cube[y, x] for x, y in pixels], axis=1).astype(np.float64)
            labels = [f"{x},{y}" for x, y in pixels]
            return colour.MultiSpectralDistributions(data, domain, labels=labels)
        if pixel is not None:
            x, y = pixel
            return colour.SpectralDistribution(cube[y, x].astype(np.float64), domain, name=f"pixel {x},{y}")
        mean = cube.reshape(-1, cube.shape[-1]).mean(axis=0, dtype=np.float64)
        return colour.SpectralDistribution(mean, domain, name="image mean")

    def __repr__(self) -> str:
        m = self.metadata
        state = " (interrupted)" if self.interrupted else ""
        return (
            f"<prism.Image {self.width}x{self.height}, {len(self.wavelengths)} buckets, "
            f"{m.get('integrator')}, spp {m.get('spp')}{state}>"
        )


def read(path: Union[str, os.PathLike]) -> Image:
    """Reads a prism EXR or spectral EXR (any Fichet 2021 spectral EXR)
    back into an `Image`. ``xyz`` comes back where the file says how its
    RGB was made (prism's EXRs and spectral EXRs do); ``spectral`` where it
    has spectral channels."""
    return Image(_native.read(os.fspath(path)))


#: The wavelengths `spectrum` evaluates at by default: 360–830 nm, 1 nm.
DEFAULT_WAVELENGTHS = np.arange(360.0, 831.0)


def spectrum(
    value: Any,
    wavelengths: Optional[Sequence[float]] = None,
    role: str = "emission",
    base_dir: Union[str, os.PathLike, None] = None,
) -> Tuple[np.ndarray, np.ndarray]:
    """A spectrum as prism sees it: ``(wavelengths, values)``.

    ``value`` is what a scene takes: a name ("D65", "A", "FL11", ...), a
    number, ``[[nm, value], ...]``, ``{"blackbody": 2856}``,
    ``{"rgb": [r, g, b]}``, ``{"file": "x.csv"}``, a numpy pair or a
    colour-science distribution. ``role`` is "emission" (illuminants are
    normalised to luminance 1), "reflectance" or "unbounded".
    """
    wl = DEFAULT_WAVELENGTHS if wavelengths is None else np.asarray(wavelengths, dtype=np.float64)
    values = _native.spectrum_values(
        _normalise(value),
        wl.astype(np.float32).tolist(),
        role=role,
        base=None if base_dir is None else os.fspath(base_dir),
    )
    return wl, np.asarray(values, dtype=np.float64)
