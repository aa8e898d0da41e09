#!/usr/bin/env bash
# Builds the Python package (an abi3 wheel, maturin) into a virtual environment under target/
# and runs its tests against the `rom` binary of the same build. Needs python3 and the
# package registries (PyPI: maturin, numpy, pytest, and FMPy, the FMI importer the FMU tests
# drive `rom export-fmu`'s FMUs with). Run from anywhere; after
# `cargo test --release --workspace --tests` (as `.ci/run` does) it compiles only PyO3 and the binding:
# the binding's crate names the features the test build switches on (python/Cargo.toml), and
# `rom` is the test build's own binary (a `cargo build --bin rom` would resolve features
# without the dev-dependencies and compile faer, ndarray and the beltwin crates again).
set -euo pipefail
cd "$(dirname "$0")/.."
venv=target/py-venv
mkdir -p target
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/pip" install -q --disable-pip-version-check "maturin>=1.5,<2" "numpy>=1.21" pytest \
    "fmpy>=0.3.20,<0.4"
# `--deps`: only the environment and its packages (.ci/run fetches them while Rust compiles).
[ "${1:-}" = "--deps" ] && exit 0
rm -rf target/wheels
(cd python && "../$venv/bin/maturin" build --release --quiet -o ../target/wheels)
"$venv/bin/pip" install -q --disable-pip-version-check --force-reinstall --no-deps target/wheels/beltwin-*.whl
cargo test --release --workspace --tests --no-run --quiet
BELTWIN_ROM="${CARGO_TARGET_DIR:-$PWD/target}/release/rom" "$venv/bin/python" -m pytest -q python/tests
