"""One full-arm frame through the session from Python, against the same call from Rust.

    cargo bench -p skin-learn --bench session_push      # the Rust figures, and the arm's files
    python python/bench/session_push.py                 # the same frames through skin.Session.push

The Rust bench writes the thesis' full arm (3,495 taxels on three links) and two frames (untouched,
and a hand held on the middle link) to target/bench-data; this pushes the same frames, as one
numpy array per link, through `Session.from_layout(layout)` (the same settings), and prints both
figures (criterion's median, read from target/criterion) and the difference per frame.
"""

import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

import skin

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "target" / "bench-data"


def median_us(fn, calls: int = 1000, repeats: int = 21) -> float:
    for _ in range(calls):
        fn()
    laps = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(calls):
            fn()
        laps.append((time.perf_counter() - t0) / calls)
    return 1e6 * statistics.median(laps)


def rust_us(name: str) -> float:
    path = ROOT / "target" / "criterion" / "session_push" / name / "new" / "estimates.json"
    if not path.exists():
        sys.exit(f"no {path}: run `cargo bench -p skin-learn --bench session_push` first")
    return json.loads(path.read_text())["median"]["point_estimate"] / 1000


def main() -> None:
    layout_path = DATA / "full_arm.json"
    if not layout_path.exists():
        sys.exit(f"no {layout_path}: run `cargo bench -p skin-learn --bench session_push` first")
    layout = skin.read_layout(layout_path)
    sizes = [len(link) for link in layout.links]
    raw = np.fromfile(DATA / "full_arm_frames.bin", dtype="<f4")
    total = sum(sizes)
    assert raw.size == 2 * total, (raw.size, sizes)
    cuts = np.cumsum(sizes)[:-1]
    idle = np.split(raw[:total].copy(), cuts)
    held = np.split(raw[total:].copy(), cuts)

    session = skin.Session.from_layout(layout)
    clock = [0.0]

    def push(frame):
        clock[0] += 0.05
        return session.push(frame, clock[0])

    for _ in range(20):
        push(idle)
    rows = []
    py_idle = median_us(lambda: push(idle))
    rows.append(("no contact", rust_us("no contact"), py_idle))
    push(held)
    py_held = median_us(lambda: push(held))
    rows.append(("hand held", rust_us("hand held"), py_held))
    print(f"full arm: {total} taxels on {len(sizes)} links; Session.push, one frame, median")
    print(f"{'frame':<12}{'Rust us':>10}{'Python us':>11}{'Python - Rust':>15}")
    for name, r, p in rows:
        print(f"{name:<12}{r:>10.2f}{p:>11.2f}{p - r:>+15.2f}")


if __name__ == "__main__":
    main()
