#!/usr/bin/env bash
# Runs every test of prism: the Rust suite (unit, rendering and CLI tests)
# and the colour-science checks under tools/tests. Sets up the Python
# environment for tools/ on first use (tools/.venv, pinned requirements).
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
