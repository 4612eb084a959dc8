import os
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tools"))


@pytest.fixture(scope="session")
def prism():
    """Runs the prism binary (PRISM_BIN, which tools/test.sh sets to the build it makes; else the release build)."""
    binary = os.environ.get("PRISM_BIN", str(ROOT / "target" / "release" / "prism"))
    if not pathlib.Path(binary).exists():
        pytest.fail(f"{binary} is missing: run `cargo build --release` (tools/test.sh does)")

    def run(*args):
        result = subprocess.run([binary, *map(str, args)], cwd=ROOT, capture_output=True, text=True)
        assert result.returncode == 0, result.stderr
        return result

    return run
