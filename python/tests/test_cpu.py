"""The native module is compiled for x86-64-v3: on an older CPU, `import
prism` raises ImportError naming what the CPU lacks, never SIGILL."""

import platform
import shutil
import subprocess
import sys

import pytest

import prism
from prism import _cpu


def test_this_cpu_lacks_nothing_the_module_uses():
    # The module imported (this file's `import prism`), so nothing is missing.
    assert _cpu.missing_features(prism._native.__file__) == []


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="x86-64 builds only")
def test_a_cpu_without_avx2_is_refused_with_a_message():
    qemu = shutil.which("qemu-x86_64")
    if qemu is None:
        pytest.skip("qemu-x86_64 not found (.ci/run installs qemu-user): no older CPU to emulate")
    # Sandy Bridge: AVX, but no AVX2, FMA or BMI; numpy's own baseline
    # (x86-64-v2) runs on it, so the refusal comes from prism alone.
    def run(cpu):
        return subprocess.run(
            [qemu, "-cpu", cpu, sys.executable, "-c", "import prism"],
            capture_output=True,
            text=True,
            timeout=600,
        )

    old = run("SandyBridge")
    assert old.returncode == 1, old.stderr  # an exception, not a signal
    last = old.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: this CPU lacks"), old.stderr
    for feature in ("avx2", "fma", "bmi2"):
        assert feature in last, last
    assert "avx," not in last and "sse4.2" not in last, last  # Sandy Bridge has those
    assert "target-cpu=native" in last, last
    # The same interpreter as a CPU with AVX2 imports it.
    new = run("Haswell")
    assert new.returncode == 0, new.stderr
