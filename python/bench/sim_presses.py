"""Scripted presses of the fixture forearm in MuJoCo through the session with the shipped models:
how often HandsNet is right over the whole skin, edges included, and how often the segmenter's
parts are the fingers that pressed.

    python python/bench/sim_presses.py [PRESSES] [SEEDS] [FIRST_SEED]   # default 50, 5, 101

The session is the fixture's (`fixtures/session/run.toml`: the shipped models and gate); set
`SKIN_RUN_TOML` to another run.toml to measure other models or another gate on the same presses.

Each seed scripts PRESSES presses, the kit's tools in turn: a hand, a bar of 12 mm radius and
balls of 15, 20 and 30 mm radius, each at a taxel drawn uniformly over the whole forearm, with a
random force (hand 8-20 N, bar 5-20 N, balls 3-20 N), yaw and, for a hand, a random set of
fingers (each pressing with probability 0.7). A press's distance from the edge is its taxel's
distance on the tactile map from the skin's border (`TactileMap.border_mm`); the table gives
each tool's presses within 15 mm of it, 15-30 mm and further. A touch's class is the class it is
released with; "gate" counts the presses for which the gate said, at any frame of the press,
what the wrong class would make it say: `stop` for a hand (the border rule, run.toml's
`[gate] border`, included), `comply` for a bar or a ball. A hand press's fingers are those whose
fingertip pressed the skin with more than 0.3 N in mid-press (MuJoCo's contacts); the
segmenter's are the finger parts it names at the touch's last classification as a hand. For
comparison, the same finger-set rule on the segmenter's own kind of data: hands from
`skin.synthesize` (a seed and subjects it was not trained on), truth from their part masks (a
finger present with 4 pixels or more).

Then where the skin places a contact: a 2 cm ball pressed with 2-20 N at 30 random points of the
forearm's middle, each up to 4 mm from a taxel (between taxels, and in the strips between
modules), the session's contact centroid against MuJoCo's contact point moved from halfway into
the penetration to the skin's surface.
"""

import os
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

import skin
from skin.sim import FINGERS, Kit, SkinBridge, SkinLoop, bare_robot, touches

ROOT = Path(__file__).resolve().parents[2]
CONFIG = Path(os.environ.get("SKIN_RUN_TOML", ROOT / "fixtures" / "session" / "run.toml"))
TOOLS = ("hand", "bar", "ball15", "ball20", "ball30")
BANDS = ((0.0, 15.0), (15.0, 30.0), (30.0, np.inf))


def presses(count: int, seed: int):
    """One row per press: (tool, mm from the border, class released with, its probability,
    fingers that pressed, fingers the segmenter named, the gate's actions during the press)."""
    import mujoco

    bridge = SkinBridge.from_config(CONFIG)
    spec = bare_robot(bridge.layout)
    kit = Kit(spec)
    kit.add_hand()
    kit.add_bar(radius=0.012)
    for r in (15, 20, 30):
        kit.add_sphere(f"ball{r}", radius=r * 1e-3)
    bridge.attach(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    kit.bind(model, data)
    border = skin.read_map(ROOT / "fixtures" / "forearm" / "layout.json").border_mm
    link = bridge.layout[0]
    actions = kit.random_presses(link.positions, link.normals, count, seed=seed)
    at = [int(np.argmin(np.linalg.norm(link.positions - a.path[0], axis=1))) for a in actions]
    session = skin.Session.from_config(CONFIG)
    loop = SkinLoop(model, data, bridge, session, control=kit.control)
    forearm = model.body("forearm").id
    pressed = [set() for _ in actions]
    gates = defaultdict(list)

    def sample(l):
        if not l.framed:
            return False
        for k, a in enumerate(actions):
            if a.start <= l.time <= a.start + a.duration + 0.2:
                gates[k].append(l.session.gate)
            if a.tool == "hand" and a.start + 0.3 < l.time < a.start + 0.8:
                forces = kit.touching("hand", forearm, distal=True)
                pressed[k] |= {p for p, f in forces.items() if p in FINGERS and f > 0.3}
        return False

    events = loop.run(actions[-1].start + actions[-1].duration + 0.5, until=sample) + loop.finish()
    found = touches(events)
    probability = {e.touch: e["probability"] for e in events if e.kind == "released"}
    rows = []
    for k, (a, i, fingers) in enumerate(zip(actions, at, pressed)):
        mine = [t for t in found if a.start <= t["start"] <= a.start + a.duration]
        cls = mine[0]["class"] if mine else None
        parts = {p["part"] for p in mine[0]["parts"] if p["part"] in FINGERS} if mine else set()
        p = probability.get(mine[0]["touch"]) if mine else None
        rows.append((a.tool, float(border[i]), cls, p, fingers, parts, set(gates[k])))
    return rows


def table(rows) -> None:
    """HandsNet per tool and band of distance from the border."""
    bands = [f"{lo:g}-{hi:g} mm" if np.isfinite(hi) else f"over {lo:g} mm" for lo, hi in BANDS]
    print("| tool | right class | " + " | ".join(bands) + " | all | gate |")
    print("|---|---|" + "---|" * (len(bands) + 2))
    for tool in TOOLS + ("bar and balls",):
        mine = [r for r in rows if r[0] == tool or (tool == "bar and balls" and r[0] != "hand")]
        want = "hand" if tool == "hand" else "non_hand"
        cells = []
        for lo, hi in BANDS + ((0.0, np.inf),):
            band = [r for r in mine if lo <= r[1] < hi]
            ok = sum(r[2] == want for r in band)
            cells.append(f"{ok}/{len(band)} ({ok / len(band):.1%})" if band else "-")
        # What a wrong class would cost: a hand the arm stops for, an object it complies with.
        wrong = "stop" if tool == "hand" else "comply"
        gate = sum(wrong in r[6] for r in mine)
        print(f"| {tool} | {want} | " + " | ".join(cells) + f" | {wrong}: {gate}/{len(mine)} |")


def synthetic_baseline():
    import onnxruntime as ort

    tmap = skin.read_map(ROOT / "fixtures" / "forearm" / "layout.json")
    data = skin.synthesize(tmap, 400, seed=99, subjects=10)
    model = ort.InferenceSession(str(ROOT / "fixtures" / "models" / "handseg.onnx"))
    name = model.get_inputs()[0].name
    exact, agree, n = 0, 0, 0
    for image, mask, hand in zip(data["images"], data["masks"], data["hand"]):
        if not hand:
            continue
        labels = model.run(None, {name: image[None, None].astype(np.float32) / 255})[0][0].argmax(0)
        truth = {FINGERS[k - 1] for k in range(1, 6) if (mask == k).sum() >= 4}
        got = {FINGERS[k - 1] for k in range(1, 6) if (labels == k).sum() >= 4}
        exact += truth == got
        agree += sum((f in truth) == (f in got) for f in FINGERS)
        n += 1
    return n, exact / n, agree / (5 * n)


def centroids(count: int = 30, seed: int = 7):
    import mujoco

    bridge = SkinBridge.from_config(CONFIG)
    spec = bare_robot(bridge.layout)
    kit = Kit(spec)
    kit.add_sphere(radius=0.02)
    bridge.attach(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    kit.bind(model, data)
    rng = np.random.default_rng(seed)
    link = bridge.layout[0]
    tmap = skin.read_map(ROOT / "fixtures" / "forearm" / "layout.json")
    lo, hi = tmap.uv.min(0), tmap.uv.max(0)
    central = np.flatnonzero(np.all(np.abs(tmap.uv - (lo + hi) / 2) <= 0.35 * (hi - lo), axis=1))
    plan = []
    for k in range(count):
        i = rng.choice(central)
        n = link.normals[i]
        t1 = np.cross(n, [0, 1, 0])
        t1 /= np.linalg.norm(t1)
        offset = rng.uniform(-4e-3, 4e-3, 2)
        point = link.positions[i] + offset[0] * t1 + offset[1] * np.cross(n, t1)
        kit.press("sphere", point, n, rng.uniform(2, 20), start=1.0 + 1.2 * k, duration=1.0)
        plan.append(1.0 + 1.2 * k + 0.7)
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=kit.control)
    forearm = model.body("forearm").id
    errors = []

    def sample(l):
        if l.framed and any(abs(l.frame.time - at) < 1e-3 for at in plan):
            for i in range(data.ncon):
                c = data.contact[i]
                sides = (model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2])
                if forearm in sides:
                    out = c.frame[:3] if sides[0] == forearm else -c.frame[:3]
                    at = c.pos + out * abs(c.dist) / 2
                    contacts = l.session.contacts(0)
                    errors.append(np.linalg.norm(np.array(contacts[0].centroid) - at) if contacts else np.inf)
                    break
        return False

    loop.run(1.0 + 1.2 * count + 0.3, until=sample)
    return np.array(errors) * 1e3


def main() -> int:
    count = int(sys.argv[1]) if len(sys.argv) > 1 else 50
    first = int(sys.argv[3]) if len(sys.argv) > 3 else 101
    seeds = range(first, first + (int(sys.argv[2]) if len(sys.argv) > 2 else 5))
    rows = [r for seed in seeds for r in presses(count, seed)]
    print(f"{len(rows)} presses over the whole forearm (seeds {seeds.start}-{seeds.stop - 1}, {count} each):")
    table(rows)
    hands = [r for r in rows if r[0] == "hand" and r[2] == "hand"]
    exact = np.mean([r[4] == r[5] for r in hands])
    agree = np.mean([(f in r[4]) == (f in r[5]) for r in hands for f in FINGERS])
    print(f"segmenter on the {len(hands)} hand presses called hand: the fingers that pressed exactly in "
          f"{exact:.1%}, finger by finger {agree:.1%}")
    try:
        n, s_exact, s_agree = synthetic_baseline()
        print(f"segmenter on {n} synthetic hands (seed 99): exactly {s_exact:.1%}, finger by finger {s_agree:.1%}")
    except ImportError:
        print("(onnxruntime is not installed: no synthetic baseline)")
    err = centroids()
    print(f"ball at {len(err)} random points: centroid to MuJoCo's contact median {np.median(err):.1f} mm, "
          f"90th percentile {np.percentile(err, 90):.1f} mm, largest {err.max():.1f} mm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
