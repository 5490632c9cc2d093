"""Shared by the ROS 2 checks: rosbags' Jazzy typestore with skin_msgs registered from the
repository's .msg files, and the events of an events.jsonl."""
import json
from pathlib import Path

from rosbags.typesys import Stores, get_types_from_msg, get_typestore

ROOT = Path(__file__).resolve().parents[3]


def typestore():
    store = get_typestore(Stores.ROS2_JAZZY)
    added = {}
    for path in sorted((ROOT / 'skin_msgs' / 'msg').glob('*.msg')):
        added.update(get_types_from_msg(path.read_text(), f'skin_msgs/msg/{path.stem}'))
    store.register(added)
    return store


def events(path):
    """The lines of events.jsonl, as written, and parsed."""
    lines = [line for line in Path(path).read_text().splitlines() if line.strip()]
    return lines, [json.loads(line) for line in lines]


def fail(problems):
    for p in problems:
        print('FAIL', p)
    raise SystemExit(1 if problems else 0)
