#!/usr/bin/env python3
"""Writes a long candump log for the benchmarks: a log (by default the fixture session's, 31 s)
repeated with its timestamps shifted, each copy starting 1 s after the one before ends, until the
file reaches the size asked for. The same log as test-support/src/long_log.rs makes as it is read.

    tools/long_log.py /tmp/session-1g.candump.log --bytes 1e9
    tools/long_log.py /tmp/x.log --copies 3 --source fixtures/session/session.candump.log

The file is written aside and renamed into place when complete. Never commit its output.
"""

import argparse
import os
import sys
from pathlib import Path

GAP_US = 1_000_000


def main() -> int:
    root = Path(__file__).resolve().parent.parent
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("output", type=Path)
    p.add_argument("--source", type=Path, default=root / "fixtures/session/session.candump.log")
    size = p.add_mutually_exclusive_group(required=True)
    size.add_argument("--bytes", type=float, help="copies until the file has at least this many bytes")
    size.add_argument("--copies", type=int)
    args = p.parse_args()

    lines = []
    for line in args.source.read_text().splitlines():
        if not line.strip():
            continue
        stamp, rest = line[1:].split(")", 1)
        secs, micros = stamp.split(".")
        lines.append((int(secs) * 1_000_000 + int(micros), ")" + rest + "\n"))
    if not lines:
        print(f"{args.source}: no CAN frames", file=sys.stderr)
        return 1
    period = lines[-1][0] - lines[0][0] + GAP_US
    one = sum(len(f"({t // 1_000_000}.{t % 1_000_000:06d}") + len(r) for t, r in lines)
    copies = args.copies if args.copies is not None else max(1, -(-int(args.bytes) // one))

    tmp = args.output.with_name(f".{args.output.name}.partial-{os.getpid()}")
    try:
        with open(tmp, "w", buffering=1 << 20) as out:
            for k in range(copies):
                shift = k * period
                out.write(
                    "".join(
                        f"({(t + shift) // 1_000_000}.{(t + shift) % 1_000_000:06d}{r}" for t, r in lines
                    )
                )
        os.replace(tmp, args.output)
    finally:
        if tmp.exists():
            tmp.unlink()
    print(f"wrote {args.output}: {copies} copies, {args.output.stat().st_size} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main())
