"""Ctrl-C during long calls: a child Python process is sent SIGINT at random (seeded) times while
a call runs, and must raise `KeyboardInterrupt` within half a second, never a `PanicException`;
a named pipe's writer thread in the same process must not deadlock its reader."""

import json
import os
import queue
import random
import signal
import subprocess
import sys
import tempfile
import textwrap
import threading
import time

import numpy as np
import pytest

import skin
from conftest import FIXTURES

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="SIGINT to a child and named pipes: Linux")

CONFIG = FIXTURES / "session" / "run.toml"
LOG = FIXTURES / "session" / "session.candump.log"
LAYOUT = FIXTURES / "forearm" / "layout.json"
BUSMAP = FIXTURES / "forearm" / "busmap.toml"
RECORDING = FIXTURES / "forearm" / "touches.txt"

TRIALS = 20
# The bound for Ctrl-C to take effect. What the test measures runs from the parent's
# kill() to the child's `except`, both on the same monotonic clock, so scheduling on a loaded
# machine counts against it: the calls themselves check every 20 ms.
BOUND_S = 0.5
# Each call is made to last at least this long, so that every signal lands inside it (the
# latest is sent LATEST_S after the call starts).
LATEST_S = 0.6
LASTS_S = 2.5

# The child: `setup` once, then per trial `prepare` (untimed), "go", the call, and what ended it.
CHILD = """
import json, os, sys, threading, time
import numpy as np
import skin
{setup}
for trial in range({trials}):
    {prepare}
    print("go", flush=True)
    try:
        {call}
        print(json.dumps({{"done": time.monotonic()}}), flush=True)
    except KeyboardInterrupt:
        print(json.dumps({{"interrupted": time.monotonic()}}), flush=True)
    {cleanup}
    sys.stdin.readline()
"""


# How long the child may take to answer: a call that Ctrl-C does not stop (a wait in open(2))
# fails the test instead of hanging it.
ANSWER_S = 60


def lines_of(stream):
    """A queue of `stream`'s lines, read by a thread of its own (None at its end)."""
    lines = queue.Queue()

    def read():
        for line in stream:
            lines.put(line)
        lines.put(None)

    threading.Thread(target=read, daemon=True).start()
    return lines


def answer(lines, trial):
    try:
        return lines.get(timeout=ANSWER_S) or ""
    except queue.Empty:
        pytest.fail(f"trial {trial}: no word from the child in {ANSWER_S} s: the call did not stop")


def interrupt_trials(seed, setup, call, *, prepare="pass", cleanup="pass", trials=TRIALS):
    """Runs the child and interrupts each trial's call at a random time; returns the latencies."""
    code = CHILD.format(
        setup=textwrap.dedent(setup),
        trials=trials,
        prepare=prepare,
        call=call,
        cleanup=cleanup,
    )
    # Its errors go to a file: read at any time, and never a full pipe that stops the child.
    errors = tempfile.TemporaryFile(mode="w+")
    child = subprocess.Popen(
        [sys.executable, "-c", code],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=errors,
        text=True,
    )

    def said():
        errors.seek(0)
        return errors.read()

    rng = random.Random(seed)
    latencies = []
    lines = lines_of(child.stdout)
    try:
        for trial in range(trials):
            line = answer(lines, trial)
            assert line == "go\n", f"trial {trial}: the child said {line!r}:\n{said()}"
            time.sleep(rng.uniform(0.0, LATEST_S))
            sent = time.monotonic()
            child.send_signal(signal.SIGINT)
            line = answer(lines, trial)
            assert line, f"trial {trial}: the child ended:\n{said()}"
            ended = json.loads(line)
            assert "interrupted" in ended, f"trial {trial}: the call ended before the signal (make it longer)"
            latencies.append(ended["interrupted"] - sent)
            child.stdin.write("\n")
            child.stdin.flush()
        child.stdin.close()
        child.wait(timeout=ANSWER_S)
        err = said()
    finally:
        child.kill()
        child.wait()
        errors.close()
    assert child.returncode == 0, err
    assert "PanicException" not in err and "panicked" not in err, err
    # Shown with `pytest -s`: the figures behind the bound.
    print(f"\n{trials} trials: Ctrl-C took effect in {np.median(latencies) * 1e3:.0f} ms (median), {max(latencies) * 1e3:.0f} ms at most")
    late = [f"{t:.3f} s" for t in latencies if t >= BOUND_S]
    assert not late, f"KeyboardInterrupt later than {BOUND_S} s in {len(late)} of {trials} trials: {late}"
    return latencies


def seconds_of(make_call, repeat=3):
    """The fastest of `repeat` calls (each made by `make_call()`, untimed): a size chosen from it
    lasts at least as long in a child, however loaded this process was while measuring."""
    best = float("inf")
    for _ in range(repeat):
        call = make_call()
        start = time.monotonic()
        call()
        best = min(best, time.monotonic() - start)
    return best


@pytest.fixture(scope="module")
def long_log(tmp_path_factory):
    """The fixture session's log played again and again, long enough for `run_log` to last
    LASTS_S here: each copy shifted in time after the one before."""
    once = seconds_of(lambda: lambda s=skin.Session.from_config(CONFIG): s.run_log(LOG), repeat=2)
    copies = max(3, int(np.ceil(LASTS_S / once)))
    lines = LOG.read_text().splitlines()
    first = float(lines[0].split(")")[0][1:])
    last = float(lines[-1].split(")")[0][1:])
    span = last - first + 0.05
    path = tmp_path_factory.mktemp("long") / "long.candump.log"
    with open(path, "w") as out:
        for k in range(copies):
            for line in lines:
                stamp, rest = line.split(")", 1)
                out.write(f"({float(stamp[1:]) + k * span:.6f}){rest}\n")
    return path


def test_ctrl_c_stops_run_log_at_once_even_as_the_first_call_that_makes_arrays(long_log):
    # A fresh process whose first call makes numpy arrays only at its end: once a
    # PanicException ("Failed to access NumPy array API capsule"), and the interrupt waited for
    # the whole log.
    interrupt_trials(
        54,
        f"log = {str(long_log)!r}",
        "session.run_log(log)",
        prepare=f"session = skin.Session.from_config({str(CONFIG)!r})",
    )


def test_ctrl_c_stops_run_recording(tmp_path):
    recording = tmp_path / "long.txt"
    lines = RECORDING.read_text().splitlines()
    layout = skin.read_layout(LAYOUT)
    once = seconds_of(lambda: lambda s=skin.Session.from_layout(layout): s.run_recording(RECORDING))
    copies = max(3, int(np.ceil(LASTS_S / once)))
    rows = [line.split() for line in lines[1:] if line.strip()]
    span = float(rows[-1][1]) - float(rows[0][1]) + 0.05
    with open(recording, "w") as out:
        out.write(lines[0] + "\n")
        for k in range(copies):
            for r in rows:
                out.write(" ".join([str(int(r[0]) + k * len(rows)), f"{float(r[1]) + k * span:.6f}", *r[2:]]) + "\n")
    interrupt_trials(
        541,
        f"layout = skin.read_layout({str(LAYOUT)!r})",
        f"session.run_recording({str(recording)!r})",
        prepare="session = skin.Session.from_layout(layout)",
        trials=5,
    )


def test_ctrl_c_stops_images():
    tmap = skin.read_map(LAYOUT)
    imager = skin.Imager(tmap, size=(68, 100))
    rng = np.random.default_rng(5)
    probe = rng.uniform(0, 50, (200, len(tmap))).astype(np.float32)
    per_frame = seconds_of(lambda: lambda: imager.images(probe)) / len(probe)
    frames = int(LASTS_S / per_frame)
    interrupt_trials(
        542,
        f"""
        tmap = skin.read_map({str(LAYOUT)!r})
        imager = skin.Imager(tmap, size=(68, 100))
        frames = np.random.default_rng(5).uniform(0, 50, ({frames}, len(tmap))).astype(np.float32)
        out = np.zeros(({frames}, 68, 100), np.uint8)
        """,
        "imager.images(frames, out=out) if trial % 2 else imager.images(frames)",
    )


def test_ctrl_c_stops_synthesize():
    tmap = skin.read_map(LAYOUT)
    per_sample = seconds_of(lambda: lambda: skin.synthesize(tmap, 24), repeat=2) / 24
    count = int(LASTS_S / per_sample)
    interrupt_trials(
        543,
        f"tmap = skin.read_map({str(LAYOUT)!r})",
        f"skin.synthesize(tmap, {count})",
    )


# Named pipes: with no writer, `read_log` and `read_recording` wait in the open; with a writer
# that stops half-way (a thread of the child), iterating waits for data.
FIFO_SETUP = f"""
import itertools
layout = skin.read_layout({str(LAYOUT)!r})
busmap = skin.BusMap.read({str(BUSMAP)!r})
half = open({str(LOG)!r}, "rb").read()[: 2 << 20]
fifo = os.path.join(sys.argv[1] if len(sys.argv) > 1 else os.environ["FIFO_DIR"], "pipe")
def stall(release):
    # Opened without blocking, so that a writer whose reader was interrupted before it opened
    # the pipe can give up.
    while not release.is_set():
        try:
            fd = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
            break
        except OSError:  # no reader yet
            time.sleep(0.005)
    else:
        return
    os.set_blocking(fd, True)
    try:
        with os.fdopen(fd, "wb") as w:
            w.write(half)
            w.flush()
            release.wait()
    except BrokenPipeError:
        pass  # the reader was interrupted before it read everything
def read(trial):
    if trial % 3 == 2:
        return skin.read_recording(fifo)
    for frame in skin.read_log(fifo, busmap, layout):
        pass
"""
FIFO_PREPARE = (
    "os.mkfifo(fifo); release = threading.Event(); writer = threading.Thread(target=stall, args=(release,)); "
    "writer.start() if trial % 3 == 1 else None"
)
FIFO_CLEANUP = "release.set(); writer.join() if trial % 3 == 1 else None; os.unlink(fifo)"


def test_ctrl_c_stops_reading_a_named_pipe(tmp_path, monkeypatch):
    # 20 trials of read_log (two in three), 10 of read_recording.
    monkeypatch.setenv("FIFO_DIR", str(tmp_path))
    interrupt_trials(544, FIFO_SETUP, "read(trial)", prepare=FIFO_PREPARE, cleanup=FIFO_CLEANUP, trials=30)


# A writer thread in the reader's own process: the reader releases the GIL while it waits.
WRITER_CHILD = """
import os, sys, threading
import skin
what, src, fifo = sys.argv[1:4]
os.mkfifo(fifo)
def write():
    with open(fifo, "wb") as w:
        w.write(open(src, "rb").read())
writer = threading.Thread(target=write)
writer.start()
if what == "read_log":
    layout = skin.read_layout(sys.argv[4])
    busmap = skin.BusMap.read(sys.argv[5])
    print(sum(1 for _ in skin.read_log(fifo, busmap, layout)))
elif what == "run_log":
    print(len(skin.Session.from_config(sys.argv[4]).run_log(fifo)))
else:
    print(len(skin.read_recording(fifo)))
writer.join()
"""


@pytest.mark.parametrize("what", ["read_log", "run_log", "read_recording"])
def test_a_named_pipe_written_by_a_thread_of_the_same_process(tmp_path, what):
    fifo = tmp_path / "pipe"
    if what == "read_log":
        args, expected = [LOG, fifo, LAYOUT, BUSMAP], sum(1 for _ in skin.read_log(LOG, skin.BusMap.read(BUSMAP), skin.read_layout(LAYOUT)))
    elif what == "run_log":
        args, expected = [LOG, fifo, CONFIG], len(skin.Session.from_config(CONFIG).run_log(LOG))
    else:
        args, expected = [RECORDING, fifo], len(skin.read_recording(RECORDING))
    try:
        done = subprocess.run(
            [sys.executable, "-c", WRITER_CHILD, what, *map(str, args)],
            capture_output=True,
            text=True,
            timeout=120,
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"{what} on a named pipe written by a thread of its own process: deadlocked")
    assert done.returncode == 0, done.stderr
    assert int(done.stdout) == expected


def test_a_log_whose_reading_was_interrupted_is_not_read_on(tmp_path):
    code = textwrap.dedent(
        f"""
        import os, signal, threading
        import skin
        fifo = {str(tmp_path / "pipe")!r}
        os.mkfifo(fifo)
        frames = None
        # Long after the reader has read what the writer gives and waits for more.
        threading.Timer(1.0, lambda: os.kill(os.getpid(), signal.SIGINT)).start()
        def stall(release):
            with open(fifo, "wb") as w:
                w.write(open({str(LOG)!r}, "rb").read()[: 256 << 10])
                w.flush()
                release.wait()
        release = threading.Event()
        threading.Thread(target=stall, args=(release,)).start()
        frames = skin.read_log(fifo, skin.BusMap.read({str(BUSMAP)!r}), skin.read_layout({str(LAYOUT)!r}))
        try:
            for _ in frames:
                pass
        except KeyboardInterrupt:
            print("interrupted")
        release.set()
        try:
            next(frames)
        except skin.InputError as e:
            print(e)
        """
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    lines = done.stdout.splitlines()
    assert lines[0] == "interrupted", done.stderr
    assert "interrupted (Ctrl-C)" in lines[1] and "read the log again" in lines[1], done.stdout
