"""Shared set-up: the repository's fixtures, the `skin` command to cross-check against, and the
real third-party data beside the project (tests that need it skip, saying so, when absent)."""

import json
import os
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
FIXTURES = REPO / "fixtures"
SHARED_DATA = REPO.parent / "shared" / "data"


def skin_binary() -> Path:
    """The `skin` command: $SKIN, or the workspace's debug build."""
    path = Path(os.environ.get("SKIN", REPO / "target" / "debug" / "skin"))
    if not path.is_file():
        pytest.fail(f"no `skin` command at {path}: build it (cargo build -p skin-cli) or set SKIN")
    return path


def run_skin(*args: str) -> subprocess.CompletedProcess:
    """Runs the `skin` command; a failure fails the test with its output."""
    done = subprocess.run([str(skin_binary()), *map(str, args)], capture_output=True, text=True)
    if done.returncode != 0:
        pytest.fail(f"skin {' '.join(map(str, args))} failed ({done.returncode}):\n{done.stderr}")
    return done


def read_events(path: Path) -> list:
    with open(path, encoding="utf-8") as f:
        return [json.loads(line) for line in f if line.strip()]


@pytest.fixture(scope="session")
def cli_session_events(tmp_path_factory) -> list:
    """The fixture session's events as `skin run` writes them."""
    out = tmp_path_factory.mktemp("cli-run") / "run"
    run_skin("run", FIXTURES / "session" / "run.toml", "--log", FIXTURES / "session" / "session.candump.log", "-o", out, "-q")
    return read_events(out / "events.jsonl")


@pytest.fixture(scope="session")
def builtin_session_events() -> list:
    """The fixture session's events from Python, with the configuration's own models."""
    import skin

    session = skin.Session.from_config(FIXTURES / "session" / "run.toml")
    return session.run_log(FIXTURES / "session" / "session.candump.log")


def shared(*parts: str) -> Path:
    """A file of the real data beside the project, or a skip naming it."""
    path = SHARED_DATA.joinpath(*parts)
    if not path.exists():
        pytest.skip(f"{path} is absent: the real third-party data lives in ../shared/data")
    return path


@pytest.fixture(scope="session")
def ray_local():
    """A local Ray instance of two CPUs (as CI's machine has), started once for the whole run:
    Ray Data reading datasets back and running skin.ray's recipe."""
    ray = pytest.importorskip("ray", reason="Ray is not installed: pip install ray[data] (python/tests/requirements.txt)")
    if not ray.is_initialized():
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False, configure_logging=False)
    ctx = ray.data.DataContext.get_current()
    ctx.enable_progress_bars = False
    yield ray
