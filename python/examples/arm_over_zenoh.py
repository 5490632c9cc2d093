"""A simulated arm and its skin over ROS 2's middleware: MuJoCo moves a two-joint arm whose
forearm carries the fixture skin, publishes its /joint_states on Zenoh as an rmw_zenoh node does,
and a `skin run` node (started here) reads the skin's CAN traffic from a named pipe and the joint
states from Zenoh. A hand presses the moving forearm; the arm stops and yields when the gate it
hears on /skin/events says "comply", and goes on when the hand leaves. Each touch is printed where
it is on the link and on the robot (the base frame, from the joint states).

Run from the repository root (needs `pip install mujoco eclipse-zenoh` and the `skin` command
built with Zenoh, `cargo build --release --all-features`):

    python python/examples/arm_over_zenoh.py [path/to/skin]
"""

import os
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import mujoco
import numpy as np

import skin
from skin.sim import Kit, PathFollower, SkinBridge, two_joint_arm
from skin.sim.zenoh import RosNode, ZenohLoop, open_pipe

SKIN = sys.argv[1] if len(sys.argv) > 1 else "skin"
FIXTURES = Path("fixtures").resolve()

# The robot as the skin node knows it: its URDF (joints named as MuJoCo's, links as the layout's).
URDF = """<robot name="arm">
  <link name="base"/><link name="upper_arm"/><link name="forearm"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper_arm"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="50" velocity="2"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper_arm"/><child link="forearm"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="50" velocity="2"/></joint>
</robot>
"""

work = Path(tempfile.mkdtemp(prefix="skin-arm-"))
(work / "arm.urdf").write_text(URDF)
config = work / "run.toml"
config.write_text(
    f"""layout = "{FIXTURES / 'forearm' / 'layout.json'}"
busmap = "{FIXTURES / 'forearm' / 'busmap.toml'}"
classifier = "{FIXTURES / 'models' / 'handsnet.onnx'}"
[gate]
hand = "comply"      # stop following the path and yield to the person
non_hand = "stop"
[stitch]
urdf = "arm.urdf"    # the joint states place the forearm: touches in the base frame too
base = "base"
"""
)

# The scene: the arm, its skin, a hand that presses the forearm's top from 2 s to 4 s.
bridge = SkinBridge.from_config(config)
spec = two_joint_arm("forearm")
kit = Kit(spec)
kit.add_hand()
bridge.attach(spec)
model = spec.compile()
data = mujoco.MjData(model)
kit.bind(model, data)
kit.press("hand", [0.0, 0.18, 0.08], [0.0, 0.0, 1.0], 12.0, start=2.0, duration=2.0, body="forearm")
arm = PathFollower(model, data, ["shoulder", "elbow"], lambda s: np.array([0.5 * np.sin(s / 1.3), 0.4 * np.sin(s)]))


def control(loop):
    kit.control(loop)
    arm(loop)


# The skin node: the pipe is its CAN bus, Zenoh its ROS 2 (no ROS installed anywhere).
pipe = work / "skin.can"
os.mkfifo(pipe)
with socket.socket() as s:
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
endpoint = f"tcp/127.0.0.1:{port}"
node = subprocess.Popen(
    [SKIN, "run", str(config), "--log", str(pipe), "-o", str(work / "out"), "--quiet",
     "--zenoh-listen", endpoint, "--joint-states", "/joint_states"],
    stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
)
try:
    with RosNode(endpoint, name="arm") as ros, open_pipe(pipe, node) as can:
        loop = ZenohLoop(model, data, bridge, ros, can, settings=skin.read_session_settings(config),
                         joints=["shoulder", "elbow"], control=control)
        events = loop.run(6.0) + loop.finish()
        loop.close()
    summary, report = node.communicate(timeout=60)
finally:
    if node.poll() is None:
        node.kill()
if node.returncode != 0:
    sys.exit(f"skin run failed:\n{report}")

for e in events:
    if e.kind == "appeared":
        print(f"{e.time:5.2f} s  touch {e.touch} appeared: {np.round(e.centroid, 3)} m on the {e.link}, "
              f"{np.round(e.centroid_base, 3)} m from the shoulder")
    elif e.kind == "classified":
        print(f"{e.time:5.2f} s  touch {e.touch} is a {e['class']} ({e.probability:.2f})")
    elif e.kind == "gate":
        print(f"{e.time:5.2f} s  gate: {e.action}")
    elif e.kind == "released":
        print(f"{e.time:5.2f} s  touch {e.touch} released after {e.duration:.2f} s")
print(f"path at {arm.s:.2f} s of 6 s: the arm waited while the hand was on it")
print(f"\nthe skin node's summary:\n{summary}")
