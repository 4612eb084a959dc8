#!/usr/bin/env bash
# Runs every test of prism: the Rust suite (unit, rendering and CLI tests)
# and the colour-science checks under tools/tests. Sets up the Python
# environment for tools/ on first use (tools/.venv, pinned requirements).
set -euo pipefail
cd "$(dirname "$0")/.."

# The property-based fuzzers (tests/fuzz.rs) draw a few hundred cases each;
# a fixed seed makes a CI run reproducible. Fresh seeds and more cases:
# PROPTEST_CASES=100000 cargo test --profile suite --test fuzz
export PROPTEST_RNG_SEED="${PROPTEST_RNG_SEED:-20261122}"
# Optimised (Monte Carlo tests need the speed), in the `suite` profile (the
# release optimisations without its slow whole-program link): building the
# tests also builds target/suite/prism, the binary the colour-science
# checks run, so nothing is compiled twice.
cargo test --profile suite
export PRISM_BIN="${PRISM_BIN:-$PWD/target/suite/prism}"

source tools/venv.sh
ensure_tools_venv
tools/.venv/bin/python -m pytest -q -c tools/pytest.ini tools/tests
