"""Imaging 1,000 frames of 3,465 taxels from Python, against the Rust bench and numpy/scipy.

    cargo bench -p skin-geom --bench tactile_image      # the Rust figure, the link, the tables
    pip install scipy
    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 python python/bench/image.py

On the link of skin-geom's `tactile_image` bench (3,465 taxels, 1 mm grid, 242 x 358 px):
`skin.Imager(map).images(frames)` on 1,000 frames (the bench's frame, each scaled differently),
one core, into a new array and into one given with `out=`; the Rust bench's "interpolate+quantise" median (criterion) times 1,000; and the numpy
reference of bench/image_numpy.py (scipy.sparse weights @ pressures, then floor(255 K / max K)),
frame by frame and as one (pixels x 1000) product, the faster of the two kept.
"""

import json
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import scipy.sparse as sp

import skin

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "target" / "bench-data"
FRAMES = 1000


def best_of(fn, repeats: int = 7) -> float:
    fn()
    laps = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        laps.append(time.perf_counter() - t0)
    return statistics.median(laps)


def tables(rows: int, cols: int):
    raw = np.fromfile(DATA / f"raster_{rows}x{cols}.bin", dtype=np.uint8)
    r, c, n = raw[:12].view(np.uint32)
    px = int(r) * int(c)
    idx = raw[12 : 12 + 12 * px].view(np.uint32).reshape(px, 3)
    rest = raw[12 + 12 * px :].view(np.float32)
    w, p = rest[: 3 * px].reshape(px, 3), rest[3 * px :]
    weights = sp.csr_matrix((w.ravel(), (np.repeat(np.arange(px), 3), idx.ravel())), shape=(px, int(n)))
    return weights, p, (int(r), int(c))


def main() -> None:
    layout_path = DATA / "arm3465.json"
    if not layout_path.exists():
        sys.exit(f"no {layout_path}: run `cargo bench -p skin-geom --bench tactile_image` first")
    tmap = skin.flatten(skin.read_layout(layout_path)[0])
    imager = skin.Imager(tmap)
    rows, cols = imager.size
    name = f"raster_{rows}x{cols}.bin"
    if not (DATA / name).exists():
        sys.exit(f"no {DATA / name} (the map's grid differs from the Rust bench's?)")
    weights, frame, _ = tables(rows, cols)
    assert frame.size == len(tmap), (frame.size, len(tmap))
    frames = np.outer(1.0 + np.arange(FRAMES) / FRAMES, frame).astype(np.float32)

    ours = best_of(lambda: imager.images(frames)) / FRAMES
    out = np.empty((FRAMES, rows, cols), dtype=np.uint8)
    ours_into = best_of(lambda: imager.images(frames, out=out)) / FRAMES

    estimates = ROOT / "target" / "criterion" / f"image_interpolate+quantise ({len(tmap)} taxels, {rows} x {cols} px)" / "new" / "estimates.json"
    if not estimates.exists():
        sys.exit(f"no {estimates}: run `cargo bench -p skin-geom --bench tactile_image` first")
    rust = json.loads(estimates.read_text())["median"]["point_estimate"] / 1e9
    batch = ROOT / "target" / "criterion" / "image batch" / f"{FRAMES} frames into one buffer ({len(tmap)} taxels, {rows} x {cols} px)" / "new" / "estimates.json"
    if not batch.exists():
        sys.exit(f"no {batch}: run `cargo bench -p skin-geom --bench tactile_image` first")
    rust_batch = json.loads(batch.read_text())["median"]["point_estimate"] / 1e9 / FRAMES

    def numpy_frame_by_frame():
        for f in frames:
            k = weights @ f
            top = k.max()
            (np.floor(255.0 * k / top) if top > 0 else np.zeros_like(k)).astype(np.uint8)

    def numpy_batch():
        k = weights @ frames.T
        top = k.max(axis=0)
        np.floor(255.0 * k / np.where(top > 0, top, 1)).astype(np.uint8)

    ref_loop = best_of(numpy_frame_by_frame, 3) / FRAMES
    ref_batch = best_of(numpy_batch, 3) / FRAMES
    ref = min(ref_loop, ref_batch)
    # The same images, checked on a few frames (float32 against float64 sums may differ by one
    # grey level at a pixel on a rounding edge).
    got = imager.images(frames[:3]).reshape(3, -1).astype(int)
    k = weights @ frames[:3].T.astype(np.float64)
    want = np.floor(255.0 * k / k.max(axis=0)).T.astype(int)
    assert np.abs(got - want).max() <= 1

    print(f"{len(tmap)} taxels, {rows} x {cols} px, {FRAMES} frames, one core; per frame:")
    print(f"  skin (Rust bench, one frame, one buffer)  {rust * 1e6:8.1f} us")
    print(f"  skin (Rust bench, 1000 into one buffer)   {rust_batch * 1e6:8.1f} us")
    print(f"  skin (Python, Imager.images, out=)        {ours_into * 1e6:8.1f} us   / Rust batch {ours_into / rust_batch:.3f}, / Rust one frame {ours_into / rust:.3f}")
    print(f"  skin (Python, Imager.images, new array)   {ours * 1e6:8.1f} us   / Rust batch {ours / rust_batch:.3f} (87 MB of new memory)")
    print(f"  numpy + scipy.sparse, by frame            {ref_loop * 1e6:8.1f} us")
    print(f"  numpy + scipy.sparse, one product         {ref_batch * 1e6:8.1f} us")
    print(f"  reference (the faster) / Python: {ref / ours_into:.2f}x with out=, {ref / ours:.2f}x into a new array")


if __name__ == "__main__":
    main()
