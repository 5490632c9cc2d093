"""The thesis' full arm simulated in MuJoCo and run through the session, against real time.

    python python/bench/sim.py            # needs `pip install mujoco` beside the package

The full arm of the Rust benches (test-support/src/full_arm.rs: three half-cylinder links of
1,165 taxels, 3,495 in all, radius 80 mm, 8 mm lattice) on three fixed bodies in a row; the
skin at 50 frames/s (MuJoCo's step 2 ms); the session of `skin run` with the shipped HandsNet
and segmenter; a hand pressing the middle link, a ball rolling on the first and a bar on the
last, one after the other, over and over. Prints how many simulated seconds one second of this
machine's time runs (the goal: at least 5 on one core), and where the time goes. Run with
OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 for one core, as BENCHMARKS.md does.
"""

import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import skin
from skin.sim import Kit, SkinBridge, SkinLoop

ROOT = Path(__file__).resolve().parents[2]
SECONDS = 20.0


def full_arm_link(k: int) -> dict:
    """Link k of test-support's full arm (the same formula), as a skin-layout/1 link."""
    radius, pitch, around, per_link = 0.08, 0.008, 31, 1165
    taxels = []
    for i in range(per_link):
        row, col = divmod(i, around)
        phi = (col + 0.5 * (row % 2)) * pitch / radius - 1.2
        n = [np.sin(phi), 0.0, np.cos(phi)]
        module = k * 110 + i // 11 + 1
        taxels.append(
            {
                "id": module << 4 | (i % 11),
                "position": [radius * n[0], row * pitch * 0.866, radius * n[2]],
                "normal": n,
            }
        )
    return {"name": f"link{k}", "taxels": taxels}


def main() -> int:
    import mujoco

    folder = Path(tempfile.mkdtemp(prefix="skin-sim-bench-"))
    layout = folder / "full_arm.json"
    layout.write_text(json.dumps({"format": "skin-layout/1", "units": "m", "links": [full_arm_link(k) for k in range(3)]}))
    config = folder / "run.toml"
    models = ROOT / "fixtures" / "models"
    config.write_text(
        f'layout = "{layout}"\nclassifier = "{models / "handsnet.onnx"}"\nsegmenter = "{models / "handseg.onnx"}"\n'
        f'cache = "{folder / "cache"}"\n[baseline]\nframes = 50\n[sim]\nframe_rate_hz = 50\n'
    )
    t0 = time.perf_counter()
    bridge = SkinBridge.from_config(config)
    spec = mujoco.MjSpec()
    kit = Kit(spec)
    for k in range(3):
        spec.worldbody.add_body(name=f"link{k}", pos=[0.0, 0.27 * k, 0.0])
    kit.add_hand()
    kit.add_sphere(radius=0.03)
    kit.add_bar(radius=0.015)
    bridge.attach(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    kit.bind(model, data)
    session = skin.Session.from_config(config)
    setup = time.perf_counter() - t0
    top = np.array([0.0, 0.0, 0.08])
    up = np.array([0.0, 0.0, 1.0])
    t = 1.5
    while t < SECONDS:
        kit.press("hand", top + [0, 0.27 + 0.13, 0], up, 15.0, t, 1.0)
        t += 1.4
        roll = [top + [0, 0.05, 0], top + [0, 0.2, 0]]
        kit.slide("sphere", roll, up, 8.0, t, 1.0, roll=True)
        t += 1.4
        kit.press("bar", top + [0, 0.54 + 0.13, 0], up, 10.0, t, 1.0)
        t += 1.4
    loop = SkinLoop(model, data, bridge, session, control=kit.control)
    # Where the time goes: the skin's frames (sensor to counts) and the session, timed apart.
    spent = {"frame": 0.0, "session": 0.0}
    make_frame = bridge.frame

    def timed_frame(d, at=None):
        start = time.perf_counter()
        frame = make_frame(d, at)
        spent["frame"] += time.perf_counter() - start
        push = frame.push

        def timed_push(s):
            start = time.perf_counter()
            events = push(s)
            spent["session"] += time.perf_counter() - start
            return events

        frame.push = timed_push
        return frame

    bridge.frame = timed_frame
    w0 = time.perf_counter()
    events = loop.run(SECONDS)
    events += loop.finish()
    wall = time.perf_counter() - w0
    frames = int(SECONDS * bridge.frame_rate)
    decided = [e for e in events if e.kind == "released"]
    print(f"full arm: {sum(len(l) for l in bridge.layout.links)} taxels on {len(bridge.links)} links, "
          f"{sum(len(bridge.surface(k).points) for k in range(3))} sensor points; set-up {setup:.1f} s")
    print(f"{SECONDS:.0f} s simulated ({frames} skin frames at {bridge.frame_rate:.0f}/s, "
          f"{int(SECONDS / model.opt.timestep)} MuJoCo steps) in {wall:.2f} s: {SECONDS / wall:.1f}x real time")
    print(f"  skin frames (sensor to counts): {1e3 * spent['frame'] / frames:.2f} ms each; "
          f"session: {1e3 * spent['session'] / frames:.2f} ms each; "
          f"MuJoCo and the tools: {1e3 * (wall - spent['frame'] - spent['session']) / frames:.2f} ms a frame")
    print(f"  touches decided: {len(decided)} ({', '.join(e['class'] for e in decided)})")
    return 0 if SECONDS / wall >= 5.0 else 1


if __name__ == "__main__":
    sys.exit(main())
