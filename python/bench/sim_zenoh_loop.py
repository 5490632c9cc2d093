"""What lock-step over Zenoh costs a simulation: the arm of python/tests/test_sim_zenoh.py (a
hand pressing the moving forearm) run in-process (`SkinLoop`) and against a `skin run` node over
Zenoh and a named pipe (`ZenohLoop`, waiting for every frame's answer), wall-clock seconds for
the same simulated seconds.

    python python/bench/sim_zenoh_loop.py [path/to/skin] [--seconds 6]

From the repository root; needs MuJoCo, eclipse-zenoh and `skin` built with Zenoh.
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import test_sim_zenoh as arm  # noqa: E402  (the scene, written once, for the test and this)

import skin  # noqa: E402
from skin.sim import SkinLoop  # noqa: E402
from skin.sim.zenoh import RosNode, ZenohLoop, open_pipe  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("skin", nargs="?", default="target/debug/skin")
    ap.add_argument("--seconds", type=float, default=6.0)
    a = ap.parse_args()
    work = Path(tempfile.mkdtemp())
    run_toml = arm.config(work)
    bridge, model, data, control, _ = arm.scene(run_toml)
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(run_toml), control=control, joints=arm.JOINTS)
    t = time.perf_counter()
    loop.run(a.seconds)
    here = time.perf_counter() - t
    bridge, model, data, control, _ = arm.scene(run_toml)
    pipe = work / "skin.can"
    os.mkfifo(pipe)
    endpoint = f"tcp/127.0.0.1:{arm.free_port()}"
    node = subprocess.Popen(
        [a.skin, "run", str(run_toml), "--log", str(pipe), "-o", str(work / "out"), "--quiet",
         "--zenoh-listen", endpoint, "--joint-states", "/joint_states"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )
    with RosNode(endpoint) as ros, open_pipe(pipe, node) as can:
        z = ZenohLoop(model, data, bridge, ros, can, settings=skin.read_session_settings(run_toml),
                      joints=arm.JOINTS, control=control)
        t = time.perf_counter()
        z.run(a.seconds)
        there = time.perf_counter() - t
        z.finish()
        z.close()
    node.wait(timeout=60)
    frames = round(a.seconds / (bridge.steps_per_frame * model.opt.timestep))
    print(f"{a.seconds:g} s simulated, {frames} skin frames: in-process {here:.2f} s ({here / frames * 1e3:.1f} ms a frame), "
          f"over Zenoh {there:.2f} s ({there / frames * 1e3:.1f} ms a frame), x{there / here:.2f}")


if __name__ == "__main__":
    main()
