#!/usr/bin/env bash
# Runs every test of prism: the Rust suite (unit, rendering and CLI tests)
# and the colour-science checks under tools/tests. Sets up the Python
# environment for tools/ on first use (tools/.venv, pinned requirements).
set -euo pipefail
cd "$(dirname "$0")/.."

# The property-based fuzzers (tests/fuzz.rs) draw a few hundred cases each;
# a fixed seed makes a CI run reproducible. Fresh seeds and more cases:
# PROPTEST_CASES=100000 cargo test --release --test fuzz
export PROPTEST_RNG_SEED="${PROPTEST_RNG_SEED:-20261122}"
# Optimised (Monte Carlo tests need the speed), and in the release profile
# so that the binary the colour-science checks run is built once with it.
cargo test --release
cargo build --release

venv=tools/.venv
if [ ! -x "$venv/bin/python" ] || ! cmp -s tools/requirements.txt "$venv/.requirements"; then
    python3 -m venv "$venv"
    "$venv/bin/python" -m pip install --quiet --upgrade pip
    "$venv/bin/python" -m pip install --quiet -r tools/requirements.txt
    cp tools/requirements.txt "$venv/.requirements"
fi
"$venv/bin/python" -m pytest -q -c tools/pytest.ini tools/tests
