#!/usr/bin/env bash
# The Python package's benchmarks, each beside its Rust figure in the same run (BENCHMARKS.md,
# "From Python"): the package built in release mode into target/py-bench-venv, the Rust benches that
# write the shared inputs, then the Python side. scipy for the numpy reference.
set -euo pipefail
cd "$(dirname "$0")/../.."
# A venv of its own: the test suite's (target/py-venv) holds the test build of the package.
venv=target/py-bench-venv
[ -x "$venv/bin/python" ] || python3 -m venv "$venv"
"$venv/bin/python" -m pip install --quiet --disable-pip-version-check maturin numpy scipy
(cd python && VIRTUAL_ENV="$PWD/../$venv" PATH="$PWD/../$venv/bin:$PATH" maturin develop --release --quiet)
cargo bench -p skin-learn --bench session_push
cargo bench -p skin-geom --bench tactile_image
OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 "$venv/bin/python" python/bench/session_push.py
OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 "$venv/bin/python" python/bench/image.py
