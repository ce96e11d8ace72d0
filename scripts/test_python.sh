#!/usr/bin/env bash
# The Python package's tests: build it into a virtualenv with `maturin develop` (it shares
# cargo's target folder, so after `cargo build` only the native module itself compiles), then
# run pytest on python/tests (the package's own tests) and examples/python (graph-evaluation
# tests as a user writes them). Run by tests/python.rs, so by `cargo test` and CI.
#   scripts/test_python.sh [pytest arguments…]     e.g. --update-golden, -k eval
set -euo pipefail
cd "$(dirname "$0")/.."
VENV="${TYNDALL_VENV:-target/python-venv}"
if [ ! -x "$VENV/bin/python" ]; then
  "${PYTHON:-python3}" -m venv "$VENV"
fi
VENV="$(cd "$VENV" && pwd)"
"$VENV/bin/python" -m pip install -q --disable-pip-version-check "maturin>=1.8,<2" "numpy>=1.21" "pytest>=7"
(cd python && VIRTUAL_ENV="$VENV" "$VENV/bin/maturin" develop -q)
export TYNDALL_BIN="${TYNDALL_BIN:-$PWD/target/debug/tyndall}"
# Any non-zero exit fails, pytest's 5 ("no tests collected") included.
"$VENV/bin/python" -m pytest -q -p no:cacheprovider python/tests examples/python "$@"
