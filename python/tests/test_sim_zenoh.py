"""skin.sim over ROS 2's middleware: the simulated arm publishes its joint states on Zenoh as an
rmw_zenoh node does, a `skin run` node reads the skin's CAN traffic from a pipe and the joint
states from Zenoh, and the arm's controller acts on the gate's action heard on /skin/events.

Needs MuJoCo and eclipse-zenoh (both in the test requirements; CI sets SKIN_REQUIRE_MUJOCO, and
these tests then fail rather than skip without them), and the `skin` command built with Zenoh
(`cargo build --all-features`)."""

import os
import re
import socket
import subprocess
from pathlib import Path

import numpy as np
import pytest

import skin
from conftest import FIXTURES, REPO, read_events, skin_binary

try:
    import mujoco
    import zenoh  # noqa: F401
except ImportError:  # pragma: no cover - depends on the machine
    if os.environ.get("SKIN_REQUIRE_MUJOCO"):
        raise
    pytest.skip("MuJoCo or eclipse-zenoh is not installed (pip install -r python/tests/requirements.txt)", allow_module_level=True)

from skin.sim import Kit, PathFollower, SkinBridge, SkinLoop, two_joint_arm
from skin.sim.zenoh import RosNode, ZenohLoop, open_pipe

ARM = FIXTURES / "arm"
JOINTS = ["shoulder", "elbow", "wrist_roll"]

# The simulated arm as its URDF gives it to the skin: a shoulder and an elbow turning about the
# vertical (two_joint_arm), and the fixture arm's wrist rolling about the forearm's axis.
URDF = """<?xml version="1.0"?>
<robot name="sim_arm">
  <link name="base"/><link name="upper_arm"/><link name="forearm"/><link name="wrist"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper_arm"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="50" velocity="2"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper_arm"/><child link="forearm"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="50" velocity="2"/></joint>
  <joint name="wrist_roll" type="revolute"><parent link="forearm"/><child link="wrist"/>
    <origin xyz="0 0.342 0"/><axis xyz="0 1 0"/><limit lower="-0.5" upper="0.5" effort="10" velocity="1.5"/></joint>
</robot>
"""


def config(tmp_path: Path) -> Path:
    (tmp_path / "sim_arm.urdf").write_text(URDF)
    path = tmp_path / "run.toml"
    path.write_text(
        f"""layout = "{ARM / 'layout.json'}"
busmap = "{ARM / 'busmap.toml'}"
classifier = "{FIXTURES / 'models' / 'handsnet.onnx'}"
cache = "{REPO / 'target' / 'skin-cache'}"
[baseline]
frames = 20
[gate]
hand = "comply"
non_hand = "stop"
[stitch]
urdf = "sim_arm.urdf"
base = "base"
"""
    )
    return path


def scene(run_toml: Path):
    """The arm, its skin on the forearm and the wrist, a hand pressing the moving forearm."""
    bridge = SkinBridge.from_config(run_toml)
    spec = two_joint_arm("forearm")
    wrist = spec.body("forearm").add_body(name="wrist", pos=[0, 0.342, 0])
    # The roll's own inertia is slight: the motor's (armature) keeps its servo stable.
    wrist.add_joint(name="wrist_roll", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0], range=[-0.5, 0.5], armature=0.02)
    core = wrist.add_geom(name="wrist_core", type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0.01, 0, 0, 0.1, 0], size=[0.025, 0, 0])
    core.mass = 0.5
    core.contype = core.conaffinity = 0
    roll = spec.add_actuator(name="wrist_roll", target="wrist_roll", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    roll.set_to_position(kp=20.0, kv=1.0)
    kit = Kit(spec)
    kit.add_hand()
    bridge.attach(spec)
    model = spec.compile()
    data = mujoco.MjData(model)
    kit.bind(model, data)
    kit.press("hand", [0, 0.18, 0.08], [0, 0, 1], 12.0, start=2.0, duration=2.0, body="forearm")
    path = lambda s: np.array([0.5 * np.sin(2 * np.pi * s / 8), 0.4 * np.sin(2 * np.pi * s / 6), 0.3 * np.sin(2 * np.pi * s / 4)])
    arm = PathFollower(model, data, JOINTS, path)
    trace = []

    def control(loop):
        kit.control(loop)
        arm(loop)
        trace.append((loop.time, loop.gate, arm.s, arm.q()))

    return bridge, model, data, control, trace


def rz(a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_the_arm_over_zenoh_gives_the_in_process_events_and_halts_on_the_gate(tmp_path):
    run_toml = config(tmp_path)
    seconds = 6.0

    # In-process: the session in this process, its gate read directly.
    bridge, model, data, control, _ = scene(run_toml)
    loop = SkinLoop(model, data, bridge, skin.Session.from_config(run_toml), control=control, joints=JOINTS)
    here = loop.run(seconds) + loop.finish()

    # Over Zenoh: `skin run` reads the pipe and the joint states, the arm hears its events.
    bridge, model, data, control, trace = scene(run_toml)
    pipe = tmp_path / "skin.can"
    os.mkfifo(pipe)
    port = free_port()
    out = tmp_path / "out"
    cmd = [str(skin_binary()), "run", str(run_toml), "--log", str(pipe), "-o", str(out), "--quiet",
           "--zenoh-listen", f"tcp/127.0.0.1:{port}", "--joint-states", "/joint_states"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        with RosNode(f"tcp/127.0.0.1:{port}", name="sim_arm") as node:
            with open_pipe(pipe, proc) as can:
                zloop = ZenohLoop(model, data, bridge, node, can, settings=skin.read_session_settings(run_toml),
                                  joints=JOINTS, control=control)
                there = zloop.run(seconds)
                there += zloop.finish()
                published = zloop.joint_states_published
                zloop.close()
        stdout, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, stderr

    # The same events, heard over Zenoh and written by the node (each session placing its
    # touches by the joint states it was given).
    assert [e.to_dict() for e in there] == [e.to_dict() for e in here]
    assert read_events(out / "events.jsonl") == [e.to_dict() for e in here]
    kinds = [e.kind for e in here]
    assert "joint_states" not in kinds and {"appeared", "classified", "released"} <= set(kinds)
    actions = [e.action for e in here if e.kind == "gate"]
    assert actions[:2] == ["comply", "resume"]
    # Every joint state the arm published reached the node and was read (none refused as of
    # another type, without rmw_zenoh's attachment or malformed), and none was missing, stale
    # or out of order (no joint_states event).
    heard = re.search(r"subscription /joint_states: (\d+) sample\(s\) received, (\d+) read", stderr)
    assert heard, stderr
    assert int(heard[1]) == int(heard[2]) == published >= seconds * 100

    # Each touch placed in the base frame where the arm was: the forearm at the shoulder's and
    # the elbow's angles at the touch's frame (both centroids rounded to 0.1 mm in JSON).
    at = {round(t, 6): q for t, _, _, q in trace}
    placed = [e for e in there if e.kind == "appeared"]
    assert placed
    for e in placed:
        shoulder, elbow = at[round(e.time, 6)][:2]
        expected = rz(shoulder) @ (np.array([0.3, 0.0, 0.0]) + rz(elbow) @ np.array(e.centroid))
        assert np.abs(np.array(e.centroid_base) - expected).max() < 2e-4, e

    # The arm halted on the action heard over Zenoh: its path stood still while complying.
    t, gates, s, _ = zip(*trace)
    t, s = np.array(t), np.array(s)
    comply = np.array([g == "comply" for g in gates])
    assert comply.any()
    assert np.ptp(s[comply]) == 0.0
    assert s[-1] > 3.0
