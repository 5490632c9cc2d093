"""Memory of a long simulated session: the full arm in MuJoCo through the session with both
shipped models, for 30 simulated minutes, resident memory read every simulated minute.

    OMP_NUM_THREADS=1 python python/bench/sim_memory.py [--minutes 30] [--max-events N|none] [--clear-events]

The scene of sim.py (the full arm's three links, a hand pressing the middle one, a ball
rolling on the first and a bar pressing the last, in turn, every 1.4 s), with each press at
its own place, force and yaw so that the classifier and the segmenter see varied images. The
loop runs with its defaults: it keeps the latest events in `loop.events` (`SkinLoop`'s
`max_events`, `skin.sim.loop.MAX_EVENTS` unless `--max-events` says otherwise; `none` keeps
every one, as the loop did before it was bounded), and the bench reads each simulated
second's events from what `run` returns; `--clear-events` also empties `loop.events` each
simulated second, as a caller had to before. Prints resident memory each minute and, after
warm-up (the first tenth of the run), its growth; exits non-zero if it grew by more than 10%.
"""

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import skin
from skin.sim import Kit, SkinBridge, SkinLoop
from skin.sim.loop import MAX_EVENTS

sys.path.insert(0, str(Path(__file__).resolve().parent))
from sim import ROOT, full_arm_link  # noqa: E402  (the same arm as the speed bench)


def resident_kb() -> int:
    """This process's resident memory, kB (VmRSS)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1])
    raise RuntimeError("no VmRSS in /proc/self/status")


def build(folder: Path):
    """The full arm's bridge, MuJoCo model and data, tool kit and session (both models)."""
    import json

    import mujoco

    layout = folder / "full_arm.json"
    layout.write_text(json.dumps({"format": "skin-layout/1", "units": "m", "links": [full_arm_link(k) for k in range(3)]}))
    config = folder / "run.toml"
    models = ROOT / "fixtures" / "models"
    config.write_text(
        f'layout = "{layout}"\nclassifier = "{models / "handsnet.onnx"}"\nsegmenter = "{models / "handseg.onnx"}"\n'
        f'cache = "{folder / "cache"}"\n[baseline]\nframes = 50\n[sim]\nframe_rate_hz = 50\n'
    )
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
    return bridge, model, data, kit, skin.Session.from_config(config)


def script(kit: Kit, seconds: float, seed: int = 54) -> None:
    """Presses until `seconds`: hand, ball, bar in turn, each at its own place, force and yaw."""
    rng = np.random.default_rng(seed)
    top = np.array([0.0, 0.0, 0.08])
    up = np.array([0.0, 0.0, 1.0])
    t = 1.5
    while t < seconds - 1.5:
        along = rng.uniform(-0.06, 0.06)
        kit.press("hand", top + [0, 0.40 + along, 0], up, rng.uniform(8.0, 18.0), t, 1.0, yaw=rng.uniform(-0.6, 0.6))
        t += 1.4
        start = rng.uniform(0.03, 0.08)
        roll = [top + [0, start, 0], top + [0, start + rng.uniform(0.08, 0.15), 0]]
        kit.slide("sphere", roll, up, rng.uniform(5.0, 10.0), t, 1.0, roll=True)
        t += 1.4
        kit.press("bar", top + [0, 0.67 + rng.uniform(-0.05, 0.05), 0], up, rng.uniform(5.0, 9.0), t, 1.0, yaw=rng.uniform(-0.8, 0.8))
        t += 1.4


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--minutes", type=float, default=30.0, help="simulated minutes (default 30)")
    parser.add_argument(
        "--max-events",
        type=lambda v: None if v == "none" else int(v),
        default=argparse.SUPPRESS,  # unsaid: the loop's own default, not passed at all
        help=f"events loop.events keeps ('none': every one; default the loop's own, {MAX_EVENTS})",
    )
    parser.add_argument("--clear-events", action="store_true", help="empty loop.events every simulated second")
    args = parser.parse_args()
    seconds = 60.0 * args.minutes
    folder = Path(tempfile.mkdtemp(prefix="skin-sim-memory-"))
    bridge, model, data, kit, session = build(folder)
    script(kit, seconds)
    bound = {"max_events": args.max_events} if "max_events" in vars(args) else {}
    loop = SkinLoop(model, data, bridge, session, control=kit.control, **bound)
    counts = {"classified": 0, "released": 0}
    rows = []
    w0 = time.perf_counter()
    for minute in range(1, int(np.ceil(args.minutes)) + 1):
        for _ in range(60):
            for e in loop.run(1.0):
                if e.kind in counts:
                    counts[e.kind] += 1
            if args.clear_events:
                loop.events.clear()
        rows.append((minute, resident_kb(), counts["classified"], counts["released"]))
        print(
            f"{minute:>3} min simulated ({time.perf_counter() - w0:6.0f} s): resident {rows[-1][1]:>7} kB, "
            f"{counts['classified']} classifications, {counts['released']} touches, "
            f"{len(loop.events)} events kept ({loop.events_dropped} let go)",
            flush=True,
        )
    warm = max(1, len(rows) // 10)
    at_warm = rows[warm - 1][1]
    highest = max(r[1] for r in rows[warm:]) if len(rows) > warm else at_warm
    growth = (highest - at_warm) / at_warm
    print(
        f"after warm-up ({warm} min): {at_warm} kB; at most {highest} kB after ({100 * growth:+.1f}%); "
        f"{rows[-1][1]} kB at {rows[-1][0]} min"
    )
    return 0 if growth <= 0.10 else 1


if __name__ == "__main__":
    sys.exit(main())
