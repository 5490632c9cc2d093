"""Fits the taxels of the calibration benchmark's datasets with scipy.optimize.curve_fit, the way
skin-learn does (plane fit of each taxel's contacts, projection, 2D Gaussian of Eq. 7.2 from the
same start point, analytic Jacobian, Levenberg-Marquardt), on one core, and writes the times to target/bench-data/scipy_calibration.json.

    pip install numpy scipy
    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python3 bench/calibration_scipy.py [target/bench-data]

Run it after `cargo bench -p skin-learn --bench calibrate`, which writes the datasets.
"""

import csv
import json
import os
import sys
import time
import warnings
from collections import defaultdict

import numpy as np
from scipy.optimize import OptimizeWarning, curve_fit

MIN_RESPONSES = 8


def gaussian(x, b1, b2, b3, b4, b5):
    return b5 * np.exp(-((x[0] - b1) ** 2 / b3**2 + (x[1] - b2) ** 2 / b4**2))


def jacobian(x, b1, b2, b3, b4, b5):
    """Analytic derivatives, as skin-learn uses (finite differences stall at a start of exactly 0)."""
    d1, d2 = x[0] - b1, x[1] - b2
    g = np.exp(-(d1**2 / b3**2 + d2**2 / b4**2))
    return np.stack(
        [b5 * g * 2 * d1 / b3**2, b5 * g * 2 * d2 / b4**2, b5 * g * 2 * d1**2 / b3**3, b5 * g * 2 * d2**2 / b4**3, g],
        axis=1,
    )


def load(path):
    samples = defaultdict(lambda: ([], []))
    with open(path) as f:
        for row in csv.DictReader(f):
            r = float(row["response"])
            if r != 0.0:
                pts, ts = samples[int(row["taxel"])]
                pts.append((float(row["x_m"]), float(row["y_m"]), float(row["z_m"])))
                ts.append(r)
    return {k: (np.array(p), np.array(t)) for k, (p, t) in samples.items()}


def fit_all(samples):
    fitted = 0
    for points, ts in samples.values():
        if len(ts) < MIN_RESPONSES:
            continue
        mean = points.mean(axis=0)
        _, _, vt = np.linalg.svd(points - mean)
        xs = (points - mean) @ vt[:2].T * 1e3  # mm in the plane
        t = ts / ts.max()
        sigma = np.sqrt(xs.var(axis=0).max())
        p0 = [xs[:, 0].mean(), xs[:, 1].mean(), sigma, sigma, 1.0]
        try:
            curve_fit(gaussian, xs.T, t, p0=p0, jac=jacobian, maxfev=2000)
            fitted += 1
        except (RuntimeError, ValueError, OptimizeWarning):
            pass
    return fitted


def main():
    folder = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "target", "bench-data")
    warnings.simplefilter("error", OptimizeWarning)
    out = {}
    for name in ["hex", "arm_2000", "arm_20000"]:
        samples = load(os.path.join(folder, f"calibration_{name}.csv"))
        fit_all(samples)  # warm-up
        times = []
        for _ in range(5 if name != "arm_20000" else 2):
            t0 = time.perf_counter()
            fitted = fit_all(samples)
            times.append(time.perf_counter() - t0)
        out[name] = {"ms": 1e3 * min(times), "fitted": fitted, "taxels": len(samples)}
        print(f"{name}: {out[name]['ms']:.1f} ms, {fitted} of {len(samples)} taxels fitted")
    with open(os.path.join(folder, "scipy_calibration.json"), "w") as f:
        json.dump(out, f, indent=1)


if __name__ == "__main__":
    main()
