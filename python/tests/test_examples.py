"""The examples run as a user runs them, from the repository root."""

import subprocess
import sys

import pytest

from conftest import REPO, skin_binary


@pytest.mark.parametrize("name", ["quickstart.py", "own_classifier.py", "training_data.py"])
def test_example_runs(name):
    if name == "own_classifier.py":
        pytest.importorskip("onnxruntime")
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
    else:
        assert "200 images" in out and "dataset of 40" in out
