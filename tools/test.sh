#!/usr/bin/env bash
# Runs every test of prism: the Rust suite (unit, rendering and CLI tests),
# the colour-science checks under tools/tests, and the Python package's
# tests and examples (python/). Sets up the Python environment on first
# use (tools/.venv, pinned requirements) and builds the Python package into
# it from the same release build.
set -euo pipefail
cd "$(dirname "$0")/.."

# The property-based fuzzers (tests/fuzz.rs) draw a few hundred cases each;
# a fixed seed makes a CI run reproducible. Fresh seeds and more cases:
# PROPTEST_CASES=100000 cargo test --release --test suite -- fuzz::
export PROPTEST_RNG_SEED="${PROPTEST_RNG_SEED:-20261122}"
# Optimised (Monte Carlo tests need the speed), in the release profile: the
# tests reuse every crate and the binary (target/release/prism, which the
# colour-science checks run) that the render command built, and link their
# one test crate (tests/suite.rs) once.
cargo test --release
export PRISM_BIN="${PRISM_BIN:-$PWD/target/release/prism}"

source tools/venv.sh
ensure_tools_venv
tools/.venv/bin/python -m pytest -q -c tools/pytest.ini tools/tests

# The Python package, as `pip install ./python` builds it (maturin, the
# release profile: it reuses the crates built above and links once more).
PATH="$PWD/tools/.venv/bin:$PATH" tools/.venv/bin/python -m pip install \
    --quiet --no-build-isolation --no-deps ./python
tools/.venv/bin/python -m pytest -q -c python/pytest.ini python/tests
