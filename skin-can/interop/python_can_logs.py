#!/usr/bin/env python3
"""Writes skin traffic with python-can's CanutilsLogWriter, and what skin-can must make of it.

For each wire format (skin16, icub8) this writes, into OUT_DIR:

  busmap_<format>.toml        the bus map: 4 buses x 16 modules (64 modules, 11 taxels each)
  <format>.log                10 s of clean traffic, 4 buses interleaved in time order
  <format>_damaged.log        the same traffic with dropped, duplicated and reordered frames
  <format>.json               ground truth of each log: one entry per assembled frame
  <format>_damaged.json       (cycle, t_us, complete, values or null, missing, duplicated modules)

The ground truth is computed here from what was written, independently of skin-can, following
the rules skin-can documents: skin16 cycles are cut at the sync frames (the time of a cycle is
the time of its first sync in the file), icub8 traffic into 50 ms windows from the first frame;
a module is missing when some data frame of it was lost, duplicated when a data frame came twice.

    python3 -m pip install python-can==4.6.1
    python3 skin-can/interop/python_can_logs.py OUT_DIR
    python3 skin-can/interop/python_can_logs.py --fixture fixtures/forearm OUT_DIR

With --fixture, it instead writes OUT_DIR/touches.python-can.log: the fixture forearm's recording
(touches.txt, bus map busmap.toml) as the same skin16 traffic as the project's own
touches.candump.log, frame for frame (python-can adds the " R" direction marker).

skin-can's test `python_can_interop` runs it when python-can is installed (.ci/run installs it).
"""

import json
import random
import sys
from pathlib import Path

import can

BUSES = 4
MODULES_PER_BUS = 16
SECONDS = 10
PERIOD_US = 50_000
CYCLES = SECONDS * 1_000_000 // PERIOD_US
T0_US = 1_700_000_000_000_000
USED = 11  # slots 0..10 carry taxels, slot 11 is unused (the Cyskin thermal pad)
FIRST_COUNTER = 250  # skin16 counters start near the wrap to exercise it


def taxel_ids(bus, module):
    cyskin_module = bus * MODULES_PER_BUS + module + 1
    return [(cyskin_module << 4) | c if c < USED else -1 for c in range(12)]


def address(fmt, module):
    # icub8: two boards of 8 triangles per bus
    return module if fmt == "skin16" else ((module // 8) << 4) | (module % 8)


def busmap(fmt):
    lines = [f'format = "{fmt}"']
    for b in range(BUSES):
        lines += ["", "[[bus]]", f'interface = "can{b}"']
        for m in range(MODULES_PER_BUS):
            ids = ", ".join(str(t) for t in taxel_ids(b, m))
            lines += ["", "[[bus.module]]", f"address = {address(fmt, m)}", f"taxels = [{ids}]"]
    return "\n".join(lines) + "\n"


class Frame:
    """One CAN frame to write, and what it carries: (bus, module, [(slot, value)])."""

    def __init__(self, t_us, bus, can_id, data, module=None, slots=()):
        self.t_us, self.bus, self.can_id, self.data = t_us, bus, can_id, bytes(data)
        self.module, self.slots = module, list(slots)


def skin16_traffic(rng):
    frames = []
    for c in range(CYCLES):
        for b in range(BUSES):
            t = T0_US + c * PERIOD_US + 7 * b
            frames.append(Frame(t, b, 0x080, [(FIRST_COUNTER + c) % 256], slots=[("sync", c)]))
            for m in range(MODULES_PER_BUS):
                readings = [rng.randrange(65536) for _ in range(12)]
                for chunk in range(3):
                    data = b"".join(v.to_bytes(2, "little") for v in readings[4 * chunk : 4 * chunk + 4])
                    can_id = 0x200 | (m << 2) | chunk
                    slots = [(4 * chunk + k, readings[4 * chunk + k]) for k in range(4)]
                    frames.append(Frame(t + 100 * (1 + 3 * m + chunk), b, can_id, data, (b, m), slots))
    frames.sort(key=lambda f: f.t_us)
    return frames


def icub8_traffic(rng):
    frames = []
    for c in range(CYCLES):
        for b in range(BUSES):
            for board in range(2):
                # Boards free-run: their own phase, up to 0.5 ms of jitter (none on the very first).
                jitter = 0 if c == 0 else rng.randrange(500)
                base = T0_US + c * PERIOD_US + 3_000 + 10_000 * b + 4_000 * board + jitter
                for tri in range(8):
                    m = board * 8 + tri
                    readings = [rng.randrange(256) for _ in range(12)]
                    can_id = (4 << 8) | address("icub8", m)
                    t = base + 300 * tri
                    a = [0x40] + readings[:7]
                    oor, err = 0, 0
                    z = [0xC0] + readings[7:] + [oor >> 4, ((oor & 0xF) << 4) | err]
                    frames.append(Frame(t, b, can_id, a, (b, m), [(k, readings[k]) for k in range(7)]))
                    frames.append(Frame(t + 150, b, can_id, z, (b, m), [(7 + k, readings[7 + k]) for k in range(5)]))
    frames.sort(key=lambda f: f.t_us)
    return frames


def damage(frames, rng, delay_bus_us):
    """Drops 0.5% and duplicates 0.5% of the data frames, swaps 2% of neighbouring data frames of
    one bus, and writes the last bus up to `delay_bus_us` late in file order (timestamps kept)."""
    out = []
    for f in frames:
        if f.module is not None and rng.random() < 0.005:
            continue
        out.append(f)
        if f.module is not None and rng.random() < 0.005:
            out.append(f)
    for i in range(len(out) - 1):
        a, b = out[i], out[i + 1]
        if a.module is not None and b.module is not None and a.bus == b.bus and rng.random() < 0.02:
            out[i], out[i + 1] = b, a
    late = BUSES - 1
    return sorted(out, key=lambda f: f.t_us + (delay_bus_us if f.bus == late else 0))


def written_times(frames):
    """Timestamps as CanutilsLogWriter writes them: never before the first message's."""
    first = frames[0].t_us
    return [max(f.t_us, first) for f in frames]


def truth_skin16(frames):
    times = written_times(frames)
    cycles, bus_cycle = {}, {}
    for f, t in zip(frames, times):
        if f.can_id == 0x080:
            c = f.slots[0][1]
            bus_cycle[f.bus] = c
            cycles.setdefault(c, {"t_us": t, "got": {}})
        else:
            got = cycles[bus_cycle[f.bus]]["got"]
            for slot, v in f.slots:
                got.setdefault((f.module, slot), []).append(v)
    return [frame_entry(FIRST_COUNTER + c, cycles[c]) for c in sorted(cycles)]


def truth_icub8(frames):
    times = written_times(frames)
    origin = min(times)
    cycles = {}
    for f, t in zip(frames, times):
        w = (t - origin) // PERIOD_US
        got = cycles.setdefault(w, {"t_us": origin + w * PERIOD_US, "got": {}})["got"]
        for slot, v in f.slots:
            got.setdefault((f.module, slot), []).append(v)
    return [frame_entry(w, cycles[w]) for w in sorted(cycles)]


def frame_entry(cycle, c):
    got = c["got"]
    values, missing, duplicated = [], [], []
    for b in range(BUSES):
        for m in range(MODULES_PER_BUS):
            lost = twice = False
            for slot in range(12):
                copies = got.get(((b, m), slot), [])
                twice |= len(copies) > 1
                if slot < USED:
                    lost |= not copies
                    values.append(copies[0] if copies else None)
            if lost:
                missing.append([b, m])
            if twice:
                duplicated.append([b, m])
    return {
        "cycle": cycle,
        "t_us": c["t_us"],
        "complete": not missing,
        "values": values,
        "missing": missing,
        "duplicated": duplicated,
    }


def write_log(path, frames):
    with can.CanutilsLogWriter(str(path)) as writer:
        for f in frames:
            writer.on_message_received(
                can.Message(
                    timestamp=f.t_us / 1e6,
                    arbitration_id=f.can_id,
                    is_extended_id=False,
                    data=f.data,
                    channel=f"can{f.bus}",
                    is_rx=True,
                )
            )


def fixture(folder, out):
    """The fixture recording as skin16 traffic, timed as fixtures/src/main.rs times it."""
    lines = (folder / "touches.txt").read_text().splitlines()
    ids = [int(t) for t in lines[0].split()]
    modules = sorted({t >> 4 for t in ids})
    frames = []
    for k, line in enumerate(lines[1:]):
        fields = line.split()
        t0 = T0_US + round(float(fields[1]) * 1e6)
        values = dict(zip(ids, (int(float(v)) for v in fields[2:])))
        frames.append(Frame(t0, 0, 0x080, [k % 256]))
        for j, m in enumerate(modules):
            readings = [values.get((m << 4) | c, 0) for c in range(12)]
            for chunk in range(3):
                data = b"".join(v.to_bytes(2, "little") for v in readings[4 * chunk : 4 * chunk + 4])
                frames.append(Frame(t0 + 150 * (j + 1), 0, 0x200 | ((m - 1) << 2) | chunk, data))
    write_log(out / "touches.python-can.log", frames)


def main():
    if len(sys.argv) == 4 and sys.argv[1] == "--fixture":
        out = Path(sys.argv[3])
        out.mkdir(parents=True, exist_ok=True)
        fixture(Path(sys.argv[2]), out)
        print(f"wrote {out}")
        return
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    for fmt, traffic, truth, delay in [
        ("skin16", skin16_traffic, truth_skin16, 20_000),
        ("icub8", icub8_traffic, truth_icub8, 20_000),
    ]:
        (out / f"busmap_{fmt}.toml").write_text(busmap(fmt))
        rng = random.Random(20261122)
        clean = traffic(rng)
        damaged = damage(clean, rng, delay)
        for name, frames in [(fmt, clean), (f"{fmt}_damaged", damaged)]:
            write_log(out / f"{name}.log", frames)
            # module indices in the truth are bus-map positions; turn them into addresses
            entries = truth(frames)
            for e in entries:
                for key in ("missing", "duplicated"):
                    e[key] = [[b, address(fmt, m)] for b, m in e[key]]
            (out / f"{name}.json").write_text(json.dumps({"format": fmt, "frames": entries}))
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
