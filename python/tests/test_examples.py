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


def test_the_readmes_at_scale_recipe_runs_as_written(tmp_path):
    """README, "At scale": its first Python block, as a user pastes it at the repository's root
    (here a copy of the root's fixtures, so its out/ is the test's), run twice: the second run
    converts nothing again."""
    pytest.importorskip("ray", reason="Ray is not installed: pip install ray[data]")
    text = (REPO / "README.md").read_text()
    section = text[text.index("## At scale") :]
    block = section[section.index("```python\n") + len("```python\n") :]
    block = block[: block.index("```\n")]
    (tmp_path / "fixtures").symlink_to(REPO / "fixtures")
    (tmp_path / "target").symlink_to(REPO / "target")
    for run, expected in ((1, "{'converted': 8, 'skipped': 0, 'failed': 0}"), (2, "{'converted': 0, 'skipped': 8, 'failed': 0}")):
        done = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr[-3000:]
        assert done.stdout.strip().splitlines()[-1] == expected, (run, done.stdout)
    datasets = [d for d in (tmp_path / "out" / "fleet").iterdir() if d.is_dir()]
    assert len(datasets) == 8 and all((d / "meta" / "info.json").is_file() for d in datasets)
