#!/usr/bin/env bash
# The Python package's tests (python/tests): a venv in target/venv with maturin, numpy, pytest and
# ray from PyPI, the bindings built into it in the dev profile (`maturin develop`, the workspace's
# target/), the `heliar` binary the tests compare against, then pytest.
#   bash tools/pytest.sh [PYTEST ARGS...]
# HELIAR_FEATURES (default `opencv`, as the README's `cargo test --features opencv`, so the binary
# that command built is reused) sets the binary's features.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="$PWD/target/venv"
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
fi
"$venv/bin/python" -m pip install -q --disable-pip-version-check "maturin>=1.5,<2" numpy pytest "ray>=2.9"
features="${HELIAR_FEATURES-opencv}"
cargo build -q ${features:+--features "$features"} --bin heliar
VIRTUAL_ENV="$venv" PATH="$venv/bin:$PATH" maturin develop -q -m python/Cargo.toml
export HELIAR_BIN="$PWD/target/debug/heliar"
# One test session; its closing line is pytest's `N passed` (exit 5, no tests collected, fails).
"$venv/bin/python" -m pytest -q python/tests "$@"
