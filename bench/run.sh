#!/usr/bin/env bash
# Runs the Rust benchmarks and the reference implementations in the same run, then prints the
# BENCHMARKS.md rows. Needs: pip install libigl numpy scipy opencv-python-headless
set -euo pipefail
cd "$(dirname "$0")/.."
cargo bench -p skin-geom --bench lscm --bench tactile_image
cargo bench -p skin-learn --bench calibrate
cargo bench -p skin-learn --features onnx --bench touch_path
cargo bench -p skin-ros --features mcap,zenoh --bench publish
cargo bench -p skin-control --bench task_stack
# One thread for the references too, as for the Rust side.
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1
python3 bench/lscm_libigl.py
python3 bench/image_numpy.py
python3 bench/calibration_scipy.py
python3 bench/task_stack_numpy.py
python3 bench/table.py
