"""Whether this CPU can run the native module, asked before it is imported.

The module is compiled for x86-64-v3 (AVX2, FMA, BMI2), as the command line
is; a CPU without them would stop the interpreter with SIGILL at the
module's first such instruction. Two exported C functions of the module,
which take only CPUID and integer code, say which features the build uses
that the CPU lacks; ctypes calls them without running the module's
initialisation.
"""

from __future__ import annotations

import ctypes
import importlib.util
from typing import List


def missing_features(library_path: str) -> List[str]:
    """The CPU features the native module at `library_path` was compiled to
    use and this CPU lacks (empty where it can run)."""
    lib = ctypes.CDLL(library_path)
    lib.prism_cpu_lacks.restype = ctypes.c_uint32
    lib.prism_cpu_feature_name.restype = ctypes.c_void_p
    lib.prism_cpu_feature_name.argtypes = [ctypes.c_uint32, ctypes.POINTER(ctypes.c_size_t)]
    mask = lib.prism_cpu_lacks()
    names = []
    k = 0
    length = ctypes.c_size_t()
    while True:
        pointer = lib.prism_cpu_feature_name(k, ctypes.byref(length))
        if not pointer:
            break
        if mask & (1 << k):
            names.append(ctypes.string_at(pointer, length.value).decode())
        k += 1
    return names


def refuse_an_unfit_cpu() -> None:
    """Raises ImportError, naming the missing features and how to build for
    this CPU, where the native module cannot run on it."""
    spec = importlib.util.find_spec("prism._native")
    if spec is None or spec.origin is None:
        return  # not built: the import that follows says so
    missing = missing_features(spec.origin)
    if missing:
        raise ImportError(
            f"this CPU lacks {', '.join(missing)}, which prism's native module "
            f"({spec.origin}) was compiled to use everywhere; build it for this CPU: "
            "RUSTFLAGS=\"-C target-cpu=native\" pip install ./python"
        )
