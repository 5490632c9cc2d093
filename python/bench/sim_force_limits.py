"""Where the scene kit's presses stop being a skin's: each tool pressed on the fixture forearm's top
with forces up to 3,000 N, against the force limit `Kit.force_limit` computes.

    python python/bench/sim_force_limits.py [TOOL ...]     # sphere15 sphere20 sphere30 bar hand

A press is scripted with the kit up to the tool's limit, and the rest of its force added by the
script's own controller along the normal (ramped as the kit ramps), as a user's controller could;
held 1 s. Per press: the deepest contact of the tool in the forearm (MuJoCo's penetration) against
the depth a skin allows there, whether the loop reported it (`loop.overpresses`) and as gone through
the link, and the touches the session found.
"""

import sys
import warnings
from pathlib import Path

import numpy as np

import skin
from skin.sim import Kit, SkinBridge, SkinLoop, bare_robot, touches

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "fixtures" / "session" / "run.toml"
TOOLS = {
    "sphere15": ("sphere", dict(radius=0.015), [10, 22, 23, 60, 100, 300, 3000]),
    "sphere20": ("sphere", dict(radius=0.02), [10, 22, 23, 60, 100, 300, 3000]),
    "sphere30": ("sphere", dict(radius=0.03), [10, 22, 23, 60, 100, 300, 3000]),
    "bar": ("bar", dict(radius=0.012), [20, 33, 60, 65, 70, 100, 300, 3000]),
    "hand": ("hand", {}, [15, 40, 60, 65, 70, 88, 100, 300, 3000]),
}


def press(kind: str, size: dict, force: float):
    import mujoco

    bridge = SkinBridge.from_config(CONFIG)
    spec = bare_robot(bridge.layout)
    kit = Kit(spec)
    {"sphere": kit.add_sphere, "bar": kit.add_bar, "hand": kit.add_hand}[kind](**size)
    bridge.attach(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    kit.bind(model, data)
    limit = kit.force_limit(kind)
    top, up = np.array([0.0, 0.18, 0.08]), np.array([0.0, 0.0, 1.0])
    action = kit.press(kind, top, up, min(force, limit), start=1.5, duration=1.0)
    body = model.body(kind).id
    forearm = model.body("forearm").id
    deepest = [0.0]

    def control(loop):
        kit.control(loop)
        share = action.force_at(loop.time) / max(action.force, 1e-9)
        data.xfrc_applied[body, :3] -= max(force - limit, 0.0) * share * up
        for i in range(data.ncon):
            c = data.contact[i]
            if forearm in (model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2]):
                deepest[0] = max(deepest[0], -c.dist)

    loop = SkinLoop(model, data, bridge, skin.Session.from_config(CONFIG), control=control)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", skin.SkinWarning)
        events = loop.run(3.0) + loop.finish()
    allowed = kit.tools[kind].limit_depth
    return limit, deepest[0], allowed, loop.overpresses, len(touches(events))


def main(names):
    print(f"{'tool':9s} {'force N':>8s} {'limit N':>8s} {'deepest mm':>10s} {'allowed mm':>10s}  reported  through  touches")
    for name in names:
        kind, size, forces = TOOLS[name]
        for force in forces:
            limit, deepest, allowed, over, found = press(kind, size, float(force))
            through = any(o.through for o in over)
            print(f"{name:9s} {force:8.0f} {limit:8.1f} {deepest * 1e3:10.2f} {allowed * 1e3:10.1f}  "
                  f"{'yes' if over else 'no':8s}  {'yes' if through else 'no':7s}  {found}", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:] or list(TOOLS))
