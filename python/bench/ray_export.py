"""Ray Data on this machine: 40 logs converted by skin.ray's recipe (README, "At scale") on one
worker and on two, wall-clock seconds, and the serial `skin.export` of the same logs for
reference: the logs' bytes read by Ray (`read_binary_files`, one block a log), and their paths
alone (`from_items`, each worker reading its own file). Each log is the fixture session's 31 s of CAN traffic played --repeat times in a row
(2 minutes by default), shifted in time by a different number of seconds for each log
(distinct bytes, so that no log is skipped as another's).

    python python/bench/ray_export.py [--logs 40] [--repeat 4]

From the repository root; needs Ray (pip install "./python[ray]").
"""

import argparse
import re
import shutil
import sys
import tempfile
import time
from pathlib import Path

import ray

import skin
import skin.ray

CONFIG = "fixtures/session/run.toml"


def shift(text: str, seconds: int) -> str:
    return re.sub(r"^\((\d+)\.", lambda m: f"({int(m.group(1)) + seconds}.", text, flags=re.M)


def make_logs(n: int, repeat: int, root: Path) -> list:
    text = Path("fixtures/session/session.candump.log").read_text()
    root.mkdir(parents=True, exist_ok=True)
    logs = []
    for k in range(n):
        path = root / f"log-{k:02d}.candump.log"
        path.write_text("".join(shift(text, 1000 * k + 40 * r) for r in range(repeat)))
        logs.append(path)
    return logs


def recipe(logs: list, out: Path, workers: int, by_path: bool = False) -> float:
    t = time.perf_counter()
    if by_path:
        ds = ray.data.from_items([{"path": str(p)} for p in logs], override_num_blocks=len(logs))
    else:
        ds = ray.data.read_binary_files([str(p) for p in logs], include_paths=True, override_num_blocks=len(logs))
    rows = (
        ds.map_batches(skin.ray.Convert(CONFIG, out), batch_size=1, compute=ray.data.TaskPoolStrategy(size=workers))
        .take_all()
    )
    took = time.perf_counter() - t
    assert skin.ray.report(rows)["converted"] == len(logs), skin.ray.report(rows)
    return took


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--logs", type=int, default=40)
    ap.add_argument("--repeat", type=int, default=4)
    a = ap.parse_args()
    work = Path(tempfile.mkdtemp())
    logs = make_logs(a.logs, a.repeat, work / "logs")
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    ray.data.DataContext.get_current().enable_progress_bars = False
    # Warm-up: the map cache, the workers' imports.
    recipe(logs[:2], work / "warm", 2)
    t = time.perf_counter()
    for k, log in enumerate(logs):
        skin.export([log], CONFIG, work / "serial" / str(k))
    serial = time.perf_counter() - t
    one = recipe(logs, work / "one", 1)
    two = recipe(logs, work / "two", 2)
    one_p = recipe(logs, work / "one-p", 1, by_path=True)
    two_p = recipe(logs, work / "two-p", 2, by_path=True)
    mb = sum(p.stat().st_size for p in logs) / 1e6
    print(f"{a.logs} logs ({mb:.0f} MB of candump text, {a.logs * 31 * a.repeat} s of traffic), Ray {ray.__version__}, skin.ray.Convert")
    print(f"serial skin.export, in-process: {serial:6.1f} s  ({serial / a.logs:.2f} s a log)")
    print(f"recipe, 1 worker:               {one:6.1f} s")
    print(f"recipe, 2 workers:              {two:6.1f} s  ({one / two:.2f}x one worker)")
    print(f"paths, 1 worker:                {one_p:6.1f} s")
    print(f"paths, 2 workers:               {two_p:6.1f} s  ({one_p / two_p:.2f}x one worker)")
    shutil.rmtree(work)


if __name__ == "__main__":
    sys.exit(main())
