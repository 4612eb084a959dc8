import os
import pathlib
import subprocess
import sys
import warnings

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
# The examples import their shared helper (checker.py) by name.
sys.path.insert(0, str(ROOT / "python" / "examples"))
warnings.filterwarnings("ignore")


@pytest.fixture(scope="session")
def cli():
    """Runs the prism binary (PRISM_BIN, which tools/test.sh sets; else the release build)."""
    binary = os.environ.get("PRISM_BIN", str(ROOT / "target" / "release" / "prism"))

    def run(*args, check=True):
        result = subprocess.run([binary, *map(str, args)], cwd=ROOT, capture_output=True, text=True)
        if check:
            assert result.returncode == 0, result.stderr
        return result

    return run


@pytest.fixture(scope="session")
def cornell():
    import prism

    return prism.load(ROOT / "scenes" / "cornell-box.toml", resolution=(48, 32))
