"""Times the tactile-image path with numpy + scipy.sparse + OpenCV on the tables that
`cargo bench -p skin-geom --bench tactile_image` wrote to target/bench-data: the same pixels, the
same taxel weights, the same frame, on one core.

    pip install numpy scipy opencv-python-headless
    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python3 bench/image_numpy.py [target/bench-data]

For each raster_RxC.bin: interpolation (sparse weights @ pressures) + 8-bit quantisation
(floor(255 K / max K)), then grey erosion (disk r=2) + dilation (disk r=4) with cv2.
"""

import glob
import json
import os
import statistics
import sys
import time

import cv2
import numpy as np
import scipy.sparse as sp


def disk(r: int) -> np.ndarray:
    y, x = np.mgrid[-r : r + 1, -r : r + 1]
    return (x * x + y * y <= r * r).astype(np.uint8)


def median_us(fn, repeats: int = 2000) -> float:
    for _ in range(50):
        fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e6 * statistics.median(times)


def main() -> None:
    cv2.setNumThreads(1)
    data = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "target", "bench-data")
    files = sorted(glob.glob(os.path.join(data, "raster_*.bin")))
    if not files:
        sys.exit(f"no raster tables in {data}: run `cargo bench -p skin-geom --bench tactile_image` first")
    results = {}
    for path in files:
        raw = np.fromfile(path, dtype=np.uint8)
        rows, cols, n = raw[:12].view(np.uint32)
        px = int(rows) * int(cols)
        idx = raw[12 : 12 + 12 * px].view(np.uint32).reshape(px, 3)
        w = raw[12 + 12 * px : 12 + 24 * px].view(np.float32).reshape(px, 3)
        p = raw[12 + 24 * px :].view(np.float32)
        assert len(p) == n
        weights = sp.csr_matrix((w.ravel(), (np.repeat(np.arange(px), 3), idx.ravel())), shape=(px, int(n)))
        weights.eliminate_zeros()
        e2, d4 = disk(2), disk(4)

        def interpolate_quantise():
            k = weights @ p
            return np.floor(255.0 * k / k.max()).clip(0, 255).astype(np.uint8).reshape(int(rows), int(cols))

        def with_morphology():
            return cv2.dilate(cv2.erode(interpolate_quantise(), e2), d4)

        a = median_us(interpolate_quantise)
        b = median_us(with_morphology)
        results[f"{int(rows)}x{int(cols)}"] = {"interpolate_quantise_us": a, "with_morphology_us": b}
        print(f"numpy/scipy {int(rows)} x {int(cols)} px, {int(n)} taxels: interpolate+quantise {a:8.1f} us, "
              f"+ cv2 erode/dilate {b:8.1f} us")


    with open(os.path.join(data, "numpy.json"), "w") as fh:
        json.dump(results, fh)


if __name__ == "__main__":
    main()
