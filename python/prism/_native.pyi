"""Type stubs of prism._native, the Rust extension behind `prism` (use the
`prism` module's functions: they wrap these)."""

from os import PathLike
from typing import Any, Callable, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

class SceneError(ValueError):
    """A scene that cannot be loaded; the message names the file, key and line."""

class RenderError(RuntimeError):
    """A render that cannot run as asked, or output that cannot be written."""

class NativeScene:
    text: str
    name: str
    base: str
    resolution: Tuple[int, int]
    spp: int
    seed: int
    integrator: str
    colour_space: str
    xyz_to_rgb: Sequence[Sequence[float]]
    observer: str
    white_balance: Optional[str]
    warnings: list[str]
    inputs: list[str]
    content_hash: str
    triangle_count: int
    light_count: int
    def reload(self, **overrides: Any) -> NativeScene: ...
    def shares_geometry(self, other: NativeScene) -> bool: ...

class NativeImage:
    width: int
    height: int
    xyz: Optional[npt.NDArray[np.float32]]
    rgb: Optional[npt.NDArray[np.float32]]
    spectral: Optional[npt.NDArray[np.float32]]
    wavelengths: list[float]
    bucket_edges: list[float]
    sample_count: Optional[npt.NDArray[np.uint64]]
    aovs: dict[str, npt.NDArray[np.float32]]
    attributes: dict[str, str]
    stats: dict[str, Any]
    interrupted: bool
    colour_space: Optional[str]
    def save(self, stem: Union[str, PathLike[str]]) -> None: ...

def load_file(path: Union[str, PathLike[str]], **overrides: Any) -> NativeScene: ...
def load_text(
    text: str,
    name: str,
    base: str,
    previous: Optional[NativeScene] = None,
    **overrides: Any,
) -> NativeScene: ...
def render(
    scene: NativeScene,
    spp: Optional[int] = None,
    samples: Optional[Tuple[int, int]] = None,
    seed: Optional[int] = None,
    threads: Optional[int] = None,
    time: Optional[float] = None,
    target_error: Optional[float] = None,
    adaptive: Optional[bool] = None,
    progress: Optional[Callable[[int, int, float], Any]] = None,
) -> NativeImage: ...
def spectrum_values(
    value: Any, wavelengths: Sequence[float], role: str = "emission", base: Optional[str] = None
) -> list[float]: ...
def read(path: Union[str, PathLike[str]]) -> NativeImage: ...
def to_toml(value: Any) -> str: ...
def parse_toml(text: str) -> dict[str, Any]: ...
