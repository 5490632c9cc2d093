"""The examples run as a user runs them, from the repository root."""

import os
import subprocess
import sys

import pytest

from conftest import REPO, skin_binary


@pytest.mark.parametrize("name", ["quickstart.py", "own_classifier.py", "training_data.py", "sim_press.py", "arm_over_zenoh.py"])
def test_example_runs(name):
    if name == "own_classifier.py":
        pytest.importorskip("onnxruntime")
    if name in ("sim_press.py", "arm_over_zenoh.py") and not os.environ.get("SKIN_REQUIRE_MUJOCO"):
        pytest.importorskip("mujoco", reason="MuJoCo is not installed (pip install mujoco; Python 3.11 or later)")
        if name == "arm_over_zenoh.py":
            pytest.importorskip("zenoh", reason="eclipse-zenoh is not installed (pip install eclipse-zenoh)")
    done = subprocess.run(
        [sys.executable, str(REPO / "python" / "examples" / name), str(skin_binary())],
        cwd=REPO,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    out = done.stdout
    if name == "quickstart.py":
        assert out.count("touch ") >= 20 and "20 touches" in out
    elif name == "own_classifier.py":
        assert out.count(": hand") == 10 and out.count(": non_hand") == 10
    elif name == "sim_press.py":
        released = [line for line in out.splitlines() if "released" in line]
        assert len(released) == 3, out
        assert ["'non_hand'" in released[0], "'non_hand'" in released[1], "'hand'" in released[2]] == [True] * 3, out
    elif name == "arm_over_zenoh.py":
        # The hand is decided, the arm complies and resumes; the touch is placed on the robot.
        assert "is a hand" in out and "gate: comply" in out and "gate: resume" in out, out
        assert "m from the shoulder" in out and "1 touch(es)" in out, out
    else:
        assert "200 images" in out and "dataset of 40" in out
