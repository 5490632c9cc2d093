"""skin.ray on a local Ray of two CPUs: the recipe converts 40 logs (and names the corrupt one
among them) as the serial export does, file for file; a run killed midway is finished by the
next, which does only the rest; synthetic shards are the same bytes on one worker and two."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import skin
from conftest import FIXTURES, REPO

ray = pytest.importorskip("ray", reason="Ray is not installed: pip install ray[data] (python/tests/requirements.txt)")
import skin.ray  # noqa: E402

LOGS = 40


@pytest.fixture(scope="module")
def fleet(tmp_path_factory):
    """40 logs cut from the fixture session (31 s of the forearm's traffic), one corrupt
    log beside them, and a run.toml without models (touches tracked: the tables, not the
    decisions, are what is compared)."""
    root = tmp_path_factory.mktemp("fleet")
    config = root / "run.toml"
    config.write_text(
        f'layout = "{FIXTURES / "forearm" / "layout.json"}"\n'
        f'busmap = "{FIXTURES / "forearm" / "busmap.toml"}"\n'
        f'cache = "{REPO / "target" / "skin-cache"}"\n'
        "[baseline]\nframes = 5\n"
    )
    lines = (FIXTURES / "session" / "session.candump.log").read_text().splitlines(keepends=True)
    per = len(lines) // LOGS
    logs = []
    for k in range(LOGS):
        path = root / "logs" / f"log-{k:02d}.candump.log"
        path.parent.mkdir(exist_ok=True)
        path.write_text("".join(lines[k * per : (k + 1) * per]))
        logs.append(path)
    bad = root / "logs" / "corrupt.candump.log"
    bad.write_text("".join(lines[:per]) + "(99.0) can0 zz#not-a-frame\n")
    return config, logs, bad


def serial(config, logs, out):
    """Each log exported alone, as `skin export LOG -o OUT/NAME` does."""
    for log in logs:
        skin.export([log], config, out / log.name)


def recipe(config, inputs, out, concurrency=2):
    ds = ray.data.read_binary_files([str(p) for p in inputs], include_paths=True)
    report = ds.map_batches(skin.ray.Convert(config, out), batch_size=1, compute=ray.data.TaskPoolStrategy(size=concurrency))
    return report.take_all()


def same_files(a: Path, b: Path):
    for rel in ("data/chunk-000/file-000.parquet", "events/chunk-000/file-000.parquet", "contacts/chunk-000/file-000.parquet"):
        assert (a / rel).read_bytes() == (b / rel).read_bytes(), (a, rel)


def leftovers(out: Path):
    return [p for p in out.rglob("*") if p.name in (".skin-partial", "INCOMPLETE") or ".partial" in p.name]


def test_the_recipe_converts_as_the_serial_export_and_names_the_corrupt_log(fleet, tmp_path, ray_local):
    config, logs, bad = fleet
    serial(config, logs, tmp_path / "serial")
    rows = recipe(config, logs[:20] + [bad] + logs[20:], tmp_path / "out")
    assert skin.ray.report(rows) == {"converted": LOGS, "skipped": 0, "failed": 1}
    failed = [r for r in rows if r["status"] == "failed"]
    assert failed[0]["path"].endswith("corrupt.candump.log")
    assert "corrupt.candump.log" in failed[0]["error"] and "line" in failed[0]["error"]
    assert not (tmp_path / "out" / failed[0]["sha256"]).exists()
    by_path = {Path(r["path"]).name: r for r in rows}
    for log in logs:
        row = by_path[log.name]
        same_files(Path(row["dataset"]), tmp_path / "serial" / log.name)
    assert leftovers(tmp_path / "out") == []
    # The folder is this configuration's: another task (or run.toml) is refused, not skipped.
    with pytest.raises(skin.SkinError, match="another configuration"):
        skin.ray.Convert(config, tmp_path / "out", task="other")({"path": [str(logs[0])]})
    # The per-input report as the recipe writes it, with Ray's own writer.
    ray.data.from_items(rows).write_parquet(str(tmp_path / "report"))
    assert ray.data.read_parquet(str(tmp_path / "report")).count() == LOGS + 1


DRIVER = """
import sys, time, ray, skin.ray
class Slow(skin.ray.Convert):
    def __call__(self, batch):
        out = super().__call__(batch)
        time.sleep(0.3)
        return out
ray.init(num_cpus=1, include_dashboard=False, log_to_driver=False)
config, out, *logs = sys.argv[1:]
ray.data.read_binary_files(logs, include_paths=True).map_batches(Slow(config, out), batch_size=1, compute=ray.data.TaskPoolStrategy(size=1)).take_all()
"""


def test_a_run_killed_midway_is_finished_by_the_next(fleet, tmp_path, ray_local):
    config, logs, _ = fleet
    out = tmp_path / "out"
    driver = subprocess.Popen(
        [sys.executable, "-c", DRIVER, str(config), str(out), *map(str, logs)],
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and driver.poll() is None:
            if out.is_dir() and sum(skin.ray.finished(d) for d in out.iterdir()) >= 5:
                break
            time.sleep(0.02)
    finally:
        os.killpg(driver.pid, signal.SIGKILL)
        driver.wait()
    done = sum(skin.ray.finished(d) for d in out.iterdir())
    assert 5 <= done < LOGS, f"{done} of {LOGS} finished when the run was killed"
    assert len(skin.ray.pending(logs, out)) == LOGS - done
    rows = recipe(config, logs, out)
    assert skin.ray.report(rows) == {"converted": LOGS - done, "skipped": done, "failed": 0}
    serial(config, logs, tmp_path / "serial")
    for r in rows:
        same_files(Path(r["dataset"]), tmp_path / "serial" / Path(r["path"]).name)
    assert leftovers(out) == []


def test_frames_and_touches_are_the_datasets_tables(fleet, tmp_path, ray_local):
    import pyarrow.parquet as pq

    config, logs, _ = fleet
    ds = ray.data.read_binary_files([str(p) for p in logs[:3]], include_paths=True)
    frames = ds.map_batches(skin.ray.Frames(config), batch_size=1).to_pandas()
    touches = ds.map_batches(skin.ray.Touches(config), batch_size=1).to_pandas()
    serial(config, logs[:3], tmp_path / "serial")
    for log in logs[:3]:
        data = pq.read_table(tmp_path / "serial" / log.name / "data").to_pandas()
        mine = frames[frames["source"].str.endswith(log.name)].sort_values("frame_index")
        assert len(mine) == len(data)
        assert (mine["observation.tactile.forearm"].map(list).tolist() == data["observation.tactile.forearm"].map(list).tolist())
        events = pq.read_table(tmp_path / "serial" / log.name / "events").to_pandas()
        assert touches[touches["source"].str.endswith(log.name)]["json"].tolist() == events["json"].tolist()


def test_synthesize_gives_the_same_bytes_on_one_worker_and_two(tmp_path, ray_local):
    # The 61-taxel patch: 20,000 samples in seconds (the forearm's 715 taxels take minutes).
    layout = FIXTURES / "hex_patch" / "layout.json"
    one = skin.ray.synthesize(layout, 20_000, tmp_path / "one", shard_size=2_500, workers=1, seed=7)
    two = skin.ray.synthesize(layout, 20_000, tmp_path / "two", shard_size=2_500, workers=2, seed=7)
    assert one == two and len(one) == 8
    for name in one:
        assert (tmp_path / "one" / name).read_bytes() == (tmp_path / "two" / name).read_bytes(), name
    # A rerun into the folder keeps its shards only for the same set.
    with pytest.raises(skin.SkinError, match="another set"):
        skin.ray.synthesize(layout, 20_000, tmp_path / "one", shard_size=2_500, workers=1, seed=8)
    # The shards are the whole set: the same as one call, sample for sample.
    import pyarrow.parquet as pq

    tmap = skin.flatten(skin.read_layout(layout)[0])
    whole = skin.synthesize(tmap, 20_000, seed=7, part=(2_500, 2_510))
    shard = pq.read_table(tmp_path / "one" / one[1]).slice(0, 10)
    assert shard.column("index").to_pylist() == list(range(2_500, 2_510))
    assert shard.column("hand").to_pylist() == whole["hand"].tolist()
    assert shard.column("image").to_pylist() == [list(i.reshape(-1)) for i in whole["images"]]
