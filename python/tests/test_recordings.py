"""Recordings and CAN logs as arrays; a module dropped from a log is reported, not lost."""

import gzip

import numpy as np
import pytest

import skin
from conftest import FIXTURES, read_events, run_skin, shared

LAYOUT = FIXTURES / "forearm" / "layout.json"
BUSMAP = FIXTURES / "forearm" / "busmap.toml"
LOG = FIXTURES / "session" / "session.candump.log"


def test_recording_as_arrays():
    rec = skin.read_recording(FIXTURES / "forearm" / "touches.txt")
    t, n = len(rec), len(rec.ids)
    assert rec.values.shape == (t, n) and rec.values.dtype == np.float32
    assert rec.times.shape == (t,) and np.all(np.diff(rec.times) > 0)
    assert rec.frame_numbers.shape == (t,)
    # The first data line of the file, as written.
    with open(FIXTURES / "forearm" / "touches.txt") as f:
        ids = [int(x) for x in f.readline().split()]
        first = [float(x) for x in f.readline().split()]
    assert rec.ids.tolist() == ids
    assert rec.frame_numbers[0] == first[0] and rec.times[0] == pytest.approx(first[1])
    np.testing.assert_array_equal(rec.values[0], np.array(first[2:], dtype=np.float32))


def test_for_taxels_orders_by_id_and_fills_missing():
    rec = skin.read_recording(FIXTURES / "forearm" / "touches.txt")
    ids = rec.ids[::-1].astype(np.int64).tolist() + [999_999]
    v = rec.for_taxels(ids)
    np.testing.assert_array_equal(v[:, :-1], rec.values[:, ::-1])
    assert np.all(v[:, -1] == 0)
    thresholded = rec.for_taxels(rec.ids, threshold=3.0)
    np.testing.assert_array_equal(thresholded, np.where(rec.values > 3.0, rec.values, 0))


def test_real_cyskin_recording():
    rec = skin.read_recording(shared("cyskin", "recordings", "0_finger", "sample_01.txt"))
    assert len(rec) > 0 and rec.values.shape == (len(rec), len(rec.ids))


def test_gzip_recording_reads_the_same(tmp_path):
    src = FIXTURES / "forearm" / "touches.txt"
    gz = tmp_path / "touches.txt.gz"
    gz.write_bytes(gzip.compress(src.read_bytes()))
    np.testing.assert_array_equal(skin.read_recording(gz).values, skin.read_recording(src).values)


def test_log_frames_per_link():
    layout = skin.read_layout(LAYOUT)
    busmap = skin.BusMap.read(BUSMAP)
    assert busmap.interfaces == ["can0"]
    frames = list(skin.read_log(LOG, busmap, layout))
    assert len(frames) == 620
    f = frames[0]
    assert f.complete and f.missing == []
    assert len(f.values) == 1 and f.values[0].shape == (715,) and f.values[0].dtype == np.float32
    assert not np.isnan(f.values[0]).any()
    assert [g.cycle for g in frames] == sorted(g.cycle for g in frames)
    assert frames[1].time - frames[0].time == pytest.approx(0.05, abs=1e-3)


def drop_module(src, dst, address: int, cycle: int) -> None:
    """Copies a skin16 log without module `address`'s data frames in the `cycle`-th sync cycle."""
    ids = {f"{0x200 + 4 * address + k:03X}" for k in range(3)}
    syncs = -1
    with open(src) as f, open(dst, "w") as out:
        for line in f:
            can_id = line.split()[2].split("#")[0]
            if can_id == "080":
                syncs += 1
            if syncs == cycle and can_id in ids:
                continue
            out.write(line)


def test_a_dropped_module_is_reported(tmp_path):
    log = tmp_path / "dropped.log"
    drop_module(LOG, log, address=1, cycle=30)
    layout = skin.read_layout(LAYOUT)
    frames = list(skin.read_log(log, skin.BusMap.read(BUSMAP), layout))
    incomplete = [f for f in frames if not f.complete]
    assert len(incomplete) == 1
    f = incomplete[0]
    assert f.missing == [("can0", 1)]
    # Module 1 carries taxels 32..42: NaN there, readings everywhere else.
    ids = layout[0].ids
    gone = np.isin(ids, np.arange(32, 43))
    assert np.isnan(f.values[0][gone]).all() and not np.isnan(f.values[0][~gone]).any()

    # The session says so, as `skin run` does.
    session = skin.Session.from_config(FIXTURES / "session" / "run.toml")
    events = session.run_log(log)
    said = [e for e in events if e.kind == "incomplete"]
    assert len(said) == 1 and said[0].missing == [{"bus": "can0", "address": 1}]
    assert session.stats["incomplete"] == 1
    out = tmp_path / "run"
    run_skin("run", FIXTURES / "session" / "run.toml", "--log", log, "-o", out, "-q")
    assert [e.to_dict() for e in events] == read_events(out / "events.jsonl")


def test_a_log_frame_can_be_pushed_once_the_session_has_the_busmap(tmp_path):
    layout = skin.read_layout(LAYOUT)
    frames = skin.read_log(LOG, skin.BusMap.read(BUSMAP), layout)
    no_can = skin.Session.from_layout(layout)
    with pytest.raises(skin.SkinError, match="bus map"):
        no_can.push_can(next(frames))


def test_frames_written_as_can_traffic_read_back_as_they_were(tmp_path):
    # BusMap.candump writes what the buses would carry; read_log assembles it back: the same
    # counts per taxel, the module left out reported missing, and no frame for the last
    # cycle's syncs (written in lock-step style: the next cycle's syncs right after a frame).
    busmap = skin.BusMap.read(BUSMAP)
    layout = skin.read_layout(LAYOUT)
    rng = np.random.default_rng(3)
    frames = [rng.integers(0, 4096, len(busmap.ids)).astype(np.float32) for _ in range(4)]
    text = ""
    for k, values in enumerate(frames):
        missing = [("can0", 2)] if k == 2 else []
        text += busmap.candump(values, 1.0 + 0.05 * k, k, missing, sync=k == 0)
        text += busmap.candump_sync(1.05 + 0.05 * k, k + 1)
    log = tmp_path / "written.log"
    log.write_text(text)
    back = list(skin.read_log(log, busmap, layout))
    assert [round(f.time, 6) for f in back] == [1.0, 1.05, 1.1, 1.15]
    assert [f.missing for f in back] == [[], [], [("can0", 2)], []]
    # Per layout taxel, its slot's count (NaN where the module was left out).
    slot = {int(t): i for i, t in enumerate(busmap.ids)}
    order = np.array([slot[int(t)] for t in layout[0].ids])
    for f, values in zip(back, frames):
        got = f.values[0]
        known = ~np.isnan(got)
        assert np.array_equal(got[known], values[order][known])
    assert np.isnan(back[2].values[0]).sum() == 11
    with pytest.raises(ValueError, match="3 values, the bus map has 715 slots"):
        busmap.candump(np.zeros(3), 0.0, 0)
    with pytest.raises(ValueError, match="no module can0:99"):
        busmap.candump(frames[0], 0.0, 0, [("can0", 99)])
